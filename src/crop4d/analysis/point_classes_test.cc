// Point classes on a hand-made terrain model: ground, vegetation by colour and by height, below
// the terrain, outside it, on nodata, and the lone points of a dense cloud.

#include "crop4d/analysis/point_classes.h"

#include <gtest/gtest.h>

#include <cmath>

namespace crop4d::analysis {
namespace {

// A flat terrain at 100 m over 10 × 10 cells of 1 m from (500000, 4000010) south-east; the
// cell (col 9, row 9) has no height.
PointClassRule Rule() {
  PointClassRule rule;
  rule.dtm.grid.epsg = 32617;
  rule.dtm.grid.min_easting = 500000.0;
  rule.dtm.grid.max_northing = 4000010.0;
  rule.dtm.grid.cell_m = 1.0;
  rule.dtm.grid.width = rule.dtm.grid.height = 10;
  rule.dtm.values.assign(100, 100.0f);
  rule.dtm.values[99] = std::nanf("");
  rule.lone_point_radius_m = 0.05;
  return rule;
}

constexpr std::array<std::uint8_t, 3> kGreen = {60, 140, 50}, kSoil = {150, 126, 104};

// Classifies points (easting offset, northing offset, height above 100 m, colour).
std::vector<std::uint8_t> Classes(
    const PointClassRule& rule, bool dense,
    const std::vector<std::pair<Eigen::Vector3d, std::array<std::uint8_t, 3>>>& in) {
  io::PlyPointCloud cloud;
  std::vector<io::LasPoint> points(in.size());
  for (std::size_t i = 0; i < in.size(); ++i) {
    const Eigen::Vector3d& d = in[i].first;
    cloud.points.push_back(d);  // the lone-point search works in any metric frame
    cloud.colors.push_back(in[i].second);
    points[i].xyz = Eigen::Vector3d(500000.0 + d.x(), 4000000.0 + d.y(), 100.0 + d.z());
  }
  ClassifyPoints(rule, 0.1, dense, cloud, points.data());
  std::vector<std::uint8_t> classes;
  for (const io::LasPoint& p : points) classes.push_back(p.classification);
  return classes;
}

TEST(PointClassesTest, GroundVegetationAndUnclassified) {
  const PointClassRule rule = Rule();
  const std::vector<std::uint8_t> c =
      Classes(rule, false,
              {{{2.5, 2.5, 0.0}, kSoil},    // ground
               {{2.5, 2.6, 0.03}, kGreen},  // green, 3 cm: low veg
               {{2.5, 2.7, 0.03}, kSoil},   // soil colour, 3 cm: ground
               {{2.5, 2.8, 0.3}, kSoil},    // any colour, 30 cm: veg
               {{2.5, 2.9, 1.0}, kGreen},   // 1 m: medium
               {{3.5, 2.5, 2.5}, kGreen},   // 2.5 m: high
               {{3.5, 3.5, -0.05}, kSoil},  // just below: ground
               {{3.5, 4.5, -0.2}, kSoil},   // 20 cm below
               {{20.0, 2.5, 0.0}, kSoil},   // outside the DTM
               {{9.5, 0.5, 0.0}, kSoil}});  // nodata cell
  EXPECT_EQ(
      c, (std::vector<std::uint8_t>{
             io::kAsprsGround, io::kAsprsLowVegetation, io::kAsprsGround, io::kAsprsLowVegetation,
             io::kAsprsMediumVegetation, io::kAsprsHighVegetation, io::kAsprsGround,
             io::kAsprsUnclassified, io::kAsprsUnclassified, io::kAsprsUnclassified}));
}

TEST(PointClassesTest, LonePointsOfADenseCloudAreUnclassified) {
  const PointClassRule rule = Rule();
  // Two points 1 cm apart and one alone 1 m away.
  const std::vector<std::pair<Eigen::Vector3d, std::array<std::uint8_t, 3>>> in = {
      {{1.5, 1.5, 0.0}, kSoil}, {{1.51, 1.5, 0.0}, kSoil}, {{2.5, 1.5, 0.0}, kSoil}};
  EXPECT_EQ(Classes(rule, true, in), (std::vector<std::uint8_t>{io::kAsprsGround, io::kAsprsGround,
                                                                io::kAsprsUnclassified}));
  // A sparse cloud keeps them all.
  EXPECT_EQ(Classes(rule, false, in), (std::vector<std::uint8_t>(3, io::kAsprsGround)));
}

}  // namespace
}  // namespace crop4d::analysis
