#include "crop4d/slam/gp_prior.h"

#include <ceres/autodiff_cost_function.h>
#include <ceres/jet.h>

#include <Eigen/Cholesky>
#include <stdexcept>

namespace crop4d::slam {

void SetBodyVelocity(const Vector6d& body_velocity, GpState* state) {
  state->vel_world = state->world_from_body.rotation() * body_velocity.head<3>();
  state->rate_body = body_velocity.tail<3>();
}

GpInterpolationWeights ComputeGpInterpolationWeights(double dt, double s) {
  if (!(dt > 0.0)) throw std::invalid_argument("ComputeGpInterpolationWeights: dt must be > 0");
  // Scalar factors (Qc cancels): Φ(t) = [1 t; 0 1], Q(t) = [t³/3 t²/2; t²/2 t].
  auto phi = [](double t) {
    Eigen::Matrix2d m;
    m << 1.0, t, 0.0, 1.0;
    return m;
  };
  auto q = [](double t) {
    Eigen::Matrix2d m;
    m << t * t * t / 3.0, t * t / 2.0, t * t / 2.0, t;
    return m;
  };
  GpInterpolationWeights w;
  // Anderson & Barfoot 2015: Ψ = Q(s) Φ(Δt − s)ᵀ Q(Δt)⁻¹, Λ = Φ(s) − Ψ Φ(Δt).
  w.psi = q(s) * phi(dt - s).transpose() * q(dt).inverse();
  w.lambda = phi(s) - w.psi * phi(dt);
  return w;
}

GpState GpInterpolate(const GpState& state_i, const GpState& state_j, double dt, double s,
                      GpInterpolationJacobians* jacobians) {
  const GpInterpolationWeights w = ComputeGpInterpolationWeights(dt, s);
  const Vector7d pose_i = PoseToBlock(state_i.world_from_body);
  const Vector7d pose_j = PoseToBlock(state_j.world_from_body);
  Vector7d pose_tau;
  GpState out;
  GpInterpolateBlocks<double>(pose_i.data(), state_i.vel_world.data(), state_i.rate_body.data(),
                              pose_j.data(), state_j.vel_world.data(), state_j.rate_body.data(), w,
                              pose_tau.data(), out.vel_world.data(), out.rate_body.data());
  out.world_from_body = BlockToPose(pose_tau.data());
  if (jacobians == nullptr) return out;

  // Forward-mode automatic differentiation over the 26 ambient inputs, then the ambient
  // Jacobians are mapped to the tangent spaces: J_tan = L(out) J_amb P(in) (state_layout.h).
  using Jet = ceres::Jet<double, 26>;
  Jet in[26];
  const double* sources[6] = {pose_i.data(), state_i.vel_world.data(), state_i.rate_body.data(),
                              pose_j.data(), state_j.vel_world.data(), state_j.rate_body.data()};
  const int sizes[6] = {7, 3, 3, 7, 3, 3};
  int offsets[6];
  for (int b = 0, k = 0; b < 6; ++b) {
    offsets[b] = k;
    for (int c = 0; c < sizes[b]; ++c, ++k) in[k] = Jet(sources[b][c], k);
  }
  Jet pose_out[7];
  GpInterpolateBlocks<Jet>(in + offsets[0], in + offsets[1], in + offsets[2], in + offsets[3],
                           in + offsets[4], in + offsets[5], w, pose_out);
  Eigen::Matrix<double, 7, 26> J_amb;
  for (int r = 0; r < 7; ++r) J_amb.row(r) = pose_out[r].v.transpose();
  const Eigen::Matrix<double, 6, 7> L = PoseLiftJacobian(pose_tau.data());
  const Eigen::Matrix<double, 6, 26> LJ = L * J_amb;
  jacobians->pose_i = LJ.middleCols<7>(offsets[0]) * PosePlusJacobian(pose_i.data());
  jacobians->vel_i = LJ.middleCols<3>(offsets[1]);
  jacobians->rate_i = LJ.middleCols<3>(offsets[2]);
  jacobians->pose_j = LJ.middleCols<7>(offsets[3]) * PosePlusJacobian(pose_j.data());
  jacobians->vel_j = LJ.middleCols<3>(offsets[4]);
  jacobians->rate_j = LJ.middleCols<3>(offsets[5]);
  return out;
}

OptionCheck GpPriorFactor::Options::Check() const {
  OptionChecker c;
  c.Greater("qc_translation", qc_translation, 0.0).Greater("qc_rotation", qc_rotation, 0.0);
  return c.Result();
}

GpPriorFactor::GpPriorFactor(const Options& options, double dt) : dt_(dt) {
  if (!options.Check().empty() || !(dt > 0.0)) {
    throw std::invalid_argument("GpPriorFactor: Qc and dt must be positive");
  }
  Matrix6d Qc = Matrix6d::Zero();
  Qc.diagonal() << Eigen::Vector3d::Constant(options.qc_translation),
      Eigen::Vector3d::Constant(options.qc_rotation);
  covariance_.topLeftCorner<6, 6>() = dt * dt * dt / 3.0 * Qc;
  covariance_.topRightCorner<6, 6>() = dt * dt / 2.0 * Qc;
  covariance_.bottomLeftCorner<6, 6>() = dt * dt / 2.0 * Qc;
  covariance_.bottomRightCorner<6, 6>() = dt * Qc;
  const Eigen::Matrix<double, 12, 12> information = covariance_.inverse();
  sqrt_information_ = information.llt().matrixL().transpose();
}

ceres::CostFunction* GpPriorFactor::Create(const Options& options, double dt) {
  return new ceres::AutoDiffCostFunction<GpPriorFactor, 12, 7, 3, 3, 7, 3, 3>(
      new GpPriorFactor(options, dt));
}

}  // namespace crop4d::slam
