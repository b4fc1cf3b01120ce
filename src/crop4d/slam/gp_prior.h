#pragma once

// Continuous-time Gaussian-process motion prior on SE(3) (white noise on acceleration) and GP
// interpolation of the trajectory between two states (DESIGN.md §2.2). After Barfoot, Tong,
// Särkkä, "Batch Continuous-Time Trajectory Estimation as Exactly Sparse Gaussian Process
// Regression", RSS 2014, and Anderson & Barfoot, "Full STEAM Ahead: Exactly Sparse Gaussian
// Process Regression for Batch Continuous-Time Trajectory Estimation on SE(3)", IROS 2015.
//
// Mapping from our state (state_layout.h) to the GP state: the GP state at time t is the pose
// T = world_from_body and the body-frame generalised velocity ϖ = [ν; ω] with Ṫ = T ϖ^ (Barfoot
// 2017, §7.2), i.e.
//   ϖ = [R_world_bodyᵀ vel_world; rate_body]   (ξ = [ρ; φ] ordering, translation first).
// Local variable between t_i and t_j (Anderson & Barfoot 2015): ξ_i(t) = Log(T_i⁻¹ T(t)),
// whose derivative is ξ̇_i(t) = Jr⁻¹(ξ_i(t)) ϖ(t) (from T(t) = T_i Exp(ξ_i(t)) and
// Ṫ = T (Jr(ξ) ξ̇)^). The local variable γ = [ξ; ξ̇] obeys the linear time-invariant SDE
// γ̇ = [0 I; 0 0] γ + [0; I] w, w ~ GP(0, Qc δ(t − t')), so with Δt = t_j − t_i
//   Φ(Δt) = [I, Δt I; 0, I],   Q(Δt) = [Δt³/3 Qc, Δt²/2 Qc; Δt²/2 Qc, Δt Qc]   (Barfoot et al.
//   2014).
// γ_i(t_i) = [0; ϖ_i] and γ_i(t_j) = [ξ_ij; Jr⁻¹(ξ_ij) ϖ_j], ξ_ij = Log(T_i⁻¹ T_j), so the prior
// error e = γ_i(t_j) − Φ(Δt) γ_i(t_i) is
//   e = [ ξ_ij − Δt ϖ_i ;  Jr⁻¹(ξ_ij) ϖ_j − ϖ_i ]   (12),  weighted by S, Sᵀ S = Q(Δt)⁻¹.
// e = 0 exactly for motion with constant body velocity ϖ (T(t) = T_i Exp(t ϖ)).
//
// Interpolation (Barfoot et al. 2014; Anderson & Barfoot 2015): for τ in [t_i, t_j], s = τ − t_i,
//   Ψ(τ) = Q(s) Φ(t_j − τ)ᵀ Q(Δt)⁻¹,   Λ(τ) = Φ(s) − Ψ(τ) Φ(Δt),
//   γ_i(τ) = Λ(τ) γ_i(t_i) + Ψ(τ) γ_i(t_j),   T(τ) = T_i Exp(ξ_i(τ)),
// and ϖ(τ) = Jr(ξ_i(τ)) ξ̇_i(τ). Because Qc multiplies every block of Q, Λ and Ψ are 2×2 scalar
// matrices (⊗ I₆) that do not depend on Qc. Exact for constant body velocity.
//
// Jacobians: the exact derivative of Jr⁻¹(ξ_ij) ϖ_j with respect to ξ_ij (a third-order tensor
// of the SE(3) series) is long and error-prone, and we do not want the usual approximation
// Jr⁻¹(ξ) ≈ I; so the prior and the interpolation are written once, templated on the scalar
// (se3_templated.h), and differentiated exactly by ceres::Jet (automatic differentiation).
// The tests check them against central differences on the manifold.

#include <Eigen/Core>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/se3_templated.h"
#include "crop4d/slam/state_layout.h"

namespace ceres {
class CostFunction;
}

namespace crop4d::slam {

// One state as the GP sees it (state_layout.h blocks).
struct GpState {
  geometry::Rigid3 world_from_body;
  // Velocity of the body in the world frame, m/s.
  Eigen::Vector3d vel_world = Eigen::Vector3d::Zero();
  // Angular velocity in the body frame, rad/s.
  Eigen::Vector3d rate_body = Eigen::Vector3d::Zero();
};

// Writes vel_world and rate_body of `state` from its body velocity ϖ = [Rᵀ vel_world; rate_body].
void SetBodyVelocity(const Vector6d& body_velocity, GpState* state);

// The 2×2 interpolation matrices Λ(τ), Ψ(τ) for s = τ − t_i in [0, Δt] (file comment).
struct GpInterpolationWeights {
  Eigen::Matrix2d lambda;
  Eigen::Matrix2d psi;
};
GpInterpolationWeights ComputeGpInterpolationWeights(double dt, double s);

// The GP's local variables of a pair of states on raw blocks: ξ_ij = Log(T_i⁻¹ T_j) and the
// body velocities ϖ_i, ϖ_j (state_layout.h blocks). Shared by the prior and the interpolation.
template <typename T>
struct GpLocalVariables {
  templated::Vec3<T> t_i;
  Eigen::Matrix<T, 4, 1> q_i;
  templated::Mat3<T> R_i;
  templated::Vec6<T> varpi_i, varpi_j, xi_ij;

  GpLocalVariables(const T* pose_i, const T* vel_i, const T* rate_i, const T* pose_j,
                   const T* vel_j, const T* rate_j) {
    using templated::Vec3;
    using Vec4 = Eigen::Matrix<T, 4, 1>;
    t_i = Vec3<T>(pose_i[0], pose_i[1], pose_i[2]);
    q_i = Vec4(pose_i[3], pose_i[4], pose_i[5], pose_i[6]);
    const Vec3<T> t_j(pose_j[0], pose_j[1], pose_j[2]);
    const Vec4 q_j(pose_j[3], pose_j[4], pose_j[5], pose_j[6]);
    R_i = templated::QuatToMatrix(q_i);
    const templated::Mat3<T> R_j = templated::QuatToMatrix(q_j);
    varpi_i << R_i.transpose() * Vec3<T>(vel_i[0], vel_i[1], vel_i[2]),
        Vec3<T>(rate_i[0], rate_i[1], rate_i[2]);
    varpi_j << R_j.transpose() * Vec3<T>(vel_j[0], vel_j[1], vel_j[2]),
        Vec3<T>(rate_j[0], rate_j[1], rate_j[2]);
    const Vec4 q_ij = templated::QuatMul(templated::QuatConj(q_i), q_j);
    const Vec3<T> t_ij = R_i.transpose() * (t_j - t_i);
    xi_ij = templated::LogSE3(t_ij, q_ij);
  }
};

// Templated GP interpolation on raw blocks (pose[7], vel[3], rate[3] of states i and j);
// writes the interpolated pose block and, if non-null, the world velocity and body rate.
template <typename T>
void GpInterpolateBlocks(const T* pose_i, const T* vel_i, const T* rate_i, const T* pose_j,
                         const T* vel_j, const T* rate_j, const GpInterpolationWeights& w,
                         T* pose_tau, T* vel_tau = nullptr, T* rate_tau = nullptr) {
  using templated::Vec3;
  using templated::Vec6;
  using Vec4 = Eigen::Matrix<T, 4, 1>;
  const GpLocalVariables<T> local(pose_i, vel_i, rate_i, pose_j, vel_j, rate_j);
  const Vec3<T>& t_i = local.t_i;
  const Vec4& q_i = local.q_i;
  const templated::Mat3<T>& R_i = local.R_i;
  const Vec6<T>& varpi_i = local.varpi_i;
  const Vec6<T>& xi_ij = local.xi_ij;
  const Vec6<T> xi_dot_j = templated::RightJacobianInverseSE3(xi_ij) * local.varpi_j;
  // γ_i(τ) = Λ [0; ϖ_i] + Ψ [ξ_ij; ξ̇_j].
  const Vec6<T> xi_tau =
      T(w.lambda(0, 1)) * varpi_i + T(w.psi(0, 0)) * xi_ij + T(w.psi(0, 1)) * xi_dot_j;
  Vec3<T> t_rel;
  Vec4 q_rel;
  templated::ExpSE3(xi_tau, &t_rel, &q_rel);
  const Vec4 q_tau = templated::QuatMul(q_i, q_rel);
  const Vec3<T> t_tau = t_i + R_i * t_rel;
  for (int k = 0; k < 3; ++k) pose_tau[k] = t_tau(k);
  for (int k = 0; k < 4; ++k) pose_tau[3 + k] = q_tau(k);
  if (vel_tau != nullptr || rate_tau != nullptr) {
    const Vec6<T> xi_dot_tau =
        T(w.lambda(1, 1)) * varpi_i + T(w.psi(1, 0)) * xi_ij + T(w.psi(1, 1)) * xi_dot_j;
    const Vec6<T> varpi_tau = templated::RightJacobianSE3(xi_tau) * xi_dot_tau;
    if (vel_tau != nullptr) {
      const Vec3<T> v = R_i * templated::QuatToMatrix(q_rel) * varpi_tau.template head<3>();
      for (int k = 0; k < 3; ++k) vel_tau[k] = v(k);
    }
    if (rate_tau != nullptr) {
      for (int k = 0; k < 3; ++k) rate_tau[k] = varpi_tau(3 + k);
    }
  }
}

// Jacobians of the interpolated pose, in the tangent spaces of state_layout.h: rows are the
// PoseManifold tangent [δt; δφ] of T(τ), columns the tangent of each input block.
struct GpInterpolationJacobians {
  Matrix6d pose_i;
  Eigen::Matrix<double, 6, 3> vel_i;
  Eigen::Matrix<double, 6, 3> rate_i;
  Matrix6d pose_j;
  Eigen::Matrix<double, 6, 3> vel_j;
  Eigen::Matrix<double, 6, 3> rate_j;
};

// The GP-interpolated state at τ = t_i + s, s in [0, dt] (dt = t_j − t_i, seconds). Fills
// vel_world and rate_body too. With `jacobians`, also the pose Jacobians (automatic
// differentiation, file comment).
GpState GpInterpolate(const GpState& state_i, const GpState& state_j, double dt, double s,
                      GpInterpolationJacobians* jacobians = nullptr);

// The GP prior between consecutive states (file comment). Parameter blocks:
// pose_i[7], vel_i[3], rate_i[3], pose_j[7], vel_j[3], rate_j[3]; residual 12.
class GpPriorFactor {
 public:
  struct Options {
    // Power spectral density of the white-noise linear acceleration (each axis), m²/s⁵·s.
    double qc_translation = 1.0;
    // Power spectral density of the white-noise angular acceleration (each axis), rad²/s³.
    double qc_rotation = 0.1;

    OptionCheck Check() const;
  };

  GpPriorFactor(const Options& options, double dt);
  // dt = t_j − t_i > 0 in seconds. Automatic differentiation (file comment).
  static ceres::CostFunction* Create(const Options& options, double dt);

  template <typename T>
  bool operator()(const T* pose_i, const T* vel_i, const T* rate_i, const T* pose_j, const T* vel_j,
                  const T* rate_j, T* residuals) const {
    const GpLocalVariables<T> local(pose_i, vel_i, rate_i, pose_j, vel_j, rate_j);
    Eigen::Matrix<T, 12, 1> e;
    e.template head<6>() = local.xi_ij - T(dt_) * local.varpi_i;
    e.template tail<6>() =
        templated::RightJacobianInverseSE3(local.xi_ij) * local.varpi_j - local.varpi_i;
    (Eigen::Map<Eigen::Matrix<T, 12, 1>>(residuals)) = sqrt_information_.cast<T>() * e;
    return true;
  }

  // Q(Δt) (12×12) and its upper Cholesky-of-inverse S (Sᵀ S = Q⁻¹).
  const Eigen::Matrix<double, 12, 12>& covariance() const { return covariance_; }
  const Eigen::Matrix<double, 12, 12>& sqrt_information() const { return sqrt_information_; }

 private:
  double dt_;
  Eigen::Matrix<double, 12, 12> covariance_;
  Eigen::Matrix<double, 12, 12> sqrt_information_;
};

}  // namespace crop4d::slam
