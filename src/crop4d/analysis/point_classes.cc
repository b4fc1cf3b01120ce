#include "crop4d/analysis/point_classes.h"

#include <cmath>
#include <vector>

#include "crop4d/analysis/lone_points.h"

namespace crop4d::analysis {

void ClassifyPoints(const PointClassRule& a, double threshold, bool dense,
                    const io::PlyPointCloud& cloud, io::LasPoint* points) {
  const io::UtmGrid& grid = a.dtm.grid;
  std::vector<std::uint8_t> lone;
  bool finite = true;
  for (const Eigen::Vector3d& p : cloud.points) finite = finite && p.allFinite();
  if (dense && a.lone_point_radius_m > 0 && finite) {
    lone = FindLonePoints(cloud.points, a.lone_point_radius_m);
  }
  const bool colours = cloud.colors.size() == cloud.points.size();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    io::LasPoint& p = points[i];
    p.classification = io::kAsprsUnclassified;
    if (!lone.empty() && lone[i]) continue;
    const double col = std::floor((p.xyz.x() - grid.min_easting) / grid.cell_m);
    const double row = std::floor((grid.max_northing - p.xyz.y()) / grid.cell_m);
    if (!(col >= 0 && row >= 0 && col < grid.width && row < grid.height)) continue;
    const float ground = a.dtm.values[std::size_t(row) * grid.width + std::size_t(col)];
    if (!std::isfinite(ground) || (a.dtm.nodata && ground == *a.dtm.nodata)) continue;
    const double h = p.xyz.z() - ground;
    const bool vegetation = colours && Greenness(a.index, cloud.colors[i][0], cloud.colors[i][1],
                                                 cloud.colors[i][2]) > threshold;
    if (a.canopy.IsCanopy(vegetation, h)) {
      p.classification = io::AsprsVegetationClass(h);
    } else if (h >= -kBelowTerrainM) {
      p.classification = io::kAsprsGround;
    }
  }
}

}  // namespace crop4d::analysis
