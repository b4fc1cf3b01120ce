// RowOptimiser alone on synthetic data: the sensors of a simulated session (no rendering) and
// landmarks projected into the true camera poses, so every error has a known cause.

#include "crop4d/slam/row_optimiser.h"

#include <gtest/gtest.h>

#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::slam {
namespace {

struct Scenario {
  sim::SimConfig config;
  sim::SessionRecord record;
  std::vector<ImuSample> imu;
  std::vector<GpsFixWorld> rtk;
  std::vector<Timestamp> times;  // image times inside the first pass
  geometry::PinholeRadTan camera;
  geometry::Rigid3 body_from_camera;
};

Scenario MakeScenario() {
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
  const sim::Pass& pass = s.record.trajectory->passes().front();
  for (Timestamp t : s.record.image_times) {
    const double ts = s.record.Seconds(t);
    if (ts >= pass.t_begin && ts <= pass.t_end) s.times.push_back(t);
  }
  s.camera = s.config.camera.Intrinsics();
  s.body_from_camera = simulator.BodyFromCamera();
  return s;
}

geometry::Rigid3 TrueBody(const Scenario& s, Timestamp t) {
  return s.record.trajectory->WorldFromBody(s.record.Seconds(t));
}

RowOptimiser::Input MakeInput(const Scenario& s, const std::vector<RowState>& initial) {
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

// Initial states: the truth perturbed by 5 cm and 2°, velocity and rate from the truth, zero
// biases.
std::vector<RowState> PerturbedTruth(const Scenario& s) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 1.0);
  std::vector<RowState> states;
  for (Timestamp t : s.times) {
    const sim::BodyState truth = s.record.trajectory->StateAt(s.record.Seconds(t));
    RowState st;
    st.t = t;
    const Eigen::Vector3d dp(noise(rng), noise(rng), noise(rng));
    const Eigen::Vector3d dphi(noise(rng), noise(rng), noise(rng));
    st.nav.world_from_body = geometry::Rigid3(
        truth.world_from_body.rotation() * geometry::ExpQuat(dphi * (2.0 * M_PI / 180)),
        truth.world_from_body.translation() + 0.05 * dp);
    st.nav.vel_world = truth.velocity_world;
    st.nav.rate_body = truth.angular_velocity_body;
    states.push_back(st);
  }
  return states;
}

struct Errors {
  double position_rms = 0, rotation_rms_deg = 0;
};

Errors CameraErrors(const Scenario& s, const std::vector<RowState>& states) {
  Errors e;
  for (const RowState& st : states) {
    const geometry::Rigid3 est = st.nav.world_from_body * s.body_from_camera;
    const geometry::Rigid3 truth = TrueBody(s, st.t) * s.body_from_camera;
    e.position_rms += (est.translation() - truth.translation()).squaredNorm();
    const double a = geometry::AngleBetween(est.rotation(), truth.rotation()) * 180 / M_PI;
    e.rotation_rms_deg += a * a;
  }
  e.position_rms = std::sqrt(e.position_rms / states.size());
  e.rotation_rms_deg = std::sqrt(e.rotation_rms_deg / states.size());
  return e;
}

TEST(RowOptimiser, ImuAndRtkAloneRecoverThePass) {
  const Scenario s = MakeScenario();
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.forward_axis_body = Eigen::Vector3d::UnitX();
  const RowOptimiser::Result result = RowOptimiser(RowOptimiser::Options()).Solve(input);
  EXPECT_GT(result.summary.num_gps_factors, 25);
  EXPECT_EQ(result.summary.num_imu_factors, static_cast<int>(s.times.size()) - 1);
  EXPECT_LT(result.summary.final_cost, result.summary.initial_cost);
  const Errors e = CameraErrors(s, result.states);
  EXPECT_LT(e.position_rms, 0.02);
  EXPECT_LT(e.rotation_rms_deg, 1.0);
}

TEST(RowOptimiser, LandmarksFixTheAttitudeAndOutliersAreRejected) {
  const Scenario s = MakeScenario();
  // Landmarks on the ground ahead of the cameras, seen with 0.5 px noise; every 50th
  // observation is an outlier 20–40 px away.
  std::mt19937 rng(11);
  std::normal_distribution<double> pixel_noise(0.0, 0.5);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  const geometry::Rigid3 first = TrueBody(s, s.times.front()) * s.body_from_camera;
  const geometry::Rigid3 last = TrueBody(s, s.times.back()) * s.body_from_camera;
  for (int k = 0; k < 1500; ++k) {
    const double a = uniform(rng);
    const Eigen::Vector3d along = (1 - a) * first.translation() + a * last.translation();
    points.emplace_back(along.x() + 2.0 * (uniform(rng) - 0.5),
                        along.y() + 6.0 * (uniform(rng) - 0.5), 0.1 * uniform(rng));
  }
  RowOptimiser::Input input = MakeInput(s, PerturbedTruth(s));
  input.camera = &s.camera;
  input.body_from_camera = s.body_from_camera;
  int outliers = 0, count = 0;
  std::vector<int> track_point;
  for (std::size_t point = 0; point < points.size(); ++point) {
    const Eigen::Vector3d& p = points[point];
    LandmarkTrack track;
    for (std::size_t i = 0; i < s.times.size(); ++i) {
      const geometry::Rigid3 camera_from_world =
          (TrueBody(s, s.times[i]) * s.body_from_camera).Inverse();
      Eigen::Vector2d pixel;
      if (!s.camera.Project(camera_from_world * p, &pixel) || !s.camera.IsInImage(pixel)) continue;
      pixel += Eigen::Vector2d(pixel_noise(rng), pixel_noise(rng));
      if (++count % 50 == 0) {
        pixel += Eigen::Vector2d(20 + 20 * uniform(rng), -20 - 20 * uniform(rng));
        ++outliers;
      }
      track.observations.push_back({static_cast<int>(i), pixel});
    }
    if (track.observations.size() >= 7) {
      input.tracks.push_back(track);
      track_point.push_back(static_cast<int>(point));
    }
  }
  ASSERT_GT(input.tracks.size(), 300u);
  const RowOptimiser::Result result = RowOptimiser(RowOptimiser::Options()).Solve(input);
  EXPECT_GT(result.summary.num_landmarks_final, 300);
  // Most outliers are removed; no more than twice their number of observations is lost.
  EXPECT_GE(result.summary.num_rejected_observations, outliers * 8 / 10);
  EXPECT_LE(result.summary.num_rejected_observations, 2 * outliers + 50);
  EXPECT_LT(result.summary.reprojection_rms_px, 1.0);
  const Errors e = CameraErrors(s, result.states);
  EXPECT_LT(e.position_rms, 0.015);
  EXPECT_LT(e.rotation_rms_deg, 0.15);
  // Landmarks land on their true positions.
  double landmark_ss = 0;
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    const Eigen::Vector3d& truth = points[track_point[result.landmark_tracks[l]]];
    landmark_ss += (result.landmarks_world[l] - truth).squaredNorm();
  }
  EXPECT_LT(std::sqrt(landmark_ss / result.landmarks_world.size()), 0.03);
}

}  // namespace
}  // namespace crop4d::slam
