#include "crop4d/analysis/area_tiles.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace crop4d::analysis {

AreaTiling TileArea(const Eigen::AlignedBox2d& area, double tile_m, double reach_m) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  AreaTiling tiling;
  const Eigen::Vector2d size =
      area.isEmpty() ? Eigen::Vector2d(Eigen::Vector2d::Zero()) : Eigen::Vector2d(area.sizes());
  tiling.axis = size.y() > size.x() ? 1 : 0;
  const double length = size[tiling.axis];
  const int n = tile_m > 0.0 && length > tile_m ? static_cast<int>(std::ceil(length / tile_m)) : 1;
  const double start = area.isEmpty() ? 0.0 : area.min()[tiling.axis];
  for (int k = 0; k < n; ++k) {
    AreaTile t;
    t.lo = k == 0 ? -kInf : start + length * k / n;
    t.hi = k + 1 == n ? kInf : start + length * (k + 1) / n;
    t.read_lo = t.lo - reach_m;
    t.read_hi = t.hi + reach_m;
    tiling.tiles.push_back(t);
  }
  return tiling;
}

}  // namespace crop4d::analysis
