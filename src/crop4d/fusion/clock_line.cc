#include "crop4d/fusion/clock_line.h"

#include <cmath>

namespace crop4d::fusion {

std::optional<std::array<double, 2>> FitClockLine(const std::vector<double>& times_ks,
                                                  const std::vector<double>& offsets_s) {
  const std::size_t n = times_ks.size();
  if (n < 2 || offsets_s.size() != n) return std::nullopt;
  double mean_t = 0.0, mean_td = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    mean_t += times_ks[i] / static_cast<double>(n);
    mean_td += offsets_s[i] / static_cast<double>(n);
  }
  double stt = 0.0, std_ = 0.0;
  for (std::size_t i = 0; i < n; ++i) {
    stt += (times_ks[i] - mean_t) * (times_ks[i] - mean_t);
    std_ += (times_ks[i] - mean_t) * (offsets_s[i] - mean_td);
  }
  // Passes within a millisecond of each other fix no slope.
  const double slope = stt > 1e-12 ? std_ / stt : 0.0;
  return std::array<double, 2>{mean_td - slope * mean_t, slope};
}

}  // namespace crop4d::fusion
