#pragma once

// A bucket grid over horizontal positions, for the evaluation's neighbourhood queries (ground
// misalignment, dense-cloud plant tops).

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <limits>
#include <utility>
#include <vector>

namespace crop4d::eval {

// Points in square cells of side `cell` on the horizontal plane: the points within `cell` of a
// position lie in its cell and the eight around it.
class Grid2d {
 public:
  Grid2d(const std::vector<Eigen::Vector2d>& xy, double cell) : cell_(cell) {
    entries_.reserve(xy.size());
    for (std::size_t i = 0; i < xy.size(); ++i) {
      entries_.emplace_back(Key(CellOf(xy[i].x()), CellOf(xy[i].y())), static_cast<int>(i));
    }
    std::sort(entries_.begin(), entries_.end());
  }

  // Calls f(index) for every point in the 3×3 cells around (x, y).
  template <typename F>
  void ForNear(double x, double y, F&& f) const {
    const std::int64_t cx = CellOf(x), cy = CellOf(y);
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const std::int64_t key = Key(cx + dx, cy + dy);
        auto it = std::lower_bound(entries_.begin(), entries_.end(),
                                   std::make_pair(key, std::numeric_limits<int>::min()));
        for (; it != entries_.end() && it->first == key; ++it) f(it->second);
      }
    }
  }

 private:
  std::int64_t CellOf(double v) const { return static_cast<std::int64_t>(std::floor(v / cell_)); }
  static std::int64_t Key(std::int64_t cx, std::int64_t cy) {
    // Fields are far smaller than 2^31 cells on a side.
    return (cx + (std::int64_t{1} << 31)) << 32 | ((cy + (std::int64_t{1} << 31)) & 0xffffffff);
  }

  double cell_;
  std::vector<std::pair<std::int64_t, int>> entries_;
};

}  // namespace crop4d::eval
