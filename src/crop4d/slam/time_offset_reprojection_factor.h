#pragma once

// Reprojection factor with the camera–IMU time offset td (seconds; capture instant = image stamp
// + td, the convention of VINS-Mono and OpenVINS): the landmark is projected from the body pose
// at the capture instant, predicted to first order from the state at the stamp (state_layout.h:
// velocity in the world frame, angular rate in the body frame):
//   R' = R Exp(ω td),   p' = p + v td.
// Camera model and residual as ReprojectionFactor (reprojection_factor.h); with td = 0 the two
// agree. Parameter blocks:
//   - motion as parameters: pose[7], vel[3], rate[3] of the state, point_world[3], td[1];
//   - motion fixed (FixedMotion, the velocity and rate of the state when the factor is built):
//     pose[7], point_world[3], td[1]. The velocity and rate enter multiplied by td, so holding
//     them for one solve changes the projection by td · (their change): 0.25 mm for 1 cm/s at
//     25 ms. What it saves: the landmarks' Schur complement then couples only the poses (and
//     td), not the velocities and rates of every state that sees a landmark — the solve of a
//     synthetic row takes a fifth of the time.
//
//   a    = Rᵀ (X − p − v td)                     (point in the body frame of the stamp)
//   X_b  = Eᵀ a,  E = Exp(ω td)                   (point in the body frame of the capture)
//   X_c  = R_cb X_b + t_cb
// Jacobians of X_b (R ← R Exp(δφ), p ← p + δp; J = Jr(−ω td)):
//   ∂/∂δp = −Eᵀ Rᵀ,   ∂/∂δφ = Eᵀ [a]×,   ∂/∂v = −td Eᵀ Rᵀ,   ∂/∂X = Eᵀ Rᵀ,
//   ∂/∂ω = td Eᵀ [a]× J,   ∂/∂td = Eᵀ ([a]× ω − Rᵀ v)   (J ω = ω since ω ∥ ω td).

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <optional>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::slam {

class TimeOffsetReprojectionFactor final : public ceres::CostFunction {
 public:
  struct FixedMotion {
    Eigen::Vector3d vel_world = Eigen::Vector3d::Zero();
    Eigen::Vector3d rate_body = Eigen::Vector3d::Zero();
  };

  TimeOffsetReprojectionFactor(const geometry::PinholeRadTan& camera,
                               const geometry::Rigid3& body_from_camera,
                               const Eigen::Vector2d& pixel, double sigma_px,
                               std::optional<FixedMotion> motion = std::nullopt);
  static ceres::CostFunction* Create(const geometry::PinholeRadTan& camera,
                                     const geometry::Rigid3& body_from_camera,
                                     const Eigen::Vector2d& pixel, double sigma_px = 1.0,
                                     std::optional<FixedMotion> motion = std::nullopt);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  geometry::PinholeRadTan camera_;
  Eigen::Matrix3d camera_from_body_rotation_;
  Eigen::Vector3d camera_from_body_translation_;
  Eigen::Vector2d pixel_;
  double inv_sigma_;
  std::optional<FixedMotion> motion_;
};

// The landmark in the body frame at the capture instant (X_b above) and its Jacobians, shared by
// the factors that project through it (this one and CalibratedReprojectionFactor): each gives
// ∂r/∂X_b and gets ∂r/∂ of the pose, the point and td.
class BodyPointAtCapture {
 public:
  // pose[7] (p, q), the state's velocity and rate, the landmark and td.
  BodyPointAtCapture(const double* pose, const Eigen::Vector3d& vel_world,
                     const Eigen::Vector3d& rate_body, const Eigen::Vector3d& point_world,
                     double td);

  const Eigen::Vector3d& point_body() const { return point_body_; }
  // ∂r/∂pose in the pose block's global size (7), for r with ∂r/∂X_b = d_r_d_pb.
  void WritePoseJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb, const double* pose,
                         double* jacobian) const;
  Eigen::Matrix<double, 2, 3> PointJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb) const {
    return d_r_d_pb * EtRt_;
  }
  Eigen::Vector2d TimeOffsetJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb) const {
    return d_r_d_pb * (Et_hat_a_ * w_ - EtRt_ * v_);
  }
  Eigen::Matrix<double, 2, 3> VelocityJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb) const {
    return -td_ * d_r_d_pb * EtRt_;
  }
  Eigen::Matrix<double, 2, 3> RateJacobian(const Eigen::Matrix<double, 2, 3>& d_r_d_pb) const;

 private:
  Eigen::Vector3d v_, w_;
  double td_;
  Eigen::Vector3d point_body_;
  Eigen::Matrix3d EtRt_;      // Eᵀ Rᵀ
  Eigen::Matrix3d Et_hat_a_;  // Eᵀ [a]×
};

// world_from_body at stamp + td, predicted from the state at the stamp as above.
geometry::Rigid3 BodyAtCapture(const geometry::Rigid3& world_from_body,
                               const Eigen::Vector3d& vel_world, const Eigen::Vector3d& rate_body,
                               double td);

}  // namespace crop4d::slam
