#include "crop4d/slam/standstill.h"

#include <algorithm>
#include <cmath>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {
namespace {

constexpr double kStandardGravity = 9.81;

// Mean and variance of each gyroscope and accelerometer axis over samples [first, last).
struct WindowStats {
  Eigen::Matrix<double, 6, 1> mean = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 1> variance = Eigen::Matrix<double, 6, 1>::Zero();
  double n = 0;
};

WindowStats Stats(const std::vector<ImuSample>& samples, std::size_t first, std::size_t last) {
  WindowStats w;
  w.n = static_cast<double>(last - first);
  const auto value = [&](std::size_t i) {
    Eigen::Matrix<double, 6, 1> v;
    v << samples[i].gyro_body, samples[i].accel_body;
    return v;
  };
  for (std::size_t i = first; i < last; ++i) w.mean += value(i);
  w.mean /= w.n;
  for (std::size_t i = first; i < last; ++i) w.variance += (value(i) - w.mean).cwiseAbs2();
  w.variance /= w.n;
  return w;
}

// Whether two consecutive windows say that nothing changed (file comment of standstill.h).
bool SameMeans(const WindowStats& a, const WindowStats& b, const StandstillOptions& o) {
  for (int axis = 0; axis < 6; ++axis) {
    const double standard_error = std::sqrt(a.variance(axis) / a.n + b.variance(axis) / b.n);
    const double floor = axis < 3 ? o.gyro_floor : o.accel_floor;
    if (std::abs(b.mean(axis) - a.mean(axis)) >
        std::max(o.mean_change_sigmas * standard_error, floor)) {
      return false;
    }
  }
  for (const WindowStats* w : {&a, &b}) {
    if (std::abs(w->mean.tail<3>().norm() - kStandardGravity) > o.max_gravity_error) return false;
  }
  return true;
}

bool Inside(const std::vector<TimeInterval>& intervals, Timestamp begin, Timestamp end) {
  for (const TimeInterval& i : intervals) {
    if (i.begin <= begin && end <= i.end) return true;
  }
  return false;
}

}  // namespace

OptionCheck StandstillOptions::Check() const {
  OptionChecker c;
  c.Greater("window_s", window_s, 0.0)
      .Greater("mean_change_sigmas", mean_change_sigmas, 0.0)
      .AtLeast("gyro_floor", gyro_floor, 0.0)
      .AtLeast("accel_floor", accel_floor, 0.0)
      .Greater("max_gravity_error", max_gravity_error, 0.0)
      .AtLeast("max_image_motion_px", max_image_motion_px, 0.0)
      .AtLeast("max_gps_speed", max_gps_speed, 0.0)
      .AtLeast("min_duration_s", min_duration_s, 0.0)
      .Greater("sigma_velocity", sigma_velocity, 0.0)
      .Greater("sigma_rate", sigma_rate, 0.0)
      .Greater("sigma_translation", sigma_translation, 0.0)
      .Greater("sigma_rotation", sigma_rotation, 0.0);
  return c.Result();
}

std::vector<TimeInterval> QuietImuIntervals(const std::vector<ImuSample>& samples, double rate_hz,
                                            const StandstillOptions& options) {
  std::vector<TimeInterval> quiet;
  if (samples.size() < 4 || !(rate_hz > 0)) return quiet;
  const Timestamp window = SecondsToTimestamp(options.window_s);
  const Timestamp step = std::max<Timestamp>(window / 2, 1);
  // A window needs half its samples: an IMU gap is not a standstill.
  const std::size_t min_samples =
      std::max<std::size_t>(2, static_cast<std::size_t>(0.5 * options.window_s * rate_hz));
  // Index of the first sample at or after t, searched forward from `from`.
  const auto first_at = [&](std::size_t from, Timestamp t) {
    while (from < samples.size() && samples[from].timestamp < t) ++from;
    return from;
  };
  std::size_t i0 = 0;
  for (Timestamp start = samples.front().timestamp; start + 2 * window <= samples.back().timestamp;
       start += step) {
    i0 = first_at(i0, start);
    const std::size_t i1 = first_at(i0, start + window);
    const std::size_t i2 = first_at(i1, start + 2 * window);
    if (i1 - i0 < min_samples || i2 - i1 < min_samples) continue;
    if (!SameMeans(Stats(samples, i0, i1), Stats(samples, i1, i2), options)) continue;
    // The middle of the two windows: a change that starts or ends inside one of them moves
    // its mean by a fraction only, so the span ends half a window short of their edges (except
    // at the ends of the data, where nothing lies beyond).
    const bool first_pair = start == samples.front().timestamp;
    const bool last_pair = start + step + 2 * window > samples.back().timestamp;
    const TimeInterval span{first_pair ? start : start + window / 2,
                            last_pair ? samples[i2 - 1].timestamp : start + 3 * window / 2};
    if (!quiet.empty() && span.begin <= quiet.back().end) {
      quiet.back().end = std::max(quiet.back().end, span.end);
    } else {
      quiet.push_back(span);
    }
  }
  std::erase_if(quiet, [&](const TimeInterval& i) { return i.seconds() < options.min_duration_s; });
  return quiet;
}

std::vector<bool> StillIntervals(const std::vector<Timestamp>& times,
                                 const std::vector<TimeInterval>& quiet_imu,
                                 const std::vector<IntervalMotion>& motion,
                                 const StandstillOptions& options) {
  const std::size_t n = times.size() < 2 ? 0 : times.size() - 1;
  std::vector<bool> still(n, false);
  for (std::size_t k = 0; k < n; ++k) {
    bool s = Inside(quiet_imu, times[k], times[k + 1]);
    if (s && k < motion.size()) {
      const IntervalMotion& m = motion[k];
      if (m.image_motion_px && !(*m.image_motion_px <= options.max_image_motion_px)) s = false;
      if (m.gps_speed && !(*m.gps_speed <= options.max_gps_speed)) s = false;
    }
    still[k] = s;
  }
  // Runs shorter than the minimum duration are not standstills.
  for (std::size_t k = 0; k < n;) {
    if (!still[k]) {
      ++k;
      continue;
    }
    std::size_t end = k;
    while (end < n && still[end]) ++end;
    if (DurationSeconds(times[k], times[end]) < options.min_duration_s) {
      std::fill(still.begin() + k, still.begin() + end, false);
    }
    k = end;
  }
  return still;
}

std::vector<TimeInterval> StillSpans(const std::vector<Timestamp>& times,
                                     const std::vector<bool>& still) {
  std::vector<TimeInterval> spans;
  for (std::size_t k = 0; k < still.size(); ++k) {
    if (!still[k]) continue;
    if (!spans.empty() && spans.back().end == times[k]) {
      spans.back().end = times[k + 1];
    } else {
      spans.push_back({times[k], times[k + 1]});
    }
  }
  return spans;
}

StandstillPoseFactor::StandstillPoseFactor(double sigma_translation, double sigma_rotation)
    : inv_sigma_translation_(1.0 / sigma_translation), inv_sigma_rotation_(1.0 / sigma_rotation) {}

ceres::CostFunction* StandstillPoseFactor::Create(double sigma_translation, double sigma_rotation) {
  return new StandstillPoseFactor(sigma_translation, sigma_rotation);
}

bool StandstillPoseFactor::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> p_i(parameters[0]), p_j(parameters[1]);
  const Eigen::Quaterniond q_i =
      Eigen::Map<const Eigen::Quaterniond>(parameters[0] + 3).normalized();
  const Eigen::Quaterniond q_j =
      Eigen::Map<const Eigen::Quaterniond>(parameters[1] + 3).normalized();
  const Eigen::Quaterniond e = q_i.conjugate() * q_j;
  const Eigen::Vector3d phi = geometry::LogQuat(e);
  Eigen::Map<Vector6d> r(residuals);
  r.head<3>() = (p_j - p_i) * inv_sigma_translation_;
  r.tail<3>() = phi * inv_sigma_rotation_;
  if (jacobians == nullptr) return true;
  const Eigen::Matrix3d jr_inv = geometry::RightJacobianInverseSO3(phi);
  for (int b = 0; b < 2; ++b) {
    if (jacobians[b] == nullptr) continue;
    Matrix6d J = Matrix6d::Zero();
    const double sign = b == 0 ? -1.0 : 1.0;
    J.topLeftCorner<3, 3>() = sign * inv_sigma_translation_ * Eigen::Matrix3d::Identity();
    J.bottomRightCorner<3, 3>() =
        (b == 0 ? Eigen::Matrix3d(-jr_inv * e.toRotationMatrix().transpose()) : jr_inv) *
        inv_sigma_rotation_;
    WritePoseJacobian<6>(J, parameters[b], jacobians[b]);
  }
  return true;
}

}  // namespace crop4d::slam
