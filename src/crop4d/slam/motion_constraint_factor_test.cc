#include "crop4d/slam/motion_constraint_factor.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

TEST(MotionConstraintFactor, ZeroForMotionAlongTheAxisAndSigmaScaled) {
  const Eigen::Vector3d forward(0.99, -0.1, 0.05);
  const Rigid3 pose(geometry::ExpQuat(Eigen::Vector3d(0.05, -0.02, 2.1)), Eigen::Vector3d(3, 4, 1));
  const MotionConstraintFactor factor(forward, 0.1);
  Vector7d block = PoseToBlock(pose);
  // Moving along the forward axis: zero residual.
  Eigen::Vector3d vel = pose.rotation() * forward.normalized() * 1.7;
  const double* params[] = {block.data(), vel.data()};
  Eigen::Vector2d r;
  ASSERT_TRUE(factor.Evaluate(params, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-12);
  // A sideways velocity of 0.3 m/s perpendicular to the axis: |r| = 0.3 / σ.
  const Eigen::Vector3d side = forward.normalized().unitOrthogonal();
  vel += pose.rotation() * side * 0.3;
  ASSERT_TRUE(factor.Evaluate(params, r.data(), nullptr));
  EXPECT_NEAR(r.norm(), 3.0, 1e-9);
}

TEST(MotionConstraintFactor, JacobiansMatchNumericalDifferences) {
  const MotionConstraintFactor factor(Eigen::Vector3d(1, 0.2, -0.1), 0.05);
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(
      Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.3, -0.4, 1.2)), Eigen::Vector3d(1, 2, 3)));
  const std::vector<std::vector<double>> params = {
      std::vector<double>(pose.data(), pose.data() + 7), {0.7, -1.2, 0.3}};
  const testing::JacobianCheckResult check =
      testing::CheckJacobians(factor, params, {&manifold, nullptr});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

TEST(MotionConstraintFactor, RecoversTheHeadingOfAStraightMotion) {
  // Alone with a known world velocity (as GPS gives it), the constraint turns a body whose
  // heading is 20° off until its forward axis points along the velocity.
  const Eigen::Vector3d forward = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d vel_world(0, 1.5, 0);  // north
  const Eigen::Quaterniond truth = geometry::ExpQuat(Eigen::Vector3d(0, 0, M_PI / 2));
  Vector7d pose = PoseToBlock(
      Rigid3(truth * geometry::ExpQuat(Eigen::Vector3d(0, 0, 0.35)), Eigen::Vector3d::Zero()));
  Eigen::Vector3d vel = vel_world;
  ceres::Problem problem;
  problem.AddParameterBlock(pose.data(), 7, new PoseManifold);
  problem.AddResidualBlock(MotionConstraintFactor::Create(forward, 0.05), nullptr, pose.data(),
                           vel.data());
  problem.SetParameterBlockConstant(vel.data());
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_QR;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Eigen::Vector3d forward_world = BlockToPose(pose.data()).rotation() * forward;
  EXPECT_LT(std::acos(std::min(1.0, forward_world.dot(vel_world.normalized()))), 1e-6);
}

}  // namespace
}  // namespace crop4d::slam
