#pragma once

// SO(3)/SE(3) maps templated on the scalar, so that ceres::Jet can differentiate them (used by
// the Gaussian-process prior and interpolation, gp_prior.h). Same conventions as
// crop4d/geometry/rotation.h and rigid.h: ξ = [ρ; φ], Exp(ξ) = [Exp(φ), Jl(φ) ρ; 0, 1],
// Jr(ξ) = Jl(−ξ) (Barfoot, "State Estimation for Robotics", 2017, §7.1). Every coefficient that
// is 0/0 at the identity is evaluated by its Taylor series in θ² below a threshold, so the
// derivatives (which flow through θ² = φᵀφ, smooth everywhere) stay exact at and near zero.
// Quaternions are (x, y, z, w) arrays as in state_layout.h.

#include <Eigen/Core>
#include <cmath>

namespace crop4d::slam::templated {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;
template <typename T>
using Mat3 = Eigen::Matrix<T, 3, 3>;
template <typename T>
using Vec6 = Eigen::Matrix<T, 6, 1>;
template <typename T>
using Mat6 = Eigen::Matrix<T, 6, 6>;

// Below θ² = kSeriesThetaSq (θ = 0.1) the Taylor series (through θ⁸) are used.
inline constexpr double kSeriesThetaSq = 0.01;

template <typename T>
Mat3<T> Hat(const Vec3<T>& v) {
  Mat3<T> m;
  m << T(0), -v(2), v(1), v(2), T(0), -v(0), -v(1), v(0), T(0);
  return m;
}

template <typename T>
T Poly(const T& t, double c0, double c1, double c2, double c3, double c4) {
  return c0 + t * (c1 + t * (c2 + t * (c3 + t * c4)));
}

// Hamilton product of (x, y, z, w) quaternions.
template <typename T>
Eigen::Matrix<T, 4, 1> QuatMul(const Eigen::Matrix<T, 4, 1>& a, const Eigen::Matrix<T, 4, 1>& b) {
  Eigen::Matrix<T, 4, 1> c;
  const Vec3<T> av = a.template head<3>();
  const Vec3<T> bv = b.template head<3>();
  c.template head<3>() = a(3) * bv + b(3) * av + av.cross(bv);
  c(3) = a(3) * b(3) - av.dot(bv);
  return c;
}

template <typename T>
Eigen::Matrix<T, 4, 1> QuatConj(const Eigen::Matrix<T, 4, 1>& q) {
  return Eigen::Matrix<T, 4, 1>(-q(0), -q(1), -q(2), q(3));
}

// Rotation matrix of a unit quaternion (x, y, z, w).
template <typename T>
Mat3<T> QuatToMatrix(const Eigen::Matrix<T, 4, 1>& q) {
  const T x = q(0), y = q(1), z = q(2), w = q(3);
  Mat3<T> R;
  R << T(1) - T(2) * (y * y + z * z), T(2) * (x * y - w * z), T(2) * (x * z + w * y),
      T(2) * (x * y + w * z), T(1) - T(2) * (x * x + z * z), T(2) * (y * z - w * x),
      T(2) * (x * z - w * y), T(2) * (y * z + w * x), T(1) - T(2) * (x * x + y * y);
  return R;
}

// Exp(φ) as a quaternion: (sin(θ/2) φ/θ, cos(θ/2)).
template <typename T>
Eigen::Matrix<T, 4, 1> ExpQuat(const Vec3<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T t = phi.squaredNorm();
  T w, s;  // s = sin(θ/2)/θ
  if (t < T(kSeriesThetaSq)) {
    w = Poly(t, 1.0, -1.0 / 8.0, 1.0 / 384.0, -1.0 / 46080.0, 1.0 / 10321920.0);
    s = Poly(t, 0.5, -1.0 / 48.0, 1.0 / 3840.0, -1.0 / 645120.0, 1.0 / 185794560.0);
  } else {
    const T theta = sqrt(t);
    w = cos(T(0.5) * theta);
    s = sin(T(0.5) * theta) / theta;
  }
  Eigen::Matrix<T, 4, 1> q;
  q << s * phi(0), s * phi(1), s * phi(2), w;
  return q;
}

// Log of a unit quaternion, |φ| ≤ π: φ = 2 atan2(|v|, w) v/|v| (q and −q give the same φ).
template <typename T>
Vec3<T> LogQuat(const Eigen::Matrix<T, 4, 1>& q_in) {
  using std::atan2;
  using std::sqrt;
  const Eigen::Matrix<T, 4, 1> q = q_in(3) < T(0) ? Eigen::Matrix<T, 4, 1>(-q_in) : q_in;
  const Vec3<T> v = q.template head<3>();
  const T n2 = v.squaredNorm();
  const T w = q(3);
  T k;  // φ = k v
  if (n2 < T(1e-10)) {
    // 2 atan(n/w)/n = (2/w)(1 − n²/(3w²) + n⁴/(5w⁴)).
    const T r = n2 / (w * w);
    k = T(2) / w * (T(1) - r / T(3) + r * r / T(5));
  } else {
    const T n = sqrt(n2);
    k = T(2) * atan2(n, w) / n;
  }
  return k * v;
}

// Jl(φ) = I + a [φ]× + b [φ]×²,  a = (1 − cos θ)/θ²,  b = (θ − sin θ)/θ³.
template <typename T>
Mat3<T> LeftJacobianSO3(const Vec3<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T t = phi.squaredNorm();
  T a, b;
  if (t < T(kSeriesThetaSq)) {
    a = Poly(t, 0.5, -1.0 / 24.0, 1.0 / 720.0, -1.0 / 40320.0, 1.0 / 3628800.0);
    b = Poly(t, 1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0, 1.0 / 39916800.0);
  } else {
    const T theta = sqrt(t);
    a = (T(1) - cos(theta)) / t;
    b = (theta - sin(theta)) / (t * theta);
  }
  const Mat3<T> P = Hat(phi);
  return Mat3<T>::Identity() + a * P + b * P * P;
}

// Jr⁻¹(φ) = I + ½[φ]× + c [φ]×²,  c = 1/θ² − (1 + cos θ)/(2θ sin θ)  (Forster eq. 9;
// Jl⁻¹(φ) = Jr⁻¹(−φ)). Series: c = 1/12 + θ²/720 + θ⁴/30240 + θ⁶/1209600 + θ⁸/47900160.
template <typename T>
Mat3<T> RightJacobianInverseSO3(const Vec3<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T t = phi.squaredNorm();
  T c;
  if (t < T(kSeriesThetaSq)) {
    c = Poly(t, 1.0 / 12.0, 1.0 / 720.0, 1.0 / 30240.0, 1.0 / 1209600.0, 1.0 / 47900160.0);
  } else {
    const T theta = sqrt(t);
    c = T(1) / t - (T(1) + cos(theta)) / (T(2) * theta * sin(theta));
  }
  const Mat3<T> P = Hat(phi);
  return Mat3<T>::Identity() + T(0.5) * P + c * P * P;
}

// Q(ρ, φ), the upper-right block of the SE(3) left Jacobian (Barfoot 2017, §7.1.5; same
// coefficients and series as crop4d/geometry/rigid.cc).
template <typename T>
Mat3<T> QMatrix(const Vec3<T>& rho, const Vec3<T>& phi) {
  using std::cos;
  using std::sin;
  using std::sqrt;
  const T t = phi.squaredNorm();
  T c1, c2, c3;
  if (t < T(kSeriesThetaSq)) {
    c1 = Poly(t, 1.0 / 6.0, -1.0 / 120.0, 1.0 / 5040.0, -1.0 / 362880.0, 1.0 / 39916800.0);
    c2 = Poly(t, 1.0 / 24.0, -1.0 / 720.0, 1.0 / 40320.0, -1.0 / 3628800.0, 1.0 / 479001600.0);
    c3 = Poly(t, 1.0 / 120.0, -1.0 / 2520.0, 1.0 / 120960.0, -1.0 / 9979200.0, 1.0 / 1245404160.0);
  } else {
    const T theta = sqrt(t);
    const T t4 = t * t;
    const T s = sin(theta);
    const T sh = sin(T(0.5) * theta);
    c1 = (theta - s) / (t * theta);
    c2 = (t - T(4) * sh * sh) / (T(2) * t4);
    c3 = (T(2) * theta - T(3) * s + theta * cos(theta)) / (T(2) * t4 * theta);
  }
  const Mat3<T> P = Hat(phi);
  const Mat3<T> Rh = Hat(rho);
  const Mat3<T> PR = P * Rh;
  const Mat3<T> RP = Rh * P;
  const Mat3<T> PRP = PR * P;
  return T(0.5) * Rh + c1 * (PR + RP + PRP) + c2 * (P * PR + RP * P - T(3) * PRP) +
         c3 * (PRP * P + P * PRP);
}

// SE(3) logarithm of (t, q): φ = Log(q), ρ = Jl⁻¹(φ) t.
template <typename T>
Vec6<T> LogSE3(const Vec3<T>& t, const Eigen::Matrix<T, 4, 1>& q) {
  const Vec3<T> phi = LogQuat(q);
  Vec6<T> xi;
  xi.template head<3>() = RightJacobianInverseSO3<T>(-phi) * t;
  xi.template tail<3>() = phi;
  return xi;
}

// SE(3) exponential: (t, q) = (Jl(φ) ρ, Exp(φ)).
template <typename T>
void ExpSE3(const Vec6<T>& xi, Vec3<T>* t, Eigen::Matrix<T, 4, 1>* q) {
  const Vec3<T> rho = xi.template head<3>();
  const Vec3<T> phi = xi.template tail<3>();
  *q = ExpQuat(phi);
  *t = LeftJacobianSO3(phi) * rho;
}

// Jr⁻¹(ξ) of SE(3). Jr(ξ) = Jl(−ξ) = [Jr(φ), Q(−ρ, −φ); 0, Jr(φ)], and the inverse of the
// block-triangular [A B; 0 A] is [A⁻¹, −A⁻¹ B A⁻¹; 0, A⁻¹].
template <typename T>
Mat6<T> RightJacobianInverseSE3(const Vec6<T>& xi) {
  const Vec3<T> rho = xi.template head<3>();
  const Vec3<T> phi = xi.template tail<3>();
  const Mat3<T> A_inv = RightJacobianInverseSO3(phi);
  const Vec3<T> mrho = -rho;
  const Vec3<T> mphi = -phi;
  Mat6<T> J = Mat6<T>::Zero();
  J.template topLeftCorner<3, 3>() = A_inv;
  J.template bottomRightCorner<3, 3>() = A_inv;
  J.template topRightCorner<3, 3>() = -A_inv * QMatrix(mrho, mphi) * A_inv;
  return J;
}

// Jr(ξ) of SE(3) = [Jr(φ), Q(−ρ, −φ); 0, Jr(φ)], Jr(φ) = Jl(−φ).
template <typename T>
Mat6<T> RightJacobianSE3(const Vec6<T>& xi) {
  const Vec3<T> mrho = -xi.template head<3>();
  const Vec3<T> mphi = -xi.template tail<3>();
  const Mat3<T> A = LeftJacobianSO3(mphi);
  Mat6<T> J = Mat6<T>::Zero();
  J.template topLeftCorner<3, 3>() = A;
  J.template bottomRightCorner<3, 3>() = A;
  J.template topRightCorner<3, 3>() = QMatrix(mrho, mphi);
  return J;
}

}  // namespace crop4d::slam::templated
