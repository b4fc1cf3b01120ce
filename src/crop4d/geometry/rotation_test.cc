#include "crop4d/geometry/rotation.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <numbers>
#include <vector>

namespace crop4d::geometry {
namespace {

constexpr double kPi = std::numbers::pi;

// Rotation vectors at the magnitudes where the formulas switch branches or lose precision:
// exactly zero, deep in the Taylor range, at the series threshold, generic, and near π.
std::vector<Eigen::Vector3d> TestRotationVectors() {
  const std::vector<Eigen::Vector3d> axes = {
      Eigen::Vector3d(1.0, 2.0, 3.0).normalized(), Eigen::Vector3d(-0.3, 0.5, 0.8).normalized(),
      Eigen::Vector3d::UnitX(), Eigen::Vector3d(0.0, -1.0, 1.0).normalized()};
  const std::vector<double> angles = {0.0, 1e-9, 1e-4,       0.1 - 1e-9, 0.1 + 1e-9,
                                      1.0, 2.5,  kPi - 1e-3, kPi - 1e-6};
  std::vector<Eigen::Vector3d> out;
  for (const double angle : angles) {
    for (const Eigen::Vector3d& axis : axes) out.push_back(angle * axis);
  }
  return out;
}

// Central differences of f at 0 (Nocedal & Wright, "Numerical Optimization", eq. 8.7):
// column j is (f(h e_j) − f(−h e_j)) / 2h; truncation O(h²), round-off O(ε/h).
Eigen::Matrix3d NumericalJacobian(const std::function<Eigen::Vector3d(const Eigen::Vector3d&)>& f,
                                  double h) {
  Eigen::Matrix3d J;
  for (int j = 0; j < 3; ++j) {
    const Eigen::Vector3d d = h * Eigen::Vector3d::Unit(j);
    J.col(j) = (f(d) - f(-d)) / (2.0 * h);
  }
  return J;
}

// A step that stays clear of the wrap of Log at angle π.
double StepFor(const Eigen::Vector3d& phi) { return std::min(1e-6, 0.25 * (kPi - phi.norm())); }

TEST(RotationTest, HatIsCrossProductAndVeeInvertsIt) {
  const Eigen::Vector3d a(0.3, -1.2, 2.0);
  const Eigen::Vector3d b(-0.7, 0.4, 1.1);
  EXPECT_TRUE((Hat(a) * b).isApprox(a.cross(b), 1e-15));
  EXPECT_TRUE((Hat(a) + Hat(a).transpose()).isZero(0.0));
  EXPECT_EQ(Vee(Hat(a)), a);
}

TEST(RotationTest, ExpMatchesAngleAxisAndQuaternion) {
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    const Eigen::Matrix3d R = ExpSO3(phi);
    const Eigen::Matrix3d expected =
        phi.norm() == 0.0 ? Eigen::Matrix3d::Identity()
                          : Eigen::AngleAxisd(phi.norm(), phi.normalized()).toRotationMatrix();
    EXPECT_LT((R - expected).norm(), 1e-15 * 4);
    EXPECT_LT((ExpQuat(phi).toRotationMatrix() - R).norm(), 1e-15 * 4);
    EXPECT_NEAR(ExpQuat(phi).norm(), 1.0, 1e-15);
    EXPECT_LT((R.transpose() * R - Eigen::Matrix3d::Identity()).norm(), 1e-15 * 4);
    EXPECT_NEAR(R.determinant(), 1.0, 1e-15 * 4);
  }
}

TEST(RotationTest, ExpIsFirstOrderForTinyAngles) {
  const Eigen::Vector3d phi(1e-9, -2e-9, 3e-9);
  const Eigen::Matrix3d first_order = Eigen::Matrix3d::Identity() + Hat(phi);
  EXPECT_LT((ExpSO3(phi) - first_order).norm(), 1e-17);
  EXPECT_EQ(ExpSO3(Eigen::Vector3d::Zero()), Eigen::Matrix3d::Identity());
  EXPECT_EQ(LogSO3(Eigen::Matrix3d::Identity()), Eigen::Vector3d::Zero());
}

TEST(RotationTest, LogInvertsExp) {
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    // Relative accuracy close to machine precision; near π the matrix entries themselves carry
    // ~1e-16 absolute error, which the axis inherits.
    const double tolerance = 1e-14 * phi.norm() + 1e-24;
    EXPECT_LT((LogSO3(ExpSO3(phi)) - phi).norm(), tolerance);
    EXPECT_LT((LogQuat(ExpQuat(phi)) - phi).norm(), tolerance);
    EXPECT_LE(LogSO3(ExpSO3(phi)).norm(), kPi);
  }
}

TEST(RotationTest, ExpInvertsLogForArbitraryRotations) {
  std::srand(7);
  for (int i = 0; i < 50; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(Eigen::Vector4d::Random()).normalized();
    const Eigen::Matrix3d R = q.toRotationMatrix();
    EXPECT_LT((ExpSO3(LogSO3(R)) - R).norm(), 1e-14);
    EXPECT_LE(LogSO3(R).norm(), kPi + 1e-15);
    // q and −q are the same rotation and have the same logarithm.
    EXPECT_LT((LogQuat(q) - LogQuat(Eigen::Quaterniond(-q.coeffs()))).norm(), 1e-14);
  }
}

TEST(RotationTest, LogAtAndNearPi) {
  for (const Eigen::Vector3d& axis : std::vector<Eigen::Vector3d>{
           Eigen::Vector3d::UnitX(), Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ(),
           Eigen::Vector3d(1.0, -1.0, 2.0).normalized()}) {
    const Eigen::Matrix3d R = Eigen::AngleAxisd(kPi, axis).toRotationMatrix();
    const Eigen::Vector3d phi = LogSO3(R);
    EXPECT_NEAR(phi.norm(), kPi, 1e-14);
    // The axis is defined up to sign at exactly π.
    EXPECT_NEAR(std::abs(phi.normalized().dot(axis)), 1.0, 1e-14);
    EXPECT_LT((ExpSO3(phi) - R).norm(), 1e-14);
  }
  // Just past π, the logarithm wraps to the shorter rotation about the opposite axis.
  const Eigen::Vector3d axis = Eigen::Vector3d(0.2, 0.3, -0.9).normalized();
  const Eigen::Vector3d wrapped = LogSO3(ExpSO3((kPi + 1e-6) * axis));
  EXPECT_LT((wrapped - (-(kPi - 1e-6) * axis)).norm(), 1e-12);
}

TEST(RotationTest, RightJacobianMatchesNumericalDifferentiation) {
  // Defining relation: Exp(φ + δ) ≈ Exp(φ) Exp(Jr(φ) δ), i.e. Jr = ∂/∂δ Log(Exp(φ)ᵀ Exp(φ + δ)).
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    const Eigen::Matrix3d R_inv = ExpSO3(phi).transpose();
    const Eigen::Matrix3d numerical = NumericalJacobian(
        [&](const Eigen::Vector3d& d) { return LogSO3(R_inv * ExpSO3(phi + d)); }, 1e-6);
    EXPECT_LT((RightJacobianSO3(phi) - numerical).norm(), 1e-6);
  }
}

TEST(RotationTest, LeftJacobianMatchesNumericalDifferentiation) {
  // Exp(φ + δ) ≈ Exp(Jl(φ) δ) Exp(φ), i.e. Jl = ∂/∂δ Log(Exp(φ + δ) Exp(φ)ᵀ).
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    const Eigen::Matrix3d R_inv = ExpSO3(phi).transpose();
    const Eigen::Matrix3d numerical = NumericalJacobian(
        [&](const Eigen::Vector3d& d) { return LogSO3(ExpSO3(phi + d) * R_inv); }, 1e-6);
    EXPECT_LT((LeftJacobianSO3(phi) - numerical).norm(), 1e-6);
  }
}

TEST(RotationTest, RightJacobianInverseMatchesNumericalDifferentiation) {
  // Log(Exp(φ) Exp(δ)) ≈ φ + Jr⁻¹(φ) δ.
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    const Eigen::Matrix3d R = ExpSO3(phi);
    const Eigen::Matrix3d numerical = NumericalJacobian(
        [&](const Eigen::Vector3d& d) { return LogSO3(R * ExpSO3(d)); }, StepFor(phi));
    EXPECT_LT((RightJacobianInverseSO3(phi) - numerical).norm(), 1e-6);
  }
}

TEST(RotationTest, LeftJacobianInverseMatchesNumericalDifferentiation) {
  // Log(Exp(δ) Exp(φ)) ≈ φ + Jl⁻¹(φ) δ.
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    const Eigen::Matrix3d R = ExpSO3(phi);
    const Eigen::Matrix3d numerical = NumericalJacobian(
        [&](const Eigen::Vector3d& d) { return LogSO3(ExpSO3(d) * R); }, StepFor(phi));
    EXPECT_LT((LeftJacobianInverseSO3(phi) - numerical).norm(), 1e-6);
  }
}

TEST(RotationTest, JacobianIdentities) {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  for (const Eigen::Vector3d& phi : TestRotationVectors()) {
    SCOPED_TRACE(phi.norm());
    EXPECT_LT((RightJacobianSO3(phi) * RightJacobianInverseSO3(phi) - I).norm(), 1e-13);
    EXPECT_LT((LeftJacobianSO3(phi) * LeftJacobianInverseSO3(phi) - I).norm(), 1e-13);
    // Jl(φ) = Exp(φ) Jr(φ) (Barfoot 2017, §7.1.5) and Jl(φ) φ = φ.
    EXPECT_LT((LeftJacobianSO3(phi) - ExpSO3(phi) * RightJacobianSO3(phi)).norm(), 1e-14);
    EXPECT_LT((LeftJacobianSO3(phi) * phi - phi).norm(), 1e-14);
    EXPECT_LT((RightJacobianInverseSO3(phi) * phi - phi).norm(), 1e-13);
  }
  EXPECT_EQ(RightJacobianSO3(Eigen::Vector3d::Zero()), I);
  EXPECT_EQ(RightJacobianInverseSO3(Eigen::Vector3d::Zero()), I);
}

TEST(RotationTest, SeriesBranchIsContinuousAtThreshold) {
  const Eigen::Vector3d axis = Eigen::Vector3d(0.6, -0.8, 0.0);
  const Eigen::Vector3d below = (0.1 - 1e-12) * axis;
  const Eigen::Vector3d above = (0.1 + 1e-12) * axis;
  EXPECT_LT((ExpSO3(below) - ExpSO3(above)).norm(), 1e-11);
  EXPECT_LT((RightJacobianSO3(below) - RightJacobianSO3(above)).norm(), 1e-11);
  EXPECT_LT((RightJacobianInverseSO3(below) - RightJacobianInverseSO3(above)).norm(), 1e-11);
}

TEST(RotationTest, InterpolationEndpointsAndMidpoint) {
  const Eigen::Quaterniond q0 = ExpQuat(Eigen::Vector3d(0.1, -0.4, 0.3));
  const Eigen::Quaterniond q1 = ExpQuat(Eigen::Vector3d(-0.5, 0.2, 1.1));
  EXPECT_LT(AngleBetween(InterpolateRotation(q0, q1, 0.0), q0), 1e-14);
  EXPECT_LT(AngleBetween(InterpolateRotation(q0, q1, 1.0), q1), 1e-14);
  const Eigen::Quaterniond mid = InterpolateRotation(q0, q1, 0.5);
  const double total = AngleBetween(q0, q1);
  EXPECT_NEAR(AngleBetween(q0, mid), 0.5 * total, 1e-14);
  EXPECT_NEAR(AngleBetween(mid, q1), 0.5 * total, 1e-14);
  // Agrees with Eigen's slerp, and ignores the sign of the quaternions.
  EXPECT_LT(AngleBetween(mid, q0.slerp(0.5, q1)), 1e-14);
  EXPECT_LT(AngleBetween(InterpolateRotation(q0, Eigen::Quaterniond(-q1.coeffs()), 0.3),
                         InterpolateRotation(q0, q1, 0.3)),
            1e-14);
  // Extrapolation continues along the same geodesic.
  EXPECT_NEAR(AngleBetween(q0, InterpolateRotation(q0, q1, 1.5)), 1.5 * total, 1e-13);
}

TEST(RotationTest, AnglesOfKnownRotations) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(RotationAngle(q), 0.7, 1e-15);
  EXPECT_NEAR(RotationAngle(Eigen::Quaterniond(-q.coeffs())), 0.7, 1e-15);
  EXPECT_NEAR(RotationAngle(Eigen::Quaterniond(Eigen::AngleAxisd(kPi, Eigen::Vector3d::UnitY()))),
              kPi, 1e-15);
  const Eigen::Quaterniond q2(Eigen::AngleAxisd(-0.2, Eigen::Vector3d::UnitZ()));
  EXPECT_NEAR(AngleBetween(q, q2), 0.9, 1e-15);
  EXPECT_EQ(RotationAngle(Eigen::Quaterniond::Identity()), 0.0);
}

}  // namespace
}  // namespace crop4d::geometry
