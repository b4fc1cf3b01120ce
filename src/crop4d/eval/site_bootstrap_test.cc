#include "crop4d/eval/site_bootstrap.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <string>
#include <vector>

namespace crop4d::eval {
namespace {

// `num_sites` sites × `num_sessions` sessions, errors drawn from N(0, sigma) with a per-site
// offset of N(0, site_sigma) shared by its sessions (a site's stems and ground).
std::vector<SiteError> DrawErrors(std::mt19937* rng, int num_sites, int num_sessions, double sigma,
                                  double site_sigma) {
  std::normal_distribution<double> noise(0.0, sigma), offset(0.0, site_sigma);
  std::vector<SiteError> errors(static_cast<std::size_t>(num_sites * num_sessions));
  for (int s = 0; s < num_sites; ++s) {
    const double site_offset = offset(*rng);
    for (int k = 0; k < num_sessions; ++k) {
      SiteError& e = errors[static_cast<std::size_t>(s * num_sessions + k)];
      e.site_id = fmt::format("s{}", s);
      e.session = fmt::format("d{}", k);
      e.error_m = site_offset + noise(*rng);
    }
  }
  return errors;
}

double Rmse(const std::vector<SiteError>& errors) {
  double sum = 0.0;
  int n = 0;
  for (const SiteError& e : errors) {
    if (!std::isfinite(e.error_m)) continue;
    sum += e.error_m * e.error_m;
    ++n;
  }
  return std::sqrt(sum / n);
}

TEST(SiteBootstrap, RmseIntervalCoversTheTrueErrorAtItsLevel) {
  // 200 fields of 12 sites × 4 sessions whose site errors have an RMS of 2 cm (1.5 cm per
  // session, 1.32 cm per site): the 95 % interval of each field's RMSE should hold the 2 cm in
  // about 95 % of the fields. The percentile bootstrap runs a little short on 12 sites, hence
  // the lower bound of 85 %.
  std::mt19937 rng(7);
  const double sigma = 0.015, site_sigma = std::sqrt(0.02 * 0.02 - sigma * sigma);
  SiteBootstrapOptions options;
  options.resamples = 1000;
  int covered = 0;
  const int fields = 200;
  for (int f = 0; f < fields; ++f) {
    const std::vector<SiteError> errors = DrawErrors(&rng, 12, 4, sigma, site_sigma);
    const BootstrapInterval interval = SiteRmseInterval(errors, options);
    ASSERT_TRUE(interval.valid());
    EXPECT_EQ(interval.num_sites, 12);
    const double rmse = Rmse(errors);
    EXPECT_LE(interval.low, rmse);
    EXPECT_GE(interval.high, rmse);
    if (interval.low <= 0.02 && 0.02 <= interval.high) ++covered;
  }
  EXPECT_GE(covered, 0.85 * fields);
  EXPECT_LE(covered, 0.99 * fields);
}

TEST(SiteBootstrap, IntervalRepeatsAndFollowsTheSeed) {
  std::mt19937 rng(3);
  const std::vector<SiteError> errors = DrawErrors(&rng, 10, 3, 0.02, 0.01);
  const BootstrapInterval a = SiteRmseInterval(errors), b = SiteRmseInterval(errors);
  EXPECT_EQ(a.low, b.low);
  EXPECT_EQ(a.high, b.high);
  EXPECT_EQ(a.resamples, 2000);
  EXPECT_EQ(a.level, 0.95);
  SiteBootstrapOptions other;
  other.seed = 2;
  const BootstrapInterval c = SiteRmseInterval(errors, other);
  EXPECT_NE(a.low, c.low);
  EXPECT_NEAR(a.low, c.low, 0.003);  // another seed, about the same interval
}

TEST(SiteBootstrap, MissingEstimatesAndTooFewSites) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  // A site whose every estimate is missing is no site of the draw.
  const std::vector<SiteError> errors = {
      {"a", "1", 0.01}, {"a", "2", 0.02}, {"b", "1", -0.03}, {"c", "1", nan}, {"c", "2", nan}};
  const BootstrapInterval interval = SiteRmseInterval(errors);
  ASSERT_TRUE(interval.valid());
  EXPECT_EQ(interval.num_sites, 2);
  // Every draw is one of aa, ab, ba, bb: the RMSE lies between site a's and site b's.
  EXPECT_GE(interval.low, std::sqrt((1e-4 + 4e-4) / 2.0) - 1e-12);
  EXPECT_LE(interval.high, 0.03 + 1e-12);
  // One site: no interval.
  EXPECT_FALSE(SiteRmseInterval({{"a", "1", 0.01}, {"a", "2", 0.02}}).valid());
  EXPECT_FALSE(SiteRmseInterval({}).valid());
  SiteBootstrapOptions bad;
  bad.level = 1.0;
  EXPECT_FALSE(bad.Check().empty());
  bad.level = 0.9;
  bad.resamples = 0;
  EXPECT_FALSE(bad.Check().empty());
  EXPECT_TRUE(SiteBootstrapOptions{}.Check().empty());
}

TEST(SiteBootstrap, PairedRatioOfTwoRuns) {
  std::mt19937 rng(11);
  const std::vector<SiteError> a = DrawErrors(&rng, 12, 4, 0.015, 0.01);
  // The same run: the ratio is 1 on every draw.
  const RmseRatio same = PairedRmseRatio(a, a);
  EXPECT_EQ(same.num_pairs, 48);
  EXPECT_DOUBLE_EQ(same.ratio, 1.0);
  EXPECT_DOUBLE_EQ(same.interval.low, 1.0);
  EXPECT_DOUBLE_EQ(same.interval.high, 1.0);
  // Every error 20 % larger: 1.2 on every draw, though each run's own interval is wide.
  std::vector<SiteError> b = a;
  for (SiteError& e : b) e.error_m *= 1.2;
  const RmseRatio scaled = PairedRmseRatio(a, b);
  EXPECT_NEAR(scaled.ratio, 1.2, 1e-12);
  EXPECT_NEAR(scaled.interval.low, 1.2, 1e-12);
  EXPECT_NEAR(scaled.interval.high, 1.2, 1e-12);
  EXPECT_GT(SiteRmseInterval(b).high - SiteRmseInterval(b).low, 0.002);
  // b = a plus noise of its own: the paired interval holds the ratio and is narrower, relative
  // to the RMSE, than the unpaired interval of either run.
  std::normal_distribution<double> noise(0.0, 0.005);
  for (SiteError& e : b) e.error_m = e.error_m / 1.2 + noise(rng);
  const RmseRatio noisy = PairedRmseRatio(a, b);
  EXPECT_LE(noisy.interval.low, noisy.ratio);
  EXPECT_GE(noisy.interval.high, noisy.ratio);
  const BootstrapInterval own = SiteRmseInterval(a);
  EXPECT_LT(noisy.interval.high - noisy.interval.low, (own.high - own.low) / Rmse(a));
  EXPECT_NEAR(noisy.rmse_a_m, Rmse(a), 1e-12);
  EXPECT_NEAR(noisy.rmse_b_m, Rmse(b), 1e-12);
}

TEST(SiteBootstrap, PairedRatioOnlyOnPairsBothRunsMeasured) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const std::vector<SiteError> a = {{"x", "1", 0.01}, {"x", "2", 0.02}, {"y", "1", 0.03}};
  const std::vector<SiteError> b = {{"x", "1", 0.02}, {"x", "2", nan}, {"z", "1", 0.5}};
  const RmseRatio r = PairedRmseRatio(a, b);
  EXPECT_EQ(r.num_pairs, 1);  // (x, 1) only
  EXPECT_NEAR(r.ratio, 2.0, 1e-12);
  EXPECT_FALSE(r.interval.valid());  // one site
  EXPECT_EQ(PairedRmseRatio(a, {}).num_pairs, 0);
  EXPECT_TRUE(std::isnan(PairedRmseRatio(a, {}).ratio));
}

}  // namespace
}  // namespace crop4d::eval
