#include "crop4d/sim/imperfections.h"

#include <gtest/gtest.h>

#include <cmath>
#include <opencv2/core.hpp>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/io/dataset.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::sim {
namespace {

double Std(const std::vector<double>& x) {
  double mean = 0.0, var = 0.0;
  for (double v : x) mean += v;
  mean /= x.size();
  for (double v : x) var += (v - mean) * (v - mean);
  return std::sqrt(var / (x.size() - 1));
}

// ---- Calibration errors ---------------------------------------------------------------------

TEST(ImperfectionsTest, CalibrationErrorsHaveTheConfiguredSizes) {
  CalibrationErrorOptions o;
  o.focal_px = 2.5;
  o.principal_point_px = 3.0;
  o.radial_distortion = 0.004;
  o.tangential_distortion = 1e-4;
  o.lever_arm_m = 0.015;
  o.rotation_deg = 0.3;
  o.camera_time_offset_s = 0.025;
  o.camera_clock_drift_ppm = 20.0;
  for (std::uint64_t seed : {1u, 2u, 3u}) {
    const CalibrationErrors e = DrawCalibrationErrors(o, seed);
    geometry::PinholeRadTan truth;
    truth.width = 640;
    truth.height = 480;
    truth.fx = truth.fy = 280.0;
    truth.cx = 321.6;
    truth.cy = 238.4;
    truth.k1 = -0.12;
    truth.k2 = 0.02;
    const geometry::PinholeRadTan w = e.WrittenIntrinsics(truth);
    EXPECT_NEAR(std::abs(w.fx - truth.fx), 2.5, 1e-12);
    EXPECT_NEAR(std::abs(w.fy - truth.fy), 2.5, 1e-12);
    EXPECT_NEAR(std::hypot(w.cx - truth.cx, w.cy - truth.cy), 3.0, 1e-9);
    EXPECT_NEAR(std::abs(w.k1 - truth.k1), 0.004, 1e-12);
    EXPECT_NEAR(std::abs(w.k2 - truth.k2), 0.004, 1e-12);
    EXPECT_NEAR(std::abs(w.p1 - truth.p1), 1e-4, 1e-12);
    const geometry::Rigid3 t_bs(geometry::ExpSO3(Eigen::Vector3d(0.1, -0.4, 0.2)),
                                Eigen::Vector3d(0.6, 0.05, 0.7));
    const geometry::Rigid3 written = e.WrittenBodyFromCamera(t_bs);
    EXPECT_NEAR((written.translation() - t_bs.translation()).norm(), 0.015, 1e-12);
    const double angle = written.rotation().angularDistance(t_bs.rotation());
    EXPECT_NEAR(angle * 180.0 / M_PI, 0.3, 1e-9);
    for (const Eigen::Vector3d& g : e.gps_antenna) EXPECT_NEAR(g.norm(), 0.015, 1e-12);
    EXPECT_NEAR(e.mag_position.norm(), 0.015, 1e-12);
    // Stamp = capture + offset + drift · (capture − start), to the nanosecond.
    const Timestamp start = 1465570800LL * kNanosPerSecond;
    const Timestamp capture = start + 100 * kNanosPerSecond;
    EXPECT_NEAR(DurationSeconds(capture, e.WrittenStamp(start, capture)),
                e.time_offset_s + e.drift * 100.0, 1e-9);
    EXPECT_NEAR(std::abs(e.time_offset_s), 0.025, 1e-15);
    EXPECT_NEAR(std::abs(e.drift), 20e-6, 1e-15);
  }
  // Nothing configured, nothing changed.
  const CalibrationErrors none = DrawCalibrationErrors(CalibrationErrorOptions(), 7);
  EXPECT_EQ(none.WrittenStamp(0, 123456789), 123456789);
  EXPECT_TRUE(none.camera_rotation.isZero(0.0));
}

TEST(ImperfectionsTest, BadMagnitudesAreInputErrors) {
  CalibrationErrorOptions c;
  c.rotation_deg = -1.0;
  EXPECT_THROW(c.Check(), InputError);
  ImageEffectsOptions i;
  i.jpeg_quality = 101;
  EXPECT_THROW(i.Check(), InputError);
  GpsFaultOptions g;
  g.outlier_probability = 1.5;
  try {
    g.Check("gps0");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("gps0.outlier_probability"), std::string::npos) << e.message();
  }
}

// ---- Images ---------------------------------------------------------------------------------

TEST(ImperfectionsTest, NormalQuantilesAreAStandardNormal) {
  const auto& table = NormalQuantiles();
  double sum = 0.0, sum_sq = 0.0;
  for (std::size_t k = 0; k < table.size(); ++k) {
    sum += table[k];
    sum_sq += static_cast<double>(table[k]) * table[k];
    if (k > 0) {
      EXPECT_GT(table[k], table[k - 1]);
    }
    EXPECT_NEAR(table[k], -table[table.size() - 1 - k], 1e-5);
  }
  EXPECT_NEAR(sum / table.size(), 0.0, 1e-6);
  EXPECT_NEAR(sum_sq / table.size(), 1.0, 1e-3);          // the tails beyond 4.3 σ are missing
  EXPECT_NEAR(table[table.size() / 2], 1.9124e-5, 1e-8);  // Φ⁻¹(½ + 2⁻¹⁷)
  EXPECT_NEAR(table.back(), 4.3249, 1e-4);                // Φ⁻¹(1 − 2⁻¹⁷)
  // Φ(1) = 0.8413: the quantile at 84.13 % is 1.
  EXPECT_NEAR(table[static_cast<std::size_t>(0.841345 * table.size())], 1.0, 1e-3);
}

TEST(ImperfectionsTest, ImageNoiseOnAFlatPatchHasTheModelledStdDev) {
  ImageEffectsOptions o;
  o.electrons_per_dn = 12.0;
  o.read_noise_dn = 1.5;
  for (const double level : {40.0, 128.0, 200.0}) {
    const cv::Mat flat(200, 200, CV_8UC3, cv::Scalar::all(level));
    const cv::Mat noisy = ExposeAndQuantise(flat, 1.0, o, 5);
    cv::Scalar mean, std;
    cv::meanStdDev(noisy.reshape(1), mean, std);
    // Shot + read noise, plus the quantisation's 1/12.
    const double expected = std::sqrt(level / 12.0 + 1.5 * 1.5 + 1.0 / 12.0);
    EXPECT_NEAR(std[0], expected, 0.2 * expected) << level;
    EXPECT_NEAR(std[0], expected, 0.05 * expected) << level;
    EXPECT_NEAR(mean[0], level, 0.1) << level;
  }
  // Read noise only; and none at all is the identity.
  o.electrons_per_dn = 0.0;
  o.read_noise_dn = 4.0;
  cv::Scalar mean, std;
  cv::meanStdDev(
      ExposeAndQuantise(cv::Mat(200, 200, CV_8UC3, cv::Scalar::all(100)), 1.0, o, 6).reshape(1),
      mean, std);
  EXPECT_NEAR(std[0], std::sqrt(16.0 + 1.0 / 12.0), 0.2);
  const cv::Mat ramp = [] {
    cv::Mat m(10, 256, CV_8UC3);
    for (int c = 0; c < 256; ++c) m.col(c).setTo(cv::Scalar::all(c));
    return m;
  }();
  EXPECT_EQ(cv::norm(ExposeAndQuantise(ramp, 1.0, ImageEffectsOptions(), 1), ramp, cv::NORM_INF),
            0.0);
}

TEST(ImperfectionsTest, AutoExposureGainIsSmoothAndWithinItsRange) {
  ImageEffectsOptions o;
  EXPECT_EQ(AutoExposureGain(o, 3, 12.0), 1.0);
  o.auto_exposure_jitter = 0.12;
  o.auto_exposure_period_s = 20.0;
  std::vector<double> gains;
  double max_step = 0.0;
  for (double t = 0.0; t < 600.0; t += 0.1) {
    const double g = AutoExposureGain(o, 3, t);
    EXPECT_GE(g, 1.0 - 0.12 - 1e-12);
    EXPECT_LE(g, 1.0 + 0.12 + 1e-12);
    if (!gains.empty()) max_step = std::max(max_step, std::abs(g - gains.back()));
    gains.push_back(g);
  }
  // It does change within a session (std-dev a sizeable part of the jitter) ...
  EXPECT_GT(Std(gains), 0.12 / 4);
  // ... smoothly: at most the derivative bound 2π·jitter·Σ(w_k / P_k) per 0.1 s.
  const double bound = 0.12 * 2 * M_PI / 20.0 * (0.6 + 0.3 / 0.43 + 0.1 / 0.17) * 0.1;
  EXPECT_LE(max_step, bound);
  // Another session (seed), another course.
  EXPECT_NE(AutoExposureGain(o, 3, 5.0), AutoExposureGain(o, 4, 5.0));
}

// The 10-90 % width of the dark-to-bright edge along row `r` of a blurred vertical edge, px.
double EdgeWidth(const cv::Mat& image, int r) {
  const float* row = image.ptr<float>(r);
  const double lo = row[0], hi = row[3 * (image.cols - 1)];
  int first = -1, last = -1;
  for (int c = 0; c < image.cols; ++c) {
    const double f = (row[3 * c] - lo) / (hi - lo);
    if (first < 0 && f > 0.1) first = c;
    if (f < 0.9) last = c;
  }
  return last - first + 1;
}

TEST(ImperfectionsTest, PixelRaysProjectBackToTheirPixels) {
  // A strongly distorted camera: every ray of the table projects back onto its pixel, and its
  // z is positive (Unproject succeeded) across the whole image.
  geometry::PinholeRadTan camera;
  camera.width = 64;
  camera.height = 48;
  camera.fx = camera.fy = 40.0;
  camera.cx = 31.5;
  camera.cy = 23.5;
  camera.k1 = -0.25;
  camera.k2 = 0.05;
  camera.p1 = 0.001;
  const PixelRays table = ComputePixelRays(camera);
  ASSERT_EQ(table.width, 64);
  ASSERT_EQ(table.height, 48);
  ASSERT_EQ(table.rays.size(), 64u * 48u);
  for (int r = 0; r < camera.height; ++r) {
    for (int c = 0; c < camera.width; ++c) {
      const Eigen::Vector3d& ray = table.rays[static_cast<std::size_t>(r) * camera.width + c];
      ASSERT_GT(ray.z(), 0.0) << c << "," << r;
      Eigen::Vector2d back;
      ASSERT_TRUE(camera.Project(ray, &back));
      EXPECT_NEAR(back.x(), c, 1e-6);
      EXPECT_NEAR(back.y(), r, 1e-6);
    }
  }
}

TEST(ImperfectionsTest, MotionBlurGrowsWithSpeedTimesExposure) {
  // A camera looking at a wall 2 m away moves sideways during the exposure: the edge on the
  // wall is smeared over fx · (speed · exposure) / depth pixels.
  geometry::PinholeRadTan camera;
  camera.width = 200;
  camera.height = 40;
  camera.fx = camera.fy = 150.0;
  camera.cx = 100.0;
  camera.cy = 20.0;
  cv::Mat sharp(40, 200, CV_8UC3, cv::Scalar::all(40));
  sharp.colRange(100, 200).setTo(cv::Scalar::all(200));
  const cv::Mat depth(40, 200, CV_32F, cv::Scalar(2.0));
  std::vector<double> widths;
  for (const double speed_times_exposure : {0.0, 0.04, 0.08, 0.16}) {
    // The camera moves by +d/2 in x at the end: points move by −d/2 in its frame.
    const double d = speed_times_exposure;
    const geometry::Rigid3 begin_from_mid(Eigen::Quaterniond::Identity(),
                                          Eigen::Vector3d(0.5 * d, 0, 0));
    const geometry::Rigid3 end_from_mid(Eigen::Quaterniond::Identity(),
                                        Eigen::Vector3d(-0.5 * d, 0, 0));
    const cv::Mat blurred = MotionBlur(sharp, depth, camera, begin_from_mid, end_from_mid);
    const double length_px = camera.fx * d / 2.0;
    const double width = EdgeWidth(blurred, 20);
    widths.push_back(width);
    // A box blur of length L: the 10-90 % width is 0.8 L (plus the one-pixel sharp edge).
    EXPECT_NEAR(width, 0.8 * length_px + 1.0, 1.5) << d;
    // The edge stays where it was at mid-exposure.
    const float* row = blurred.ptr<float>(20);
    EXPECT_NEAR(0.5 * (row[3 * 99] + row[3 * 100]), 120.0, 0.5 + 160.0 / (length_px + 1)) << d;
  }
  EXPECT_LT(widths[0], widths[1]);
  EXPECT_LT(widths[1], widths[2]);
  EXPECT_LT(widths[2], widths[3]);
  // No motion, no blur.
  const cv::Mat still = MotionBlur(sharp, depth, camera, geometry::Rigid3(), geometry::Rigid3());
  cv::Mat sharp_f;
  sharp.convertTo(sharp_f, CV_32FC3);
  EXPECT_LT(cv::norm(still, sharp_f, cv::NORM_INF), 1e-3);
}

// The sub-pixel column where row `r` of a dark-to-bright edge image crosses the middle grey.
double EdgeColumn(const cv::Mat& image, int r) {
  const float* row = image.ptr<float>(r);
  const double lo = row[0], hi = row[3 * (image.cols - 1)], mid = 0.5 * (lo + hi);
  for (int c = 1; c < image.cols; ++c) {
    if (row[3 * c] >= mid && row[3 * (c - 1)] < mid) {
      return c - 1 + (mid - row[3 * (c - 1)]) / (row[3 * c] - row[3 * (c - 1)]);
    }
  }
  return -1.0;
}

TEST(ImperfectionsTest, RollingShutterSlantsWhatMovesSideways) {
  // A camera moving sideways at v past a wall 2 m away, rows read out top to bottom over R:
  // a vertical edge is slanted by fx · v · R / depth pixels from the top row to the bottom.
  geometry::PinholeRadTan camera;
  camera.width = 200;
  camera.height = 41;
  camera.fx = camera.fy = 150.0;
  camera.cx = 100.0;
  camera.cy = 20.0;
  // A linear ramp from 40 to 200 over columns 90..110 (bilinear sampling keeps it exact).
  cv::Mat sharp(41, 200, CV_32FC3, cv::Scalar::all(40));
  for (int c = 90; c < 200; ++c)
    sharp.col(c).setTo(cv::Scalar::all(std::min(200.0, 40.0 + 8.0 * (c - 90))));
  const cv::Mat depth(41, 200, CV_32F, cv::Scalar(2.0));
  const double v = 1.5, readout = 0.03;
  std::vector<geometry::Rigid3> rows;
  for (int k = 0; k < 41; ++k) {
    const double dt = (k / 40.0 - 0.5) * readout;  // row k's time after the middle row's
    rows.emplace_back(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-v * dt, 0, 0));
  }
  const cv::Mat out = MotionBlur(sharp, depth, camera, rows, rows);  // no exposure blur
  const double slant = EdgeColumn(out, 0) - EdgeColumn(out, 40);
  EXPECT_NEAR(slant, camera.fx * v * readout / 2.0, 0.02);  // 3.4 px
  // The middle row is the reference: its edge stays where it was.
  EXPECT_NEAR(
      EdgeColumn(out, 20),
      EdgeColumn(MotionBlur(sharp, depth, camera, geometry::Rigid3(), geometry::Rigid3()), 20),
      1e-3);
}

// ---- IMU and GPS ----------------------------------------------------------------------------

TEST(ImperfectionsTest, ImuAxisErrorsFollowTheirSigmas) {
  std::vector<double> scales, misalignments;
  for (std::uint64_t seed = 0; seed < 200; ++seed) {
    const ImuAxisErrors e = DrawImuAxisErrors(0.005, 0.002, seed);
    for (int i = 0; i < 3; ++i) {
      scales.push_back(e.gyro_scale(i, i) - 1.0);
      scales.push_back(e.accel_scale(i, i) - 1.0);
      EXPECT_EQ(e.gyro_misalignment(i, i), 0.0);
      for (int j = 0; j < 3; ++j) {
        if (i != j) misalignments.push_back(e.accel_misalignment(i, j));
      }
    }
    EXPECT_TRUE(e.gyro_scale.isDiagonal(0.0));
  }
  EXPECT_NEAR(Std(scales), 0.005, 0.0005);
  EXPECT_NEAR(Std(misalignments), 0.002, 0.0002);
  EXPECT_TRUE(DrawImuAxisErrors(0.0, 0.0, 1).IsIdentity());
}

TEST(ImperfectionsTest, GpsFaultsHaveTheConfiguredRatesAndSizes) {
  GpsFaultOptions o;
  o.outlier_probability = 0.01;
  o.outlier_sigma_m = 0.3;
  o.float_rate_per_min = 0.5;
  o.float_duration_s = 15.0;
  o.float_sigma_h_m = 0.15;
  o.float_sigma_v_m = 0.30;
  o.dropout_rate_per_min = 2.0;
  o.dropout_duration_s = 3.0;
  // Five hours at 5 Hz, in the headland for 20 s of every 100 s.
  std::vector<double> seconds;
  std::vector<bool> headland;
  for (int k = 0; k < 5 * 3600 * 5; ++k) {
    seconds.push_back(0.2 * k);
    headland.push_back(std::fmod(0.2 * k, 100.0) >= 80.0);
  }
  const std::vector<GpsFault> faults =
      SimulateGpsFaults(o, true, 0.02, 0.04, seconds, headland, 11);
  int outliers = 0, floats = 0, dropped = 0, dropped_in_rows = 0;
  std::vector<double> outlier_x, float_x, float_z;
  for (size_t k = 0; k < faults.size(); ++k) {
    const GpsFault& f = faults[k];
    dropped += f.dropped;
    if (f.dropped && !headland[k]) {
      // A dropout that began in the headland may last up to dropout_duration_s into a row.
      const double into_row = std::fmod(seconds[k], 100.0);
      if (into_row > o.dropout_duration_s) ++dropped_in_rows;
    }
    if (f.outlier) {
      ++outliers;
      if (!f.is_float) outlier_x.push_back(f.extra.x());
    }
    if (f.is_float && !f.outlier) {
      ++floats;
      float_x.push_back(f.extra.x());
      float_z.push_back(f.extra.z());
    }
    if (!f.outlier && !f.is_float) {
      EXPECT_TRUE(f.extra.isZero(0.0));
    }
  }
  const double n = faults.size();
  // Outliers: binomial, within 4 sigma.
  EXPECT_NEAR(outliers / n, 0.01, 4 * std::sqrt(0.01 * 0.99 / n));
  EXPECT_NEAR(Std(outlier_x), 0.3, 0.03);
  // RTK float: episodes start at 0.5/min and last 15 s on average (at least 1 s): the share of
  // time in float is ≈ r·d / (1 + r·d) = 0.111.
  EXPECT_NEAR(floats / n, 0.111, 0.04);
  // Float noise: the receiver's white noise plus this makes the float sigma.
  EXPECT_NEAR(Std(float_x), std::sqrt(0.15 * 0.15 - 0.02 * 0.02), 0.01);
  EXPECT_NEAR(Std(float_z), std::sqrt(0.30 * 0.30 - 0.04 * 0.04), 0.02);
  // Dropouts only start in the headland: 2/min during 20 % of the time, 3 s each.
  EXPECT_EQ(dropped_in_rows, 0);
  EXPECT_NEAR(dropped / n, 0.2 * 2.0 / 60.0 * 3.0 / (1 + 2.0 / 60.0 * 3.0), 0.01);
  // A standard receiver never goes to RTK float.
  for (const GpsFault& f : SimulateGpsFaults(o, false, 1.5, 2.5, seconds, headland, 11)) {
    EXPECT_FALSE(f.is_float);
  }
}

// ---- Configuration --------------------------------------------------------------------------

TEST(ImperfectionsTest, RealismLevelsSetEveryMagnitudeAndRoundTrip) {
  SimConfig ideal = PresetConfig("tiny");
  EXPECT_EQ(ideal.realism, "ideal");
  EXPECT_FALSE(ideal.calibration_error.Any());
  EXPECT_FALSE(ideal.image.Any());
  EXPECT_FALSE(ideal.gps0.faults.Any());
  SimConfig real = ideal;
  ApplyRealism("real", &real);
  EXPECT_TRUE(real.calibration_error.Any());
  EXPECT_GT(real.calibration_error.camera_time_offset_s, 0.009);
  EXPECT_TRUE(real.image.Any());
  EXPECT_GT(real.imu.scale_factor_sigma, 0.0);
  EXPECT_GT(real.gps0.faults.float_rate_per_min, 0.0);
  EXPECT_GT(real.soil_change.fraction, 0.0);
  EXPECT_GT(real.drive.standstill_start_s, 0.0);
  EXPECT_EQ(real.gps1.faults.float_rate_per_min, 0.0);  // a standard receiver has no RTK
  // Printed and loaded back over the ideal preset, the real configuration is the same.
  SimConfig loaded = ideal;
  ApplySimConfigYaml("real.yaml", SimConfigToYaml(real, "tiny"), &loaded);
  EXPECT_EQ(SimConfigToYaml(loaded), SimConfigToYaml(real));
  // realism applies first, the file's other keys override it, whatever their order.
  loaded = ideal;
  ApplySimConfigYaml("f.yaml", "camera:\n  read_noise_dn: 0\nrealism: real\n", &loaded);
  EXPECT_EQ(loaded.image.read_noise_dn, 0.0);
  EXPECT_EQ(loaded.image.exposure_s, real.image.exposure_s);
  // And back to ideal.
  ApplySimConfigYaml("f.yaml", "realism: ideal\n", &loaded);
  EXPECT_EQ(SimConfigToYaml(loaded), SimConfigToYaml(ideal));
  try {
    ApplySimConfigYaml("f.yaml", "seed: 3\nrealism: perfect\n", &loaded);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 2);
    EXPECT_NE(e.message().find("realism"), std::string::npos) << e.message();
  }
}

// ---- Whole sessions (no rendering) ----------------------------------------------------------

SimConfig ShortTiny() {
  SimConfig c = PresetConfig("tiny");
  c.drive.max_duration_s = 40.0;
  return c;
}

TEST(ImperfectionsTest, ImuOutputIsTheScaledMisalignedTruth) {
  SimConfig c = ShortTiny();
  c.imu.gyroscope_noise_density = c.imu.gyroscope_random_walk = 0.0;
  c.imu.accelerometer_noise_density = c.imu.accelerometer_random_walk = 0.0;
  c.imu.gyroscope_bias_sigma = c.imu.accelerometer_bias_sigma = 0.0;
  c.imu.scale_factor_sigma = 0.01;
  c.imu.misalignment_sigma_rad = 0.003;
  const Simulator sim(c);
  const ImuAxisErrors& e = sim.imu_axis_errors();
  ASSERT_FALSE(e.IsIdentity());
  const SessionRecord rec = sim.SimulateSession(0);
  ASSERT_GT(rec.imu.size(), 1000u);
  double max_gyro = 0.0, max_accel = 0.0, max_change = 0.0;
  for (const io::ImuSample& s : rec.imu) {
    Eigen::Vector3d gyro, accel;
    IdealImu(rec.trajectory->StateAt(rec.Seconds(s.t)), &gyro, &accel);
    const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
    max_gyro =
        std::max(max_gyro, (s.gyro - (I + e.gyro_misalignment) * e.gyro_scale * gyro).norm());
    max_accel =
        std::max(max_accel, (s.accel - (I + e.accel_misalignment) * e.accel_scale * accel).norm());
    max_change = std::max(max_change, (s.accel - accel).norm());
  }
  EXPECT_LT(max_gyro, 1e-12);
  EXPECT_LT(max_accel, 1e-12);
  EXPECT_GT(max_change, 0.05);  // 1 % of gravity: the errors are really there
}

TEST(ImperfectionsTest, ImageStampsCarryTheClockOffsetAndDrift) {
  SimConfig c = ShortTiny();
  c.calibration_error.camera_time_offset_s = 0.03;
  c.calibration_error.camera_clock_drift_ppm = 50.0;
  const Simulator sim(c);
  const SessionRecord ideal = Simulator(ShortTiny()).SimulateSession(0);
  const SessionRecord rec = sim.SimulateSession(0);
  const CalibrationErrors& e = sim.calibration_errors();
  ASSERT_EQ(rec.image_times.size(), rec.image_capture_times.size());
  EXPECT_EQ(rec.image_capture_times, ideal.image_times);  // the same instants are captured
  for (size_t k = 0; k < rec.image_times.size(); ++k) {
    const double since_start = rec.Seconds(rec.image_capture_times[k]);
    // 1 ns rounding, plus a few ns when a stamp collided with another sensor's.
    EXPECT_NEAR(DurationSeconds(rec.image_capture_times[k], rec.image_times[k]),
                e.time_offset_s + e.drift * since_start, 1e-8);
  }
  // Every other sensor is as in the ideal world.
  ASSERT_EQ(rec.imu.size(), ideal.imu.size());
  for (size_t k = 0; k < rec.imu.size(); ++k) ASSERT_EQ(rec.imu[k].gyro, ideal.imu[k].gyro);
  EXPECT_EQ(rec.gps[0].size(), ideal.gps[0].size());
}

TEST(ImperfectionsTest, GpsFixStateSetsTheReportedSigmasAndChangesNothingElse) {
  SimConfig c = ShortTiny();
  c.drive.max_duration_s = 0.0;  // the whole tiny field: every headland
  c.gps0.faults.float_rate_per_min = 6.0;
  c.gps0.faults.float_duration_s = 5.0;
  c.gps0.faults.outlier_probability = 0.05;
  c.gps0.faults.outlier_sigma_m = 0.5;
  c.gps1.faults.dropout_rate_per_min = 30.0;
  c.gps1.faults.dropout_duration_s = 2.0;
  SimConfig ideal_config = c;
  ideal_config.gps0.faults = ideal_config.gps1.faults = GpsFaultOptions();
  const SessionRecord ideal = Simulator(ideal_config).SimulateSession(0);
  const SessionRecord rec = Simulator(c).SimulateSession(0);
  // gps0: every sample kept; float samples report the float sigmas and fix 5.
  ASSERT_EQ(rec.gps[0].size(), ideal.gps[0].size());
  int floats = 0, outliers = 0;
  for (size_t k = 0; k < rec.gps[0].size(); ++k) {
    const io::GpsSample& s = rec.gps[0][k];
    const GpsFault& f = rec.gps_faults[0][k];
    if (f.is_float) {
      ++floats;
      EXPECT_EQ(s.fix, io::GpsFix::kRtkFloat);
      EXPECT_EQ(s.sigma_h, 0.15);
      EXPECT_EQ(s.sigma_v, 0.30);
    } else {
      EXPECT_EQ(s.fix, io::GpsFix::kRtkFixed);
      EXPECT_EQ(s.sigma_h, ideal.gps[0][k].sigma_h);
    }
    outliers += f.outlier;
    // Measured = ideal measurement + the fault's extra offset.
    EXPECT_LT((rec.gps_measured_enu[0][k] - ideal.gps_measured_enu[0][k] - f.extra).norm(), 1e-9);
  }
  EXPECT_GT(floats, 0);
  EXPECT_GT(outliers, 0);
  // gps1: samples are missing only beyond the row ends (and up to 2 s after leaving them).
  EXPECT_LT(rec.gps[1].size(), ideal.gps[1].size());
  size_t j = 0;
  const double row_end = c.world.row_length_m;
  for (size_t k = 0; k < ideal.gps[1].size(); ++k) {
    if (j < rec.gps[1].size() && rec.gps[1][j].t == ideal.gps[1][k].t) {
      EXPECT_EQ(rec.gps_measured_enu[1][j], ideal.gps_measured_enu[1][k]);
      ++j;
      continue;
    }
    // Dropped: the antenna is in the headland or was there within the dropout's duration.
    bool near_headland = false;
    for (double back = 0.0; back <= 2.0 + 1e-9; back += 0.1) {
      const double s = std::max(0.0, ideal.Seconds(ideal.gps[1][k].t) - back);
      const double y = (rec.trajectory->WorldFromBody(s) * c.gps1.antenna_in_body).y();
      near_headland |= y < 0.0 || y > row_end;
    }
    EXPECT_TRUE(near_headland) << k;
  }
  EXPECT_EQ(j, rec.gps[1].size());
  // The IMU is untouched.
  ASSERT_EQ(rec.imu.size(), ideal.imu.size());
  EXPECT_EQ(rec.imu.back().accel, ideal.imu.back().accel);
}

TEST(ImperfectionsTest, StandstillsAreStillAndTheMotionStaysSmooth) {
  const World world(PresetConfig("tiny").MakeWorldOptions());
  TrajectoryOptions o;
  const Trajectory driving(world, o, 5);
  o.standstill_start_s = 4.0;
  o.stop_probability_row_end = 1.0;
  o.stop_probability_in_row = 1.0;
  o.stop_duration_s = 2.5;
  o.stop_ramp_s = 1.5;
  const Trajectory traj(world, o, 5);
  const std::vector<Standstill>& stills = traj.standstills();
  // The start, one stop in each pass and one at each pass end but the last (no room to brake
  // before the session ends).
  ASSERT_EQ(stills.size(), 1 + 2 * driving.passes().size() - 1);
  EXPECT_EQ(stills[0].t_begin, 0.0);
  EXPECT_EQ(stills[0].t_end, 4.0);
  // Each stop adds its duration and one ramp (braking and accelerating at half speed on
  // average); the start adds half a ramp.
  const double added = 4.0 + 0.75 + (stills.size() - 1) * (2.5 + 1.5);
  EXPECT_NEAR(traj.Duration(), driving.Duration() + added, 1e-9);
  // Still: no velocity, acceleration or rotation, the pose fixed.
  for (const Standstill& still : stills) {
    const BodyState a = traj.StateAt(still.t_begin + 1e-6);
    for (double t = still.t_begin; t <= still.t_end; t += 0.1) {
      const BodyState s = traj.StateAt(t);
      EXPECT_EQ(s.velocity_world.norm(), 0.0);
      EXPECT_LT(s.acceleration_world.norm(), 1e-9);
      EXPECT_EQ(s.angular_velocity_body.norm(), 0.0);
      EXPECT_LT((s.world_from_body.translation() - a.world_from_body.translation()).norm(), 1e-9);
    }
  }
  // Every pass keeps its stops (the camera trigger over the passes sees them).
  for (size_t k = 1; k < stills.size(); ++k) {
    const double t = 0.5 * (stills[k].t_begin + stills[k].t_end);
    EXPECT_TRUE(std::any_of(traj.passes().begin(), traj.passes().end(), [&](const Pass& p) {
      return t >= p.t_begin && t <= p.t_end;
    })) << k;
  }
  // Velocity and acceleration are the derivatives of the position across the ramps: central
  // differences agree to the differencing error.
  const double h = 1e-3;
  double max_v = 0.0, max_a = 0.0;
  for (double t = 0.01; t < traj.Duration() - 0.01; t += 0.0537) {
    const BodyState s = traj.StateAt(t);
    const Eigen::Vector3d fd_v = (traj.StateAt(t + h).world_from_body.translation() -
                                  traj.StateAt(t - h).world_from_body.translation()) /
                                 (2 * h);
    const Eigen::Vector3d fd_a =
        (traj.StateAt(t + h).velocity_world - traj.StateAt(t - h).velocity_world) / (2 * h);
    max_v = std::max(max_v, (fd_v - s.velocity_world).norm());
    max_a = std::max(max_a, (fd_a - s.acceleration_world).norm());
  }
  EXPECT_LT(max_v, 1e-4);
  EXPECT_LT(max_a, 2e-2);
  // Braking from cruise speed over 1.5 s: at most π/2 · 1.5 m/s / 1.5 s ≈ 1.6 m/s² (plus the
  // path's own acceleration).
  double peak = 0.0;
  for (double t = 0.0; t < traj.Duration(); t += 0.01) {
    peak = std::max(peak, traj.StateAt(t).acceleration_world.head<2>().norm());
  }
  EXPECT_LT(peak, 3.0);
}

TEST(ImperfectionsTest, SensorsKeepRecordingWhileStillAndAgreeWithZeroVelocity) {
  SimConfig c = ShortTiny();
  c.drive.standstill_start_s = 5.0;
  c.drive.stop_probability_in_row = 1.0;
  c.imu.gyroscope_noise_density = c.imu.accelerometer_noise_density = 0.0;
  c.imu.gyroscope_random_walk = c.imu.accelerometer_random_walk = 0.0;
  c.imu.gyroscope_bias_sigma = c.imu.accelerometer_bias_sigma = 0.0;
  c.gps0.sigma_h_m = 1e-9;
  c.gps0.sigma_v_m = 1e-9;
  const SessionRecord rec = Simulator(c).SimulateSession(0);
  const std::vector<Standstill>& stills = rec.trajectory->standstills();
  ASSERT_GE(stills.size(), 2u);
  int imu_still = 0, gps_still = 0, images_still = 0;
  for (const Standstill& still : stills) {
    auto inside = [&](Timestamp t) {
      return rec.Seconds(t) >= still.t_begin && rec.Seconds(t) <= still.t_end;
    };
    for (const io::ImuSample& s : rec.imu) {
      if (!inside(s.t)) continue;
      ++imu_still;
      EXPECT_LT(s.gyro.norm(), 1e-12);
      // Specific force = gravity only: |f| = 9.81.
      EXPECT_NEAR(s.accel.norm(), 9.81, 1e-9);
    }
    Eigen::Vector3d first = Eigen::Vector3d::Constant(NAN);
    for (size_t k = 0; k < rec.gps[0].size(); ++k) {
      if (!inside(rec.gps[0][k].t)) continue;
      ++gps_still;
      if (!first.allFinite()) first = rec.gps_measured_enu[0][k];
      EXPECT_LT((rec.gps_measured_enu[0][k] - first).norm(), 1e-6);
    }
    for (const Timestamp t : rec.image_times) images_still += inside(t);
  }
  EXPECT_GT(imu_still, 167 * 5);
  EXPECT_GT(gps_still, 5 * 5);
  EXPECT_GT(images_still, 7 * 5);
}

}  // namespace
}  // namespace crop4d::sim
