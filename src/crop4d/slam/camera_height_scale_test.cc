#include "crop4d/slam/camera_height_scale.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {
namespace {

using Rgb = std::array<std::uint8_t, 3>;

// A camera 1.5 m above furrows, driving north along x = 0.3 on a slope rising 2 % to the north;
// beds 6 cm above the furrows every other 0.375 m; green plants on the beds. The deepest soil
// (the furrows) lies 1.5 m below the camera wherever the camera passes.
struct Field {
  std::vector<Eigen::Vector3d> cameras, points;
  std::vector<Rgb> colors;
};

Field MakeField(double scale) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Field f;
  const auto ground = [](double x, double y) {
    const bool bed = std::fmod(x + 10.0, 0.75) < 0.375;
    return 0.02 * y + (bed ? 0.06 : 0.0);
  };
  for (int k = 0; k <= 100; ++k) {
    const double y = 0.2 * k;
    f.cameras.emplace_back(0.3, y, 0.02 * y + 1.5);
  }
  for (int i = 0; i < 3000; ++i) {
    const double x = -1.5 + 3.0 * u(rng), y = -2.0 + 24.0 * u(rng);
    const bool plant = u(rng) < 0.3;
    const double z = ground(x, y) + (plant ? 0.05 + 0.2 * u(rng) : 0.004 * (u(rng) - 0.5));
    f.points.emplace_back(x, y, z);
    f.colors.push_back(plant ? Rgb{60, 140, 50} : Rgb{120, 95, 70});
  }
  // The same field as a pass with a scale error reconstructs it (about its first camera).
  const Eigen::Vector3d origin = f.cameras.front();
  for (Eigen::Vector3d& c : f.cameras) c = origin + scale * (c - origin);
  for (Eigen::Vector3d& p : f.points) p = origin + scale * (p - origin);
  return f;
}

TEST(SoilDepthBelowCamera, DeepestSoilFollowsThePassScale) {
  CameraHeightOptions options;
  options.quantile = 0.95;
  for (const double scale : {1.0, 1.02, 0.985}) {
    const Field f = MakeField(scale);
    const std::optional<SoilDepth> d = SoilDepthBelowCamera(f.cameras, f.points, f.colors, options);
    ASSERT_TRUE(d.has_value());
    // Soil only (no plants, which stand up to 25 cm higher), within 1 m of the track and
    // within its length: about 0.7 × 2/3 × 20/24 of the points.
    EXPECT_GT(d->num_points, 900);
    EXPECT_LT(d->num_points, 1300);
    EXPECT_NEAR(d->depth_m, 1.5 * scale, 0.004) << scale;
  }
}

TEST(SoilDepthBelowCamera, TooFewSoilPointsOrBadInput) {
  Field f = MakeField(1.0);
  CameraHeightOptions options;
  for (Rgb& c : f.colors) c = Rgb{50, 150, 40};  // all green
  EXPECT_FALSE(SoilDepthBelowCamera(f.cameras, f.points, f.colors, options).has_value());
  f.colors.pop_back();
  EXPECT_THROW(SoilDepthBelowCamera(f.cameras, f.points, f.colors, options), std::invalid_argument);
  options.quantile = 1.5;
  EXPECT_THROW(SoilDepthBelowCamera(f.cameras, f.points, f.colors, options), std::invalid_argument);
  EXPECT_FALSE(SoilDepthBelowCamera({f.cameras.front()}, {}, {}, CameraHeightOptions{}));
}

TEST(PassLengthFactor, ResidualAndJacobians) {
  const PassLengthFactor factor(20.0, 0.1);
  const PoseManifold manifold;
  const Vector7d a = PoseToBlock(geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.1, 0.2, 1.3)),
                                                  Eigen::Vector3d(1, 2, 0.5)));
  const Vector7d b = PoseToBlock(geometry::Rigid3(
      geometry::ExpQuat(Eigen::Vector3d(-0.2, 0.1, 1.1)), Eigen::Vector3d(3, 22.3, 0.9)));
  const double* params[] = {a.data(), b.data()};
  double r = 0;
  ASSERT_TRUE(factor.Evaluate(params, &r, nullptr));
  EXPECT_NEAR(r, ((b.head<3>() - a.head<3>()).norm() - 20.0) / 0.1, 1e-12);
  const testing::JacobianCheckResult check = testing::CheckJacobians(
      factor,
      {std::vector<double>(a.data(), a.data() + 7), std::vector<double>(b.data(), b.data() + 7)},
      {&manifold, &manifold});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

TEST(PassLengthFactor, HoldsTwoPositionsAtTheLength) {
  Vector7d a =
      PoseToBlock(geometry::Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d::Zero()));
  Vector7d b = PoseToBlock(
      geometry::Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 19.0, 0.2)));
  ceres::Problem problem;
  problem.AddParameterBlock(a.data(), 7, new PoseManifold);
  problem.AddParameterBlock(b.data(), 7, new PoseManifold);
  problem.SetParameterBlockConstant(a.data());
  problem.AddResidualBlock(PassLengthFactor::Create(20.0, 0.01), nullptr, a.data(), b.data());
  ceres::Solver::Options options;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  EXPECT_NEAR((b.head<3>() - a.head<3>()).norm(), 20.0, 1e-6);
  EXPECT_THROW(PassLengthFactor(0.0, 1.0), std::invalid_argument);
  EXPECT_THROW(PassLengthFactor(1.0, 0.0), std::invalid_argument);
}

}  // namespace
}  // namespace crop4d::slam
