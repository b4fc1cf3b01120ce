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
  const Eigen::Map<const Eigen::Vector3d> p(parameters[0]);
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0] + 3);
  const Eigen::Map<const Eigen::Vector3d> point_world(parameters[1]);
  const double td = parameters[2][0];
  const double* intrinsics = parameters[3];
  const Eigen::Map<const Eigen::Vector3d> delta(parameters[4]);
  const Eigen::Map<const Eigen::Vector3d> lever_arm_shift(parameters[5]);
  const Eigen::Vector3d& v = motion_.vel_world;
  const Eigen::Vector3d& w = motion_.rate_body;

  const Eigen::Matrix3d Rt = q.normalized().toRotationMatrix().transpose();
  const Eigen::Matrix3d Et = geometry::ExpSO3(w * td).transpose();
  const Eigen::Vector3d a = Rt * (point_world - p - v * td);
  const Eigen::Vector3d point_body = Et * a;
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
  const Eigen::Matrix3d EtRt = Et * Rt;
  const Eigen::Matrix3d Et_hat_a = Et * geometry::Hat(a);
  if (jacobians[0] != nullptr) {
    Eigen::Matrix<double, 3, 6> d_pb_d_pose;
    d_pb_d_pose.leftCols<3>() = -EtRt;
    d_pb_d_pose.rightCols<3>() = Et_hat_a;
    const Eigen::Matrix<double, 2, 6> J = d_r_d_pb * d_pb_d_pose;
    WritePoseJacobian<2>(J, parameters[0], jacobians[0]);
  }
  if (jacobians[1] != nullptr) {
    (Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>(jacobians[1])) = d_r_d_pb * EtRt;
  }
  if (jacobians[2] != nullptr) {
    (Eigen::Map<Eigen::Vector2d>(jacobians[2])) = d_r_d_pb * (Et_hat_a * w - EtRt * v);
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
    (Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>(jacobians[4])) =
        d_r_d_pc * correction * geometry::Hat(point_camera0) * geometry::RightJacobianSO3(-delta);
  }
  if (jacobians[5] != nullptr) {
    (Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>(jacobians[5])) = -d_r_d_pb;
  }
  return true;
}

}  // namespace crop4d::slam
