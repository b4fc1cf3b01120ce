#include "crop4d/geometry/rigid.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "crop4d/geometry/rotation.h"

namespace crop4d::geometry {
namespace {

constexpr double kPi = std::numbers::pi;

Vector6d Xi(const Eigen::Vector3d& rho, const Eigen::Vector3d& phi) {
  Vector6d xi;
  xi << rho, phi;
  return xi;
}

// Tangent vectors with rotation magnitudes at 0, in the Taylor range, at the series threshold,
// generic and near π, each with a few translations.
std::vector<Vector6d> TestTangents() {
  const std::vector<Eigen::Vector3d> axes = {Eigen::Vector3d(1.0, 2.0, 3.0).normalized(),
                                             Eigen::Vector3d(-0.3, 0.5, 0.8).normalized()};
  const std::vector<Eigen::Vector3d> rhos = {
      Eigen::Vector3d::Zero(), Eigen::Vector3d(1.0, -2.0, 0.5), Eigen::Vector3d(-30.0, 4.0, 12.0)};
  const std::vector<double> angles = {0.0,        1e-9, 1e-4, 0.1 - 1e-9,
                                      0.1 + 1e-9, 1.0,  2.5,  kPi - 1e-6};
  std::vector<Vector6d> out;
  for (const double angle : angles) {
    for (const Eigen::Vector3d& axis : axes) {
      for (const Eigen::Vector3d& rho : rhos) out.push_back(Xi(rho, angle * axis));
    }
  }
  return out;
}

// Central differences at 0 (Nocedal & Wright, "Numerical Optimization", eq. 8.7).
Matrix6d NumericalJacobian(const std::function<Vector6d(const Vector6d&)>& f, double h) {
  Matrix6d J;
  for (int j = 0; j < 6; ++j) {
    const Vector6d d = h * Vector6d::Unit(j);
    J.col(j) = (f(d) - f(-d)) / (2.0 * h);
  }
  return J;
}

// A step that keeps the perturbed rotation clear of the wrap of Log at angle π.
double StepFor(const Vector6d& xi) { return std::min(1e-6, 0.25 * (kPi - xi.tail<3>().norm())); }

// Error measure relative to the size of the Jacobian (translations up to 30 m make entries
// of order 30).
double RelativeError(const Matrix6d& a, const Matrix6d& b) {
  return (a - b).norm() / std::max(1.0, b.norm());
}

Eigen::Matrix4d Twist(const Vector6d& xi) {
  // ξ^ = [φ^, ρ; 0, 0] (Barfoot 2017, §7.1.2).
  Eigen::Matrix4d m = Eigen::Matrix4d::Zero();
  m.topLeftCorner<3, 3>() = Hat(xi.tail<3>());
  m.topRightCorner<3, 1>() = xi.head<3>();
  return m;
}

TEST(RigidTest, CompositionInverseAndPoints) {
  const Rigid3 a_from_b(ExpQuat(Eigen::Vector3d(0.1, 0.2, -0.3)), Eigen::Vector3d(1.0, 2.0, 3.0));
  const Rigid3 b_from_c(ExpQuat(Eigen::Vector3d(-0.5, 0.4, 0.9)), Eigen::Vector3d(-4.0, 0.5, 2.0));
  const Eigen::Vector3d x_in_c(0.3, -0.7, 5.0);
  const Rigid3 a_from_c = a_from_b * b_from_c;
  EXPECT_LT((a_from_c * x_in_c - a_from_b * (b_from_c * x_in_c)).norm(), 1e-14);
  EXPECT_LT((a_from_c.Matrix() - a_from_b.Matrix() * b_from_c.Matrix()).norm(), 1e-14);
  EXPECT_LT((a_from_b.Inverse().Matrix() - a_from_b.Matrix().inverse()).norm(), 1e-14);
  EXPECT_LT(((a_from_b * a_from_b.Inverse()).Matrix() - Eigen::Matrix4d::Identity()).norm(), 1e-15);
  EXPECT_LT((a_from_b.Inverse() * (a_from_b * x_in_c) - x_in_c).norm(), 1e-14);
  EXPECT_EQ(Rigid3::Identity().Matrix(), Eigen::Matrix4d::Identity());
  // The quaternion is normalised on construction.
  const Rigid3 scaled(Eigen::Quaterniond(2.0, 0.0, 0.0, 0.0), Eigen::Vector3d::Zero());
  EXPECT_NEAR(scaled.rotation().norm(), 1.0, 1e-15);
}

TEST(RigidTest, FromMatrixRoundTripsAndReorthonormalises) {
  const Rigid3 T(ExpQuat(Eigen::Vector3d(0.7, -0.2, 1.4)), Eigen::Vector3d(0.1, -0.2, 0.3));
  EXPECT_LT((Rigid3::FromMatrix(T.Matrix()).Matrix() - T.Matrix()).norm(), 1e-15);
  // A rotation block printed with 6 decimals (as in Kalibr YAML files) is not quite
  // orthonormal; the result is the nearest rotation.
  Eigen::Matrix4d rounded = T.Matrix();
  rounded.topLeftCorner<3, 3>() = (rounded.topLeftCorner<3, 3>() * 1e6).array().round() / 1e6;
  const Rigid3 fixed = Rigid3::FromMatrix(rounded);
  const Eigen::Matrix3d R = fixed.RotationMatrix();
  EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-15);
  EXPECT_LT((R - T.RotationMatrix()).norm(), 2e-6);
  EXPECT_EQ(fixed.translation(), T.translation());
}

TEST(RigidTest, ExpMatchesMatrixExponential) {
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    const Eigen::Matrix4d expected = Twist(xi).exp();
    EXPECT_LT((ExpSE3(xi).Matrix() - expected).norm(), 1e-12 * std::max(1.0, expected.norm()));
  }
}

TEST(RigidTest, LogInvertsExp) {
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    // Near π the rotation's own round-off (~1e-16) is amplified in ρ = Jl⁻¹(φ) t by |t|.
    EXPECT_LT((LogSE3(ExpSE3(xi)) - xi).norm(), 1e-12 * std::max(1.0, xi.norm()));
  }
  EXPECT_EQ(LogSE3(Rigid3::Identity()), Vector6d::Zero());
}

TEST(RigidTest, RightJacobianMatchesNumericalDifferentiation) {
  // Exp(ξ + δ) ≈ Exp(ξ) Exp(Jr(ξ) δ): Jr = ∂/∂δ Log(Exp(ξ)⁻¹ Exp(ξ + δ)).
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    const Rigid3 T_inv = ExpSE3(xi).Inverse();
    const Matrix6d numerical =
        NumericalJacobian([&](const Vector6d& d) { return LogSE3(T_inv * ExpSE3(xi + d)); }, 1e-6);
    EXPECT_LT(RelativeError(RightJacobianSE3(xi), numerical), 1e-6);
  }
}

TEST(RigidTest, LeftJacobianMatchesNumericalDifferentiation) {
  // Exp(ξ + δ) ≈ Exp(Jl(ξ) δ) Exp(ξ): Jl = ∂/∂δ Log(Exp(ξ + δ) Exp(ξ)⁻¹).
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    const Rigid3 T_inv = ExpSE3(xi).Inverse();
    const Matrix6d numerical =
        NumericalJacobian([&](const Vector6d& d) { return LogSE3(ExpSE3(xi + d) * T_inv); }, 1e-6);
    EXPECT_LT(RelativeError(LeftJacobianSE3(xi), numerical), 1e-6);
  }
}

TEST(RigidTest, RightJacobianInverseMatchesNumericalDifferentiation) {
  // Log(Exp(ξ) Exp(δ)) ≈ ξ + Jr⁻¹(ξ) δ.
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    const Rigid3 T = ExpSE3(xi);
    const Matrix6d numerical =
        NumericalJacobian([&](const Vector6d& d) { return LogSE3(T * ExpSE3(d)); }, StepFor(xi));
    EXPECT_LT(RelativeError(RightJacobianInverseSE3(xi), numerical), 1e-6);
  }
}

TEST(RigidTest, LeftJacobianInverseMatchesNumericalDifferentiation) {
  // Log(Exp(δ) Exp(ξ)) ≈ ξ + Jl⁻¹(ξ) δ.
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    const Rigid3 T = ExpSE3(xi);
    const Matrix6d numerical =
        NumericalJacobian([&](const Vector6d& d) { return LogSE3(ExpSE3(d) * T); }, StepFor(xi));
    EXPECT_LT(RelativeError(LeftJacobianInverseSE3(xi), numerical), 1e-6);
  }
}

TEST(RigidTest, JacobianIdentities) {
  const Matrix6d I = Matrix6d::Identity();
  for (const Vector6d& xi : TestTangents()) {
    SCOPED_TRACE(xi.transpose());
    EXPECT_LT((RightJacobianSE3(xi) * RightJacobianInverseSE3(xi) - I).norm(), 1e-12);
    EXPECT_LT((LeftJacobianSE3(xi) * LeftJacobianInverseSE3(xi) - I).norm(), 1e-12);
    // Jl(ξ) = Ad(Exp(ξ)) Jr(ξ) (Barfoot 2017, §7.1.5) and Jl(ξ) ξ = ξ.
    EXPECT_LT(RelativeError(LeftJacobianSE3(xi), ExpSE3(xi).Adjoint() * RightJacobianSE3(xi)),
              1e-13);
    EXPECT_LT((LeftJacobianSE3(xi) * xi - xi).norm(), 1e-12 * std::max(1.0, xi.norm()));
  }
  EXPECT_EQ(LeftJacobianSE3(Vector6d::Zero()), I);
  EXPECT_EQ(RightJacobianInverseSE3(Vector6d::Zero()), I);
}

TEST(RigidTest, SeriesBranchIsContinuousAtThreshold) {
  const Eigen::Vector3d axis(0.6, -0.8, 0.0);
  const Eigen::Vector3d rho(3.0, -1.0, 2.0);
  const Vector6d below = Xi(rho, (0.1 - 1e-12) * axis);
  const Vector6d above = Xi(rho, (0.1 + 1e-12) * axis);
  EXPECT_LT((LeftJacobianSE3(below) - LeftJacobianSE3(above)).norm(), 1e-10);
  EXPECT_LT((LeftJacobianInverseSE3(below) - LeftJacobianInverseSE3(above)).norm(), 1e-10);
}

TEST(RigidTest, AdjointMovesPerturbationsAcrossTheTransform) {
  // T Exp(ξ) T⁻¹ = Exp(Ad(T) ξ) (Barfoot 2017, §7.1.4).
  const Rigid3 T(ExpQuat(Eigen::Vector3d(0.4, -1.1, 0.6)), Eigen::Vector3d(2.0, -3.0, 0.7));
  for (const Vector6d& xi : TestTangents()) {
    if (xi.tail<3>().norm() > 3.0) continue;  // Ad ξ may land past π, where Log wraps.
    SCOPED_TRACE(xi.transpose());
    const Rigid3 lhs = T * ExpSE3(xi) * T.Inverse();
    const Rigid3 rhs = ExpSE3(T.Adjoint() * xi);
    EXPECT_LT((lhs.Matrix() - rhs.Matrix()).norm(), 1e-12 * std::max(1.0, xi.norm()));
  }
  // The adjoint of a composition is the product of adjoints.
  const Rigid3 U(ExpQuat(Eigen::Vector3d(-0.2, 0.3, 0.1)), Eigen::Vector3d(0.5, 0.5, -1.0));
  EXPECT_LT(((T * U).Adjoint() - T.Adjoint() * U.Adjoint()).norm(), 1e-13);
  EXPECT_LT((T.Inverse().Adjoint() - T.Adjoint().inverse()).norm(), 1e-13);
}

TEST(RigidTest, InterpolationEndpointsAndMidpoint) {
  const Rigid3 T0(ExpQuat(Eigen::Vector3d(0.1, -0.2, 0.3)), Eigen::Vector3d(1.0, 0.0, -2.0));
  const Rigid3 T1(ExpQuat(Eigen::Vector3d(-0.4, 0.6, 1.2)), Eigen::Vector3d(5.0, 3.0, 1.0));
  EXPECT_LT((Interpolate(T0, T1, 0.0).Matrix() - T0.Matrix()).norm(), 1e-14);
  EXPECT_LT((Interpolate(T0, T1, 1.0).Matrix() - T1.Matrix()).norm(), 1e-13);
  // The geodesic midpoint M splits T0⁻¹ T1 into two equal steps: T0⁻¹ M = M⁻¹ T1.
  const Rigid3 mid = Interpolate(T0, T1, 0.5);
  EXPECT_LT(((T0.Inverse() * mid).Matrix() - (mid.Inverse() * T1).Matrix()).norm(), 1e-13);
  EXPECT_LT((LogSE3(T0.Inverse() * mid) - 0.5 * LogSE3(T0.Inverse() * T1)).norm(), 1e-13);

  EXPECT_LT((InterpolateSeparately(T0, T1, 0.0).Matrix() - T0.Matrix()).norm(), 1e-14);
  EXPECT_LT((InterpolateSeparately(T0, T1, 1.0).Matrix() - T1.Matrix()).norm(), 1e-14);
  const Rigid3 separate = InterpolateSeparately(T0, T1, 0.25);
  EXPECT_LT((separate.translation() - (0.75 * T0.translation() + 0.25 * T1.translation())).norm(),
            1e-14);
  EXPECT_LT(AngleBetween(separate.rotation(), T0.rotation().slerp(0.25, T1.rotation())), 1e-14);
  // Both schemes share the rotation path.
  EXPECT_LT(AngleBetween(separate.rotation(), Interpolate(T0, T1, 0.25).rotation()), 1e-14);

  // For a pure translation the two schemes coincide.
  const Rigid3 S1(T0.rotation(), Eigen::Vector3d(-3.0, 2.0, 8.0));
  EXPECT_LT(
      (Interpolate(T0, S1, 0.3).Matrix() - InterpolateSeparately(T0, S1, 0.3).Matrix()).norm(),
      1e-13);
}

}  // namespace
}  // namespace crop4d::geometry
