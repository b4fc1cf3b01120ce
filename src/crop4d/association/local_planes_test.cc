#include "crop4d/association/local_planes.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <numbers>
#include <random>

namespace crop4d::association {
namespace {

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  // Normals have no sign.
  return std::acos(std::min(1.0, std::abs(a.normalized().dot(b.normalized())))) * 180 /
         std::numbers::pi;
}

// Points on a grid of `spacing` over the plane through `origin` with normal `normal`, with
// Gaussian noise along every axis.
std::vector<Eigen::Vector3d> PlanePoints(const Eigen::Vector3d& origin,
                                         const Eigen::Vector3d& normal, int n, double spacing,
                                         double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> gauss(0, noise);
  const Eigen::Vector3d u = normal.unitOrthogonal();
  const Eigen::Vector3d v = normal.normalized().cross(u);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    for (int j = 0; j < n; ++j) {
      points.push_back(origin + (i - n / 2) * spacing * u + (j - n / 2) * spacing * v +
                       Eigen::Vector3d(gauss(rng), gauss(rng), gauss(rng)));
    }
  }
  return points;
}

TEST(LocalPlanesTest, RecoversTheNormalOfATiltedPlane) {
  const Eigen::Vector3d normal = Eigen::Vector3d(0.3, -0.2, 1.0).normalized();
  const std::vector<Eigen::Vector3d> points = PlanePoints({5, 3, 0.2}, normal, 30, 0.05, 0.002, 1);
  const LocalPlanes planes(points);
  ASSERT_EQ(planes.size(), points.size());
  int valid = 0;
  std::vector<double> errors;
  for (std::size_t i = 0; i < planes.size(); ++i) {
    const LocalPlane& plane = planes.plane(i);
    if (!plane.valid) continue;
    ++valid;
    errors.push_back(AngleDeg(plane.normal, normal));
    EXPECT_LT(errors.back(), 6.0) << i;  // 2 mm of noise on neighbours 5–10 cm apart
    EXPECT_NEAR(plane.normal.norm(), 1.0, 1e-9);
    EXPECT_EQ(plane.num_neighbors, 10);
    EXPECT_LT((plane.centroid - points[i]).norm(), 0.1);
  }
  EXPECT_EQ(valid, static_cast<int>(points.size()));
  std::nth_element(errors.begin(), errors.begin() + errors.size() / 2, errors.end());
  EXPECT_LT(errors[errors.size() / 2], 1.5);
  // A fit anywhere near the plane, and PlaneFor with a position that is not point i.
  EXPECT_LT(AngleDeg(planes.FitAt({5.01, 3.02, 0.2}).normal, normal), 3.0);
  const LocalPlane elsewhere = planes.PlaneFor(0, Eigen::Vector3d(5, 3, 0.2));
  EXPECT_TRUE(elsewhere.valid);
  EXPECT_EQ(planes.PlaneFor(7, points[7]).normal, planes.plane(7).normal);
}

TEST(LocalPlanesTest, RejectsBlobsLinesSparseAndNonFinitePoints) {
  std::mt19937 rng(3);
  std::normal_distribution<double> gauss(0, 0.05);
  std::vector<Eigen::Vector3d> blob;
  for (int i = 0; i < 200; ++i) blob.push_back({gauss(rng), gauss(rng), gauss(rng)});
  const LocalPlanes blob_planes(blob);
  int valid = 0;
  for (std::size_t i = 0; i < blob.size(); ++i) valid += blob_planes.plane(i).valid;
  EXPECT_LT(valid, 40);  // an isotropic cloud is no surface (a few chance planar neighbourhoods)

  std::vector<Eigen::Vector3d> line;
  for (int i = 0; i < 50; ++i) line.push_back({0.02 * i, 0.01 * i, 0.001 * (i % 2)});
  const LocalPlanes line_planes(line);
  for (std::size_t i = 0; i < line.size(); ++i) EXPECT_FALSE(line_planes.plane(i).valid) << i;

  // Neighbours farther than max_neighbor_distance_m do not count.
  std::vector<Eigen::Vector3d> sparse =
      PlanePoints({0, 0, 0}, Eigen::Vector3d::UnitZ(), 5, 2.0, 0, 1);
  const LocalPlanes sparse_planes(sparse);
  EXPECT_FALSE(sparse_planes.plane(12).valid);
  EXPECT_LT(sparse_planes.plane(12).num_neighbors, 6);

  // Non-finite points (untriangulated landmarks) keep their index but get no plane, and do not
  // disturb the others.
  std::vector<Eigen::Vector3d> points =
      PlanePoints({0, 0, 0}, Eigen::Vector3d::UnitZ(), 10, 0.05, 0.0, 1);
  points[3] = Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  const LocalPlanes with_nan(points);
  EXPECT_FALSE(with_nan.plane(3).valid);
  EXPECT_TRUE(with_nan.plane(4).valid);
  EXPECT_LT(AngleDeg(with_nan.plane(4).normal, Eigen::Vector3d::UnitZ()), 1e-6);

  const LocalPlanes empty(std::vector<Eigen::Vector3d>{});
  EXPECT_FALSE(empty.FitAt(Eigen::Vector3d::Zero()).valid);
}

}  // namespace
}  // namespace crop4d::association
