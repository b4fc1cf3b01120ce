#include "crop4d/sim/imperfections.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/sim/random.h"

namespace crop4d::sim {
namespace {

void Require(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(fmt::format("{}: {}", key, what));
}
bool In(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }

double Sign(Random* random) { return random->Bernoulli(0.5) ? 1.0 : -1.0; }

// A uniformly distributed unit vector (normalised Gaussian).
Eigen::Vector3d RandomDirection(Random* random) {
  Eigen::Vector3d v;
  do {
    v = Eigen::Vector3d(random->Normal(), random->Normal(), random->Normal());
  } while (v.norm() < 1e-9);
  return v.normalized();
}

// Bilinear sample of a CV_32FC3 image at (x, y), clamped to the border.
inline void Sample(const cv::Mat& image, double x, double y, float out[3]) {
  x = std::clamp(x, 0.0, image.cols - 1.0);
  y = std::clamp(y, 0.0, image.rows - 1.0);
  const int x0 = std::min(static_cast<int>(x), image.cols - 2 < 0 ? 0 : image.cols - 2);
  const int y0 = std::min(static_cast<int>(y), image.rows - 2 < 0 ? 0 : image.rows - 2);
  const int x1 = std::min(x0 + 1, image.cols - 1), y1 = std::min(y0 + 1, image.rows - 1);
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const float* a = image.ptr<float>(y0) + 3 * x0;
  const float* b = image.ptr<float>(y0) + 3 * x1;
  const float* c = image.ptr<float>(y1) + 3 * x0;
  const float* d = image.ptr<float>(y1) + 3 * x1;
  for (int k = 0; k < 3; ++k) {
    out[k] = (1 - fy) * ((1 - fx) * a[k] + fx * b[k]) + fy * ((1 - fx) * c[k] + fx * d[k]);
  }
}

}  // namespace

// ---- Calibration errors ---------------------------------------------------------------------

bool CalibrationErrorOptions::Any() const {
  return focal_px != 0.0 || principal_point_px != 0.0 || radial_distortion != 0.0 ||
         tangential_distortion != 0.0 || lever_arm_m != 0.0 || rotation_deg != 0.0 ||
         camera_time_offset_s != 0.0 || camera_clock_drift_ppm != 0.0;
}

void CalibrationErrorOptions::Check() const {
  const std::string p = "calibration_error.";
  Require(In(focal_px, 0.0, 1000.0), p + "focal_px", "must be in [0, 1000]");
  Require(In(principal_point_px, 0.0, 1000.0), p + "principal_point_px", "must be in [0, 1000]");
  Require(In(radial_distortion, 0.0, 1.0), p + "radial_distortion", "must be in [0, 1]");
  Require(In(tangential_distortion, 0.0, 0.1), p + "tangential_distortion", "must be in [0, 0.1]");
  Require(In(lever_arm_m, 0.0, 1.0), p + "lever_arm_m", "must be in [0, 1]");
  Require(In(rotation_deg, 0.0, 10.0), p + "rotation_deg", "must be in [0, 10]");
  Require(In(camera_time_offset_s, 0.0, 1.0), p + "camera_time_offset_s", "must be in [0, 1]");
  Require(In(camera_clock_drift_ppm, 0.0, 1000.0), p + "camera_clock_drift_ppm",
          "must be in [0, 1000]");
}

CalibrationErrors DrawCalibrationErrors(const CalibrationErrorOptions& o, std::uint64_t seed) {
  Random random(seed);
  CalibrationErrors e;
  e.dfx = Sign(&random) * o.focal_px;
  e.dfy = Sign(&random) * o.focal_px;
  const double angle = random.Uniform(0.0, 2.0 * M_PI);
  e.dcx = o.principal_point_px * std::cos(angle);
  e.dcy = o.principal_point_px * std::sin(angle);
  e.dk1 = Sign(&random) * o.radial_distortion;
  e.dk2 = Sign(&random) * o.radial_distortion;
  e.dp1 = Sign(&random) * o.tangential_distortion;
  e.dp2 = Sign(&random) * o.tangential_distortion;
  e.camera_translation = o.lever_arm_m * RandomDirection(&random);
  e.camera_rotation = o.rotation_deg * M_PI / 180.0 * RandomDirection(&random);
  for (Eigen::Vector3d& g : e.gps_antenna) g = o.lever_arm_m * RandomDirection(&random);
  e.mag_position = o.lever_arm_m * RandomDirection(&random);
  e.time_offset_s = Sign(&random) * o.camera_time_offset_s;
  e.drift = Sign(&random) * o.camera_clock_drift_ppm * 1e-6;
  return e;
}

geometry::PinholeRadTan CalibrationErrors::WrittenIntrinsics(
    const geometry::PinholeRadTan& truth) const {
  geometry::PinholeRadTan c = truth;
  c.fx += dfx;
  c.fy += dfy;
  c.cx += dcx;
  c.cy += dcy;
  c.k1 += dk1;
  c.k2 += dk2;
  c.p1 += dp1;
  c.p2 += dp2;
  return c;
}

geometry::Rigid3 CalibrationErrors::WrittenBodyFromCamera(const geometry::Rigid3& truth) const {
  const Eigen::Matrix3d rotation = geometry::ExpSO3(camera_rotation) * truth.RotationMatrix();
  return geometry::Rigid3(rotation, truth.translation() + camera_translation);
}

Timestamp CalibrationErrors::WrittenStamp(Timestamp start, Timestamp capture) const {
  const double since_start = DurationSeconds(start, capture);
  return capture + SecondsToTimestamp(time_offset_s + drift * since_start);
}

// ---- Images ---------------------------------------------------------------------------------

bool ImageEffectsOptions::Any() const {
  return exposure_s != 0.0 || electrons_per_dn != 0.0 || read_noise_dn != 0.0 ||
         auto_exposure_jitter != 0.0 || jpeg_quality != 0 || readout_s != 0.0;
}

void ImageEffectsOptions::Check() const {
  Require(In(exposure_s, 0.0, 0.5), "camera.exposure_s", "must be in [0, 0.5]");
  Require(In(electrons_per_dn, 0.0, 1e6), "camera.electrons_per_dn", "must be in [0, 1e6]");
  Require(In(read_noise_dn, 0.0, 100.0), "camera.read_noise_dn", "must be in [0, 100]");
  Require(In(auto_exposure_jitter, 0.0, 0.9), "camera.auto_exposure_jitter", "must be in [0, 0.9]");
  Require(In(auto_exposure_period_s, 0.1, 1e5), "camera.auto_exposure_period_s",
          "must be in [0.1, 1e5]");
  Require(jpeg_quality >= 0 && jpeg_quality <= 100, "camera.jpeg_quality",
          "must be in [0, 100] (0 = PNG)");
  Require(In(readout_s, 0.0, 0.5), "camera.readout_s", "must be in [0, 0.5]");
}

double AutoExposureGain(const ImageEffectsOptions& o, std::uint64_t seed, double seconds) {
  if (o.auto_exposure_jitter == 0.0) return 1.0;
  Random random(seed);
  const double p1 = random.Uniform(0.0, 2.0 * M_PI), p2 = random.Uniform(0.0, 2.0 * M_PI),
               p3 = random.Uniform(0.0, 2.0 * M_PI);
  const double w = 2.0 * M_PI / o.auto_exposure_period_s;
  // Incommensurate periods P, 0.43 P and 0.17 P; weights sum to 1, so |n| <= 1.
  const double n = 0.6 * std::sin(w * seconds + p1) + 0.3 * std::sin(w / 0.43 * seconds + p2) +
                   0.1 * std::sin(w / 0.17 * seconds + p3);
  return 1.0 + o.auto_exposure_jitter * n;
}

PixelRays ComputePixelRays(const geometry::PinholeRadTan& camera) {
  PixelRays table;
  table.width = camera.width;
  table.height = camera.height;
  table.rays.assign(static_cast<std::size_t>(camera.width) * camera.height,
                    Eigen::Vector3d::Zero());
  tbb::parallel_for(0, camera.height, [&](int r) {
    for (int c = 0; c < camera.width; ++c) {
      Eigen::Vector3d ray;
      if (camera.Unproject(Eigen::Vector2d(c, r), &ray)) {
        table.rays[static_cast<std::size_t>(r) * camera.width + c] = ray;
      }
    }
  });
  return table;
}

cv::Mat MotionBlur(const cv::Mat& bgr, const cv::Mat& depth, const geometry::PinholeRadTan& camera,
                   const std::vector<geometry::Rigid3>& begin_rows,
                   const std::vector<geometry::Rigid3>& end_rows) {
  return MotionBlur(bgr, depth, camera, ComputePixelRays(camera), begin_rows, end_rows);
}

cv::Mat MotionBlur(const cv::Mat& bgr, const cv::Mat& depth, const geometry::PinholeRadTan& camera,
                   const PixelRays& rays, const std::vector<geometry::Rigid3>& begin_rows,
                   const std::vector<geometry::Rigid3>& end_rows) {
  CROP4D_CHECK(bgr.size() == depth.size() && depth.type() == CV_32F);
  CROP4D_CHECK(rays.width == bgr.cols && rays.height == bgr.rows);
  CROP4D_CHECK(begin_rows.size() == end_rows.size() &&
               (begin_rows.size() == 1 || static_cast<int>(begin_rows.size()) == bgr.rows));
  cv::Mat sharp;
  bgr.convertTo(sharp, CV_32FC3);
  cv::Mat out(sharp.size(), CV_32FC3);
  constexpr double kSkyDepth = 1e4;  // sky: far enough that only rotation moves it
  constexpr int kMaxSamples = 64;
  for (int r = 0; r < sharp.rows; ++r) {
    const float* z = depth.ptr<float>(r);
    float* o = out.ptr<float>(r);
    const Eigen::Vector3d* row_rays = rays.rays.data() + static_cast<std::size_t>(r) * rays.width;
    const size_t row = begin_rows.size() == 1 ? 0 : static_cast<size_t>(r);
    const geometry::Rigid3& begin_from_mid = begin_rows[row];
    const geometry::Rigid3& end_from_mid = end_rows[row];
    for (int c = 0; c < sharp.cols; ++c) {
      const Eigen::Vector2d pixel(c, r);
      const Eigen::Vector3d& ray = row_rays[c];
      Eigen::Vector2d p0 = pixel, p1 = pixel;
      if (ray.z() > 1e-9) {
        const double d = std::isfinite(z[c]) && z[c] > 0.0f ? z[c] : kSkyDepth;
        const Eigen::Vector3d point = ray * (d / ray.z());
        Eigen::Vector2d q0, q1;
        if (camera.Project(begin_from_mid * point, &q0) &&
            camera.Project(end_from_mid * point, &q1)) {
          p0 = q0;
          p1 = q1;
        }
      }
      // The scene point seen at `pixel` at mid-exposure is at pixel + f(s) at time s; at time s
      // the pixel shows the point whose mid-exposure position is ≈ pixel − f(s).
      const Eigen::Vector2d f0 = p0 - pixel, f1 = p1 - pixel;
      const int n = std::clamp(static_cast<int>(std::ceil((f1 - f0).norm())) + 1, 1, kMaxSamples);
      float sum[3] = {0, 0, 0};
      for (int k = 0; k < n; ++k) {
        const double s = n == 1 ? 0.5 : static_cast<double>(k) / (n - 1);
        const Eigen::Vector2d at = pixel - ((1.0 - s) * f0 + s * f1);
        float v[3];
        Sample(sharp, at.x(), at.y(), v);
        for (int ch = 0; ch < 3; ++ch) sum[ch] += v[ch];
      }
      for (int ch = 0; ch < 3; ++ch) o[3 * c + ch] = sum[ch] / n;
    }
  }
  return out;
}

const std::array<float, kNormalTableSize>& NormalQuantiles() {
  // Φ⁻¹ by Newton's method on Φ(x) = erfc(−x/√2)/2 from x = 0; Φ is convex below 0 and concave
  // above, so the iterates approach each root monotonically.
  static const std::array<float, kNormalTableSize> table = [] {
    std::array<float, kNormalTableSize> t{};
    for (std::size_t k = 0; k < kNormalTableSize; ++k) {
      const double p = (static_cast<double>(k) + 0.5) / kNormalTableSize;
      double x = 0.0;
      for (int iteration = 0; iteration < 100; ++iteration) {
        const double f = 0.5 * std::erfc(-x / std::sqrt(2.0)) - p;
        const double step = f / (std::exp(-0.5 * x * x) / std::sqrt(2.0 * M_PI));
        x -= step;
        if (std::abs(step) < 1e-12) break;
      }
      t[k] = static_cast<float>(x);
    }
    return t;
  }();
  return table;
}

cv::Mat ExposeAndQuantise(const cv::Mat& in, double gain, const ImageEffectsOptions& o,
                          std::uint64_t seed) {
  cv::Mat image;
  in.convertTo(image, CV_32FC3);
  Random random(seed);
  cv::Mat out(image.size(), CV_8UC3);
  const double read_var = o.read_noise_dn * o.read_noise_dn;
  const bool noisy = o.electrons_per_dn > 0.0 || read_var > 0.0;
  // Normal deviates from the quantile table, four per 64-bit draw: a sample of a 2^16-level
  // discrete normal (exact to 4.3 σ) at a fraction of the cost of a polar-method deviate,
  // which was a tenth of the simulator's time (a million per 640×480 image).
  const std::array<float, kNormalTableSize>& normal = NormalQuantiles();
  std::uint64_t bits = 0;
  int left = 0;
  const float shot_per_dn =
      o.electrons_per_dn > 0.0 ? static_cast<float>(1.0 / o.electrons_per_dn) : 0.0f;
  const float gain_f = static_cast<float>(gain), read_var_f = static_cast<float>(read_var);
  for (int r = 0; r < image.rows; ++r) {
    const float* src = image.ptr<float>(r);
    std::uint8_t* dst = out.ptr<std::uint8_t>(r);
    for (int i = 0; i < 3 * image.cols; ++i) {
      float v = gain_f * src[i];
      if (noisy) {
        if (left == 0) {
          bits = random.engine()();
          left = 4;
        }
        const float deviate = normal[bits & (kNormalTableSize - 1)];
        bits >>= 16;
        --left;
        v += std::sqrt(std::max(v, 0.0f) * shot_per_dn + read_var_f) * deviate;
      }
      dst[i] = static_cast<std::uint8_t>(std::clamp(std::round(v), 0.0f, 255.0f));
    }
  }
  return out;
}

// ---- IMU ------------------------------------------------------------------------------------

bool ImuAxisErrors::IsIdentity() const {
  return gyro_scale.isIdentity(0.0) && accel_scale.isIdentity(0.0) &&
         gyro_misalignment.isZero(0.0) && accel_misalignment.isZero(0.0);
}

ImuAxisErrors DrawImuAxisErrors(double scale_sigma, double misalignment_sigma_rad,
                                std::uint64_t seed) {
  Random random(seed);
  ImuAxisErrors e;
  for (Eigen::Matrix3d* s : {&e.gyro_scale, &e.accel_scale}) {
    for (int k = 0; k < 3; ++k) (*s)(k, k) = 1.0 + random.Normal(0.0, scale_sigma);
  }
  for (Eigen::Matrix3d* m : {&e.gyro_misalignment, &e.accel_misalignment}) {
    for (int i = 0; i < 3; ++i) {
      for (int j = 0; j < 3; ++j) {
        if (i != j) (*m)(i, j) = random.Normal(0.0, misalignment_sigma_rad);
      }
    }
  }
  return e;
}

// ---- GPS ------------------------------------------------------------------------------------

bool GpsFaultOptions::Any() const {
  return outlier_probability != 0.0 || float_rate_per_min != 0.0 || dropout_rate_per_min != 0.0;
}

void GpsFaultOptions::Check(const std::string& name) const {
  const std::string p = name + ".";
  Require(In(outlier_probability, 0.0, 1.0), p + "outlier_probability", "must be in [0, 1]");
  Require(In(outlier_sigma_m, 0.0, 1000.0), p + "outlier_sigma_m", "must be in [0, 1000]");
  Require(In(float_rate_per_min, 0.0, 600.0), p + "float_rate_per_min", "must be in [0, 600]");
  Require(In(float_duration_s, 0.0, 1e5), p + "float_duration_s", "must be in [0, 1e5]");
  Require(In(float_sigma_h_m, 0.0, 100.0), p + "float_sigma_h_m", "must be in [0, 100]");
  Require(In(float_sigma_v_m, 0.0, 100.0), p + "float_sigma_v_m", "must be in [0, 100]");
  Require(In(dropout_rate_per_min, 0.0, 600.0), p + "dropout_rate_per_min", "must be in [0, 600]");
  Require(In(dropout_duration_s, 0.0, 1e4), p + "dropout_duration_s", "must be in [0, 1e4]");
}

std::vector<GpsFault> SimulateGpsFaults(const GpsFaultOptions& o, bool rtk, double fix_sigma_h,
                                        double fix_sigma_v, const std::vector<double>& seconds,
                                        const std::vector<bool>& in_headland, std::uint64_t seed) {
  CROP4D_CHECK(seconds.size() == in_headland.size());
  Random random(seed);
  std::vector<GpsFault> faults(seconds.size());
  const double extra_h =
      std::sqrt(std::max(0.0, o.float_sigma_h_m * o.float_sigma_h_m - fix_sigma_h * fix_sigma_h));
  const double extra_v =
      std::sqrt(std::max(0.0, o.float_sigma_v_m * o.float_sigma_v_m - fix_sigma_v * fix_sigma_v));
  double float_until = -1.0, dropout_until = -1.0;
  for (size_t k = 0; k < seconds.size(); ++k) {
    const double t = seconds[k];
    const double dt = k == 0 ? 0.0 : t - seconds[k - 1];
    GpsFault& f = faults[k];
    // Poisson arrivals: an event starts within dt with probability 1 − e^(−rate dt).
    if (t >= dropout_until && in_headland[k] && o.dropout_rate_per_min > 0.0 &&
        random.Bernoulli(1.0 - std::exp(-o.dropout_rate_per_min / 60.0 * dt))) {
      dropout_until = t + o.dropout_duration_s;
    }
    if (rtk && t >= float_until && o.float_rate_per_min > 0.0 &&
        random.Bernoulli(1.0 - std::exp(-o.float_rate_per_min / 60.0 * dt))) {
      const double duration = std::max(1.0, -o.float_duration_s * std::log(1.0 - random.Uniform()));
      float_until = t + duration;
    }
    f.dropped = t < dropout_until;
    f.is_float = t < float_until;
    if (f.is_float) {
      f.extra += Eigen::Vector3d(extra_h * random.Normal(), extra_h * random.Normal(),
                                 extra_v * random.Normal());
    }
    if (o.outlier_probability > 0.0 && random.Bernoulli(o.outlier_probability)) {
      f.outlier = true;
      f.extra +=
          Eigen::Vector3d(o.outlier_sigma_m * random.Normal(), o.outlier_sigma_m * random.Normal(),
                          1.5 * o.outlier_sigma_m * random.Normal());
    }
  }
  return faults;
}

}  // namespace crop4d::sim
