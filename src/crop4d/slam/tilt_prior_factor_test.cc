#include "crop4d/slam/tilt_prior_factor.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

TEST(TiltPriorFactor, ResidualIsTheTiltOverSigmaAndJacobiansMatch) {
  const Eigen::Vector3d up_body(0.1, -0.2, 1.0);
  const TiltPriorFactor factor(up_body, 0.05);
  // A pose that holds the axis up: zero residual whatever its heading.
  const Eigen::Quaterniond level =
      Eigen::Quaterniond::FromTwoVectors(up_body.normalized(), Eigen::Vector3d::UnitZ());
  for (double heading : {0.0, 1.0, -2.5}) {
    const Vector7d pose = PoseToBlock(Rigid3(
        geometry::ExpQuat(Eigen::Vector3d(0, 0, heading)) * level, Eigen::Vector3d(4, 5, 6)));
    const double* p = pose.data();
    double r[2];
    ASSERT_TRUE(factor.Evaluate(&p, r, nullptr));
    EXPECT_NEAR(r[0], 0.0, 1e-12);
    EXPECT_NEAR(r[1], 0.0, 1e-12);
  }
  // Tilted by 0.01 rad about the world x axis: |r| = sin(0.01) / 0.05.
  const Vector7d tilted = PoseToBlock(
      Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.01, 0, 0)) * level, Eigen::Vector3d::Zero()));
  const double* p = tilted.data();
  double r[2];
  ASSERT_TRUE(factor.Evaluate(&p, r, nullptr));
  EXPECT_NEAR(std::hypot(r[0], r[1]), std::sin(0.01) / 0.05, 1e-9);

  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(
      Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.3, -0.4, 1.2)), Eigen::Vector3d(1, 2, 3)));
  const testing::JacobianCheckResult check = testing::CheckJacobians(
      factor, {std::vector<double>(pose.data(), pose.data() + 7)}, {&manifold});
  EXPECT_LT(check.max_relative_error, 1e-6);
  EXPECT_THROW(TiltPriorFactor(up_body, 0.0), std::invalid_argument);
}

TEST(TiltPriorFactor, LevelsAPoseAndLeavesItsHeading) {
  const Eigen::Vector3d up_body = Eigen::Vector3d::UnitZ();
  Vector7d pose = PoseToBlock(
      Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.2, -0.1, 0.7)), Eigen::Vector3d(1, 2, 3)));
  ceres::Problem problem;
  problem.AddParameterBlock(pose.data(), 7, new PoseManifold);
  problem.AddResidualBlock(TiltPriorFactor::Create(up_body, 0.1), nullptr, pose.data());
  ceres::Solver::Options options;
  options.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Eigen::Matrix3d R = BlockToPose(pose.data()).RotationMatrix();
  EXPECT_GT((R * up_body).z(), 1.0 - 1e-9);
  // The translation is untouched.
  EXPECT_EQ(pose.head<3>(), Eigen::Vector3d(1, 2, 3));
}

}  // namespace
}  // namespace crop4d::slam
