#include "crop4d/slam/stream_coverage.h"

#include <algorithm>
#include <limits>

namespace crop4d::slam {

TimeGaps FindTimeGaps(const std::vector<Timestamp>& sorted, Timestamp begin, Timestamp end,
                      double threshold_s) {
  TimeGaps gaps;
  Timestamp previous = begin;
  auto add = [&](Timestamp t) {
    const double gap = DurationSeconds(previous, t);
    gaps.longest_s = std::max(gaps.longest_s, gap);
    if (gap > threshold_s) ++gaps.count_over;
    previous = t;
  };
  for (auto it = std::lower_bound(sorted.begin(), sorted.end(), begin);
       it != sorted.end() && *it <= end; ++it) {
    add(*it);
  }
  add(end);
  return gaps;
}

double MedianSigmaH(const std::vector<GpsFixWorld>& fixes) { return SigmaHQuantile(fixes, 0.5); }

double SigmaHQuantile(const std::vector<GpsFixWorld>& fixes, double q) {
  if (fixes.empty()) return std::numeric_limits<double>::infinity();
  std::vector<double> sigmas;
  sigmas.reserve(fixes.size());
  for (const GpsFixWorld& fix : fixes) sigmas.push_back(fix.sigma_h);
  const std::size_t k = std::min(sigmas.size() - 1,
                                 static_cast<std::size_t>(std::clamp(q, 0.0, 1.0) * sigmas.size()));
  std::nth_element(sigmas.begin(), sigmas.begin() + k, sigmas.end());
  return sigmas[k];
}

}  // namespace crop4d::slam
