#pragma once

// GPS position factors (DESIGN.md §2.2). The antenna sits at p_B_antenna in the body frame, so
// the position the receiver reports is p_world_antenna = t_world_body + R_world_body p_B_antenna.
// The residual is whitened per axis, r = S (p_world_antenna − z_gps), S = diag(1/σ_h, 1/σ_h, 1/σ_v)
// (horizontal east/north, vertical up; the receiver's sigma_h / sigma_v).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

// One GPS fix in the local ENU world frame.
struct GpsMeasurement {
  // Antenna position, m.
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  // Horizontal standard deviation (east and north), m.
  double sigma_horizontal = 0.02;
  // Vertical standard deviation, m.
  double sigma_vertical = 0.04;
};

// GPS fix at a state's own time (e.g. images triggered with the RTK fix). Parameter block:
// pose[7]. r = S (t + R p_B − z); ∂r/∂δt = S, ∂r/∂δφ = −S R [p_B]× (R ← R Exp(δφ)).
class GpsFactor final : public ceres::SizedCostFunction<3, 7> {
 public:
  GpsFactor(const GpsMeasurement& measurement, const Eigen::Vector3d& p_body_antenna);
  static ceres::CostFunction* Create(const GpsMeasurement& measurement,
                                     const Eigen::Vector3d& p_body_antenna);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d position_world_;
  Eigen::Vector3d p_body_antenna_;
  Eigen::Vector3d sqrt_information_diagonal_;
};

// GPS fix at a time τ between the times t_i and t_j of two states: the pose at τ is the GP
// interpolation T(τ) = T_i Exp(Λ γ_i + Ψ γ_j) of gp_prior.h, so the residual
//   r = S (t(τ) + R(τ) p_B − z)
// depends on pose_i[7], vel_i[3], rate_i[3], pose_j[7], vel_j[3], rate_j[3] (the GPS is not
// synchronised with the images). Differentiated by ceres::Jet through the templated
// interpolation, for the reason given in gp_prior.h (the analytic chain through Jr⁻¹(ξ_ij) and
// the SE(3) exponential is long); tested against numerical differences.
class GpsInterpolatedFactor {
 public:
  // dt = t_j − t_i > 0 and s = τ − t_i in [0, dt], seconds.
  GpsInterpolatedFactor(const GpsMeasurement& measurement, const Eigen::Vector3d& p_body_antenna,
                        double dt, double s);
  static ceres::CostFunction* Create(const GpsMeasurement& measurement,
                                     const Eigen::Vector3d& p_body_antenna, double dt, double s);

  template <typename T>
  bool operator()(const T* pose_i, const T* vel_i, const T* rate_i, const T* pose_j, const T* vel_j,
                  const T* rate_j, T* residuals) const {
    T pose_tau[7];
    GpInterpolateBlocks<T>(pose_i, vel_i, rate_i, pose_j, vel_j, rate_j, weights_, pose_tau);
    const Eigen::Matrix<T, 4, 1> q(pose_tau[3], pose_tau[4], pose_tau[5], pose_tau[6]);
    const Eigen::Matrix<T, 3, 1> t(pose_tau[0], pose_tau[1], pose_tau[2]);
    const Eigen::Matrix<T, 3, 1> p = t + templated::QuatToMatrix(q) * p_body_antenna_.cast<T>();
    for (int k = 0; k < 3; ++k) {
      residuals[k] = T(sqrt_information_diagonal_(k)) * (p(k) - T(position_world_(k)));
    }
    return true;
  }

 private:
  Eigen::Vector3d position_world_;
  Eigen::Vector3d p_body_antenna_;
  Eigen::Vector3d sqrt_information_diagonal_;
  GpInterpolationWeights weights_;
};

}  // namespace crop4d::slam
