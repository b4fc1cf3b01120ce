#include "crop4d/slam/calibrated_reprojection_factor.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/reprojection_factor.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

CameraCalibrationBlocks CameraCalibrationBlocks::From(const geometry::PinholeRadTan& camera) {
  CameraCalibrationBlocks b;
  const double values[kIntrinsicsSize] = {camera.fx, camera.fy, camera.cx,
                                          camera.cy, camera.k1, camera.k2};
  std::copy(values, values + kIntrinsicsSize, b.intrinsics);
  return b;
}

namespace {

// `nominal` with the intrinsics block's fx, fy, cx, cy, k1, k2.
geometry::PinholeRadTan WithIntrinsics(const geometry::PinholeRadTan& nominal,
                                       const double* intrinsics) {
  geometry::PinholeRadTan c = nominal;
  c.fx = intrinsics[0];
  c.fy = intrinsics[1];
  c.cx = intrinsics[2];
  c.cy = intrinsics[3];
  c.k1 = intrinsics[4];
  c.k2 = intrinsics[5];
  return c;
}

}  // namespace

geometry::PinholeRadTan CameraCalibrationBlocks::Camera(
    const geometry::PinholeRadTan& nominal) const {
  return WithIntrinsics(nominal, intrinsics);
}

geometry::Rigid3 CameraCalibrationBlocks::BodyFromCamera(const geometry::Rigid3& nominal) const {
  return geometry::Rigid3(
      nominal.rotation() * geometry::ExpQuat(Eigen::Map<const Eigen::Vector3d>(rotation)),
      nominal.translation() + Eigen::Map<const Eigen::Vector3d>(lever_arm));
}

CalibratedReprojectionFactor::CalibratedReprojectionFactor(
    const geometry::PinholeRadTan& camera, const geometry::Rigid3& body_from_camera,
    const Eigen::Vector2d& pixel, double sigma_px,
    const TimeOffsetReprojectionFactor::FixedMotion& motion)
    : camera_(camera), pixel_(pixel), motion_(motion) {
  if (!camera.Check().empty() || !(sigma_px > 0.0)) {
    throw std::invalid_argument("CalibratedReprojectionFactor: invalid camera or sigma");
  }
  const geometry::Rigid3 camera_from_body = body_from_camera.Inverse();
  camera_from_body_rotation_ = camera_from_body.RotationMatrix();
  camera_from_body_translation_ = camera_from_body.translation();
  inv_sigma_ = 1.0 / sigma_px;
}

bool CalibratedReprojectionFactor::Evaluate(double const* const* parameters, double* residuals,
                                            double** jacobians) const {
  const double* intrinsics = parameters[3];
  const Eigen::Map<const Eigen::Vector3d> delta(parameters[4]);
  const Eigen::Map<const Eigen::Vector3d> lever_arm_shift(parameters[5]);
  const BodyPointAtCapture body(parameters[0], motion_.vel_world, motion_.rate_body,
                                Eigen::Vector3d(parameters[1]), parameters[2][0]);
  const Eigen::Vector3d& point_body = body.point_body();
  const Eigen::Vector3d point_camera0 =
      camera_from_body_rotation_ * (point_body - lever_arm_shift) + camera_from_body_translation_;
  const Eigen::Matrix3d correction = geometry::ExpSO3(-delta);
  const Eigen::Vector3d point_camera = correction * point_camera0;

  const geometry::PinholeRadTan camera = WithIntrinsics(camera_, intrinsics);
  Eigen::Matrix<double, 2, 3> d_r_d_pc;
  if (!WhitenedReprojection(camera, pixel_, inv_sigma_, point_camera, residuals,
                            jacobians != nullptr ? &d_r_d_pc : nullptr)) {
    return false;
  }
  if (jacobians == nullptr) return true;

  const Eigen::Matrix<double, 2, 3> d_r_d_pb = d_r_d_pc * correction * camera_from_body_rotation_;
  using Map23 = Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>;
  if (jacobians[0] != nullptr) body.WritePoseJacobian(d_r_d_pb, parameters[0], jacobians[0]);
  if (jacobians[1] != nullptr) (Map23(jacobians[1])) = body.PointJacobian(d_r_d_pb);
  if (jacobians[2] != nullptr) {
    (Eigen::Map<Eigen::Vector2d>(jacobians[2])) = body.TimeOffsetJacobian(d_r_d_pb);
  }
  if (jacobians[3] != nullptr) {
    const Eigen::Vector2d xy = point_camera.head<2>() / point_camera.z();
    const Eigen::Vector2d xy_d = camera.Distort(xy);
    const double r2 = xy.squaredNorm();
    Eigen::Matrix<double, 2, 6, Eigen::RowMajor> J;
    J << xy_d.x(), 0.0, 1.0, 0.0, camera.fx * xy.x() * r2, camera.fx * xy.x() * r2 * r2,  //
        0.0, xy_d.y(), 0.0, 1.0, camera.fy * xy.y() * r2, camera.fy * xy.y() * r2 * r2;
    (Eigen::Map<Eigen::Matrix<double, 2, 6, Eigen::RowMajor>>(jacobians[3])) = inv_sigma_ * J;
  }
  if (jacobians[4] != nullptr) {
    (Map23(jacobians[4])) =
        d_r_d_pc * correction * geometry::Hat(point_camera0) * geometry::RightJacobianSO3(-delta);
  }
  if (jacobians[5] != nullptr) (Map23(jacobians[5])) = -d_r_d_pb;
  return true;
}

}  // namespace crop4d::slam
