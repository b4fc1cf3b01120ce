#include "crop4d/eval/site_bootstrap.h"

#include <cmath>
#include <map>
#include <random>
#include <string>
#include <utility>

#include "crop4d/eval/quantile.h"

namespace crop4d::eval {
namespace {

// Per site, the sum of squared errors of each run and the number of pairs: a draw of the sites
// then costs one addition per site drawn.
struct SiteSums {
  double sum_sq_a = 0.0;
  double sum_sq_b = 0.0;
  int count = 0;
};

// The percentile interval of `values` at `level`.
BootstrapInterval PercentileInterval(std::vector<double> values, double level, int num_sites) {
  BootstrapInterval interval;
  interval.num_sites = num_sites;
  if (values.empty()) return interval;
  const double tail = 0.5 * (1.0 - level);
  interval.level = level;
  interval.low = Quantile(&values, tail);
  interval.high = Quantile(&values, 1.0 - tail);
  interval.resamples = static_cast<int>(values.size());
  return interval;
}

// Draws the sites `options.resamples` times and returns `statistic` of each draw's summed
// squares (NaN values, a draw where the statistic is undefined, are dropped).
template <typename Statistic>
std::vector<double> Resample(const std::vector<SiteSums>& sites,
                             const SiteBootstrapOptions& options, Statistic statistic) {
  std::vector<double> values;
  if (sites.size() < 2) return values;
  // mt19937_64 with a modulo draw rather than uniform_int_distribution: the distribution's
  // algorithm is the library's choice, and the intervals must repeat on any platform.
  std::mt19937_64 rng(options.seed);
  const std::uint64_t n = sites.size();
  values.reserve(options.resamples);
  for (int r = 0; r < options.resamples; ++r) {
    SiteSums drawn;
    for (std::uint64_t i = 0; i < n; ++i) {
      const SiteSums& s = sites[rng() % n];
      drawn.sum_sq_a += s.sum_sq_a;
      drawn.sum_sq_b += s.sum_sq_b;
      drawn.count += s.count;
    }
    const double value = statistic(drawn);
    if (std::isfinite(value)) values.push_back(value);
  }
  return values;
}

bool HasError(const SiteError& e) { return std::isfinite(e.error_m); }

}  // namespace

OptionCheck SiteBootstrapOptions::Check() const {
  OptionChecker c;
  c.Greater("level", level, 0.0).Less("level", level, 1.0).AtLeast("resamples", resamples, 1);
  return c.Result();
}

BootstrapInterval SiteRmseInterval(const std::vector<SiteError>& errors,
                                   const SiteBootstrapOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "SiteRmseInterval");
  std::map<std::string, SiteSums> by_site;
  for (const SiteError& p : errors) {
    if (!HasError(p)) continue;
    SiteSums& s = by_site[p.site_id];
    s.sum_sq_a += p.error_m * p.error_m;
    ++s.count;
  }
  std::vector<SiteSums> sites;
  for (const auto& [id, s] : by_site) sites.push_back(s);
  const std::vector<double> values =
      Resample(sites, options, [](const SiteSums& d) { return std::sqrt(d.sum_sq_a / d.count); });
  return PercentileInterval(values, options.level, static_cast<int>(sites.size()));
}

RmseRatio PairedRmseRatio(const std::vector<SiteError>& a, const std::vector<SiteError>& b,
                          const SiteBootstrapOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "PairedRmseRatio");
  std::map<std::pair<std::string, std::string>, double> error_a;
  for (const SiteError& p : a) {
    if (HasError(p)) error_a[{p.site_id, p.session}] = p.error_m;
  }
  std::map<std::string, SiteSums> by_site;
  SiteSums total;
  for (const SiteError& p : b) {
    if (!HasError(p)) continue;
    const auto found = error_a.find({p.site_id, p.session});
    if (found == error_a.end()) continue;
    SiteSums& s = by_site[p.site_id];
    for (SiteSums* sums : {&s, &total}) {
      sums->sum_sq_a += found->second * found->second;
      sums->sum_sq_b += p.error_m * p.error_m;
      ++sums->count;
    }
  }
  RmseRatio result;
  result.num_pairs = total.count;
  if (total.count == 0) return result;
  result.rmse_a_m = std::sqrt(total.sum_sq_a / total.count);
  result.rmse_b_m = std::sqrt(total.sum_sq_b / total.count);
  if (total.sum_sq_a > 0.0) result.ratio = result.rmse_b_m / result.rmse_a_m;
  std::vector<SiteSums> sites;
  for (const auto& [id, s] : by_site) sites.push_back(s);
  const std::vector<double> values = Resample(sites, options, [](const SiteSums& d) {
    return d.sum_sq_a > 0.0 ? std::sqrt(d.sum_sq_b / d.sum_sq_a)
                            : std::numeric_limits<double>::quiet_NaN();
  });
  result.interval = PercentileInterval(values, options.level, static_cast<int>(sites.size()));
  return result;
}

}  // namespace crop4d::eval
