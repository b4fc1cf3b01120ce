#include "crop4d/geometry/rotation.h"

#include <cmath>

namespace crop4d::geometry {
namespace {

// Below this angle the coefficient functions of θ are evaluated by their Taylor series (through
// θ⁸, truncation error < 1e-17); above it by the closed forms, which no longer suffer from
// catastrophic cancellation (e.g. θ − sin θ at θ = 0.1 keeps 13 significant digits).
constexpr double kSeriesAngle = 0.1;

// Horner evaluation of c0 + c1 t + c2 t² + c3 t³ + c4 t⁴ with t = θ².
double Series(double t, double c0, double c1, double c2, double c3, double c4) {
  return c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)));
}

// sin θ / θ.  Series: 1 − θ²/6 + θ⁴/120 − θ⁶/5040 + θ⁸/362880.
double SinOverTheta(double theta) {
  if (theta < kSeriesAngle) {
    return Series(theta * theta, 1.0, -1.0 / 6.0, 1.0 / 120.0, -1.0 / 5040.0, 1.0 / 362880.0);
  }
  return std::sin(theta) / theta;
}

// (1 − cos θ) / θ², evaluated as 2 sin²(θ/2) / θ² to avoid the cancellation in 1 − cos θ.
// Series: 1/2 − θ²/24 + θ⁴/720 − θ⁶/40320 + θ⁸/3628800.
double OneMinusCosOverTheta2(double theta) {
  if (theta < kSeriesAngle) {
    return Series(theta * theta, 0.5, -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0, 1.0 / 3628800.0);
  }
  const double s = std::sin(0.5 * theta);
  return 2.0 * s * s / (theta * theta);
}

// (θ − sin θ) / θ³.  Series: 1/6 − θ²/120 + θ⁴/5040 − θ⁶/362880 + θ⁸/39916800.
double ThetaMinusSinOverTheta3(double theta) {
  if (theta < kSeriesAngle) {
    return Series(theta * theta, 1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0,
                  1.0 / 39916800.0);
  }
  return (theta - std::sin(theta)) / (theta * theta * theta);
}

// 1/θ² − (1 + cos θ) / (2 θ sin θ), written as 1/θ² − cot(θ/2) / (2θ) so that it stays finite
// at θ = π (Forster et al. 2017, eq. 9).  Series: 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600 +
// θ⁸/47900160.
double JrInverseCoefficient(double theta) {
  if (theta < kSeriesAngle) {
    return Series(theta * theta, 1.0 / 12.0, 1.0 / 720.0, 1.0 / 30240.0, 1.0 / 1209600.0,
                  1.0 / 47900160.0);
  }
  const double half = 0.5 * theta;
  return 1.0 / (theta * theta) - std::cos(half) / (std::sin(half) * 2.0 * theta);
}

// sin(θ/2) / θ.  Series: 1/2 − θ²/48 + θ⁴/3840 − θ⁶/645120 + θ⁸/185794560.
double HalfSinOverTheta(double theta) {
  if (theta < kSeriesAngle) {
    return Series(theta * theta, 0.5, -1.0 / 48.0, 1.0 / 3840.0, -1.0 / 645120.0,
                  1.0 / 185794560.0);
  }
  return std::sin(0.5 * theta) / theta;
}

}  // namespace

Eigen::Matrix3d Hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0.0, -v.z(), v.y(),  //
      v.z(), 0.0, -v.x(),   //
      -v.y(), v.x(), 0.0;
  return m;
}

Eigen::Vector3d Vee(const Eigen::Matrix3d& m) {
  // The skew-symmetric part's entries, so that Vee(Hat(v)) = v exactly and a slightly
  // non-skew input gives its nearest skew matrix's vector.
  return 0.5 * Eigen::Vector3d(m(2, 1) - m(1, 2), m(0, 2) - m(2, 0), m(1, 0) - m(0, 1));
}

Eigen::Matrix3d ExpSO3(const Eigen::Vector3d& phi) {
  // Rodrigues' formula (Forster et al. 2017, eq. 3; Barfoot 2017, §7.1.3):
  //   Exp(φ) = I + (sin θ / θ) φ^ + ((1 − cos θ) / θ²) φ^².
  const double theta = phi.norm();
  const Eigen::Matrix3d W = Hat(phi);
  return Eigen::Matrix3d::Identity() + SinOverTheta(theta) * W +
         OneMinusCosOverTheta2(theta) * W * W;
}

Eigen::Quaterniond ExpQuat(const Eigen::Vector3d& phi) {
  // q = [cos(θ/2), sin(θ/2) φ/θ] (Solà, "Quaternion kinematics for the error-state Kalman
  // filter", 2017, §4.4 "The exponential map").
  const double theta = phi.norm();
  const Eigen::Vector3d v = HalfSinOverTheta(theta) * phi;
  return Eigen::Quaterniond(std::cos(0.5 * theta), v.x(), v.y(), v.z());
}

Eigen::Vector3d LogSO3(const Eigen::Matrix3d& R) {
  // Through the quaternion: Eigen converts with Shepperd's method (largest of trace and
  // diagonal pivots), which keeps full accuracy near θ = π, where the usual
  // θ = acos((tr R − 1)/2), φ = θ/(2 sin θ) Vee(R − Rᵀ) loses all digits of the axis.
  return LogQuat(Eigen::Quaterniond(R));
}

Eigen::Vector3d LogQuat(const Eigen::Quaterniond& q_in) {
  // φ = 2 atan2(|v|, w) v / |v| with w ≥ 0 (Solà 2017, §4.4 "The logarithmic map"), so
  // |φ| ≤ π; the atan2 form is well conditioned both near θ = 0 and near θ = π (w → 0).
  Eigen::Quaterniond q = q_in.normalized();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  const Eigen::Vector3d v = q.vec();
  const double n = v.norm();
  const double w = q.w();
  if (n < kSeriesAngle * w) {
    // atan(x)/x = 1 − x²/3 + x⁴/5 − x⁶/7 + x⁸/9 with x = n/w.
    const double x2 = (n / w) * (n / w);
    return (2.0 / w) * Series(x2, 1.0, -1.0 / 3.0, 1.0 / 5.0, -1.0 / 7.0, 1.0 / 9.0) * v;
  }
  return (2.0 * std::atan2(n, w) / n) * v;
}

Eigen::Matrix3d RightJacobianSO3(const Eigen::Vector3d& phi) {
  // Forster et al. 2017, eq. 8 (Barfoot 2017, §7.1.5, with φ → −φ):
  //   Jr(φ) = I − ((1 − cos θ)/θ²) φ^ + ((θ − sin θ)/θ³) φ^².
  const double theta = phi.norm();
  const Eigen::Matrix3d W = Hat(phi);
  return Eigen::Matrix3d::Identity() - OneMinusCosOverTheta2(theta) * W +
         ThetaMinusSinOverTheta3(theta) * W * W;
}

Eigen::Matrix3d RightJacobianInverseSO3(const Eigen::Vector3d& phi) {
  // Forster et al. 2017, eq. 9:
  //   Jr⁻¹(φ) = I + ½ φ^ + (1/θ² − (1 + cos θ)/(2θ sin θ)) φ^².
  const double theta = phi.norm();
  const Eigen::Matrix3d W = Hat(phi);
  return Eigen::Matrix3d::Identity() + 0.5 * W + JrInverseCoefficient(theta) * W * W;
}

Eigen::Matrix3d LeftJacobianSO3(const Eigen::Vector3d& phi) {
  // Jl(φ) = Jr(−φ) (Barfoot 2017, §7.1.5).
  return RightJacobianSO3(-phi);
}

Eigen::Matrix3d LeftJacobianInverseSO3(const Eigen::Vector3d& phi) {
  // Jl⁻¹(φ) = Jr⁻¹(−φ) (Barfoot 2017, §7.1.5).
  return RightJacobianInverseSO3(-phi);
}

Eigen::Quaterniond InterpolateRotation(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1,
                                       double alpha) {
  // R(α) = R0 Exp(α Log(R0ᵀ R1)) (geodesic on SO(3); Barfoot 2017, §7.1.7). LogQuat takes
  // the shortest way, whatever the signs of q0 and q1.
  const Eigen::Quaterniond q0n = q0.normalized();
  const Eigen::Vector3d delta = LogQuat(q0n.conjugate() * q1.normalized());
  return (q0n * ExpQuat(alpha * delta)).normalized();
}

double RotationAngle(const Eigen::Quaterniond& q) {
  // θ = 2 atan2(|v|, |w|) ∈ [0, π] (Solà 2017, §4.4 "The logarithmic map").
  return 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
}

double AngleBetween(const Eigen::Quaterniond& q0, const Eigen::Quaterniond& q1) {
  return RotationAngle(q0.conjugate() * q1);
}

}  // namespace crop4d::geometry
