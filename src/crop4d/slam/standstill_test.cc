#include "crop4d/slam/standstill.h"

#include <gtest/gtest.h>

#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/row_optimiser.h"

namespace crop4d::slam {
namespace {

// ADIS16448 (EuRoC's imu0/sensor.yaml) white noise at 200 Hz.
constexpr double kRate = 200.0;
constexpr double kGyroDensity = 1.6968e-4, kAccelDensity = 2.0e-3;

struct ImuRecording {
  Eigen::Matrix3d attitude = geometry::ExpSO3(Eigen::Vector3d(0.05, -0.08, 0.7));
  Eigen::Vector3d gyro_bias{0.002, -0.0015, 0.003};
  Eigen::Vector3d accel_bias{0.05, -0.03, 0.08};
  std::vector<ImuSample> samples;
};

// An IMU that stands still except inside `moving` ([begin, end) seconds), where it turns and
// accelerates as a vehicle does. White noise of the ADIS16448; with `vibration`, the shaking of a
// running engine or rotors throughout (EuRoC V1_01's standstill: about 1 m/s², 0.06 rad/s).
ImuRecording Recording(double duration, const std::vector<std::pair<double, double>>& moving,
                       bool vibration = false, unsigned seed = 3) {
  ImuRecording rec;
  std::mt19937 rng(seed);
  std::normal_distribution<double> unit(0.0, 1.0);
  const double sg = kGyroDensity * std::sqrt(kRate), sa = kAccelDensity * std::sqrt(kRate);
  for (int k = 0; k / kRate <= duration; ++k) {
    const double t = k / kRate;
    ImuSample s;
    s.timestamp = SecondsToTimestamp(t);
    s.gyro_body = rec.gyro_bias + sg * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    s.accel_body = rec.attitude.transpose() * Eigen::Vector3d(0, 0, 9.81) + rec.accel_bias +
                   sa * Eigen::Vector3d(unit(rng), unit(rng), unit(rng));
    for (const auto& [begin, end] : moving) {
      if (t >= begin && t < end) {
        s.gyro_body += Eigen::Vector3d(0.02 * std::sin(1.3 * t), 0.03 * std::sin(0.7 * t),
                                       0.3 * std::sin(1.5 * t));
        s.accel_body += Eigen::Vector3d(0.5 * std::sin(1.1 * t), 0.4 * std::cos(0.9 * t),
                                        0.3 * std::sin(1.7 * t));
      }
    }
    if (vibration) {
      s.gyro_body +=
          0.08 * Eigen::Vector3d(std::sin(2 * M_PI * 43 * t), std::cos(2 * M_PI * 41 * t),
                                 std::sin(2 * M_PI * 47 * t + 1));
      s.accel_body +=
          1.4 * Eigen::Vector3d(std::sin(2 * M_PI * 37 * t + 0.3), std::cos(2 * M_PI * 43 * t),
                                std::sin(2 * M_PI * 39 * t));
    }
    rec.samples.push_back(s);
  }
  return rec;
}

std::vector<Timestamp> Times(double begin, double end, double rate) {
  std::vector<Timestamp> times;
  for (int k = 0; begin + k / rate <= end + 1e-9; ++k) {
    times.push_back(SecondsToTimestamp(begin + k / rate));
  }
  return times;
}

TEST(StandstillTest, QuietImuIntervalsAreTheStandstillsAndNotTheMotion) {
  // Still 0–3 s, moving 3–6 s, still 6–6.6 s (too short), moving 6.6–8 s, still 8–10 s.
  const ImuRecording rec = Recording(10.0, {{3.0, 6.0}, {6.6, 8.0}});
  const std::vector<TimeInterval> quiet =
      QuietImuIntervals(rec.samples, kRate, StandstillOptions());
  ASSERT_EQ(quiet.size(), 2u);
  EXPECT_NEAR(TimestampToSeconds(quiet[0].begin), 0.0, 1e-9);
  EXPECT_GT(TimestampToSeconds(quiet[0].end), 2.4);
  EXPECT_LE(TimestampToSeconds(quiet[0].end), 3.0);
  EXPECT_GE(TimestampToSeconds(quiet[1].begin), 8.0);
  EXPECT_LT(TimestampToSeconds(quiet[1].begin), 8.6);
  EXPECT_GT(TimestampToSeconds(quiet[1].end), 9.4);
}

TEST(StandstillTest, AVibratingStandstillIsQuietAndItsMotionIsNot) {
  const ImuRecording rec = Recording(10.0, {{4.0, 7.0}}, /*vibration=*/true);
  const std::vector<TimeInterval> quiet =
      QuietImuIntervals(rec.samples, kRate, StandstillOptions());
  // Within half a window (0.25 s) of the data's start, and never into the motion by more than
  // half a window: the other sensors (image, GPS) veto the rest.
  ASSERT_EQ(quiet.size(), 2u);
  EXPECT_EQ(quiet[0].begin, rec.samples.front().timestamp);
  EXPECT_GT(TimestampToSeconds(quiet[0].end), 3.4);
  EXPECT_LE(TimestampToSeconds(quiet[0].end), 4.0);
  EXPECT_GE(TimestampToSeconds(quiet[1].begin), 6.5);
  EXPECT_LT(TimestampToSeconds(quiet[1].begin), 7.6);
}

TEST(StandstillTest, AnImuGapIsNotAStandstill) {
  ImuRecording rec = Recording(6.0, {});
  std::erase_if(rec.samples, [](const ImuSample& s) {
    return s.timestamp > SecondsToTimestamp(2.0) && s.timestamp < SecondsToTimestamp(4.0);
  });
  const std::vector<TimeInterval> quiet =
      QuietImuIntervals(rec.samples, kRate, StandstillOptions());
  for (const TimeInterval& i : quiet) {
    EXPECT_FALSE(i.begin < SecondsToTimestamp(3.0) && i.end > SecondsToTimestamp(3.0));
  }
}

TEST(StandstillTest, ImageOrGpsMotionOverrulesAQuietImu) {
  // A vehicle at constant speed is as quiet as one at rest: another sensor decides.
  const std::vector<Timestamp> times = Times(0.0, 4.0, 10.0);  // 41 states
  const std::vector<TimeInterval> quiet = {{0, SecondsToTimestamp(4.0)}};
  std::vector<IntervalMotion> motion(times.size() - 1);
  for (std::size_t k = 0; k < motion.size(); ++k) motion[k].image_motion_px = 0.1;
  for (std::size_t k = 10; k < 20; ++k) motion[k].image_motion_px = 3.0;  // 1–2 s moving
  motion[30].gps_speed = 1.2;                                             // 3.0–3.1 s
  StandstillOptions options;
  const std::vector<bool> still = StillIntervals(times, quiet, motion, options);
  for (std::size_t k = 0; k < still.size(); ++k) {
    // 0–1 s: a run of exactly 1 s is kept; 2–3 s too; 3.1–4 s is 0.9 s: dropped.
    const bool expected = k < 10 || (k >= 20 && k < 30);
    EXPECT_EQ(still[k], expected) << "interval " << k;
  }
  const std::vector<TimeInterval> spans = StillSpans(times, still);
  ASSERT_EQ(spans.size(), 2u);
  EXPECT_EQ(spans[1].begin, times[20]);
  EXPECT_EQ(spans[1].end, times[30]);
  // Without motion information the quiet IMU decides alone.
  const std::vector<bool> imu_only = StillIntervals(times, quiet, {}, options);
  EXPECT_EQ(std::count(imu_only.begin(), imu_only.end(), true), 40);
}

TEST(StandstillTest, PoseFactorIsZeroForOnePoseAndItsJacobiansMatchNumericalDifferences) {
  const geometry::Rigid3 pose(geometry::ExpQuat(Eigen::Vector3d(0.2, -0.1, 1.3)),
                              Eigen::Vector3d(1, -2, 0.5));
  const StandstillPoseFactor factor(0.001, 0.0005);
  Vector7d a = PoseToBlock(pose), b = PoseToBlock(pose);
  const double* same[] = {a.data(), b.data()};
  Vector6d r;
  ASSERT_TRUE(factor.Evaluate(same, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-9);
  // 2 mm and 0.1° apart: residuals 2 and 3.49 sigmas.
  b = PoseToBlock(
      geometry::Rigid3(pose.rotation() * geometry::ExpQuat(Eigen::Vector3d(0, 0, 0.1 * M_PI / 180)),
                       pose.translation() + Eigen::Vector3d(0, 0.002, 0)));
  ASSERT_TRUE(factor.Evaluate(same, r.data(), nullptr));
  EXPECT_NEAR(r.head<3>().norm(), 2.0, 1e-6);
  EXPECT_NEAR(r.tail<3>().norm(), 0.1 * M_PI / 180 / 0.0005, 1e-6);

  const PoseManifold manifold;
  const Vector7d p1 = PoseToBlock(geometry::Rigid3(
      geometry::ExpQuat(Eigen::Vector3d(0.3, -0.4, 1.2)), Eigen::Vector3d(1, 2, 3)));
  const Vector7d p2 = PoseToBlock(geometry::Rigid3(
      geometry::ExpQuat(Eigen::Vector3d(0.5, -0.2, 0.9)), Eigen::Vector3d(1.3, 1.8, 3.2)));
  const testing::JacobianCheckResult check =
      testing::CheckJacobians(factor,
                              {std::vector<double>(p1.data(), p1.data() + 7),
                               std::vector<double>(p2.data(), p2.data() + 7)},
                              {&manifold, &manifold});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

// Yaw and position of an IMU standing still for 6 s with no GPS and no camera, solved with and
// without the standstill constraints; the gauge prior holds the first state.
struct StandstillDrift {
  double yaw_deg = 0, position_m = 0, gyro_bias_error = 0;
};

StandstillDrift SolveStandstill(bool use_standstill) {
  const ImuRecording rec = Recording(6.5, {});
  const std::vector<Timestamp> times = Times(0.25, 6.25, 20.0);
  RowOptimiser::Input input;
  for (Timestamp t : times) {
    RowState s;
    s.t = t;
    s.nav.world_from_body =
        geometry::Rigid3(Eigen::Quaterniond(rec.attitude), Eigen::Vector3d::Zero());
    input.initial_states.push_back(s);
  }
  input.imu_samples = &rec.samples;
  input.imu_noise.gyro_noise_density = kGyroDensity;
  input.imu_noise.accel_noise_density = kAccelDensity;
  input.imu_noise.gyro_random_walk = 1.9393e-5;
  input.imu_noise.accel_random_walk = 3.0e-3;
  input.imu_rate_hz = kRate;
  if (use_standstill) {
    const std::vector<TimeInterval> quiet =
        QuietImuIntervals(rec.samples, kRate, StandstillOptions());
    input.still_intervals = StillIntervals(times, quiet, {}, StandstillOptions());
  }
  const RowOptimiser::Result result = RowOptimiser(RowOptimiser::Options()).Solve(input);
  EXPECT_EQ(result.summary.num_still_intervals, use_standstill ? 120 : 0);
  const geometry::Rigid3& first = result.states.front().nav.world_from_body;
  const geometry::Rigid3& last = result.states.back().nav.world_from_body;
  StandstillDrift d;
  // Yaw: the heading of the body x axis projected on the horizontal plane.
  const auto heading = [](const geometry::Rigid3& p) {
    const Eigen::Vector3d x = p.rotation() * Eigen::Vector3d::UnitX();
    return std::atan2(x.y(), x.x());
  };
  d.yaw_deg = std::abs(std::remainder(heading(last) - heading(first), 2 * M_PI)) * 180 / M_PI;
  for (const RowState& s : result.states) {
    d.position_m =
        std::max(d.position_m, (s.nav.world_from_body.translation() - first.translation()).norm());
  }
  d.gyro_bias_error = (result.states.back().bias.head<3>() - rec.gyro_bias).norm();
  return d;
}

TEST(StandstillTest, YawAndPositionDoNotWanderWhileNothingMoves) {
  const StandstillDrift held = SolveStandstill(true);
  EXPECT_LT(held.yaw_deg, 0.01);
  EXPECT_LT(held.position_m, 0.001);
  // A zero angular rate makes the gyroscope bias observable (3 mrad/s here).
  EXPECT_LT(held.gyro_bias_error, 3e-4);
  // Without the constraints the same data lets both wander (what they are for).
  const StandstillDrift free = SolveStandstill(false);
  EXPECT_GT(free.yaw_deg + 100 * free.position_m, 10 * (held.yaw_deg + 100 * held.position_m));
}

}  // namespace
}  // namespace crop4d::slam
