#pragma once

// Non-holonomic motion constraint of a ground vehicle (Groves, "Principles of GNSS, Inertial,
// and Multisensor Integrated Navigation Systems", 2nd ed., §16.4.1; Dissanayake et al., IEEE
// T-RA 2001): a wheeled vehicle moves along its forward axis, so its velocity in the body frame
// has no component across it (no side slip) nor along the body's up axis (the body follows the
// ground). On a straight row at constant speed the accelerometer sees no horizontal force and
// IMU + GPS cannot tell the heading apart from a sideways shift of the antenna; this constraint
// ties the heading to the direction of travel.
//
// Parameter blocks: pose[7] (world_from_body, state_layout.h) and vel_world[3]. With the unit
// forward axis f_B and two unit axes a₁, a₂ completing it to an orthonormal basis of the body:
//   v_B = Rᵀ v,   r = (1/σ) [a₁ᵀ; a₂ᵀ] v_B
// Jacobians (R ← R Exp(δφ), so Rᵀ ← Exp(−δφ) Rᵀ and v_B ← v_B + [v_B]× δφ):
//   ∂r/∂δt = 0,   ∂r/∂δφ = (1/σ) A [v_B]×,   ∂r/∂v = (1/σ) A Rᵀ   (A = [a₁ᵀ; a₂ᵀ]).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

namespace crop4d::slam {

class MotionConstraintFactor final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  // forward_axis_body: the direction of travel in the body frame (normalised here); sigma: the
  // standard deviation of the velocity across it, m/s.
  MotionConstraintFactor(const Eigen::Vector3d& forward_axis_body, double sigma);
  static ceres::CostFunction* Create(const Eigen::Vector3d& forward_axis_body, double sigma);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  // Rows a₁ᵀ, a₂ᵀ divided by σ.
  Eigen::Matrix<double, 2, 3> weighted_axes_;
};

}  // namespace crop4d::slam
