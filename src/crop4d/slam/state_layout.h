#pragma once

// The per-frame state of the row SLAM back end and its Ceres parameterisation (DESIGN.md §2.2).
//
// Each state (one per image) is four Ceres parameter blocks:
//   pose[7]  = (t_world_body x, y, z, q_world_body x, y, z, w)  — Eigen's quaternion storage
//              order (coeffs()), so `Eigen::Map<const Eigen::Quaterniond>(pose + 3)` reads it;
//   vel[3]   = vel_world, the body's velocity in the world (ENU) frame, m/s;
//   rate[3]  = rate_body, the body's angular velocity in the body (IMU) frame, rad/s;
//   bias[6]  = (bg, ba), the gyroscope (rad/s) and accelerometer (m/s²) biases.
// The pose block uses PoseManifold (tangent 6 = [δt; δφ]):
//   t ⊞ δt = t + δt (world frame),   q ⊞ δφ = q ⊗ Exp(δφ) (right perturbation, body frame),
// the convention of Forster et al. (T-RO 2017, §III), so every analytic Jacobian in this
// module is derived for R ← R Exp(δφ), p ← p + δp.
//
// Analytic cost functions compute their Jacobians J_tan w.r.t. this 6-vector and hand Ceres the
// ambient 7-column Jacobian J_amb = J_tan · L(q), where L is the left inverse of the manifold's
// PlusJacobian P (L P = I): Ceres then forms J_amb P = J_tan exactly. L has zero response to a
// change of the quaternion along itself (the unit-norm direction), so J_amb is also the correct
// ambient Jacobian on the unit sphere and analytic and automatic (ceres::Jet) cost functions
// can share the same manifold.

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "crop4d/geometry/rigid.h"

namespace crop4d::slam {

inline constexpr int kPoseSize = 7;
inline constexpr int kPoseTangentSize = 6;
inline constexpr int kVelocitySize = 3;
inline constexpr int kRateSize = 3;
inline constexpr int kBiasSize = 6;

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Vector7d = Eigen::Matrix<double, 7, 1>;
using Vector9d = Eigen::Matrix<double, 9, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Matrix9d = Eigen::Matrix<double, 9, 9>;

// Pose block <-> Rigid3 (world_from_body).
Vector7d PoseToBlock(const geometry::Rigid3& world_from_body);
geometry::Rigid3 BlockToPose(const double* pose);

// P(q) = d(q ⊗ Exp(δφ))/dδφ at δφ = 0, 4×3, rows in (x, y, z, w) order:
//   P = ½ [w I + [v]×; −vᵀ]   (q = (v, w)),   Pᵀ P = ¼ I.
Eigen::Matrix<double, 4, 3> QuaternionPlusJacobian(const Eigen::Quaterniond& q);
// The pose block's PlusJacobian, 7×6 row-major: [I 0; 0 P(q)].
Eigen::Matrix<double, 7, 6, Eigen::RowMajor> PosePlusJacobian(const double* pose);
// Its left inverse L (6×7), L P = I: [I 0; 0 4 Pᵀ].
Eigen::Matrix<double, 6, 7, Eigen::RowMajor> PoseLiftJacobian(const double* pose);

// Writes J_tan (rows × 6) as the ambient rows × 7 row-major Jacobian J_tan · L into `jacobian`
// (Ceres layout). No-op when `jacobian` is null.
template <int Rows>
void WritePoseJacobian(const Eigen::Matrix<double, Rows, 6>& jacobian_tangent, const double* pose,
                       double* jacobian) {
  if (jacobian == nullptr) return;
  Eigen::Map<Eigen::Matrix<double, Rows, 7, Eigen::RowMajor>> out(jacobian);
  out = jacobian_tangent * PoseLiftJacobian(pose);
}

}  // namespace crop4d::slam
