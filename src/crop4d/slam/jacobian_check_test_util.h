#pragma once

// Test helper (GTSAM / Basalt convention, DESIGN.md §7): compares the Jacobians a Ceres cost
// function returns, mapped to the tangent spaces of the parameter blocks' manifolds
// (J_amb · PlusJacobian, exactly what the solver uses), with central differences taken by
// perturbing each block on its manifold (x ⊞ ±h e_k).

#include <ceres/cost_function.h>
#include <ceres/manifold.h>

#include <Eigen/Core>
#include <vector>

namespace crop4d::slam::testing {

struct JacobianCheckResult {
  // Largest |analytic − numerical| over all blocks, divided by the largest |numerical| entry.
  double max_relative_error = 0.0;
  // Per block, the tangent-space Jacobians.
  std::vector<Eigen::MatrixXd> analytic;
  std::vector<Eigen::MatrixXd> numerical;
};

// `parameters` holds one vector per block; `manifolds` one entry per block (nullptr =
// Euclidean). step = h of the central difference.
JacobianCheckResult CheckJacobians(const ceres::CostFunction& cost_function,
                                   const std::vector<std::vector<double>>& parameters,
                                   const std::vector<const ceres::Manifold*>& manifolds,
                                   double step = 1e-6);

}  // namespace crop4d::slam::testing
