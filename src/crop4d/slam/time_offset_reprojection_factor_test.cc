#include "crop4d/slam/time_offset_reprojection_factor.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/camera_test_util.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/reprojection_factor.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

struct Rig {
  geometry::PinholeRadTan camera = testing::DistortedTestCamera();
  Rigid3 body_from_camera = testing::TestBodyFromCamera();
  Rigid3 world_from_body{geometry::ExpQuat(Eigen::Vector3d(0.02, -0.03, 0.8)),
                         Eigen::Vector3d(2.0, 1.0, 0.1)};
  Eigen::Vector3d vel{1.1, 0.4, -0.05};
  Eigen::Vector3d rate{0.05, -0.08, 0.3};
  Eigen::Vector3d point_world = world_from_body * body_from_camera * Eigen::Vector3d(0.6, 0.3, 4.0);
};

bool Evaluate(const ceres::CostFunction& f, const Vector7d& pose, const Eigen::Vector3d& vel,
              const Eigen::Vector3d& rate, const Eigen::Vector3d& point, double td,
              Eigen::Vector2d* r) {
  const double* params[5] = {pose.data(), vel.data(), rate.data(), point.data(), &td};
  return f.Evaluate(params, r->data(), nullptr);
}

TEST(TimeOffsetReprojectionFactor, ProjectsFromThePoseAtTheCaptureInstant) {
  const Rig s;
  const double td = 0.04;
  // The pixel as seen from the predicted pose at stamp + td, plus a known offset.
  const Rigid3 capture = BodyAtCapture(s.world_from_body, s.vel, s.rate, td);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(s.camera.Project((capture * s.body_from_camera).Inverse() * s.point_world, &pixel));
  const TimeOffsetReprojectionFactor factor(s.camera, s.body_from_camera,
                                            pixel + Eigen::Vector2d(3.0, -4.0), 2.0);
  const Vector7d pose = PoseToBlock(s.world_from_body);
  Eigen::Vector2d r;
  ASSERT_TRUE(Evaluate(factor, pose, s.vel, s.rate, s.point_world, td, &r));
  EXPECT_LT((r - Eigen::Vector2d(-1.5, 2.0)).norm(), 1e-9);
  // The motion over td moves the projection by several pixels: the offset is observable.
  ASSERT_TRUE(Evaluate(factor, pose, s.vel, s.rate, s.point_world, 0.0, &r));
  EXPECT_GT((r - Eigen::Vector2d(-1.5, 2.0)).norm(), 5.0);

  // With td = 0 it is the plain reprojection factor.
  const ReprojectionFactor plain(s.camera, s.body_from_camera, pixel, 2.0);
  const TimeOffsetReprojectionFactor offset(s.camera, s.body_from_camera, pixel, 2.0);
  const double* plain_params[2] = {pose.data(), s.point_world.data()};
  Eigen::Vector2d r_plain, r_offset;
  ASSERT_TRUE(plain.Evaluate(plain_params, r_plain.data(), nullptr));
  ASSERT_TRUE(Evaluate(offset, pose, s.vel, s.rate, s.point_world, 0.0, &r_offset));
  EXPECT_LT((r_plain - r_offset).norm(), 1e-12);

  // Behind the camera: evaluation fails.
  const Eigen::Vector3d behind = s.world_from_body * s.body_from_camera * Eigen::Vector3d(0, 0, -2);
  EXPECT_FALSE(Evaluate(factor, pose, s.vel, s.rate, behind, td, &r));
}

TEST(TimeOffsetReprojectionFactor, JacobiansMatchNumericalDerivatives) {
  const Rig s;
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(s.world_from_body);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(
      s.camera.Project((s.world_from_body * s.body_from_camera).Inverse() * s.point_world, &pixel));
  const TimeOffsetReprojectionFactor factor(s.camera, s.body_from_camera,
                                            pixel + Eigen::Vector2d(1.0, 2.0), 1.5);
  // Positive, negative and zero offsets (at zero the rate's Jacobian vanishes), and a fast turn.
  for (const double td : {0.03, -0.12, 0.0}) {
    for (const double yaw_rate : {0.3, 2.5}) {
      const Eigen::Vector3d rate(0.05, -0.08, yaw_rate);
      const testing::JacobianCheckResult check = testing::CheckJacobians(
          factor, {Vec(pose), Vec(s.vel), Vec(rate), Vec(s.point_world), std::vector<double>{td}},
          {&manifold, nullptr, nullptr, nullptr, nullptr});
      EXPECT_LT(check.max_relative_error, 1e-6) << "td " << td << ", yaw rate " << yaw_rate;
      // The time offset's column is not zero: it is observed through the motion.
      EXPECT_GT(check.analytic[4].norm(), 1.0);
    }
  }
}

// With the motion fixed: the same residual, and the pose, point and td Jacobians of the full
// factor.
TEST(TimeOffsetReprojectionFactor, FixedMotionAgreesWithTheFullFactor) {
  const Rig s;
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(s.world_from_body);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(
      s.camera.Project((s.world_from_body * s.body_from_camera).Inverse() * s.point_world, &pixel));
  TimeOffsetReprojectionFactor::FixedMotion motion;
  motion.vel_world = s.vel;
  motion.rate_body = s.rate;
  const TimeOffsetReprojectionFactor full(s.camera, s.body_from_camera, pixel, 1.5);
  const TimeOffsetReprojectionFactor fixed(s.camera, s.body_from_camera, pixel, 1.5, motion);
  ASSERT_EQ(fixed.parameter_block_sizes(), (std::vector<std::int32_t>{7, 3, 1}));
  for (const double td : {0.03, -0.12}) {
    const testing::JacobianCheckResult check_fixed =
        testing::CheckJacobians(fixed, {Vec(pose), Vec(s.point_world), std::vector<double>{td}},
                                {&manifold, nullptr, nullptr});
    EXPECT_LT(check_fixed.max_relative_error, 1e-6) << "td " << td;
    const testing::JacobianCheckResult check_full = testing::CheckJacobians(
        full, {Vec(pose), Vec(s.vel), Vec(s.rate), Vec(s.point_world), std::vector<double>{td}},
        {&manifold, nullptr, nullptr, nullptr, nullptr});
    EXPECT_LT((check_fixed.analytic[0] - check_full.analytic[0]).norm(), 1e-9);
    EXPECT_LT((check_fixed.analytic[1] - check_full.analytic[3]).norm(), 1e-9);
    EXPECT_LT((check_fixed.analytic[2] - check_full.analytic[4]).norm(), 1e-9);
    Eigen::Vector2d r_full, r_fixed;
    ASSERT_TRUE(Evaluate(full, pose, s.vel, s.rate, s.point_world, td, &r_full));
    const double* params[3] = {pose.data(), s.point_world.data(), &td};
    ASSERT_TRUE(fixed.Evaluate(params, r_fixed.data(), nullptr));
    EXPECT_LT((r_full - r_fixed).norm(), 1e-12);
  }
}

TEST(TimeOffsetReprojectionFactor, BodyAtCaptureIsFirstOrderMotion) {
  const Rig s;
  const Rigid3 at = BodyAtCapture(s.world_from_body, s.vel, s.rate, 0.1);
  EXPECT_LT((at.translation() - s.world_from_body.translation() - 0.1 * s.vel).norm(), 1e-12);
  // The rotation turns by |ω| td about the body-frame rate axis.
  const Eigen::Quaterniond delta = s.world_from_body.rotation().conjugate() * at.rotation();
  EXPECT_LT((geometry::LogQuat(delta) - 0.1 * s.rate).norm(), 1e-12);
}

TEST(TimeOffsetReprojectionFactor, RejectsInvalidSigma) {
  const Rig s;
  EXPECT_THROW(
      TimeOffsetReprojectionFactor(s.camera, s.body_from_camera, Eigen::Vector2d(1, 1), 0.0),
      std::invalid_argument);
}

}  // namespace
}  // namespace crop4d::slam
