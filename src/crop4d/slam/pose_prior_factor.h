#pragma once

// Prior on a pose block (gauge fixing, initial state; DESIGN.md §2.2). Parameter block pose[7]
// (state_layout.h). With the prior world_from_body_prior = (t₀, R₀):
//   r = S [t − t₀; Log(R₀ᵀ R)],   Sᵀ S = Σ⁻¹ (Σ the 6×6 covariance of [δt; δφ]),
//   ∂r/∂δt = S [I; 0],   ∂r/∂δφ = S [0; Jr⁻¹(Log(R₀ᵀ R))]   (R ← R Exp(δφ); Forster eq. 9).

#include <ceres/sized_cost_function.h>

#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

class PosePriorFactor final : public ceres::SizedCostFunction<6, 7> {
 public:
  PosePriorFactor(const geometry::Rigid3& world_from_body_prior, const Matrix6d& covariance);
  static ceres::CostFunction* Create(const geometry::Rigid3& world_from_body_prior,
                                     const Matrix6d& covariance);
  // Diagonal covariance from the translation (m) and rotation (rad) standard deviations.
  static ceres::CostFunction* Create(const geometry::Rigid3& world_from_body_prior,
                                     double sigma_translation, double sigma_rotation);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d translation_prior_;
  Eigen::Quaterniond rotation_prior_;
  Matrix6d sqrt_information_;
};

}  // namespace crop4d::slam
