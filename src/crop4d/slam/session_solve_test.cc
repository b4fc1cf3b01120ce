#include "crop4d/slam/session_solve.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>

#include "crop4d/slam/simulated_session_test_util.h"

namespace crop4d::slam {
namespace {

constexpr double kDeg = M_PI / 180.0;

RowState StateWithYaw(double t_s, double yaw_rad, const Eigen::Vector3d& vel_body,
                      double turn_rate) {
  RowState s;
  s.t = SecondsToTimestamp(t_s);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  s.nav.world_from_body = geometry::Rigid3(Eigen::Quaterniond(R), Eigen::Vector3d(t_s, 0, 0));
  s.nav.vel_world = R * vel_body;
  s.nav.rate_body = Eigen::Vector3d(0, 0, turn_rate);
  return s;
}

TEST(SessionSolveTest, ImuNoiseScalesWhiteNoiseAndRandomWalks) {
  io::ImuSensor sensor;
  sensor.gyroscope_noise_density = 1e-3;
  sensor.accelerometer_noise_density = 2e-2;
  sensor.gyroscope_random_walk = 3e-5;
  sensor.accelerometer_random_walk = 4e-4;
  const ImuPreintegration::Options noise = ImuNoise(sensor, 4.0);
  EXPECT_DOUBLE_EQ(noise.gyro_noise_density, 4e-3);
  EXPECT_DOUBLE_EQ(noise.accel_noise_density, 8e-2);
  EXPECT_DOUBLE_EQ(noise.gyro_random_walk, 1.2e-4);
  EXPECT_DOUBLE_EQ(noise.accel_random_walk, 1.6e-3);
}

TEST(SessionSolveTest, InterpolateStateIsLinearInsideAndHeldOutside) {
  RowState a = StateWithYaw(1.0, 0.0, Eigen::Vector3d(1, 0, 0), 0.0);
  RowState b = StateWithYaw(2.0, 0.2, Eigen::Vector3d(3, 0, 0), 0.4);
  a.bias.setConstant(0.1);
  b.bias.setConstant(0.3);
  const std::vector<RowState> states{a, b};
  const RowState mid = InterpolateState(states, SecondsToTimestamp(1.25));
  EXPECT_EQ(mid.t, SecondsToTimestamp(1.25));
  EXPECT_NEAR(mid.nav.world_from_body.translation().x(), 1.25, 1e-12);
  const Eigen::AngleAxisd yaw(mid.nav.world_from_body.rotation());
  EXPECT_NEAR(yaw.angle(), 0.05, 1e-9);
  EXPECT_NEAR(mid.nav.rate_body.z(), 0.1, 1e-12);
  EXPECT_NEAR(mid.bias(0), 0.15, 1e-12);
  EXPECT_TRUE(mid.nav.vel_world.isApprox(0.75 * a.nav.vel_world + 0.25 * b.nav.vel_world));
  const RowState before = InterpolateState(states, SecondsToTimestamp(0.5));
  EXPECT_EQ(before.t, SecondsToTimestamp(0.5));
  EXPECT_TRUE(
      before.nav.world_from_body.translation().isApprox(a.nav.world_from_body.translation()));
  const RowState after = InterpolateState(states, SecondsToTimestamp(3.0));
  EXPECT_NEAR(after.nav.rate_body.z(), 0.4, 1e-12);
}

TEST(SessionSolveTest, ForwardAxisComesFromMovingStatesInTurnsOnly) {
  const Eigen::Vector3d truth = Eigen::Vector3d(1.0, 0.03, -0.01).normalized();
  std::vector<RowState> states;
  // Turning states: the body-frame velocity along the true axis at any heading.
  for (int k = 0; k < 12; ++k) states.push_back(StateWithYaw(k, 0.3 * k, 2.0 * truth, 0.4));
  // Straight (crabbing) states and slow turning ones point elsewhere: left out.
  for (int k = 12; k < 40; ++k) {
    states.push_back(StateWithYaw(k, 0.0, Eigen::Vector3d(1.0, 0.3, 0.0), 0.01));
  }
  for (int k = 40; k < 50; ++k) {
    states.push_back(StateWithYaw(k, 0.0, Eigen::Vector3d(0.1, 0.3, 0.0), 0.5));
  }
  const std::optional<ForwardAxisEstimate> estimate = EstimateForwardAxisFromStates(states);
  ASSERT_TRUE(estimate.has_value());
  EXPECT_EQ(estimate->num_states, 12);
  EXPECT_LT(std::acos(std::min(1.0, estimate->axis_body.dot(truth))), 1e-9);
  ForwardAxisOptions strict;
  strict.min_states = 13;
  EXPECT_FALSE(EstimateForwardAxisFromStates(states, strict).has_value());
}

TEST(SessionSolveTest, OptionsCheckNamesTheOption) {
  SessionSolveOptions options;
  EXPECT_EQ(options.Check(), "");
  options.forward_axis.min_speed_m_s = 0;
  EXPECT_EQ(options.Check(), "forward_axis.min_speed_m_s: must be > 0 (got 0)");
  options = SessionSolveOptions();
  options.state_rate_hz = 0;
  EXPECT_EQ(options.Check(), "state_rate_hz: must be > 0 (got 0)");
}

TEST(SessionSolveTest, InitialisationWindowsFollowTheReceiver) {
  StateInitialiser::Options options;
  options.gps_half_window_s = 1.0;
  EXPECT_EQ(InitialisationFor(options, io::GpsKind::kRtk).gps_half_window_s, 1.0);
  EXPECT_EQ(InitialisationFor(options, io::GpsKind::kStandard).gps_half_window_s,
            kMetreGpsHalfWindowS);
  EXPECT_EQ(AnchorInitialisation(options).gps_half_window_s, kAnchorGpsHalfWindowS);
  options.gps_half_window_s = 10.0;
  EXPECT_EQ(AnchorInitialisation(options).gps_half_window_s, 10.0);
}

// The tiny preset's first session (IMU and RTK, simulated without rendering): the solve started
// from a forward axis 4° off finds the mounting the trajectory shows, and its positions follow
// the true body.
TEST(SessionSolveTest, SimulatedSessionGivesTheForwardAxisAndTheTrack) {
  const testing::Scenario s = testing::MakeScenario();
  ImuStream imu;
  imu.sensor.rate_hz = s.config.imu.rate_hz;
  imu.sensor.gyroscope_noise_density = s.config.imu.gyroscope_noise_density;
  imu.sensor.accelerometer_noise_density = s.config.imu.accelerometer_noise_density;
  imu.sensor.gyroscope_random_walk = s.config.imu.gyroscope_random_walk;
  imu.sensor.accelerometer_random_walk = s.config.imu.accelerometer_random_walk;
  imu.samples = s.imu;
  GpsStream gps;
  gps.sensor.antenna_in_body = s.config.gps0.antenna_in_body;
  gps.fixes = s.rtk;
  for (GpsFixWorld& fix : gps.fixes) {
    fix.sigma_h = s.config.gps0.sigma_h_m;
    fix.sigma_v = s.config.gps0.sigma_v_m;
  }
  // The true forward axis: the mean body-frame direction of travel while moving.
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (std::size_t k = 1; k + 1 < s.record.image_times.size(); ++k) {
    const Timestamp t = s.record.image_times[k];
    const Eigen::Vector3d step = testing::TrueBody(s, s.record.image_times[k + 1]).translation() -
                                 testing::TrueBody(s, s.record.image_times[k - 1]).translation();
    if (step.norm() < 0.05) continue;
    sum += (testing::TrueBody(s, t).rotation().inverse() * step).normalized();
  }
  const Eigen::Vector3d truth = sum.normalized();
  const Eigen::Vector3d start = Eigen::AngleAxisd(4 * kDeg, Eigen::Vector3d::UnitZ()) * truth;

  SessionSolveOptions options;
  const SessionSolveResult result = SolveSession(imu, gps, start, options);
  ASSERT_GE(result.states.size(), 50u);
  ASSERT_TRUE(result.forward_axis.has_value());
  const double error_deg =
      std::acos(std::min(1.0, result.forward_axis->axis_body.dot(truth))) / kDeg;
  EXPECT_LT(error_deg, 1.0);
  double sq = 0;
  for (const RowState& state : result.states) {
    sq += (state.nav.world_from_body.translation() - testing::TrueBody(s, state.t).translation())
              .squaredNorm();
  }
  // Measured: 0.43° and 0.9 cm (RTK fixes of 2 cm).
  EXPECT_LT(std::sqrt(sq / result.states.size()), 0.03);
}

}  // namespace
}  // namespace crop4d::slam
