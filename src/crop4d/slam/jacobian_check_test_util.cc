#include "crop4d/slam/jacobian_check_test_util.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace crop4d::slam::testing {
namespace {

Eigen::VectorXd EvaluateResidual(const ceres::CostFunction& cost_function,
                                 const std::vector<std::vector<double>>& parameters) {
  std::vector<const double*> blocks;
  for (const auto& p : parameters) blocks.push_back(p.data());
  Eigen::VectorXd residual(cost_function.num_residuals());
  if (!cost_function.Evaluate(blocks.data(), residual.data(), nullptr)) {
    throw std::runtime_error("CheckJacobians: Evaluate failed");
  }
  return residual;
}

}  // namespace

JacobianCheckResult CheckJacobians(const ceres::CostFunction& cost_function,
                                   const std::vector<std::vector<double>>& parameters,
                                   const std::vector<const ceres::Manifold*>& manifolds,
                                   double step) {
  const int num_residuals = cost_function.num_residuals();
  const std::vector<int32_t>& sizes = cost_function.parameter_block_sizes();
  if (sizes.size() != parameters.size() || manifolds.size() != parameters.size()) {
    throw std::invalid_argument("CheckJacobians: block count mismatch");
  }
  // Analytic, ambient (row-major), then mapped through PlusJacobian.
  std::vector<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> ambient;
  std::vector<double*> jacobian_ptrs;
  std::vector<const double*> blocks;
  for (size_t b = 0; b < parameters.size(); ++b) {
    ambient.emplace_back(num_residuals, sizes[b]);
    blocks.push_back(parameters[b].data());
  }
  for (auto& a : ambient) jacobian_ptrs.push_back(a.data());
  Eigen::VectorXd residual(num_residuals);
  if (!cost_function.Evaluate(blocks.data(), residual.data(), jacobian_ptrs.data())) {
    throw std::runtime_error("CheckJacobians: Evaluate failed");
  }

  JacobianCheckResult result;
  for (size_t b = 0; b < parameters.size(); ++b) {
    const ceres::Manifold* manifold = manifolds[b];
    const int tangent = manifold != nullptr ? manifold->TangentSize() : sizes[b];
    Eigen::MatrixXd analytic = ambient[b];
    if (manifold != nullptr) {
      Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor> plus(sizes[b],
                                                                                  tangent);
      manifold->PlusJacobian(parameters[b].data(), plus.data());
      analytic = ambient[b] * plus;
    }
    Eigen::MatrixXd numerical(num_residuals, tangent);
    for (int k = 0; k < tangent; ++k) {
      std::vector<std::vector<double>> plus_params = parameters;
      std::vector<std::vector<double>> minus_params = parameters;
      Eigen::VectorXd delta = Eigen::VectorXd::Zero(tangent);
      delta(k) = step;
      if (manifold != nullptr) {
        manifold->Plus(parameters[b].data(), delta.data(), plus_params[b].data());
        delta(k) = -step;
        manifold->Plus(parameters[b].data(), delta.data(), minus_params[b].data());
      } else {
        plus_params[b][k] += step;
        minus_params[b][k] -= step;
      }
      numerical.col(k) = (EvaluateResidual(cost_function, plus_params) -
                          EvaluateResidual(cost_function, minus_params)) /
                         (2.0 * step);
    }
    result.analytic.push_back(analytic);
    result.numerical.push_back(numerical);
  }
  // Relative to the largest Jacobian entry of the cost function.
  double scale = 1e-300;
  for (const Eigen::MatrixXd& n : result.numerical) {
    if (n.size() > 0) scale = std::max(scale, n.cwiseAbs().maxCoeff());
  }
  for (size_t b = 0; b < result.numerical.size(); ++b) {
    if (result.numerical[b].size() == 0) continue;
    result.max_relative_error =
        std::max(result.max_relative_error,
                 (result.analytic[b] - result.numerical[b]).cwiseAbs().maxCoeff() / scale);
  }
  return result;
}

}  // namespace crop4d::slam::testing
