// The plant tops' search ceiling from a sparse cloud (SparseCanopyCeiling) and the count of
// dense points that reach it (PointsNearCeiling), on in-memory clouds.

#include "crop4d/dense/ground_levels.h"

#include <gtest/gtest.h>

#include <vector>

namespace crop4d::dense {
namespace {

// Flat soil at z = 0.05 over [0, 2] × [0, 1] and, in the middle, plant points up to
// `plant_height_m` above it (evenly spread heights: the quantile is known).
std::vector<Eigen::Vector3d> SoilAndPlants(double plant_height_m, int plant_points) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 200; ++i) {
    for (int j = 0; j < 100; j += 4) {
      const double x = 0.01 * i + 0.005, y = 0.01 * j + 0.005;
      points.emplace_back(x, y, 0.05);
    }
  }
  for (int k = 0; k < plant_points; ++k) {
    const double x = 1.0 + 0.001 * (k % 100), y = 0.5;
    points.emplace_back(x, y, 0.05 + plant_height_m * (k + 1) / plant_points);
  }
  return points;
}

GroundLevels Ground(const std::vector<Eigen::Vector3d>& points) {
  return GroundLevels(points, Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 1)),
                      GroundLevels::Options{});
}

const Eigen::AlignedBox2d kField(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 1));

TEST(CanopyCeilingTest, ScalesTheSparseQuantileAboveTheGround) {
  // 5 000 soil points and 1 000 plant points up to 0.3 m: the 99.5 % quantile of all 6 000
  // heights is the plant point of rank 970, at 0.291 m.
  const std::vector<Eigen::Vector3d> points = SoilAndPlants(0.3, 1000);
  const GroundLevels ground = Ground(points);
  CanopyCeilingOptions options;
  const CanopyCeiling c = SparseCanopyCeiling(points, ground, kField, options, 1.0);
  EXPECT_EQ(c.num_points, 6000);
  EXPECT_NEAR(c.quantile_height_m, 0.291, 0.002);
  EXPECT_NEAR(c.ceiling_m, 2.0 * c.quantile_height_m + 0.1, 1e-12);
  // Capped at the fixed range's top.
  EXPECT_DOUBLE_EQ(SparseCanopyCeiling(points, ground, kField, options, 0.5).ceiling_m, 0.5);
}

TEST(CanopyCeilingTest, BareSoilKeepsTheLeastCeiling) {
  const std::vector<Eigen::Vector3d> points = SoilAndPlants(0.0, 0);
  const GroundLevels ground = Ground(points);
  const CanopyCeiling c = SparseCanopyCeiling(points, ground, kField, CanopyCeilingOptions{}, 1.0);
  EXPECT_NEAR(c.quantile_height_m, 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.ceiling_m, 0.25);
}

TEST(CanopyCeilingTest, OnlyThePointsInsideTheBoxAndNoneGivesTheFixedRange) {
  std::vector<Eigen::Vector3d> points = SoilAndPlants(0.1, 200);
  const GroundLevels ground = Ground(points);
  // Tall points outside the box (the tree line) do not raise the ceiling.
  for (int k = 0; k < 1000; ++k) points.emplace_back(1.9, 0.9, 5.0);
  const Eigen::AlignedBox2d box(Eigen::Vector2d(0, 0), Eigen::Vector2d(1.5, 0.8));
  const CanopyCeiling c = SparseCanopyCeiling(points, ground, box, CanopyCeilingOptions{}, 1.0);
  EXPECT_LT(c.ceiling_m, 0.35);
  const CanopyCeiling none = SparseCanopyCeiling(
      points, ground, Eigen::AlignedBox2d(Eigen::Vector2d(5, 5), Eigen::Vector2d(6, 6)),
      CanopyCeilingOptions{}, 1.0);
  EXPECT_EQ(none.num_points, 0);
  EXPECT_DOUBLE_EQ(none.ceiling_m, 1.0);
}

TEST(CanopyCeilingTest, CountsTheDensePointsNearTheCeiling) {
  const std::vector<Eigen::Vector3d> sparse = SoilAndPlants(0.0, 0);
  const GroundLevels ground = Ground(sparse);
  // Points at 0.10, 0.29, 0.31 and 0.40 m above the ground: three lie within 2 cm below a
  // 0.31 m ceiling or above it.
  std::vector<Eigen::Vector3d> dense;
  for (const double h : {0.10, 0.29, 0.31, 0.40}) dense.emplace_back(1.0, 0.5, 0.05 + h);
  EXPECT_EQ(PointsNearCeiling(dense, ground, 0.31, 0.02), 3);
  EXPECT_EQ(PointsNearCeiling(dense, ground, 0.5, 0.02), 0);
}

}  // namespace
}  // namespace crop4d::dense
