#pragma once

// The imperfections of real rigs that the simulator can add (issue 26): calibration errors
// (the sensor.yaml crop4d reads differs from the truth the renderer and sensor models use, and
// the camera's clock is offset from and drifts against the IMU's), image sensor effects (shot
// and read noise, motion blur, auto-exposure changes, JPEG), IMU scale factors and axis
// misalignment, and GPS faults (multipath outliers, RTK fix/float switching, dropouts near the
// tree line). Every magnitude defaults to 0 (the ideal world); `realism: real` sets all of them
// to the values of RealOptions below. docs/simulator.md lists the keys.
//
// Each effect draws from its own random stream (random.h HashCombine with its own tag), so
// switching one on does not change any other file of the field.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/dataset.h"

namespace crop4d::sim {

// ---- Calibration errors ---------------------------------------------------------------------

// Magnitudes of the errors of the calibration written to the dataset. Each error has exactly
// the configured size; its sign or direction is seeded (one draw per field: the rig and its
// calibration are the same in every session).
struct CalibrationErrorOptions {
  // fx and fy are each written off by ± this, px.
  double focal_px = 0.0;
  // The principal point is written off by this distance (random direction), px.
  double principal_point_px = 0.0;
  // k1 and k2 are each written off by ± this (radial distortion).
  double radial_distortion = 0.0;
  // p1 and p2 are each written off by ± this (tangential distortion).
  double tangential_distortion = 0.0;
  // Every lever arm (camera T_BS translation, GPS antennas, magnetometer) is written off by
  // this distance (random direction), m.
  double lever_arm_m = 0.0;
  // The rotation of the camera's T_BS is written off by this angle (random axis), degrees.
  double rotation_deg = 0.0;
  // Image timestamps = capture time (mid-exposure) on the IMU's clock ± this offset, s.
  double camera_time_offset_s = 0.0;
  // ... plus a drift of the camera clock against the IMU's, parts per million of the time
  // since the session start (sign seeded).
  double camera_clock_drift_ppm = 0.0;

  bool Any() const;
  void Check() const;  // prefix "calibration_error."
};

// The drawn calibration errors of one field.
struct CalibrationErrors {
  double dfx = 0.0, dfy = 0.0, dcx = 0.0, dcy = 0.0;
  double dk1 = 0.0, dk2 = 0.0, dp1 = 0.0, dp2 = 0.0;
  Eigen::Vector3d camera_translation = Eigen::Vector3d::Zero();  // added to T_BS translation
  Eigen::Vector3d camera_rotation = Eigen::Vector3d::Zero();     // axis-angle, R_written = R_err R
  Eigen::Vector3d gps_antenna[2] = {Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero()};
  Eigen::Vector3d mag_position = Eigen::Vector3d::Zero();
  double time_offset_s = 0.0;  // written stamp − capture time at the session start
  double drift = 0.0;          // dimensionless (ppm × 1e-6)

  // The intrinsics and T_BS written to the dataset, from the true ones.
  geometry::PinholeRadTan WrittenIntrinsics(const geometry::PinholeRadTan& truth) const;
  geometry::Rigid3 WrittenBodyFromCamera(const geometry::Rigid3& truth) const;
  // The image timestamp written for a capture at `capture` in a session started at `start`.
  Timestamp WrittenStamp(Timestamp start, Timestamp capture) const;
};

CalibrationErrors DrawCalibrationErrors(const CalibrationErrorOptions& options, std::uint64_t seed);

// ---- Images -----------------------------------------------------------------------------------

struct ImageEffectsOptions {
  // Exposure time, s: the image integrates the motion over it (motion blur); 0 = instant.
  double exposure_s = 0.0;
  // Photo-electrons per digital number: shot noise variance = signal / this (DN²); 0 = none.
  double electrons_per_dn = 0.0;
  // Read noise std-dev, DN.
  double read_noise_dn = 0.0;
  // Auto exposure within a session (passing clouds): the image gain varies smoothly by up to
  // ± this fraction.
  double auto_exposure_jitter = 0.0;
  // Time scale of those changes, s.
  double auto_exposure_period_s = 20.0;
  // Write JPEG images of this quality (1-100); 0 writes PNG (lossless).
  int jpeg_quality = 0;
  // Rolling shutter: the rows are exposed one after the other over this time, top first; the
  // image's timestamp is the middle row's (0 = global shutter), s.
  double readout_s = 0.0;

  bool Any() const;
  void Check() const;  // prefix "camera."
};

// The smooth auto-exposure gain of a session at `seconds` after its start: 1 + jitter · n(t),
// n a sum of three sinusoids with seeded phases in [-1, 1].
double AutoExposureGain(const ImageEffectsOptions& options, std::uint64_t seed, double seconds);

// Motion blur and rolling shutter: every pixel averages the sharp image along the path its
// scene point travels in the image while the pixel's row is exposed. `depth` (CV_32F, camera
// z, 0 = sky = far away) and `bgr` are of the same camera, rendered at the reference instant;
// `begin_from_mid[k]` and `end_from_mid[k]` map points of the reference camera frame into the
// camera frames at the start and the end of the exposure of row k (one entry each: every row
// at once, a global shutter). Returns CV_32FC3.
cv::Mat MotionBlur(const cv::Mat& bgr, const cv::Mat& depth, const geometry::PinholeRadTan& camera,
                   const std::vector<geometry::Rigid3>& begin_from_mid,
                   const std::vector<geometry::Rigid3>& end_from_mid);

// The viewing ray of every pixel of a camera, row-major (Unproject; z = 0 where it fails).
// Undistorting is iterative and was most of MotionBlur's time: a session computes the table
// once and blurs every image with it.
struct PixelRays {
  int width = 0;
  int height = 0;
  std::vector<Eigen::Vector3d> rays;
};
PixelRays ComputePixelRays(const geometry::PinholeRadTan& camera);

// MotionBlur with the camera's ray table (ComputePixelRays(camera)): the same image.
cv::Mat MotionBlur(const cv::Mat& bgr, const cv::Mat& depth, const geometry::PinholeRadTan& camera,
                   const PixelRays& rays, const std::vector<geometry::Rigid3>& begin_from_mid,
                   const std::vector<geometry::Rigid3>& end_from_mid);
inline cv::Mat MotionBlur(const cv::Mat& bgr, const cv::Mat& depth,
                          const geometry::PinholeRadTan& camera,
                          const geometry::Rigid3& begin_from_mid,
                          const geometry::Rigid3& end_from_mid) {
  return MotionBlur(bgr, depth, camera, std::vector<geometry::Rigid3>{begin_from_mid},
                    std::vector<geometry::Rigid3>{end_from_mid});
}

// The standard normal's quantiles at the probabilities (k + ½) / kNormalTableSize: a uniformly
// drawn entry is a normal deviate to 4.3 σ (the image noise's generator).
inline constexpr std::size_t kNormalTableSize = std::size_t{1} << 16;
const std::array<float, kNormalTableSize>& NormalQuantiles();

// Gain, shot and read noise and 8-bit quantisation: out = round(gain · in + n) with
// n ~ N(0, gain · in / electrons_per_dn + read_noise²). `in` CV_8UC3 or CV_32FC3; out CV_8UC3.
cv::Mat ExposeAndQuantise(const cv::Mat& in, double gain, const ImageEffectsOptions& options,
                          std::uint64_t seed);

// ---- IMU ------------------------------------------------------------------------------------

// The deterministic errors of an IMU's axes: measured = (I + M) · S · truth (+ bias + noise),
// S diagonal scale factors (1 + s), M the small axis misalignment (zero diagonal).
struct ImuAxisErrors {
  Eigen::Matrix3d gyro_scale = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d gyro_misalignment = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d accel_scale = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d accel_misalignment = Eigen::Matrix3d::Zero();
  bool IsIdentity() const;
  Eigen::Vector3d Gyro(const Eigen::Vector3d& truth) const {
    return (Eigen::Matrix3d::Identity() + gyro_misalignment) * gyro_scale * truth;
  }
  Eigen::Vector3d Accel(const Eigen::Vector3d& truth) const {
    return (Eigen::Matrix3d::Identity() + accel_misalignment) * accel_scale * truth;
  }
};

// Scale factors s ~ N(0, scale_sigma) per axis, misalignment entries ~ N(0, misalignment_sigma).
ImuAxisErrors DrawImuAxisErrors(double scale_sigma, double misalignment_sigma_rad,
                                std::uint64_t seed);

// ---- GPS ------------------------------------------------------------------------------------

struct GpsFaultOptions {
  // Chance that a sample is a multipath outlier.
  double outlier_probability = 0.0;
  // Std-dev of an outlier's extra offset per horizontal axis (vertical: 1.5×), m.
  double outlier_sigma_m = 0.0;
  // RTK receivers only: rate at which the fix is lost (RTK float), per minute.
  double float_rate_per_min = 0.0;
  // Mean duration of an RTK float episode (exponential, at least 1 s), s.
  double float_duration_s = 20.0;
  // Noise std-dev while in RTK float (and the sigma the receiver then reports), m.
  double float_sigma_h_m = 0.15;
  double float_sigma_v_m = 0.30;
  // Rate of dropouts while the antenna is beyond the ends of the rows (headlands, near the
  // tree line), per minute; no samples are recorded during a dropout.
  double dropout_rate_per_min = 0.0;
  // Duration of a dropout, s.
  double dropout_duration_s = 3.0;

  bool Any() const;
  void Check(const std::string& name) const;
};

// What happened to one GPS sample.
struct GpsFault {
  bool dropped = false;
  bool is_float = false;
  bool outlier = false;
  Eigen::Vector3d extra = Eigen::Vector3d::Zero();  // added to the measurement, ENU, m
};

// The faults of a receiver's samples at `seconds` (increasing), `in_headland[k]` whether
// sample k's antenna is beyond the row ends. `fix_sigma_h/v` are the receiver's white noise
// (RTK float adds N(0, float² − fix²) per axis).
std::vector<GpsFault> SimulateGpsFaults(const GpsFaultOptions& options, bool rtk,
                                        double fix_sigma_h, double fix_sigma_v,
                                        const std::vector<double>& seconds,
                                        const std::vector<bool>& in_headland, std::uint64_t seed);

}  // namespace crop4d::sim
