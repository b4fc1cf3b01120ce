#include "crop4d/sim/sensor_models.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <set>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/sim/sim_config.h"

namespace crop4d::sim {
namespace {

struct Stats {
  double mean = 0.0, std = 0.0;
};
Stats Compute(const std::vector<double>& x) {
  Stats s;
  for (double v : x) s.mean += v;
  s.mean /= x.size();
  for (double v : x) s.std += (v - s.mean) * (v - s.mean);
  s.std = std::sqrt(s.std / (x.size() - 1));
  return s;
}

// State of the strapdown integration: orientation (world_from_body), velocity, position.
struct Nav {
  Eigen::Vector4d q;  // (w, x, y, z)
  Eigen::Vector3d v, p;
};
Eigen::Quaterniond ToQuat(const Eigen::Vector4d& q) {
  return Eigen::Quaterniond(q[0], q[1], q[2], q[3]).normalized();
}
// d/dt of the state for body rate ω and specific force f: q̇ = ½ q ⊗ (0, ω),
// v̇ = R f + g, ṗ = v.
Nav Derivative(const Nav& s, const Eigen::Vector3d& gyro, const Eigen::Vector3d& accel) {
  const Eigen::Quaterniond q = ToQuat(s.q);
  const Eigen::Quaterniond dq = q * Eigen::Quaterniond(0.0, gyro.x(), gyro.y(), gyro.z());
  Nav d;
  d.q = 0.5 * Eigen::Vector4d(dq.w(), dq.x(), dq.y(), dq.z());
  d.v = q * accel + kGravityWorld;
  d.p = s.v;
  return d;
}
Nav Add(const Nav& s, const Nav& d, double h) {
  return {s.q + h * d.q, s.v + h * d.v, s.p + h * d.p};
}

TEST(SensorModelsTest, NoiseFreeImuIntegratesToTheTrueTrajectory) {
  // Ten seconds through the first headland turn of the tiny field: noise-free 167 Hz samples,
  // integrated with classical RK4 over pairs of sample intervals (the middle sample is the
  // midpoint value), must land on the true pose.
  const World world(PresetConfig("tiny").MakeWorldOptions());
  const Trajectory traj(world, TrajectoryOptions(), 11);
  const double t_begin = traj.passes()[0].t_end - 5.0;
  ASSERT_GT(traj.Duration(), t_begin + 10.0);
  ImuOptions noiseless;
  noiseless.gyroscope_noise_density = noiseless.gyroscope_random_walk = 0.0;
  noiseless.accelerometer_noise_density = noiseless.accelerometer_random_walk = 0.0;
  noiseless.gyroscope_bias_sigma = noiseless.accelerometer_bias_sigma = 0.0;
  ImuModel imu(noiseless, 1);
  const Timestamp start = FromDate(2016, 6, 1);
  std::vector<Timestamp> times =
      SensorTimestamps(start + SecondsToTimestamp(t_begin),
                       start + SecondsToTimestamp(t_begin + 10.0 + 0.02), 167.0, 0);
  std::vector<io::ImuSample> samples;
  for (size_t k = 0; k < times.size(); ++k) {
    Eigen::Vector3d gyro, accel;
    IdealImu(traj.StateAt(DurationSeconds(start, times[k])), &gyro, &accel);
    samples.push_back(imu.Measure(times[k], 1.0 / 167.0, gyro, accel));
    EXPECT_EQ(samples.back().gyro, gyro);
  }

  const BodyState first = traj.StateAt(DurationSeconds(start, times[0]));
  const Eigen::Quaterniond q0 = first.world_from_body.rotation();
  Nav s{Eigen::Vector4d(q0.w(), q0.x(), q0.y(), q0.z()), first.velocity_world,
        first.world_from_body.translation()};
  size_t k = 0;
  double turned = 0.0;
  for (; k + 2 < samples.size() && DurationSeconds(times[0], times[k + 2]) <= 10.0 + 1e-9; k += 2) {
    const double h = DurationSeconds(times[k], times[k + 2]);
    const io::ImuSample &a = samples[k], &m = samples[k + 1], &b = samples[k + 2];
    const Nav k1 = Derivative(s, a.gyro, a.accel);
    const Nav k2 = Derivative(Add(s, k1, h / 2), m.gyro, m.accel);
    const Nav k3 = Derivative(Add(s, k2, h / 2), m.gyro, m.accel);
    const Nav k4 = Derivative(Add(s, k3, h), b.gyro, b.accel);
    s.q += h / 6 * (k1.q + 2 * k2.q + 2 * k3.q + k4.q);
    s.q.normalize();
    s.v += h / 6 * (k1.v + 2 * k2.v + 2 * k3.v + k4.v);
    s.p += h / 6 * (k1.p + 2 * k2.p + 2 * k3.p + k4.p);
    turned = std::max(turned, std::abs(a.gyro.z()));
  }
  const double elapsed = DurationSeconds(times[0], times[k]);
  EXPECT_NEAR(elapsed, 10.0, 0.02);
  const BodyState truth = traj.StateAt(DurationSeconds(start, times[k]));
  EXPECT_GT(turned, 0.3);  // the window includes the turn
  EXPECT_LT((s.p - truth.world_from_body.translation()).norm(), 1e-3);
  EXPECT_LT((s.v - truth.velocity_world).norm(), 1e-3);
  EXPECT_LT(geometry::AngleBetween(ToQuat(s.q), truth.world_from_body.rotation()), 1e-5);
  // Travelled far enough for the check to mean something.
  EXPECT_GT((truth.world_from_body.translation() - first.world_from_body.translation()).norm(),
            5.0);
}

TEST(SensorModelsTest, ImuNoiseAndBiasFollowTheContinuousParameters) {
  ImuOptions o;
  o.gyroscope_bias_sigma = 0.0;
  o.accelerometer_bias_sigma = 0.0;
  ImuModel imu(o, 4);
  const double dt = 1.0 / o.rate_hz;
  std::vector<double> gyro_noise, accel_noise;
  Eigen::Vector3d previous_bias = Eigen::Vector3d::Zero();
  std::vector<double> bias_steps;
  for (int k = 0; k < 20000; ++k) {
    const io::ImuSample s = imu.Measure(k, dt, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    gyro_noise.push_back(s.gyro.x() - imu.gyro_bias().x());
    accel_noise.push_back(s.accel.y() - imu.accel_bias().y());
    if (k > 0) bias_steps.push_back(imu.accel_bias().z() - previous_bias.z());
    previous_bias = imu.accel_bias();
  }
  // Discrete white noise σ_d = σ / √Δt; bias steps σ_b √Δt (Kalibr IMU noise model).
  EXPECT_NEAR(Compute(gyro_noise).std, o.gyroscope_noise_density / std::sqrt(dt),
              0.03 * o.gyroscope_noise_density / std::sqrt(dt));
  EXPECT_NEAR(Compute(accel_noise).std, o.accelerometer_noise_density / std::sqrt(dt),
              0.03 * o.accelerometer_noise_density / std::sqrt(dt));
  EXPECT_NEAR(Compute(bias_steps).std, o.accelerometer_random_walk * std::sqrt(dt),
              0.03 * o.accelerometer_random_walk * std::sqrt(dt));
  EXPECT_NEAR(Compute(gyro_noise).mean, 0.0, 4 * o.gyroscope_noise_density / std::sqrt(dt) / 141);
}

TEST(SensorModelsTest, MagnetometerMeasuresTheRotatedEarthField) {
  MagOptions o;
  o.noise_ut = 0.0;
  MagModel mag(o, 1);
  const Eigen::Quaterniond world_from_sensor(
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1.0).normalized()));
  const io::MagSample s = mag.Measure(5, world_from_sensor);
  EXPECT_EQ(s.t, 5);
  EXPECT_LT((world_from_sensor * s.field_ut - o.field_enu_ut).norm(), 1e-12);
}

TEST(SensorModelsTest, RtkGpsNoiseHasTheStatedSigma) {
  GpsOptions o;  // defaults: RTK, 2 cm / 4 cm, no bias
  GpsModel gps(o, 9);
  std::vector<double> ex, ey, ez;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d truth(k * 0.3, 2.0, 0.1);
    const Eigen::Vector3d e = gps.Measure(0.2, truth) - truth;
    ex.push_back(e.x());
    ey.push_back(e.y());
    ez.push_back(e.z());
  }
  const double n = ex.size();
  for (const auto& [errors, sigma] :
       {std::pair{&ex, o.sigma_h_m}, {&ey, o.sigma_h_m}, {&ez, o.sigma_v_m}}) {
    const Stats s = Compute(*errors);
    EXPECT_NEAR(s.mean, 0.0, 4.0 * sigma / std::sqrt(n));
    EXPECT_NEAR(s.std, sigma, 0.03 * sigma);
  }
  EXPECT_DOUBLE_EQ(o.ReportedSigmaH(), 0.02);
  EXPECT_EQ(o.Fix(), io::GpsFix::kRtkFixed);
}

TEST(SensorModelsTest, StandardGpsHasWhiteNoiseAndASlowlyDriftingBias) {
  const SimConfig config = PresetConfig("demo");
  const GpsOptions& o = config.gps1;
  ASSERT_GT(o.bias_sigma_h_m, 0.0);
  GpsModel gps(o, 21);
  // Long run, one sample a minute (the Gauss–Markov discretisation is exact for any Δt).
  const double dt = 60.0;
  std::vector<double> white, bias_x, bias_z, total;
  for (int k = 0; k < 20000; ++k) {
    const Eigen::Vector3d truth(1.0, 2.0, 3.0);
    const Eigen::Vector3d e = gps.Measure(dt, truth) - truth;
    white.push_back(e.x() - gps.bias().x());
    total.push_back(e.y());
    bias_x.push_back(gps.bias().x());
    bias_z.push_back(gps.bias().z());
  }
  const Stats w = Compute(white), bx = Compute(bias_x), bz = Compute(bias_z), t = Compute(total);
  EXPECT_NEAR(w.mean, 0.0, 4.0 * o.sigma_h_m / std::sqrt(white.size()));
  EXPECT_NEAR(w.std, o.sigma_h_m, 0.03 * o.sigma_h_m);
  // The bias: zero mean, stationary σ_b, correlation e^(−lag/τ).
  EXPECT_NEAR(bx.mean, 0.0, 0.1 * o.bias_sigma_h_m);
  EXPECT_NEAR(bx.std, o.bias_sigma_h_m, 0.08 * o.bias_sigma_h_m);
  EXPECT_NEAR(bz.std, o.bias_sigma_v_m, 0.08 * o.bias_sigma_v_m);
  const int lag = static_cast<int>(o.bias_time_constant_s / dt);
  double c = 0.0;
  for (size_t k = lag; k < bias_x.size(); ++k) c += bias_x[k] * bias_x[k - lag];
  c /= (bias_x.size() - lag) * bx.std * bx.std;
  EXPECT_NEAR(c, std::exp(-1.0), 0.08);
  // The whole error has the reported sigma and zero mean.
  EXPECT_NEAR(t.std, o.ReportedSigmaH(), 0.08 * o.ReportedSigmaH());
  EXPECT_NEAR(t.mean, 0.0, 0.1 * o.ReportedSigmaH());
  EXPECT_EQ(o.Fix(), io::GpsFix::kSingle);
}

TEST(SensorModelsTest, ClocksHaveTheirRateAndNeverShareATimestamp) {
  const Timestamp start = FromDate(2016, 6, 1);
  const Timestamp end = start + 60 * kNanosPerSecond;
  std::vector<Timestamp> a = SensorTimestamps(start, end, 5.0, 0);
  std::vector<Timestamp> b = SensorTimestamps(start, end, 5.0, 0);  // same phase on purpose
  std::vector<Timestamp> c = SensorTimestamps(start, end, 167.0, 0);
  EXPECT_EQ(a.size(), 301u);
  EXPECT_EQ(c.size(), 60u * 167u + 1u);
  MakeTimestampsUnique({&a, &b, &c});
  std::set<Timestamp> all;
  for (const auto* v : {&a, &b, &c}) {
    for (size_t k = 0; k < v->size(); ++k) {
      EXPECT_TRUE(all.insert((*v)[k]).second);
      if (k > 0) {
        EXPECT_GT((*v)[k], (*v)[k - 1]);
      }
    }
  }
  EXPECT_EQ(b[1] - b[0], 200'000'000);
}

TEST(SensorModelsTest, OptionsAreChecked) {
  ImuOptions imu;
  imu.rate_hz = 0.0;
  EXPECT_THROW(imu.Check(), InputError);
  GpsOptions gps;
  gps.kind = "dgps";
  try {
    gps.Check("gps1");
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("gps1.kind"), std::string::npos);
  }
}

}  // namespace
}  // namespace crop4d::sim
