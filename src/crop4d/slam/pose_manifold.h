#pragma once

// Ceres manifold of the pose block (state_layout.h): translation additive in the world frame,
// rotation perturbed on the right, q ⊞ δφ = q ⊗ Exp(δφ) (Forster et al., T-RO 2017, §III).
// Ceres' own EigenQuaternionManifold perturbs on the left (Exp(δ) ⊗ q), which would not match
// the body-frame Jacobians derived in this module.

#include <ceres/manifold.h>

namespace crop4d::slam {

class PoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  // x ⊞ δ = (t + δt, q ⊗ Exp(δφ)).
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  // 7×6 row-major [I 0; 0 P(q)] (state_layout.h).
  bool PlusJacobian(const double* x, double* jacobian) const override;
  // y ⊟ x = (t_y − t_x, Log(q_x⁻¹ q_y)).
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  // 6×7 row-major d(y ⊟ x)/dy at y = x: [I 0; 0 4 P(q)ᵀ].
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

}  // namespace crop4d::slam
