#pragma once

// A simulated session for back-end tests (tests only): the sensors of the tiny preset's first
// session (no rendering) with its exact trajectory, and a pass's problem built from them.

#include <algorithm>
#include <vector>

#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"
#include "crop4d/slam/row_optimiser.h"

namespace crop4d::slam::testing {

struct Scenario {
  sim::SimConfig config;
  sim::SessionRecord record;
  std::vector<ImuSample> imu;
  std::vector<GpsFixWorld> rtk;
  std::vector<Timestamp> times;  // image times inside the first pass
  geometry::PinholeRadTan camera;
  geometry::Rigid3 body_from_camera;
};

// The tiny preset's first session, simulated without rendering; `times`: the image times of
// pass `pass_index`.
inline Scenario MakeScenario(int pass_index = 0) {
  Scenario s;
  s.config = sim::PresetConfig("tiny");
  const sim::Simulator simulator(s.config);
  s.record = simulator.SimulateSession(0);
  for (const io::ImuSample& in : s.record.imu) s.imu.push_back({in.t, in.gyro, in.accel});
  for (std::size_t k = 0; k < s.record.gps[0].size(); ++k) {
    GpsFixWorld fix;
    fix.t = s.record.gps[0][k].t;
    fix.position_world = s.record.gps_measured_enu[0][k];
    s.rtk.push_back(fix);
  }
  const sim::Pass& pass = s.record.trajectory->passes().at(pass_index);
  for (Timestamp t : s.record.image_times) {
    const double ts = s.record.Seconds(t);
    if (ts >= pass.t_begin && ts <= pass.t_end) s.times.push_back(t);
  }
  s.camera = s.config.camera.Intrinsics();
  s.body_from_camera = simulator.BodyFromCamera();
  return s;
}

inline geometry::Rigid3 TrueBody(const Scenario& s, Timestamp t) {
  return s.record.trajectory->WorldFromBody(s.record.Seconds(t));
}

// The pass's problem with IMU and RTK, and the true bias as the bias prior.
inline RowOptimiser::Input MakeInput(const Scenario& s, const std::vector<RowState>& initial) {
  RowOptimiser::Input input;
  input.initial_states = initial;
  input.imu_samples = &s.imu;
  input.imu_noise.gyro_noise_density = s.config.imu.gyroscope_noise_density;
  input.imu_noise.accel_noise_density = s.config.imu.accelerometer_noise_density;
  input.imu_noise.gyro_random_walk = s.config.imu.gyroscope_random_walk;
  input.imu_noise.accel_random_walk = s.config.imu.accelerometer_random_walk;
  input.imu_rate_hz = s.config.imu.rate_hz;
  input.gps_fixes = s.rtk;
  input.p_body_antenna = s.config.gps0.antenna_in_body;
  // On a straight pass the accelerometer bias is indistinguishable from roll and pitch; the
  // stage takes the bias prior from a session-wide solve (turns included). Here: the true
  // bias at the first state with that solve's standard deviations.
  const auto it = std::lower_bound(s.record.imu.begin(), s.record.imu.end(), s.times.front(),
                                   [](const io::ImuSample& a, Timestamp t) { return a.t < t; });
  const std::size_t k = it - s.record.imu.begin();
  input.bias_prior_mean << s.record.gyro_bias[k], s.record.accel_bias[k];
  Vector6d sigma;
  sigma << Eigen::Vector3d::Constant(1e-3), Eigen::Vector3d::Constant(0.02);
  input.bias_prior_sigma = sigma;
  return input;
}

}  // namespace crop4d::slam::testing
