// StateInitialiser on the sensors of a simulated session (no images): the forward axis from
// the headland turns, and the initial states of a row pass against the true trajectory.

#include "crop4d/slam/initialisation.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/geometry/rotation.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::slam {
namespace {

struct SimulatedStreams {
  sim::SimConfig config;
  sim::SessionRecord record;
  ImuStream imu;
  GpsStream rtk;
};

SimulatedStreams Simulate(const std::string& preset) {
  SimulatedStreams s;
  s.config = sim::PresetConfig(preset);
  const sim::Simulator simulator(s.config);
  s.record = simulator.SimulateSession(0);
  for (const io::ImuSample& in : s.record.imu) {
    ImuSample out;
    out.timestamp = in.t;
    out.gyro_body = in.gyro;
    out.accel_body = in.accel;
    s.imu.samples.push_back(out);
  }
  s.rtk.sensor.antenna_in_body = s.config.gps0.antenna_in_body;
  for (std::size_t k = 0; k < s.record.gps[0].size(); ++k) {
    GpsFixWorld fix;
    fix.t = s.record.gps[0][k].t;
    fix.position_world = s.record.gps_measured_enu[0][k];
    fix.sigma_h = 0.02;
    fix.sigma_v = 0.04;
    fix.fix = io::GpsFix::kRtkFixed;
    s.rtk.fixes.push_back(fix);
  }
  return s;
}

TEST(FitGpsTrack, ExactOnAStraightLineAndNulloptWithoutFixes) {
  std::vector<GpsFixWorld> fixes;
  for (int k = 0; k < 20; ++k) {
    GpsFixWorld f;
    f.t = SecondsToTimestamp(0.2 * k);
    f.position_world = Eigen::Vector3d(1, 2, 3) + 0.2 * k * Eigen::Vector3d(1.5, -0.5, 0.1);
    fixes.push_back(f);
  }
  const std::optional<GpsTrackSample> fit = FitGpsTrack(fixes, SecondsToTimestamp(1.1), 0.6);
  ASSERT_TRUE(fit.has_value());
  EXPECT_LT((fit->velocity_world - Eigen::Vector3d(1.5, -0.5, 0.1)).norm(), 1e-9);
  EXPECT_LT(
      (fit->position_world - (Eigen::Vector3d(1, 2, 3) + 1.1 * Eigen::Vector3d(1.5, -0.5, 0.1)))
          .norm(),
      1e-9);
  EXPECT_FALSE(FitGpsTrack(fixes, SecondsToTimestamp(30.0), 0.6).has_value());
}

TEST(StateInitialiser, ForwardAxisFromTheTurnsOfADemoSession) {
  const SimulatedStreams s = Simulate("demo");
  StateInitialiser initialiser(StateInitialiser::Options(), s.imu, &s.rtk);
  StateInitialiser::Summary summary;
  const Eigen::Vector3d axis =
      initialiser.EstimateForwardAxis(s.rtk.sensor.antenna_in_body, &summary);
  EXPECT_FALSE(summary.forward_axis_fallback);
  EXPECT_GE(summary.num_alignment_windows, 3);
  // The simulated vehicle moves along body x.
  const double angle_deg =
      std::acos(std::min(1.0, axis.dot(Eigen::Vector3d::UnitX()))) * 180 / M_PI;
  EXPECT_LT(angle_deg, 2.0) << axis.transpose();
}

TEST(StateInitialiser, StatesOfARowPassAreCloseToTheTruth) {
  const SimulatedStreams s = Simulate("tiny");
  StateInitialiser initialiser(StateInitialiser::Options(), s.imu, &s.rtk);
  initialiser.set_forward_axis(Eigen::Vector3d::UnitX());
  const sim::Pass& pass = s.record.trajectory->passes().front();
  std::vector<Timestamp> times;
  for (Timestamp t : s.record.image_times) {
    const double ts = s.record.Seconds(t);
    if (ts >= pass.t_begin + 1.0 && ts <= pass.t_end - 1.0) times.push_back(t);
  }
  ASSERT_GT(times.size(), 20u);
  StateInitialiser::Summary summary;
  const std::vector<RowState> states =
      initialiser.Initialise(times, s.rtk.sensor.antenna_in_body, &summary);
  ASSERT_EQ(states.size(), times.size());
  EXPECT_EQ(summary.num_states_without_gps, 0);
  for (std::size_t k = 0; k < states.size(); ++k) {
    const sim::BodyState truth = s.record.trajectory->StateAt(s.record.Seconds(times[k]));
    const RowState& st = states[k];
    EXPECT_LT((st.nav.world_from_body.translation() - truth.world_from_body.translation()).norm(),
              0.08);
    EXPECT_LT((st.nav.vel_world - truth.velocity_world).norm(), 0.15);
    EXPECT_LT(geometry::AngleBetween(st.nav.world_from_body.rotation(),
                                     truth.world_from_body.rotation()) *
                  180 / M_PI,
              4.0);
  }
  // Dead reckoning from the first state keeps the heading of the gyro.
  const std::vector<RowState> reckoned = initialiser.InitialiseFromAnchor(states.front(), times);
  const sim::BodyState last = s.record.trajectory->StateAt(s.record.Seconds(times.back()));
  EXPECT_LT(geometry::AngleBetween(reckoned.back().nav.world_from_body.rotation(),
                                   last.world_from_body.rotation()) *
                180 / M_PI,
            5.0);
}

}  // namespace
}  // namespace crop4d::slam

namespace crop4d::slam {
namespace {

TEST(StateInitialiser, LocalLevelStateIsGravityAlignedAndHeadedAlongTheForwardAxis) {
  // A tilted body at rest (roll 4°, pitch −6°, heading 70°), an IMU without noise.
  const Eigen::Matrix3d truth = geometry::ExpSO3(Eigen::Vector3d(0, 0, 70 * M_PI / 180)) *
                                geometry::ExpSO3(Eigen::Vector3d(0, -6 * M_PI / 180, 0)) *
                                geometry::ExpSO3(Eigen::Vector3d(4 * M_PI / 180, 0, 0));
  ImuStream imu;
  for (int k = 0; k < 400; ++k) {
    ImuSample s;
    s.timestamp = SecondsToTimestamp(k / 200.0);
    s.gyro_body = Eigen::Vector3d(0.001, 0, -0.002);
    s.accel_body = truth.transpose() * Eigen::Vector3d(0, 0, 9.81);
    imu.samples.push_back(s);
  }
  StateInitialiser initialiser(StateInitialiser::Options(), imu, nullptr);
  const RowState state = initialiser.LocalLevelState(SecondsToTimestamp(1.0));
  const Eigen::Matrix3d R = state.nav.world_from_body.RotationMatrix();
  // Roll and pitch as the truth's: the body's up maps onto the world's up.
  EXPECT_LT((R * truth.transpose() * Eigen::Vector3d::UnitZ() - Eigen::Vector3d::UnitZ()).norm(),
            1e-9);
  // Heading zero by convention: the body x axis points east (no north component).
  const Eigen::Vector3d x = R * Eigen::Vector3d::UnitX();
  EXPECT_NEAR(x.y(), 0, 1e-9);
  EXPECT_GT(x.x(), 0.99);
  EXPECT_LT(state.nav.world_from_body.translation().norm(), 1e-12);
  EXPECT_LT(state.nav.vel_world.norm(), 1e-12);
  EXPECT_NEAR(state.nav.rate_body.z(), -0.002, 1e-12);
}

}  // namespace
}  // namespace crop4d::slam
