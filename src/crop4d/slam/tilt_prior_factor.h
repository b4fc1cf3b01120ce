#pragma once

// A weak prior that a body axis points up: r = [(R u)_x, (R u)_y] / σ, with R = world_from_body
// and u the unit axis of the body that is up when the rig is level. For a small tilt θ of u away
// from the world's z the residual is θ/σ. Without an IMU (sensor sets cam+rtk, cam+gps) nothing
// else observes a rotation of a straight pass about its line of travel: RTK positions on a line
// do not change, and the camera measures the rig's motion relative to its own start. One such
// prior per state, with σ of several degrees, fixes that gauge and leaves each state's attitude
// to the camera (n states pull the common tilt to ~σ/√n).
//
// Parameter block pose[7] (state_layout.h); with R ← R Exp(δφ):
//   ∂(R u)/∂δφ = −R [u]×,   ∂r/∂δt = 0.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

namespace crop4d::slam {

class TiltPriorFactor final : public ceres::SizedCostFunction<2, 7> {
 public:
  TiltPriorFactor(const Eigen::Vector3d& up_body, double sigma_rad);
  static ceres::CostFunction* Create(const Eigen::Vector3d& up_body, double sigma_rad);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d up_body_;
  double inverse_sigma_;
};

}  // namespace crop4d::slam
