#pragma once

// Order statistics for the evaluation's robust summaries (medians, 90th percentiles).

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

namespace crop4d::eval {

// The q-quantile (q in [0, 1]) with linear interpolation between the closest ranks (NumPy's
// default, Hyndman & Fan type 7); NaN for an empty list. Sorts `values` when they are not sorted
// yet, so that several quantiles of one list cost one sort.
inline double Quantile(std::vector<double>* values, double q) {
  if (values->empty()) return std::numeric_limits<double>::quiet_NaN();
  if (!std::is_sorted(values->begin(), values->end())) std::sort(values->begin(), values->end());
  const double position = std::clamp(q, 0.0, 1.0) * static_cast<double>(values->size() - 1);
  const std::size_t lo = static_cast<std::size_t>(std::floor(position));
  const std::size_t hi = std::min(lo + 1, values->size() - 1);
  const double f = position - static_cast<double>(lo);
  return (*values)[lo] * (1.0 - f) + (*values)[hi] * f;
}

}  // namespace crop4d::eval
