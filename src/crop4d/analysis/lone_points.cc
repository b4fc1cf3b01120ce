#include "crop4d/analysis/lone_points.h"

#include <tbb/parallel_for.h>

#include "crop4d/analysis/point_buckets.h"
#include "crop4d/core/error.h"

namespace crop4d::analysis {

std::vector<std::uint8_t> FindLonePoints(const std::vector<Eigen::Vector3d>& points,
                                         double radius_m, int min_neighbors) {
  CROP4D_CHECK_MSG(radius_m > 0 && min_neighbors >= 1, "FindLonePoints: bad radius or count");
  std::vector<std::uint8_t> lone(points.size(), 0);
  if (points.empty()) return lone;
  // Buckets of the radius: a query visits about 3 × 3 of them.
  const PointBuckets buckets(points, radius_m);
  const double r2 = radius_m * radius_m;
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, points.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      std::vector<std::uint32_t> near;
                      for (std::size_t i = range.begin(); i < range.end(); ++i) {
                        near.clear();
                        buckets.Query(points[i].head<2>(), radius_m, points, &near);
                        int count = 0;
                        for (const std::uint32_t j : near) {
                          if (j != i && (points[j] - points[i]).squaredNorm() <= r2 &&
                              ++count >= min_neighbors) {
                            break;
                          }
                        }
                        lone[i] = count < min_neighbors ? 1 : 0;
                      }
                    });
  return lone;
}

}  // namespace crop4d::analysis
