#pragma once

// Ordering sessions and passes as people expect: "row2" before "row10" (core/natural_less.h),
// sessions in recording order where it is known.

#include <algorithm>
#include <string>
#include <vector>

#include "crop4d/core/natural_less.h"

namespace crop4d::eval {

// `names` ordered by their position in `order` (those in it first), the rest in natural order.
inline void SortByOrder(const std::vector<std::string>& order, std::vector<std::string>* names) {
  const auto rank = [&](const std::string& name) {
    const auto it = std::find(order.begin(), order.end(), name);
    return static_cast<std::size_t>(it - order.begin());
  };
  std::stable_sort(names->begin(), names->end(), [&](const std::string& a, const std::string& b) {
    const std::size_t ra = rank(a), rb = rank(b);
    if (ra != rb) return ra < rb;
    return NaturalLess(a, b);
  });
}

}  // namespace crop4d::eval
