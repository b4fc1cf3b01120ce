#include "crop4d/geometry/rigid.h"

#include <Eigen/SVD>
#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"

namespace crop4d::geometry {
namespace {

// Below this angle the coefficients of Q are evaluated by their Taylor series (through θ⁸,
// truncation error < 1e-18). The closed forms cancel badly for small θ: the numerator of c3
// is O(θ⁵) built from O(θ) terms, so at θ = 0.1 it still keeps ~12 significant digits but at
// θ = 1e-3 none.
constexpr double kSeriesAngle = 0.1;

double Series(double t, double c0, double c1, double c2, double c3, double c4) {
  return c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)));
}

// The three coefficients of Q, the upper-right block of the SE(3) left Jacobian (Barfoot 2017,
// §7.1.5):
//   c1 = (θ − sin θ)/θ³
//   c2 = (θ² + 2 cos θ − 2)/(2θ⁴)
//   c3 = (2θ − 3 sin θ + θ cos θ)/(2θ⁵)
// Series (expanded with sympy): c1 = 1/6 − θ²/120 + θ⁴/5040 − θ⁶/362880 + θ⁸/39916800,
// c2 = 1/24 − θ²/720 + θ⁴/40320 − θ⁶/3628800 + θ⁸/479001600,
// c3 = 1/120 − θ²/2520 + θ⁴/120960 − θ⁶/9979200 + θ⁸/1245404160.
struct QCoefficients {
  double c1, c2, c3;
};

QCoefficients ComputeQCoefficients(double theta) {
  if (theta < kSeriesAngle) {
    const double t = theta * theta;
    return {Series(t, 1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0, 1.0 / 39916800.0),
            Series(t, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0),
            Series(t, 1.0 / 120.0, -1.0 / 2520.0, 1.0 / 120960.0, -1.0 / 9979200.0,
                   1.0 / 1245404160.0)};
  }
  const double t2 = theta * theta;
  const double t4 = t2 * t2;
  const double s = std::sin(theta);
  const double c = std::cos(theta);
  const double sh = std::sin(0.5 * theta);
  // 2 cos θ − 2 = −4 sin²(θ/2), which avoids one cancellation.
  return {(theta - s) / (t2 * theta), (t2 - 4.0 * sh * sh) / (2.0 * t4),
          (2.0 * theta - 3.0 * s + theta * c) / (2.0 * t4 * theta)};
}

// Q(ρ, φ), the upper-right block of the SE(3) left Jacobian (Barfoot 2017, §7.1.5; also
// Barfoot & Furgale, "Associating Uncertainty With Three-Dimensional Poses for Use in
// Estimation Problems", T-RO 2014, §III):
//   Q = ½ ρ^ + c1 (φ^ρ^ + ρ^φ^ + φ^ρ^φ^) + c2 (φ^φ^ρ^ + ρ^φ^φ^ − 3 φ^ρ^φ^)
//         + c3 (φ^ρ^φ^φ^ + φ^φ^ρ^φ^).
Eigen::Matrix3d QMatrix(const Eigen::Vector3d& rho, const Eigen::Vector3d& phi) {
  const QCoefficients k = ComputeQCoefficients(phi.norm());
  const Eigen::Matrix3d P = Hat(phi);
  const Eigen::Matrix3d Rh = Hat(rho);
  const Eigen::Matrix3d PR = P * Rh;
  const Eigen::Matrix3d RP = Rh * P;
  const Eigen::Matrix3d PRP = PR * P;
  return 0.5 * Rh + k.c1 * (PR + RP + PRP) + k.c2 * (P * PR + RP * P - 3.0 * PRP) +
         k.c3 * (PRP * P + P * PRP);
}

}  // namespace

Rigid3::Rigid3(const Eigen::Quaterniond& rotation, const Eigen::Vector3d& translation)
    : rotation_(rotation.normalized()), translation_(translation) {}

Rigid3::Rigid3(const Eigen::Matrix3d& rotation, const Eigen::Vector3d& translation)
    : rotation_(Eigen::Quaterniond(rotation).normalized()), translation_(translation) {}

Rigid3 Rigid3::FromUnitQuaternion(const Eigen::Quaterniond& rotation,
                                  const Eigen::Vector3d& translation) {
  CROP4D_CHECK_MSG(std::abs(rotation.norm() - 1.0) <= kUnitQuaternionTolerance,
                   "|q| = " + std::to_string(rotation.norm()));
  Rigid3 pose;
  pose.rotation_ = rotation;
  pose.translation_ = translation;
  return pose;
}

Rigid3 Rigid3::FromMatrix(const Eigen::Matrix4d& m) {
  // Nearest rotation in the Frobenius norm: R = U diag(1, 1, det(U Vᵀ)) Vᵀ from the SVD of the
  // block (Horn, Hilden & Negahdaripour, "Closed-form solution of absolute orientation using
  // orthonormal matrices", JOSA A 1988).
  const Eigen::Matrix3d block = m.topLeftCorner<3, 3>();
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(block, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
  D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0.0 ? -1.0 : 1.0;
  const Eigen::Matrix3d R = svd.matrixU() * D * svd.matrixV().transpose();
  return Rigid3(R, m.topRightCorner<3, 1>());
}

Eigen::Matrix4d Rigid3::Matrix() const {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = RotationMatrix();
  m.topRightCorner<3, 1>() = translation_;
  return m;
}

Rigid3 Rigid3::Inverse() const {
  // [R, t]⁻¹ = [Rᵀ, −Rᵀ t].
  const Eigen::Quaterniond inv = rotation_.conjugate();
  return Rigid3(inv, -(inv * translation_));
}

Rigid3 Rigid3::operator*(const Rigid3& other) const {
  // [R1, t1][R2, t2] = [R1 R2, R1 t2 + t1].
  return Rigid3(rotation_ * other.rotation_, rotation_ * other.translation_ + translation_);
}

Eigen::Vector3d Rigid3::operator*(const Eigen::Vector3d& point) const {
  return rotation_ * point + translation_;
}

Matrix6d Rigid3::Adjoint() const {
  // Barfoot 2017, §7.1.4, with ξ = [ρ; φ]: Ad(T) = [R, t^ R; 0, R].
  const Eigen::Matrix3d R = RotationMatrix();
  Matrix6d ad = Matrix6d::Zero();
  ad.topLeftCorner<3, 3>() = R;
  ad.topRightCorner<3, 3>() = Hat(translation_) * R;
  ad.bottomRightCorner<3, 3>() = R;
  return ad;
}

Rigid3 ExpSE3(const Vector6d& xi) {
  // Barfoot 2017, §7.1.3: Exp(ξ) = [Exp(φ), Jl(φ) ρ; 0, 1].
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  return Rigid3(ExpQuat(phi), LeftJacobianSO3(phi) * rho);
}

Vector6d LogSE3(const Rigid3& T) {
  // Inverse of ExpSE3: φ = Log(R), ρ = Jl⁻¹(φ) t (Barfoot 2017, §7.1.3).
  const Eigen::Vector3d phi = LogQuat(T.rotation());
  Vector6d xi;
  xi.head<3>() = LeftJacobianInverseSO3(phi) * T.translation();
  xi.tail<3>() = phi;
  return xi;
}

Matrix6d LeftJacobianSE3(const Vector6d& xi) {
  // Barfoot 2017, §7.1.5: Jl(ξ) = [Jl(φ), Q(ρ, φ); 0, Jl(φ)].
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const Eigen::Matrix3d Jl = LeftJacobianSO3(phi);
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = Jl;
  J.topRightCorner<3, 3>() = QMatrix(rho, phi);
  J.bottomRightCorner<3, 3>() = Jl;
  return J;
}

Matrix6d RightJacobianSE3(const Vector6d& xi) {
  // Jr(ξ) = Jl(−ξ) (Barfoot 2017, §7.1.5).
  return LeftJacobianSE3(-xi);
}

Matrix6d LeftJacobianInverseSE3(const Vector6d& xi) {
  // Barfoot 2017, §7.1.5 (block-triangular inverse):
  //   Jl⁻¹(ξ) = [Jl⁻¹(φ), −Jl⁻¹(φ) Q(ρ, φ) Jl⁻¹(φ); 0, Jl⁻¹(φ)].
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const Eigen::Matrix3d Jl_inv = LeftJacobianInverseSO3(phi);
  Matrix6d J = Matrix6d::Zero();
  J.topLeftCorner<3, 3>() = Jl_inv;
  J.topRightCorner<3, 3>() = -Jl_inv * QMatrix(rho, phi) * Jl_inv;
  J.bottomRightCorner<3, 3>() = Jl_inv;
  return J;
}

Matrix6d RightJacobianInverseSE3(const Vector6d& xi) {
  // Jr⁻¹(ξ) = Jl⁻¹(−ξ) (Barfoot 2017, §7.1.5).
  return LeftJacobianInverseSE3(-xi);
}

Rigid3 Interpolate(const Rigid3& T0, const Rigid3& T1, double alpha) {
  // T(α) = T0 Exp(α Log(T0⁻¹ T1)) (Barfoot 2017, §7.1.7, interpolation on SE(3)).
  return T0 * ExpSE3(alpha * LogSE3(T0.Inverse() * T1));
}

Rigid3 InterpolateSeparately(const Rigid3& T0, const Rigid3& T1, double alpha) {
  // Slerp on the rotation, linear interpolation on the translation.
  return Rigid3(InterpolateRotation(T0.rotation(), T1.rotation(), alpha),
                (1.0 - alpha) * T0.translation() + alpha * T1.translation());
}

}  // namespace crop4d::geometry
