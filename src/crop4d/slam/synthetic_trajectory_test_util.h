#pragma once

// A smooth synthetic trajectory with analytic derivatives, and the exact IMU signal it produces
// (tests only). Position and rotation vector are sums of sinusoids:
//   p(t) = [2t + 0.5 sin 1.1t, 0.8 sin 0.7t + 0.3 cos 1.3t, 0.2 sin 0.9t]
//   φ(t) = [0.1 sin 0.8t, 0.15 sin(0.6t + 0.3), 0.3 sin 0.4t + 0.2t],  R(t) = Exp(φ(t)).
// Body angular rate ω = Jr(φ) φ̇ (since Rᵀ Ṙ = [Jr(φ) φ̇]×), specific force f = Rᵀ (p̈ − g).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/imu_preintegration.h"

namespace crop4d::slam::testing {

struct TrueState {
  Eigen::Matrix3d rotation;
  Eigen::Vector3d position;
  Eigen::Vector3d velocity;
  Eigen::Vector3d acceleration;
  Eigen::Vector3d rate_body;

  geometry::Rigid3 Pose() const { return geometry::Rigid3(rotation, position); }
};

inline TrueState SinusoidalState(double t) {
  using std::cos;
  using std::sin;
  TrueState s;
  s.position << 2 * t + 0.5 * sin(1.1 * t), 0.8 * sin(0.7 * t) + 0.3 * cos(1.3 * t),
      0.2 * sin(0.9 * t);
  s.velocity << 2 + 0.55 * cos(1.1 * t), 0.56 * cos(0.7 * t) - 0.39 * sin(1.3 * t),
      0.18 * cos(0.9 * t);
  s.acceleration << -0.605 * sin(1.1 * t), -0.392 * sin(0.7 * t) - 0.507 * cos(1.3 * t),
      -0.162 * sin(0.9 * t);
  const Eigen::Vector3d phi(0.1 * sin(0.8 * t), 0.15 * sin(0.6 * t + 0.3),
                            0.3 * sin(0.4 * t) + 0.2 * t);
  const Eigen::Vector3d phi_dot(0.08 * cos(0.8 * t), 0.09 * cos(0.6 * t + 0.3),
                                0.12 * cos(0.4 * t) + 0.2);
  s.rotation = geometry::ExpSO3(phi);
  s.rate_body = geometry::RightJacobianSO3(phi) * phi_dot;
  return s;
}

inline constexpr double kGravity = 9.81;

// Exact IMU samples of SinusoidalState at `rate_hz` from 0 to `duration` seconds, with an
// optional constant bias [bg; ba].
inline std::vector<ImuSample> SinusoidalImu(
    double rate_hz, double duration,
    const Eigen::Matrix<double, 6, 1>& bias = Eigen::Matrix<double, 6, 1>::Zero()) {
  std::vector<ImuSample> samples;
  const Eigen::Vector3d g(0, 0, -kGravity);
  for (int k = 0;; ++k) {
    const Timestamp stamp = SecondsToTimestamp(k / rate_hz);
    const double t = TimestampToSeconds(stamp);
    if (t > duration) break;
    const TrueState s = SinusoidalState(t);
    ImuSample sample;
    sample.timestamp = stamp;
    sample.gyro_body = s.rate_body + bias.head<3>();
    sample.accel_body = s.rotation.transpose() * (s.acceleration - g) + bias.tail<3>();
    samples.push_back(sample);
  }
  return samples;
}

}  // namespace crop4d::slam::testing
