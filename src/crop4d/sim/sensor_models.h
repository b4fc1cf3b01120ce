#pragma once

// Models of the rig's non-camera sensors: IMU (gyroscope + accelerometer with white noise and
// bias random walk), magnetometer, and GPS receivers (white noise plus, for a standard
// receiver, a slowly drifting bias), and the sensors' free-running clocks.

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/dataset.h"
#include "crop4d/sim/imperfections.h"
#include "crop4d/sim/random.h"
#include "crop4d/sim/trajectory.h"

namespace crop4d::sim {

// Standard gravity in the ENU world frame, g_w = (0, 0, −9.81) m/s².
inline const Eigen::Vector3d kGravityWorld(0.0, 0.0, -9.81);

// ---- IMU ------------------------------------------------------------------------------------

// Continuous-time noise parameters in the Kalibr/EuRoC convention (written to imu0/sensor.yaml
// as they are). Defaults: a consumer MEMS IMU (InvenSense MPU-9250 datasheet: gyro rate noise
// 0.01 °/s/√Hz, accelerometer noise 300 µg/√Hz), inflated for vehicle vibration as Kalibr's
// wiki recommends.
struct ImuOptions {
  // Sample rate, Hz.
  double rate_hz = 167.0;
  // Gyroscope white noise σ_g, rad/s/√Hz.
  double gyroscope_noise_density = 3.0e-4;
  // Gyroscope bias random walk σ_bg, rad/s²/√Hz.
  double gyroscope_random_walk = 2.0e-5;
  // Accelerometer white noise σ_a, m/s²/√Hz.
  double accelerometer_noise_density = 4.0e-3;
  // Accelerometer bias random walk σ_ba, m/s³/√Hz.
  double accelerometer_random_walk = 4.0e-4;
  // Std-dev of the gyroscope bias at the start of a session (turn-on bias), rad/s.
  double gyroscope_bias_sigma = 5.0e-3;
  // Std-dev of the accelerometer bias at the start of a session, m/s².
  double accelerometer_bias_sigma = 5.0e-2;
  // Std-dev of each axis's scale factor error (fraction; 0 = exact), gyro and accelerometer,
  // drawn once per field (imperfections.h ImuAxisErrors).
  double scale_factor_sigma = 0.0;
  // Std-dev of each off-diagonal entry of the axis misalignment matrix, rad.
  double misalignment_sigma_rad = 0.0;

  // Throws InputError naming the bad option (prefix "imu.").
  void Check() const;
};

// The noise-free IMU signals of the body frame (B = IMU frame): gyro = ω_B, and the specific
// force f = R_wbᵀ (a_w − g_w) (e.g. Forster et al., T-RO 2017, eq. 27–28).
void IdealImu(const BodyState& state, Eigen::Vector3d* gyro, Eigen::Vector3d* accel);

// Discrete-time IMU noise (Kalibr wiki "IMU Noise Model"; Crassidis, "Sigma-point Kalman
// filtering for integrated GPS and inertial navigation", 2006): for a sample interval Δt,
//   measured = true + b_k + σ / √Δt · n_k,   b_k = b_{k−1} + σ_b √Δt · w_k,
// with n_k, w_k independent standard normal vectors.
class ImuModel {
 public:
  ImuModel(const ImuOptions& options, std::uint64_t seed);

  // Advances the bias by `dt` seconds (no change for the first sample) and returns the
  // measurement of the true signals at `t`.
  io::ImuSample Measure(Timestamp t, double dt, const Eigen::Vector3d& true_gyro,
                        const Eigen::Vector3d& true_accel);

  // The biases used for the last measurement.
  const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }
  const Eigen::Vector3d& accel_bias() const { return accel_bias_; }

 private:
  ImuOptions options_;
  Random random_;
  Eigen::Vector3d gyro_bias_, accel_bias_;
  bool first_ = true;
};

// ---- Magnetometer ---------------------------------------------------------------------------

struct MagOptions {
  // Sample rate, Hz.
  double rate_hz = 110.0;
  // Earth's field in the ENU world frame, µT. Default: roughly the geomagnetic field in southern
  // Georgia, USA (NOAA World Magnetic Model: horizontal ≈ 24 µT pointing ≈ 5° west of north,
  // vertical ≈ 41 µT downward).
  Eigen::Vector3d field_enu_ut = Eigen::Vector3d(-2.0, 24.0, -41.0);
  // White noise std-dev per axis, µT.
  double noise_ut = 0.3;
  // Position of the magnetometer in the body frame (its axes are the body's), m.
  Eigen::Vector3d position_in_body = Eigen::Vector3d(0.12, -0.08, 0.05);

  void Check() const;
};

class MagModel {
 public:
  MagModel(const MagOptions& options, std::uint64_t seed);
  // m_s = R_ws⁻¹ m_w + n, for the sensor's orientation `world_from_sensor`.
  io::MagSample Measure(Timestamp t, const Eigen::Quaterniond& world_from_sensor);

 private:
  MagOptions options_;
  Random random_;
};

// ---- GPS ------------------------------------------------------------------------------------

struct GpsOptions {
  // "rtk" (fix code 4, RTK fixed) or "standard" (fix code 1, single point).
  std::string kind = "rtk";
  // Sample rate, Hz.
  double rate_hz = 5.0;
  // White noise std-dev of each horizontal axis (east, north), m.
  double sigma_h_m = 0.02;
  // White noise std-dev of the vertical axis, m.
  double sigma_v_m = 0.04;
  // Stationary std-dev of the drifting bias per horizontal axis (0: no bias), m.
  double bias_sigma_h_m = 0.0;
  // Stationary std-dev of the drifting vertical bias, m.
  double bias_sigma_v_m = 0.0;
  // Correlation time of the bias (first-order Gauss–Markov), s.
  double bias_time_constant_s = 600.0;
  // Antenna phase centre in the body frame (lever arm), m.
  Eigen::Vector3d antenna_in_body = Eigen::Vector3d(-0.30, 0.20, 1.20);
  // Multipath outliers, RTK float episodes and dropouts (all off by default).
  GpsFaultOptions faults;

  // `name` prefixes messages ("gps0").
  void Check(const std::string& name) const;
  io::GpsKind Kind() const { return kind == "rtk" ? io::GpsKind::kRtk : io::GpsKind::kStandard; }
  io::GpsFix Fix() const { return kind == "rtk" ? io::GpsFix::kRtkFixed : io::GpsFix::kSingle; }
  // The 1-sigma the receiver reports: white noise and stationary bias together,
  // √(σ² + σ_b²).
  double ReportedSigmaH() const;
  double ReportedSigmaV() const;
};

// A GPS receiver in the local ENU frame: measured = true + b(t) + n, with b a first-order
// Gauss–Markov process discretised exactly (Gelb, "Applied Optimal Estimation", 1974, §3.8):
//   b_k = e^(−Δt/τ) b_{k−1} + σ_b √(1 − e^(−2Δt/τ)) w_k,   b_0 ~ N(0, σ_b²).
class GpsModel {
 public:
  GpsModel(const GpsOptions& options, std::uint64_t seed);
  // The measured ENU position of an antenna at `antenna_enu`, `dt` seconds after the
  // previous measurement.
  Eigen::Vector3d Measure(double dt, const Eigen::Vector3d& antenna_enu);
  // The bias used for the last measurement, ENU, m.
  const Eigen::Vector3d& bias() const { return bias_; }

 private:
  GpsOptions options_;
  Random random_;
  Eigen::Vector3d bias_;
  bool first_ = true;
};

// ---- Clocks ---------------------------------------------------------------------------------

// Timestamps of a free-running sensor: start + phase + round(k · 10⁹ / rate) for every k with a
// time in [start, end].
std::vector<Timestamp> SensorTimestamps(Timestamp start, Timestamp end, double rate_hz,
                                        Timestamp phase);

// Makes the timestamps of all sensors pairwise distinct: processing the sensors in order, a
// timestamp already used by an earlier sensor is moved 1 ns later (repeatedly). Deterministic.
void MakeTimestampsUnique(std::vector<std::vector<Timestamp>*> sensors);

}  // namespace crop4d::sim
