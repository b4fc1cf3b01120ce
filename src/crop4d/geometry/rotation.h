#pragma once

// SO(3) on Eigen: hat/vee, exponential and logarithm maps, and the left/right Jacobians.
// Conventions follow Forster et al., "On-Manifold Preintegration for Real-Time
// Visual-Inertial Odometry" (T-RO 2017), §III, and Barfoot, "State Estimation for Robotics"
// (2017), §7.1: a perturbation on the right is R * Exp(δφ), on the left Exp(δφ) * R.
//   Exp(φ + δφ) ≈ Exp(φ) Exp(Jr(φ) δφ)        Log(Exp(φ) Exp(δφ)) ≈ φ + Jr⁻¹(φ) δφ
//   Exp(φ + δφ) ≈ Exp(Jl(φ) δφ) Exp(φ)        Jl(φ) = Jr(−φ)

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace crop4d::geometry {

// [v]×, the skew-symmetric matrix with Hat(a) * b = a × b.
Eigen::Matrix3d Hat(const Eigen::Vector3d& v);
// Inverse of Hat for a skew-symmetric matrix.
Eigen::Vector3d Vee(const Eigen::Matrix3d& m);

// Rodrigues' formula; accurate for small angles (Taylor series of the coefficients below 0.1 rad).
Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi);
Eigen::Quaterniond ExpQuat(const Eigen::Vector3d& phi);
// Rotation vector with |φ| ≤ π; stable near 0 and near π.
Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R);
Eigen::Vector3d LogQuat(const Eigen::Quaterniond& q);

// Right Jacobian of SO(3) and its inverse (Forster eq. 8, 9).
Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& phi);
Eigen::Matrix3d RightJacobianInverseSO3(const Eigen::Vector3d& phi);
// Left Jacobian and its inverse: Jl(φ) = Jr(−φ).
Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi);
Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& phi);

// Geodesic interpolation R(α) = R0 Exp(α Log(R0ᵀ R1)), α in [0, 1] (extrapolates outside).
Eigen::Quaterniond InterpolateRotation(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                       double alpha);

// The rotation's angle in radians, in [0, π].
double RotationAngle(const Eigen::Quaterniond& q);
// Angle of q0⁻¹ q1 in radians.
double AngleBetween(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1);

}  // namespace crop4d::geometry
