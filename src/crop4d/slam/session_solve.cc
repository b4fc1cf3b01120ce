#include "crop4d/slam/session_solve.h"

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::slam {

ImuPreintegration::Options ImuNoise(const io::ImuSensor& sensor, double factor) {
  ImuPreintegration::Options noise;
  noise.gyro_noise_density = factor * sensor.gyroscope_noise_density;
  noise.accel_noise_density = factor * sensor.accelerometer_noise_density;
  noise.gyro_random_walk = factor * sensor.gyroscope_random_walk;
  noise.accel_random_walk = factor * sensor.accelerometer_random_walk;
  return noise;
}

OptionCheck ForwardAxisOptions::Check() const {
  OptionChecker c;
  c.AtLeast("min_turn_rate_rad_s", min_turn_rate_rad_s, 0.0)
      .Greater("min_speed_m_s", min_speed_m_s, 0.0)
      .AtLeast("min_states", min_states, 1);
  return c.Result();
}

std::optional<ForwardAxisEstimate> EstimateForwardAxisFromStates(
    const std::vector<RowState>& states, const ForwardAxisOptions& options) {
  const std::string invalid = options.Check();
  CROP4D_CHECK_MSG(invalid.empty(), "EstimateForwardAxisFromStates: " + invalid);
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int count = 0;
  for (const RowState& s : states) {
    const Eigen::Vector3d v = s.nav.world_from_body.rotation().inverse() * s.nav.vel_world;
    if (std::abs(s.nav.rate_body.z()) < options.min_turn_rate_rad_s ||
        v.norm() < options.min_speed_m_s) {
      continue;
    }
    sum += v.normalized();
    ++count;
  }
  if (count < options.min_states) return std::nullopt;
  return ForwardAxisEstimate{sum.normalized(), count};
}

RowState InterpolateState(const std::vector<RowState>& states, Timestamp t) {
  CROP4D_CHECK_MSG(!states.empty(), "InterpolateState: no states");
  auto it = std::lower_bound(states.begin(), states.end(), t,
                             [](const RowState& s, Timestamp x) { return s.t < x; });
  if (it == states.begin() || it == states.end()) {
    RowState s = it == states.begin() ? states.front() : states.back();
    s.t = t;
    return s;
  }
  const RowState& b = *it;
  const RowState& a = *(it - 1);
  const double alpha = DurationSeconds(a.t, t) / DurationSeconds(a.t, b.t);
  RowState s;
  s.t = t;
  s.nav.world_from_body =
      geometry::InterpolateSeparately(a.nav.world_from_body, b.nav.world_from_body, alpha);
  s.nav.vel_world = (1 - alpha) * a.nav.vel_world + alpha * b.nav.vel_world;
  s.nav.rate_body = (1 - alpha) * a.nav.rate_body + alpha * b.nav.rate_body;
  s.bias = (1 - alpha) * a.bias + alpha * b.bias;
  return s;
}

OptionCheck SessionSolveOptions::Check() const {
  OptionChecker c;
  c.Greater("state_rate_hz", state_rate_hz, 0.0)
      .Nested("initialisation", initialisation.Check())
      .Nested("optimiser", optimiser.Check())
      .Nested("forward_axis", forward_axis.Check());
  return c.Result();
}

SessionSolveResult SolveSession(const ImuStream& imu, const GpsStream& gps,
                                const Eigen::Vector3d& forward_axis_body,
                                const SessionSolveOptions& options) {
  const std::string invalid = options.Check();
  CROP4D_CHECK_MSG(invalid.empty(), "SolveSession: " + invalid);
  CROP4D_CHECK_MSG(!imu.samples.empty() && !gps.fixes.empty(),
                   "SolveSession: needs IMU samples and GPS fixes");
  SessionSolveResult out;
  const Timestamp begin = std::max(imu.samples.front().timestamp, gps.fixes.front().t);
  const Timestamp end = std::min(imu.samples.back().timestamp, gps.fixes.back().t);
  const Timestamp step = SecondsToTimestamp(1.0 / options.state_rate_hz);
  std::vector<Timestamp> times;
  for (Timestamp t = begin; t <= end; t += step) times.push_back(t);
  if (times.size() < 2) return out;
  StateInitialiser initialiser(options.initialisation, imu, &gps);
  initialiser.set_forward_axis(forward_axis_body);
  RowOptimiser::Input input;
  input.initial_states = initialiser.Initialise(times, gps.sensor.antenna_in_body);
  input.imu_samples = &imu.samples;
  input.imu_noise = ImuNoise(imu.sensor, 1.0);
  input.imu_rate_hz = imu.sensor.rate_hz;
  input.gps_fixes = gps.fixes;
  input.p_body_antenna = gps.sensor.antenna_in_body;
  const RowOptimiser optimiser(options.optimiser);
  RowOptimiser::Result result = optimiser.Solve(input);
  out.stated_misfit = result.summary.gps_normalised_rms;
  if (out.stated_misfit > kNoiseMisfit && options.imu_noise_auto) {
    double factor = 1.0;
    while (result.summary.gps_normalised_rms > kNoiseTarget && factor < kMaxNoiseFactor) {
      factor *= 2.0;
      input.imu_noise = ImuNoise(imu.sensor, factor);
      result = optimiser.Solve(input);
    }
    out.imu_noise_factor = factor;
  }
  out.final_misfit = result.summary.gps_normalised_rms;
  out.forward_axis = EstimateForwardAxisFromStates(result.states, options.forward_axis);
  out.states = std::move(result.states);
  return out;
}

StateInitialiser::Options AnchorInitialisation(StateInitialiser::Options options) {
  options.gps_half_window_s = std::max(options.gps_half_window_s, kAnchorGpsHalfWindowS);
  return options;
}

StateInitialiser::Options InitialisationFor(StateInitialiser::Options options, io::GpsKind kind) {
  if (kind == io::GpsKind::kStandard) {
    options.gps_half_window_s = std::max(options.gps_half_window_s, kMetreGpsHalfWindowS);
  }
  return options;
}

}  // namespace crop4d::slam
