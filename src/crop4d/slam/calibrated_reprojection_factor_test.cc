#include "crop4d/slam/calibrated_reprojection_factor.h"

#include <gtest/gtest.h>

#include <vector>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/camera_test_util.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/state_layout.h"
#include "crop4d/slam/time_offset_reprojection_factor.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

template <typename V>
std::vector<double> Vec(const V& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}
std::vector<double> Vec(const double* v, int n) { return std::vector<double>(v, v + n); }

// A forward-looking camera tilted down, a moving and turning body, a point 4 m in front.
struct Rig {
  geometry::PinholeRadTan camera = testing::DistortedTestCamera();
  Rigid3 body_from_camera = testing::TestBodyFromCamera();
  Rigid3 world_from_body{geometry::ExpQuat(Eigen::Vector3d(0.02, -0.03, 0.8)),
                         Eigen::Vector3d(2.0, 1.0, 0.1)};
  TimeOffsetReprojectionFactor::FixedMotion motion{Eigen::Vector3d(1.1, 0.4, -0.05),
                                                   Eigen::Vector3d(0.05, -0.08, 0.3)};
  Eigen::Vector3d point_world = world_from_body * body_from_camera * Eigen::Vector3d(0.9, 0.5, 4.0);
  // A calibration off the nominal one: every intrinsic and the rotation changed.
  CameraCalibrationBlocks Changed() const {
    CameraCalibrationBlocks b = CameraCalibrationBlocks::From(camera);
    const double change[6] = {4.0, -3.0, 2.5, -1.5, 0.01, -0.005};
    for (int i = 0; i < 6; ++i) b.intrinsics[i] += change[i];
    b.rotation[0] = 0.004;
    b.rotation[1] = -0.006;
    b.rotation[2] = 0.003;
    b.lever_arm[0] = 0.02;
    b.lever_arm[1] = -0.015;
    b.lever_arm[2] = 0.01;
    return b;
  }
};

bool Evaluate(const ceres::CostFunction& f, const Vector7d& pose, const Eigen::Vector3d& point,
              double td, const CameraCalibrationBlocks& calibration, Eigen::Vector2d* r) {
  const double* params[6] = {
      pose.data(),          point.data(),         &td, calibration.intrinsics,
      calibration.rotation, calibration.lever_arm};
  return f.Evaluate(params, r->data(), nullptr);
}

bool EvaluateTimeOffset(const ceres::CostFunction& f, const Vector7d& pose,
                        const Eigen::Vector3d& point, double td, Eigen::Vector2d* r) {
  const double* params[3] = {pose.data(), point.data(), &td};
  return f.Evaluate(params, r->data(), nullptr);
}

// At the calibrated values it is the time-offset factor, residual and Jacobians alike.
TEST(CalibratedReprojectionFactor, AtTheCalibrationItIsTheTimeOffsetFactor) {
  const Rig s;
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(s.world_from_body);
  const Eigen::Vector2d pixel(700.0, 500.0);
  const CalibratedReprojectionFactor factor(s.camera, s.body_from_camera, pixel, 1.5, s.motion);
  const TimeOffsetReprojectionFactor plain(s.camera, s.body_from_camera, pixel, 1.5, s.motion);
  const CameraCalibrationBlocks nominal = CameraCalibrationBlocks::From(s.camera);
  for (const double td : {0.0, 0.03}) {
    Eigen::Vector2d r, r_plain;
    ASSERT_TRUE(Evaluate(factor, pose, s.point_world, td, nominal, &r));
    ASSERT_TRUE(EvaluateTimeOffset(plain, pose, s.point_world, td, &r_plain));
    EXPECT_LT((r - r_plain).norm(), 1e-12);
    const testing::JacobianCheckResult a = testing::CheckJacobians(
        factor,
        {Vec(pose), Vec(s.point_world), std::vector<double>{td}, Vec(nominal.intrinsics, 6),
         Vec(nominal.rotation, 3), Vec(nominal.lever_arm, 3)},
        {&manifold, nullptr, nullptr, nullptr, nullptr, nullptr});
    const testing::JacobianCheckResult b =
        testing::CheckJacobians(plain, {Vec(pose), Vec(s.point_world), std::vector<double>{td}},
                                {&manifold, nullptr, nullptr});
    for (int i = 0; i < 3; ++i) EXPECT_LT((a.analytic[i] - b.analytic[i]).norm(), 1e-9) << i;
  }
}

// Changed blocks project as the camera and T_BS that CameraCalibrationBlocks gives back: what
// the joint problem writes is what it solved.
TEST(CalibratedReprojectionFactor, ChangedBlocksProjectThroughTheCameraTheyDescribe) {
  const Rig s;
  const Vector7d pose = PoseToBlock(s.world_from_body);
  const CameraCalibrationBlocks changed = s.Changed();
  const geometry::PinholeRadTan camera = changed.Camera(s.camera);
  const Rigid3 body_from_camera = changed.BodyFromCamera(s.body_from_camera);
  EXPECT_EQ(camera.p1, s.camera.p1);
  EXPECT_EQ(camera.k3, s.camera.k3);
  EXPECT_EQ(camera.fx, s.camera.fx + 4.0);
  EXPECT_LT((body_from_camera.translation() - s.body_from_camera.translation() -
             Eigen::Vector3d(0.02, -0.015, 0.01))
                .norm(),
            1e-15);
  const double td = 0.02;
  const Rigid3 capture =
      BodyAtCapture(s.world_from_body, s.motion.vel_world, s.motion.rate_body, td);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.Project((capture * body_from_camera).Inverse() * s.point_world, &pixel));
  const CalibratedReprojectionFactor factor(s.camera, s.body_from_camera,
                                            pixel + Eigen::Vector2d(3.0, -4.0), 2.0, s.motion);
  Eigen::Vector2d r;
  ASSERT_TRUE(Evaluate(factor, pose, s.point_world, td, changed, &r));
  EXPECT_LT((r - Eigen::Vector2d(-1.5, 2.0)).norm(), 1e-9);
  // The change is visible: through the nominal calibration the pixel is several pixels away.
  ASSERT_TRUE(
      Evaluate(factor, pose, s.point_world, td, CameraCalibrationBlocks::From(s.camera), &r));
  EXPECT_GT((r - Eigen::Vector2d(-1.5, 2.0)).norm(), 2.0);
  // Behind the camera: evaluation fails.
  const Eigen::Vector3d behind = s.world_from_body * s.body_from_camera * Eigen::Vector3d(0, 0, -2);
  EXPECT_FALSE(Evaluate(factor, pose, behind, td, changed, &r));
}

TEST(CalibratedReprojectionFactor, JacobiansMatchNumericalDerivatives) {
  const Rig s;
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(s.world_from_body);
  const CalibratedReprojectionFactor factor(s.camera, s.body_from_camera,
                                            Eigen::Vector2d(710.0, 540.0), 1.5, s.motion);
  for (const CameraCalibrationBlocks& calibration :
       {CameraCalibrationBlocks::From(s.camera), s.Changed()}) {
    for (const double td : {0.0, -0.04}) {
      const testing::JacobianCheckResult check = testing::CheckJacobians(
          factor,
          {Vec(pose), Vec(s.point_world), std::vector<double>{td}, Vec(calibration.intrinsics, 6),
           Vec(calibration.rotation, 3), Vec(calibration.lever_arm, 3)},
          {&manifold, nullptr, nullptr, nullptr, nullptr, nullptr});
      EXPECT_LT(check.max_relative_error, 1e-6) << "td " << td;
      // Every intrinsic, every rotation axis and every lever-arm axis moves the projection.
      for (int c = 0; c < 6; ++c) EXPECT_GT(check.analytic[3].col(c).norm(), 1e-3) << c;
      for (int c = 0; c < 3; ++c) EXPECT_GT(check.analytic[4].col(c).norm(), 1.0) << c;
      for (int c = 0; c < 3; ++c) EXPECT_GT(check.analytic[5].col(c).norm(), 1.0) << c;
    }
  }
}

}  // namespace
}  // namespace crop4d::slam
