#include "crop4d/slam/time_offset_reprojection_factor.h"

#include <Eigen/Geometry>
#include <cstdint>
#include <stdexcept>
#include <utility>
#include <vector>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/reprojection_factor.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

TimeOffsetReprojectionFactor::TimeOffsetReprojectionFactor(const geometry::PinholeRadTan& camera,
                                                           const geometry::Rigid3& body_from_camera,
                                                           const Eigen::Vector2d& pixel,
                                                           double sigma_px,
                                                           std::optional<FixedMotion> motion)
    : camera_(camera), pixel_(pixel), motion_(std::move(motion)) {
  if (!camera.Check().empty() || !(sigma_px > 0.0)) {
    throw std::invalid_argument("TimeOffsetReprojectionFactor: invalid camera or sigma");
  }
  const geometry::Rigid3 camera_from_body = body_from_camera.Inverse();
  camera_from_body_rotation_ = camera_from_body.RotationMatrix();
  camera_from_body_translation_ = camera_from_body.translation();
  inv_sigma_ = 1.0 / sigma_px;
  set_num_residuals(2);
  *mutable_parameter_block_sizes() =
      motion_ ? std::vector<std::int32_t>{7, 3, 1} : std::vector<std::int32_t>{7, 3, 3, 3, 1};
}

ceres::CostFunction* TimeOffsetReprojectionFactor::Create(const geometry::PinholeRadTan& camera,
                                                          const geometry::Rigid3& body_from_camera,
                                                          const Eigen::Vector2d& pixel,
                                                          double sigma_px,
                                                          std::optional<FixedMotion> motion) {
  return new TimeOffsetReprojectionFactor(camera, body_from_camera, pixel, sigma_px,
                                          std::move(motion));
}

BodyPointAtCapture::BodyPointAtCapture(const double* pose, const Eigen::Vector3d& vel_world,
                                       const Eigen::Vector3d& rate_body,
                                       const Eigen::Vector3d& point_world, double td)
    : v_(vel_world), w_(rate_body), td_(td) {
  const Eigen::Map<const Eigen::Vector3d> p(pose);
  const Eigen::Map<const Eigen::Quaterniond> q(pose + 3);
  const Eigen::Matrix3d Rt = q.normalized().toRotationMatrix().transpose();
  const Eigen::Matrix3d Et = geometry::ExpSO3(w_ * td).transpose();
  const Eigen::Vector3d a = Rt * (point_world - p - v_ * td);
  point_body_ = Et * a;
  EtRt_ = Et * Rt;
  Et_hat_a_ = Et * geometry::Hat(a);
}

void BodyPointAtCapture::WritePoseJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb,
                                           const double* pose, double* jacobian) const {
  Eigen::Matrix<double, 3, 6> d_pb_d_pose;
  d_pb_d_pose.leftCols<3>() = -EtRt_;
  d_pb_d_pose.rightCols<3>() = Et_hat_a_;
  const Eigen::Matrix<double, 2, 6> J = d_r_d_pb * d_pb_d_pose;
  slam::WritePoseJacobian<2>(J, pose, jacobian);
}

Eigen::Matrix<double, 2, 3> BodyPointAtCapture::RateJacobian(
    const Eigen::Matrix<double, 2, 3>& d_r_d_pb) const {
  return td_ * d_r_d_pb * Et_hat_a_ * geometry::RightJacobianSO3(-w_ * td_);
}

bool TimeOffsetReprojectionFactor::Evaluate(double const* const* parameters, double* residuals,
                                            double** jacobians) const {
  // Block indices: pose, [vel, rate,] point, td.
  const int point_index = motion_ ? 1 : 3;
  const int td_index = point_index + 1;
  const Eigen::Vector3d v = motion_ ? motion_->vel_world : Eigen::Vector3d(parameters[1]);
  const Eigen::Vector3d w = motion_ ? motion_->rate_body : Eigen::Vector3d(parameters[2]);
  const BodyPointAtCapture body(parameters[0], v, w, Eigen::Vector3d(parameters[point_index]),
                                parameters[td_index][0]);
  const Eigen::Vector3d point_camera =
      camera_from_body_rotation_ * body.point_body() + camera_from_body_translation_;
  Eigen::Matrix<double, 2, 3> d_r_d_pc;
  if (!WhitenedReprojection(camera_, pixel_, inv_sigma_, point_camera, residuals,
                            jacobians != nullptr ? &d_r_d_pc : nullptr)) {
    return false;
  }
  if (jacobians == nullptr) return true;
  // ∂r/∂X_b (X_c = R_cb X_b + t_cb).
  const Eigen::Matrix<double, 2, 3> d_r_d_pb = d_r_d_pc * camera_from_body_rotation_;
  using Map23 = Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>;
  if (jacobians[0] != nullptr) body.WritePoseJacobian(d_r_d_pb, parameters[0], jacobians[0]);
  if (!motion_ && jacobians[1] != nullptr) (Map23(jacobians[1])) = body.VelocityJacobian(d_r_d_pb);
  if (!motion_ && jacobians[2] != nullptr) (Map23(jacobians[2])) = body.RateJacobian(d_r_d_pb);
  if (jacobians[point_index] != nullptr) {
    (Map23(jacobians[point_index])) = body.PointJacobian(d_r_d_pb);
  }
  if (jacobians[td_index] != nullptr) {
    (Eigen::Map<Eigen::Vector2d>(jacobians[td_index])) = body.TimeOffsetJacobian(d_r_d_pb);
  }
  return true;
}

geometry::Rigid3 BodyAtCapture(const geometry::Rigid3& world_from_body,
                               const Eigen::Vector3d& vel_world, const Eigen::Vector3d& rate_body,
                               double td) {
  return geometry::Rigid3(world_from_body.rotation() * geometry::ExpQuat(rate_body * td),
                          world_from_body.translation() + vel_world * td);
}

}  // namespace crop4d::slam
