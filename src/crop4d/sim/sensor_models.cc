#include "crop4d/sim/sensor_models.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <unordered_set>

#include "crop4d/core/error.h"

namespace crop4d::sim {
namespace {

void Require(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(fmt::format("{}: {}", key, what));
}

bool NonNegative(double x) { return std::isfinite(x) && x >= 0.0; }
bool Positive(double x) { return std::isfinite(x) && x > 0.0; }
bool Finite(const Eigen::Vector3d& v) { return v.allFinite(); }

}  // namespace

// ---- IMU ------------------------------------------------------------------------------------

void ImuOptions::Check() const {
  Require(Positive(rate_hz) && rate_hz <= 10000.0, "imu.rate_hz", "must be in (0, 10000]");
  Require(NonNegative(gyroscope_noise_density), "imu.gyroscope_noise_density", "must be >= 0");
  Require(NonNegative(gyroscope_random_walk), "imu.gyroscope_random_walk", "must be >= 0");
  Require(NonNegative(accelerometer_noise_density), "imu.accelerometer_noise_density",
          "must be >= 0");
  Require(NonNegative(accelerometer_random_walk), "imu.accelerometer_random_walk", "must be >= 0");
  Require(NonNegative(gyroscope_bias_sigma), "imu.gyroscope_bias_sigma", "must be >= 0");
  Require(NonNegative(accelerometer_bias_sigma), "imu.accelerometer_bias_sigma", "must be >= 0");
  Require(NonNegative(scale_factor_sigma) && scale_factor_sigma <= 0.2, "imu.scale_factor_sigma",
          "must be in [0, 0.2]");
  Require(NonNegative(misalignment_sigma_rad) && misalignment_sigma_rad <= 0.2,
          "imu.misalignment_sigma_rad", "must be in [0, 0.2]");
}

void IdealImu(const BodyState& state, Eigen::Vector3d* gyro, Eigen::Vector3d* accel) {
  *gyro = state.angular_velocity_body;
  *accel =
      state.world_from_body.rotation().conjugate() * (state.acceleration_world - kGravityWorld);
}

ImuModel::ImuModel(const ImuOptions& options, std::uint64_t seed)
    : options_(options), random_(seed) {
  gyro_bias_ = Eigen::Vector3d::Zero();
  accel_bias_ = Eigen::Vector3d::Zero();
  for (int k = 0; k < 3; ++k) gyro_bias_[k] = random_.Normal(0.0, options_.gyroscope_bias_sigma);
  for (int k = 0; k < 3; ++k) {
    accel_bias_[k] = random_.Normal(0.0, options_.accelerometer_bias_sigma);
  }
}

io::ImuSample ImuModel::Measure(Timestamp t, double dt, const Eigen::Vector3d& true_gyro,
                                const Eigen::Vector3d& true_accel) {
  CROP4D_CHECK(dt > 0.0);
  if (!first_) {
    const double sqrt_dt = std::sqrt(dt);
    for (int k = 0; k < 3; ++k) {
      gyro_bias_[k] += options_.gyroscope_random_walk * sqrt_dt * random_.Normal();
    }
    for (int k = 0; k < 3; ++k) {
      accel_bias_[k] += options_.accelerometer_random_walk * sqrt_dt * random_.Normal();
    }
  }
  first_ = false;
  const double inv_sqrt_dt = 1.0 / std::sqrt(dt);
  io::ImuSample sample;
  sample.t = t;
  for (int k = 0; k < 3; ++k) {
    sample.gyro[k] = true_gyro[k] + gyro_bias_[k] +
                     options_.gyroscope_noise_density * inv_sqrt_dt * random_.Normal();
  }
  for (int k = 0; k < 3; ++k) {
    sample.accel[k] = true_accel[k] + accel_bias_[k] +
                      options_.accelerometer_noise_density * inv_sqrt_dt * random_.Normal();
  }
  return sample;
}

// ---- Magnetometer ---------------------------------------------------------------------------

void MagOptions::Check() const {
  Require(Positive(rate_hz) && rate_hz <= 10000.0, "mag.rate_hz", "must be in (0, 10000]");
  Require(Finite(field_enu_ut) && field_enu_ut.norm() > 0.0, "mag.field_enu_ut",
          "must be a finite, non-zero vector");
  Require(NonNegative(noise_ut), "mag.noise_ut", "must be >= 0");
  Require(Finite(position_in_body), "mag.position_in_body", "must be finite");
}

MagModel::MagModel(const MagOptions& options, std::uint64_t seed)
    : options_(options), random_(seed) {}

io::MagSample MagModel::Measure(Timestamp t, const Eigen::Quaterniond& world_from_sensor) {
  io::MagSample sample;
  sample.t = t;
  sample.field_ut = world_from_sensor.conjugate() * options_.field_enu_ut;
  for (int k = 0; k < 3; ++k) sample.field_ut[k] += random_.Normal(0.0, options_.noise_ut);
  return sample;
}

// ---- GPS ------------------------------------------------------------------------------------

void GpsOptions::Check(const std::string& name) const {
  Require(kind == "rtk" || kind == "standard", name + ".kind",
          "must be \"rtk\" or \"standard\", not \"" + kind + "\"");
  Require(Positive(rate_hz) && rate_hz <= 1000.0, name + ".rate_hz", "must be in (0, 1000]");
  Require(NonNegative(sigma_h_m), name + ".sigma_h_m", "must be >= 0");
  Require(NonNegative(sigma_v_m), name + ".sigma_v_m", "must be >= 0");
  Require(NonNegative(bias_sigma_h_m), name + ".bias_sigma_h_m", "must be >= 0");
  Require(NonNegative(bias_sigma_v_m), name + ".bias_sigma_v_m", "must be >= 0");
  Require(Positive(bias_time_constant_s), name + ".bias_time_constant_s", "must be positive");
  Require(Finite(antenna_in_body), name + ".antenna_in_body", "must be finite");
  Require(ReportedSigmaH() > 0.0 && ReportedSigmaV() > 0.0, name + ".sigma_h_m",
          "the reported sigmas must be positive (the dataset format needs them)");
  faults.Check(name);
}

double GpsOptions::ReportedSigmaH() const { return std::hypot(sigma_h_m, bias_sigma_h_m); }
double GpsOptions::ReportedSigmaV() const { return std::hypot(sigma_v_m, bias_sigma_v_m); }

GpsModel::GpsModel(const GpsOptions& options, std::uint64_t seed)
    : options_(options), random_(seed), bias_(Eigen::Vector3d::Zero()) {}

Eigen::Vector3d GpsModel::Measure(double dt, const Eigen::Vector3d& antenna_enu) {
  const Eigen::Vector3d bias_sigma(options_.bias_sigma_h_m, options_.bias_sigma_h_m,
                                   options_.bias_sigma_v_m);
  if (first_) {
    for (int k = 0; k < 3; ++k) bias_[k] = random_.Normal(0.0, bias_sigma[k]);
    first_ = false;
  } else {
    CROP4D_CHECK(dt > 0.0);
    const double phi = std::exp(-dt / options_.bias_time_constant_s);
    const double drive = std::sqrt(1.0 - phi * phi);
    for (int k = 0; k < 3; ++k)
      bias_[k] = phi * bias_[k] + bias_sigma[k] * drive * random_.Normal();
  }
  const Eigen::Vector3d sigma(options_.sigma_h_m, options_.sigma_h_m, options_.sigma_v_m);
  Eigen::Vector3d measured = antenna_enu + bias_;
  for (int k = 0; k < 3; ++k) measured[k] += random_.Normal(0.0, sigma[k]);
  return measured;
}

// ---- Clocks ---------------------------------------------------------------------------------

std::vector<Timestamp> SensorTimestamps(Timestamp start, Timestamp end, double rate_hz,
                                        Timestamp phase) {
  CROP4D_CHECK(rate_hz > 0.0 && phase >= 0);
  std::vector<Timestamp> out;
  const double period_ns = 1e9 / rate_hz;
  for (std::int64_t k = 0;; ++k) {
    const Timestamp t = start + phase + static_cast<Timestamp>(std::llround(k * period_ns));
    if (t > end) break;
    out.push_back(t);
  }
  return out;
}

void MakeTimestampsUnique(std::vector<std::vector<Timestamp>*> sensors) {
  std::unordered_set<Timestamp> used;
  for (std::vector<Timestamp>* times : sensors) {
    std::unordered_set<Timestamp> own;
    for (Timestamp& t : *times) {
      while (used.count(t) > 0) ++t;
      own.insert(t);
    }
    // A sensor's own timestamps stay strictly increasing: a nudge is 1 ns, periods are ≥ 1 ms.
    used.insert(own.begin(), own.end());
  }
}

}  // namespace crop4d::sim
