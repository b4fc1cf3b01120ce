#pragma once

// Rigid transforms SE(3). A Rigid3 named `a_from_b` maps points in frame b to frame a:
//   x_in_a = a_from_b * x_in_b,   a_from_c = a_from_b * b_from_c   (DESIGN.md §3).
// Tangent vectors are ξ = [ρ; φ] (translation part first, then rotation), as in Barfoot,
// "State Estimation for Robotics" (2017), §7.1.
// Exp(ξ) = [Exp(φ), Jl(φ) ρ; 0, 1].

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace crop4d::geometry {

using Vector6d = Eigen::Matrix<double, 6, 1>;
using Matrix6d = Eigen::Matrix<double, 6, 6>;

class Rigid3 {
 public:
  // How far from 1 the norm of a quaternion given as a unit one may be.
  static constexpr double kUnitQuaternionTolerance = 1e-9;

  Rigid3() : rotation_(Eigen::Quaterniond::Identity()), translation_(Eigen::Vector3d::Zero()) {}
  // The quaternion is normalised.
  Rigid3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation);
  Rigid3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation);

  static Rigid3 Identity() { return Rigid3(); }
  // From a unit quaternion kept as it is (one read back from crop4d's own binary files), so that
  // writing and reading a pose round-trips bit for bit; normalising again could move the last
  // bit. Aborts when |q| is not 1 within 1e-9 (the reader checks that first).
  static Rigid3 FromUnitQuaternion(const Eigen::Quaterniond& rotation,
                                   const Eigen::Vector3d& translation);
  // From a 4x4 homogeneous matrix (the EuRoC/Kalibr T_BS layout). The rotation block is
  // re-orthonormalised.
  static Rigid3 FromMatrix(const Eigen::Matrix4d& m);

  const Eigen::Quaterniond& rotation() const { return rotation_; }
  const Eigen::Vector3d& translation() const { return translation_; }
  Eigen::Matrix3d RotationMatrix() const { return rotation_.toRotationMatrix(); }
  Eigen::Matrix4d Matrix() const;

  Rigid3 Inverse() const;
  Rigid3 operator*(const Rigid3& other) const;
  Eigen::Vector3d operator*(const Eigen::Vector3d& point) const;

  // Adjoint Ad(T) with T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ), for ξ = [ρ; φ]:
  //   Ad = [R, [t]× R; 0, R].
  Matrix6d Adjoint() const;

 private:
  Eigen::Quaterniond rotation_;
  Eigen::Vector3d translation_;
};

Rigid3 ExpSE3(const Vector6d& xi);
Vector6d LogSE3(const Rigid3& T);

// Right and left Jacobians of SE(3) and their inverses (Barfoot §7.1.5, eq. 7.95 for the
// Q block): Exp(ξ + δξ) ≈ Exp(ξ) Exp(Jr(ξ) δξ) ≈ Exp(Jl(ξ) δξ) Exp(ξ), Jr(ξ) = Jl(−ξ).
Matrix6d LeftJacobianSE3(const Vector6d& xi);
Matrix6d RightJacobianSE3(const Vector6d& xi);
Matrix6d LeftJacobianInverseSE3(const Vector6d& xi);
Matrix6d RightJacobianInverseSE3(const Vector6d& xi);

// Geodesic interpolation on SE(3): T0 Exp(α Log(T0⁻¹ T1)).
Rigid3 Interpolate(const Rigid3& T0, const Rigid3& T1, double alpha);
// Rotation and translation interpolated separately (slerp + lerp), the usual choice for
// trajectories sampled at other timestamps (e.g. ground-truth poses at GPS times).
Rigid3 InterpolateSeparately(const Rigid3& T0, const Rigid3& T1, double alpha);

}  // namespace crop4d::geometry
