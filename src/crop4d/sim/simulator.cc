#include "crop4d/sim/simulator.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>
#include <tbb/task_group.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iterator>
#include <mutex>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <semaphore>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/random.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/sensor_models.h"

namespace crop4d::sim {
namespace fs = std::filesystem;
namespace {

// Tags of the random streams (HashCombine(seed, tag, session)).
enum StreamTag : std::uint64_t {
  kTagTrajectory = 0x7aa1,
  kTagClock = 0xc10c,
  kTagImu = 0x1a10,
  kTagMag = 0x3a60,
  kTagGps0 = 0x6b50,
  kTagGps1 = 0x6b51,
  kTagLight = 0x119b,
  kTagWind = 0x3119,
  kTagRuler = 0x2a1e,
  // Imperfections (issue 26): their own streams, so that the ideal world's are untouched.
  kTagCalibration = 0xca1b,
  kTagImuAxes = 0x1a5c,
  kTagGpsFaults0 = 0x6bf0,
  kTagGpsFaults1 = 0x6bf1,
  kTagImageNoise = 0x1a9e,
  kTagExposure = 0xe7b0,
};

constexpr double kDegToRad = M_PI / 180.0;

std::string Join(const std::string& a, const std::string& b) { return (fs::path(a) / b).string(); }

void AppendTumLine(fmt::memory_buffer* out, Timestamp t, const geometry::Rigid3& pose) {
  const std::string line = io::FormatTumLine(t, pose);
  out->append(line.data(), line.data() + line.size());
}

void WriteBuffer(const std::string& path, const fmt::memory_buffer& buffer) {
  io::WriteFileAtomic(path, std::string(buffer.data(), buffer.size()));
}

// 16-bit PNG depth in millimetres: 0 = no surface (sky), 65535 = 65.535 m or farther.
cv::Mat DepthToMillimetres(const cv::Mat& depth) {
  cv::Mat out(depth.size(), CV_16UC1);
  for (int r = 0; r < depth.rows; ++r) {
    const float* in = depth.ptr<float>(r);
    std::uint16_t* o = out.ptr<std::uint16_t>(r);
    for (int c = 0; c < depth.cols; ++c) {
      const double mm = std::isfinite(in[c]) && in[c] > 0.0f ? std::round(in[c] * 1000.0) : 0.0;
      o[c] = static_cast<std::uint16_t>(std::clamp(mm, 0.0, 65535.0));
    }
  }
  return out;
}

void EncodeJpeg(const cv::Mat& image, int quality, const std::string& path) {
  std::vector<unsigned char> bytes;
  if (!cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality})) {
    throw std::runtime_error("cannot encode " + path + " as JPEG");
  }
  io::WriteFileAtomic(path, std::string(bytes.begin(), bytes.end()));
}

std::string FormatVector(const Eigen::Vector3d& v) {
  return fmt::format("[{:.9g}, {:.9g}, {:.9g}]", v.x(), v.y(), v.z());
}

std::string FormatMatrix(const Eigen::Matrix3d& m) {
  return fmt::format("[{}, {}, {}]", FormatVector(m.row(0).transpose()),
                     FormatVector(m.row(1).transpose()), FormatVector(m.row(2).transpose()));
}

std::string FormatIntrinsics(const geometry::PinholeRadTan& c) {
  return fmt::format(
      "{{fx: {:.9g}, fy: {:.9g}, cx: {:.9g}, cy: {:.9g}, k1: {:.9g}, k2: {:.9g}, p1: {:.9g}, "
      "p2: {:.9g}, k3: {:.9g}}}",
      c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3);
}

void EncodePng(const cv::Mat& image, const std::string& path) {
  std::vector<unsigned char> bytes;
  // Compression level 1: PNG encoding dominates the write time; level 1 is ~30% faster than
  // OpenCV's default 3 for ~2% larger files (bench/RESULTS.md, "Simulator"). The rendered
  // images are noise-textured, so zlib's string matching finds little in them: Huffman coding
  // alone encodes them in 15 instead of 20 ms (640×480) for 6% larger files. Depth maps are
  // smooth and keep the default strategy.
  std::vector<int> params = {cv::IMWRITE_PNG_COMPRESSION, 1};
  if (image.depth() == CV_8U) {
    params.insert(params.end(), {cv::IMWRITE_PNG_STRATEGY, cv::IMWRITE_PNG_STRATEGY_HUFFMAN_ONLY});
  }
  if (!cv::imencode(".png", image, bytes, params)) {
    throw std::runtime_error("cannot encode " + path + " as PNG");
  }
  io::WriteFileAtomic(path, std::string(bytes.begin(), bytes.end()));
}

std::string SiteId(int row, int k) { return fmt::format("r{:02d}s{}", row, k + 1); }

}  // namespace

// ---- Sun ------------------------------------------------------------------------------------

void SunPosition(Timestamp t, double lat_deg, double lon_deg, double* elevation_rad,
                 double* azimuth_rad) {
  using namespace std::chrono;
  const sys_days day{days{static_cast<int>(std::floor(static_cast<double>(t) / 86400e9))}};
  const year_month_day ymd{day};
  const sys_days jan1{ymd.year() / January / 1};
  const int day_of_year = (day - jan1).count() + 1;
  const double hours =
      static_cast<double>(t - static_cast<Timestamp>(day.time_since_epoch().count()) * 86400 *
                                  kNanosPerSecond) /
      3600e9;
  // NOAA: fractional year γ, equation of time (minutes) and declination (radians).
  const double g = 2.0 * M_PI / 365.0 * (day_of_year - 1 + (hours - 12.0) / 24.0);
  const double eqtime = 229.18 * (0.000075 + 0.001868 * std::cos(g) - 0.032077 * std::sin(g) -
                                  0.014615 * std::cos(2 * g) - 0.040849 * std::sin(2 * g));
  const double decl = 0.006918 - 0.399912 * std::cos(g) + 0.070257 * std::sin(g) -
                      0.006758 * std::cos(2 * g) + 0.000907 * std::sin(2 * g) -
                      0.002697 * std::cos(3 * g) + 0.00148 * std::sin(3 * g);
  const double true_solar_minutes = hours * 60.0 + eqtime + 4.0 * lon_deg;
  const double hour_angle = (true_solar_minutes / 4.0 - 180.0) * kDegToRad;  // + afternoon
  const double lat = lat_deg * kDegToRad;
  // The sun's direction in the local East-North-Up frame.
  const double east = -std::cos(decl) * std::sin(hour_angle);
  const double north =
      std::sin(decl) * std::cos(lat) - std::cos(decl) * std::cos(hour_angle) * std::sin(lat);
  const double up =
      std::sin(decl) * std::sin(lat) + std::cos(decl) * std::cos(hour_angle) * std::cos(lat);
  *elevation_rad = std::asin(std::clamp(up, -1.0, 1.0));
  double azimuth = std::atan2(east, north);
  if (azimuth < 0) azimuth += 2.0 * M_PI;
  *azimuth_rad = azimuth;
}

// ---- Output folder --------------------------------------------------------------------------

void PrepareOutputFolder(const std::string& out_dir, bool force) {
  std::error_code ec;
  if (!fs::exists(out_dir, ec)) {
    fs::create_directories(out_dir, ec);
    if (ec) throw InputError(out_dir, 0, "cannot create the output folder: " + ec.message());
    return;
  }
  if (!fs::is_directory(out_dir, ec)) {
    throw InputError(out_dir, 0, "--out exists and is not a folder");
  }
  if (fs::is_empty(out_dir, ec)) return;
  const bool looks_like_field =
      fs::exists(Join(out_dir, "field.yaml")) || fs::exists(Join(out_dir, "sessions"));
  if (!force) {
    throw InputError(out_dir, 0,
                     "the output folder is not empty; choose another --out, or add --force to "
                     "replace the field in it");
  }
  if (!looks_like_field) {
    throw InputError(out_dir, 0,
                     "the output folder is not empty and holds no field (no field.yaml or "
                     "sessions/); --force only replaces a field, choose another --out");
  }
  for (const char* name : {"field.yaml", "sessions", "ground_truth"}) {
    fs::remove_all(Join(out_dir, name), ec);
    if (ec) throw InputError(Join(out_dir, name), 0, "cannot delete: " + ec.message());
  }
}

// ---- Simulator ------------------------------------------------------------------------------

Simulator::Simulator(const SimConfig& config) : config_(config) {
  config_.Check();
  world_ = std::make_unique<World>(config_.MakeWorldOptions());
  if (config_.calibration_error.Any()) {
    calibration_errors_ = DrawCalibrationErrors(config_.calibration_error,
                                                HashCombine(config_.seed, kTagCalibration));
  }
  if (config_.imu.scale_factor_sigma > 0.0 || config_.imu.misalignment_sigma_rad > 0.0) {
    imu_axis_errors_ =
        DrawImuAxisErrors(config_.imu.scale_factor_sigma, config_.imu.misalignment_sigma_rad,
                          HashCombine(config_.seed, kTagImuAxes));
  }
}

geometry::Rigid3 Simulator::BodyFromCamera() const {
  return config_.camera.BodyFromCamera(config_.drive.body_height_m);
}

SessionConditions Simulator::ConditionsOf(int i) const {
  CROP4D_CHECK(i >= 0 && i < static_cast<int>(config_.sessions.size()));
  Random light(HashCombine(config_.seed, kTagLight, static_cast<std::uint64_t>(i)));
  light.Uniform();  // the start time's draw (SessionStart)
  SessionConditions c;
  c.date = config_.SessionDates()[i];
  // The sun ten minutes into the session.
  SunPosition(SessionStart(i) + 10 * 60 * kNanosPerSecond, config_.origin.lat_deg,
              config_.origin.lon_deg, &c.sun_elevation_rad, &c.sun_azimuth_rad);
  c.brightness = 1.0 + light.Uniform(-1.0, 1.0) * config_.recording.brightness_jitter;
  c.rain_before = config_.sessions[i].rain_before;
  c.soil_epoch = 0;
  for (int k = 0; k <= i; ++k) c.soil_epoch += config_.sessions[k].rain_before ? 1 : 0;
  c.wind_seed = HashCombine(config_.seed, kTagWind, static_cast<std::uint64_t>(i));
  for (int k = i; k > 0 && !config_.sessions[k].rain_before; --k) ++c.soil_change_level;
  c.soil_change = config_.soil_change;
  if (config_.recording.wind_sway_m > 0.0) {
    Random wind(HashCombine(c.wind_seed, 0xa3u));
    c.wind_sway_m = config_.recording.wind_sway_m * wind.Uniform(0.3, 1.0);
    c.wind_period_s = config_.recording.wind_period_s;
  }
  return c;
}

Timestamp Simulator::SessionStart(int i) const {
  CROP4D_CHECK(i >= 0 && i < static_cast<int>(config_.sessions.size()));
  Random light(HashCombine(config_.seed, kTagLight, static_cast<std::uint64_t>(i)));
  const double hours =
      config_.recording.start_utc_h + config_.recording.start_jitter_h * light.Uniform();
  // Whole seconds after midnight UTC of the session date.
  return config_.SessionDates()[i] +
         static_cast<Timestamp>(std::llround(hours * 3600.0)) * kNanosPerSecond;
}

SessionRecord Simulator::SimulateSession(int i) const {
  const SimConfig& cfg = config_;
  SessionRecord rec;
  rec.index = i;
  rec.conditions = ConditionsOf(i);
  rec.start = SessionStart(i);
  rec.info.id = cfg.sessions[i].date;
  rec.info.date = rec.conditions.date;
  rec.info.rain_before = cfg.sessions[i].rain_before;
  rec.info.notes = fmt::format(
      "synthetic session (crop4d simulate, seed {}): day {:.0f} after sowing, sun elevation "
      "{:.0f} deg azimuth {:.0f} deg, exposure {:.2f}{}",
      cfg.seed, world_->DaysAfterSowing(rec.conditions.date),
      rec.conditions.sun_elevation_rad / kDegToRad, rec.conditions.sun_azimuth_rad / kDegToRad,
      rec.conditions.brightness, rec.info.rain_before ? ", rain since the previous session" : "");

  auto trajectory = std::make_shared<Trajectory>(
      *world_, cfg.drive, HashCombine(cfg.seed, kTagTrajectory, static_cast<std::uint64_t>(i)));
  rec.trajectory = trajectory;
  const Trajectory& traj = *trajectory;
  const Timestamp end = rec.start + SecondsToTimestamp(traj.Duration());

  // Free-running clocks: each sensor starts at its own random phase within one period.
  Random clock(HashCombine(cfg.seed, kTagClock, static_cast<std::uint64_t>(i)));
  auto phase = [&](double rate_hz) {
    return static_cast<Timestamp>(clock.UniformInt(static_cast<std::uint64_t>(1e9 / rate_hz)));
  };
  rec.image_times = SensorTimestamps(rec.start, end, cfg.camera.rate_hz, phase(cfg.camera.rate_hz));
  if (cfg.camera.trigger == "passes") {
    // The camera is triggered over the row passes only; the clock keeps its phase.
    std::erase_if(rec.image_times, [&](Timestamp t) {
      const double s = DurationSeconds(rec.start, t);
      return std::none_of(traj.passes().begin(), traj.passes().end(),
                          [&](const Pass& p) { return s >= p.t_begin && s <= p.t_end; });
    });
  }
  std::vector<Timestamp> imu_times =
      SensorTimestamps(rec.start, end, cfg.imu.rate_hz, phase(cfg.imu.rate_hz));
  std::vector<Timestamp> mag_times =
      SensorTimestamps(rec.start, end, cfg.mag.rate_hz, phase(cfg.mag.rate_hz));
  std::array<std::vector<Timestamp>, 2> gps_times = {
      SensorTimestamps(rec.start, end, cfg.gps0.rate_hz, phase(cfg.gps0.rate_hz)),
      SensorTimestamps(rec.start, end, cfg.gps1.rate_hz, phase(cfg.gps1.rate_hz))};
  MakeTimestampsUnique({&rec.image_times, &imu_times, &mag_times, &gps_times[0], &gps_times[1]});
  // The camera's clock: its stamps are off the capture times by the time offset and drift
  // (kept distinct from every other sensor's stamps, 1 ns later when they collide).
  rec.image_capture_times = rec.image_times;
  if (calibration_errors_.time_offset_s != 0.0 || calibration_errors_.drift != 0.0) {
    std::vector<Timestamp> others;
    for (const std::vector<Timestamp>* v : {&imu_times, &mag_times, &gps_times[0], &gps_times[1]}) {
      others.insert(others.end(), v->begin(), v->end());
    }
    std::sort(others.begin(), others.end());
    for (Timestamp& t : rec.image_times) {
      t = calibration_errors_.WrittenStamp(rec.start, t);
      while (std::binary_search(others.begin(), others.end(), t)) ++t;
    }
  }

  // IMU.
  ImuModel imu(cfg.imu, HashCombine(cfg.seed, kTagImu, static_cast<std::uint64_t>(i)));
  rec.imu.reserve(imu_times.size());
  for (size_t k = 0; k < imu_times.size(); ++k) {
    const double dt =
        k == 0 ? 1.0 / cfg.imu.rate_hz : DurationSeconds(imu_times[k - 1], imu_times[k]);
    Eigen::Vector3d gyro, accel;
    IdealImu(traj.StateAt(rec.Seconds(imu_times[k])), &gyro, &accel);
    if (!imu_axis_errors_.IsIdentity()) {
      gyro = imu_axis_errors_.Gyro(gyro);
      accel = imu_axis_errors_.Accel(accel);
    }
    rec.imu.push_back(imu.Measure(imu_times[k], dt, gyro, accel));
    rec.gyro_bias.push_back(imu.gyro_bias());
    rec.accel_bias.push_back(imu.accel_bias());
  }

  // Magnetometer: its axes are the body's.
  MagModel mag(cfg.mag, HashCombine(cfg.seed, kTagMag, static_cast<std::uint64_t>(i)));
  for (const Timestamp t : mag_times) {
    rec.mag.push_back(mag.Measure(t, traj.WorldFromBody(rec.Seconds(t)).rotation()));
  }

  // GPS: the antenna's true position, noise and bias in ENU, then WGS84.
  const geometry::LocalEnu enu(cfg.origin);
  const std::array<const GpsOptions*, 2> gps_options = {&cfg.gps0, &cfg.gps1};
  const std::array<std::uint64_t, 2> gps_tags = {kTagGps0, kTagGps1};
  const std::array<std::uint64_t, 2> fault_tags = {kTagGpsFaults0, kTagGpsFaults1};
  // "Near the tree line": beyond the ends of the rows, over the headlands.
  const double rows_y0 = std::min(world_->RowStart(0).y(), world_->RowEnd(0).y());
  const double rows_y1 = std::max(world_->RowStart(0).y(), world_->RowEnd(0).y());
  for (int g = 0; g < 2; ++g) {
    const GpsOptions& o = *gps_options[g];
    GpsModel model(o, HashCombine(cfg.seed, gps_tags[g], static_cast<std::uint64_t>(i)));
    const std::vector<Timestamp>& times = gps_times[g];
    std::vector<Eigen::Vector3d> antennas;
    std::vector<double> seconds;
    std::vector<bool> in_headland;
    for (const Timestamp t : times) {
      antennas.push_back(traj.WorldFromBody(rec.Seconds(t)) * o.antenna_in_body);
      seconds.push_back(rec.Seconds(t));
      in_headland.push_back(antennas.back().y() < rows_y0 || antennas.back().y() > rows_y1);
    }
    const std::vector<GpsFault> faults =
        o.faults.Any()
            ? SimulateGpsFaults(o.faults, o.kind == "rtk", o.sigma_h_m, o.sigma_v_m, seconds,
                                in_headland,
                                HashCombine(cfg.seed, fault_tags[g], static_cast<std::uint64_t>(i)))
            : std::vector<GpsFault>(times.size());
    for (size_t k = 0; k < times.size(); ++k) {
      const double dt = k == 0 ? 1.0 / o.rate_hz : DurationSeconds(times[k - 1], times[k]);
      const Eigen::Vector3d& antenna = antennas[k];
      // Every sample draws its noise, dropped or not, so a dropout changes no other sample.
      Eigen::Vector3d measured = model.Measure(dt, antenna);
      const GpsFault& fault = faults[k];
      if (fault.dropped) continue;
      measured += fault.extra;
      io::GpsSample sample;
      sample.t = times[k];
      sample.position = enu.ToGeodetic(measured);
      sample.sigma_h = fault.is_float ? o.faults.float_sigma_h_m : o.ReportedSigmaH();
      sample.sigma_v = fault.is_float ? o.faults.float_sigma_v_m : o.ReportedSigmaV();
      sample.fix = fault.is_float ? io::GpsFix::kRtkFloat : o.Fix();
      rec.gps[g].push_back(sample);
      rec.gps_true_enu[g].push_back(antenna);
      rec.gps_measured_enu[g].push_back(measured);
      rec.gps_bias[g].push_back(model.bias());
      rec.gps_faults[g].push_back(fault);
    }
  }
  return rec;
}

io::FieldInfo Simulator::MakeFieldInfo() const {
  io::FieldInfo field;
  field.name = config_.name;
  field.origin = config_.origin;
  const WorldOptions& w = world_->options();
  for (int r = 0; r < w.num_rows; ++r) {
    io::RowDeclaration row;
    row.index = r;
    row.start_enu = world_->RowStart(r).head<2>();
    row.end_enu = world_->RowEnd(r).head<2>();
    field.rows.push_back(row);
    const int n = config_.ground_truth.sites_per_row;
    for (int k = 0; k < n; ++k) {
      io::Site site;
      site.id = SiteId(r, k);
      site.center_enu = row.start_enu + (k + 0.5) / n * (row.end_enu - row.start_enu);
      site.radius_m = config_.ground_truth.site_radius_m;
      field.sites.push_back(site);
    }
  }
  for (const SessionSpec& s : config_.sessions) field.sessions.push_back(s.date);
  return field;
}

Simulator::Summary Simulator::Write(const std::string& out_dir) {
  const auto t0 = std::chrono::steady_clock::now();
  const SimConfig& cfg = config_;
  Summary summary;
  fs::create_directories(out_dir);
  const std::string truth_dir = Join(out_dir, "ground_truth");
  const io::FieldInfo field = MakeFieldInfo();
  const geometry::Rigid3 body_from_camera = BodyFromCamera();

  // ---- Field-wide ground truth.
  io::WriteFileAtomic(Join(truth_dir, "simulate.yaml"), SimConfigToYaml(cfg));
  const CalibrationErrors& calib = calibration_errors_;
  const geometry::PinholeRadTan written_intrinsics =
      calib.WrittenIntrinsics(cfg.camera.Intrinsics());
  const geometry::Rigid3 written_body_from_camera = calib.WrittenBodyFromCamera(body_from_camera);
  const std::array<const GpsOptions*, 2> all_gps = {&cfg.gps0, &cfg.gps1};
  if (cfg.calibration_error.Any() || !imu_axis_errors_.IsIdentity()) {
    // The true calibration next to the one written to the sensor.yaml files.
    std::string y =
        "# The rig's true calibration (used to render and to simulate the sensors) and the one\n"
        "# written to sessions/*/*/sensor.yaml (calibration_error in simulate.yaml).\n";
    y +=
        fmt::format("camera_time_offset_s: {:.9g}  # image stamp - capture time at session start\n",
                    calib.time_offset_s);
    y += fmt::format("camera_clock_drift: {:.9g}  # d(stamp - capture)/dt\n", calib.drift);
    y += "cam0:\n";
    y += "  true_intrinsics: " + FormatIntrinsics(cfg.camera.Intrinsics()) + "\n";
    y += "  written_intrinsics: " + FormatIntrinsics(written_intrinsics) + "\n";
    auto matrix4 = [](const Eigen::Matrix4d& m) {
      std::string rows;
      for (int r = 0; r < 4; ++r) {
        rows += fmt::format("{}[{:.12g}, {:.12g}, {:.12g}, {:.12g}]", r ? ", " : "", m(r, 0),
                            m(r, 1), m(r, 2), m(r, 3));
      }
      return "[" + rows + "]";
    };
    y += "  true_T_BS: " + matrix4(body_from_camera.Matrix()) + "\n";
    y += "  written_T_BS: " + matrix4(written_body_from_camera.Matrix()) + "\n";
    y += "  # T_BS rows; written R = Exp(rotation_error_rad) R_true\n";
    y += "  rotation_error_rad: " + FormatVector(calib.camera_rotation) + "\n";
    y += "  translation_error_m: " + FormatVector(calib.camera_translation) + "\n";
    for (int g = 0; g < 2; ++g) {
      y += fmt::format("gps{}:\n  true_antenna_in_body: {}\n  written_antenna_in_body: {}\n", g,
                       FormatVector(all_gps[g]->antenna_in_body),
                       FormatVector(all_gps[g]->antenna_in_body + calib.gps_antenna[g]));
    }
    y += fmt::format("mag0:\n  true_position_in_body: {}\n  written_position_in_body: {}\n",
                     FormatVector(cfg.mag.position_in_body),
                     FormatVector(cfg.mag.position_in_body + calib.mag_position));
    y += "imu0:  # measured = (I + misalignment) * scale * truth + bias + noise\n";
    y += "  gyro_scale: " + FormatVector(imu_axis_errors_.gyro_scale.diagonal()) + "\n";
    y += "  gyro_misalignment: " + FormatMatrix(imu_axis_errors_.gyro_misalignment) + "\n";
    y += "  accel_scale: " + FormatVector(imu_axis_errors_.accel_scale.diagonal()) + "\n";
    y += "  accel_misalignment: " + FormatMatrix(imu_axis_errors_.accel_misalignment) + "\n";
    io::WriteFileAtomic(Join(truth_dir, "calibration_truth.yaml"), y);
  }
  {
    fmt::memory_buffer b;
    fmt::format_to(std::back_inserter(b), "x,y,z\n");
    const Eigen::AlignedBox2d box = world_->Bounds();
    const double step = cfg.ground_truth.terrain_grid_m;
    const int nx = static_cast<int>(std::floor(box.sizes().x() / step + 1e-9)) + 1;
    const int ny = static_cast<int>(std::floor(box.sizes().y() / step + 1e-9)) + 1;
    for (int iy = 0; iy < ny; ++iy) {
      for (int ix = 0; ix < nx; ++ix) {
        const double x = box.min().x() + ix * step, y = box.min().y() + iy * step;
        fmt::format_to(std::back_inserter(b), "{:.4f},{:.4f},{:.5f}\n", x, y,
                       world_->TerrainHeight(x, y));
      }
    }
    WriteBuffer(Join(truth_dir, "terrain.csv"), b);
  }
  {
    fmt::memory_buffer truth, measured;
    fmt::format_to(std::back_inserter(truth), "site_id,session,date,height_m\n");
    fmt::format_to(std::back_inserter(measured), "site_id,date,height_m\n");
    Random ruler(HashCombine(cfg.seed, kTagRuler));
    const std::vector<Timestamp> dates = cfg.SessionDates();
    for (size_t s = 0; s < cfg.sessions.size(); ++s) {
      for (const io::Site& site : field.sites) {
        const double h = world_->TrueCanopyHeight(site.center_enu, site.radius_m, dates[s]);
        fmt::format_to(std::back_inserter(truth), "{},{},{},{:.5f}\n", site.id,
                       cfg.sessions[s].date, cfg.sessions[s].date, h);
        // A person with a ruler: ≈1 cm noise, read to the centimetre; nothing to measure
        // before emergence.
        const double noise = ruler.Normal(0.0, cfg.ground_truth.measurement_noise_m);
        const double reading =
            h > 0.0 ? std::max(0.0, std::round((h + noise) * 100.0) / 100.0) : 0.0;
        fmt::format_to(std::back_inserter(measured), "{},{},{:.2f}\n", site.id,
                       cfg.sessions[s].date, reading);
      }
    }
    WriteBuffer(Join(truth_dir, "site_truth.csv"), truth);
    WriteBuffer(Join(truth_dir, "site_measurements.csv"), measured);
  }

  // ---- The renderer lives on this thread (its GL context is current here); PNG encoding and
  // writing run in parallel on TBB workers, at most `max_in_flight` frames ahead.
  RenderOptions render_options;
  render_options.camera = cfg.camera.Intrinsics();
  render_options.msaa_samples = cfg.camera.msaa_samples;
  const auto setup_start = std::chrono::steady_clock::now();
  Renderer renderer(*world_, render_options);
  summary.setup_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();
  const int concurrency = tbb::this_task_arena::max_concurrency();
  const bool parallel = concurrency > 1;
  const std::ptrdiff_t max_in_flight = 2 * concurrency + 2;

  for (int i = 0; i < static_cast<int>(cfg.sessions.size()); ++i) {
    const SessionRecord rec = SimulateSession(i);
    const Trajectory& traj = *rec.trajectory;
    const std::string session_dir = Join(Join(out_dir, "sessions"), rec.info.id);
    const std::string session_truth = Join(truth_dir, rec.info.id);
    spdlog::info("simulate: session {} ({}/{}): {:.0f} s, {} images, {} passes", rec.info.id, i + 1,
                 cfg.sessions.size(), traj.Duration(), rec.image_times.size(),
                 traj.passes().size());

    // Images.
    const std::string image_dir = Join(Join(session_dir, "cam0"), "data");
    const std::string depth_dir = Join(session_truth, "cam0_depth");
    fs::create_directories(image_dir);
    if (cfg.ground_truth.depth) fs::create_directories(depth_dir);
    const auto session_start = std::chrono::steady_clock::now();
    renderer.SetSession(rec.conditions);
    const auto images_start = std::chrono::steady_clock::now();
    summary.setup_seconds += std::chrono::duration<double>(images_start - session_start).count();
    std::vector<io::ImageEntry> entries;
    fmt::memory_buffer camera_tum;
    fmt::format_to(std::back_inserter(camera_tum),
                   "# world_from_camera of cam0 (OpenCV camera frame) in the field's ENU frame\n"
                   "# t[s] tx ty tz qx qy qz qw\n");
    const ImageEffectsOptions& effects = cfg.image;
    const bool image_effects = effects.Any();
    // Motion blur and rolling shutter both warp the rendered image along the motion.
    const bool blur = effects.exposure_s > 0.0 || effects.readout_s > 0.0;
    const std::string image_extension = effects.jpeg_quality > 0 ? "jpg" : "png";
    const std::uint64_t exposure_seed =
        HashCombine(cfg.seed, kTagExposure, static_cast<std::uint64_t>(i));
    fmt::memory_buffer exposure_csv;
    fmt::format_to(std::back_inserter(exposure_csv),
                   "#timestamp [ns],capture [ns],gain,exposure [s]\n");
    const geometry::PinholeRadTan intrinsics = cfg.camera.Intrinsics();
    const PixelRays rays = blur ? ComputePixelRays(intrinsics) : PixelRays();
    {
      Progress progress("render " + rec.info.id, rec.image_times.size(), "img");
      tbb::task_group group;
      std::counting_semaphore<> slots(max_in_flight);
      std::atomic<bool> failed{false};
      for (size_t f = 0; f < rec.image_times.size(); ++f) {
        if (failed) break;
        // The image is stamped t on the camera's clock and shows the capture instant.
        const Timestamp t = rec.image_times[f];
        const double capture = rec.Seconds(rec.image_capture_times[f]);
        const geometry::Rigid3 world_from_camera = traj.WorldFromBody(capture) * body_from_camera;
        AppendTumLine(&camera_tum, t, world_from_camera);
        io::ImageEntry entry;
        entry.t = t;
        entry.filename = fmt::format("{}.{}", t, image_extension);
        entries.push_back(entry);
        auto frame = std::make_shared<std::pair<cv::Mat, cv::Mat>>();
        const auto r0 = std::chrono::steady_clock::now();
        renderer.SetTime(capture);
        renderer.Render(world_from_camera, &frame->first,
                        cfg.ground_truth.depth || blur ? &frame->second : nullptr);
        summary.render_seconds +=
            std::chrono::duration<double>(std::chrono::steady_clock::now() - r0).count();
        const std::string image_path = Join(image_dir, entry.filename);
        const std::string depth_path = Join(depth_dir, fmt::format("{}.png", t));
        // The camera at the start and the end of the exposure, seen from its mid-exposure frame.
        // With a rolling shutter, row k is exposed around capture + (k / (H − 1) − ½) readout.
        std::vector<geometry::Rigid3> begin_from_mid, end_from_mid;
        if (blur) {
          auto from_mid = [&](double s) {
            return (traj.WorldFromBody(std::clamp(s, 0.0, traj.Duration())) * body_from_camera)
                       .Inverse() *
                   world_from_camera;
          };
          const int rows = effects.readout_s > 0.0 ? cfg.camera.height : 1;
          for (int k = 0; k < rows; ++k) {
            const double row_time =
                rows == 1 ? capture : capture + (k / (rows - 1.0) - 0.5) * effects.readout_s;
            begin_from_mid.push_back(from_mid(row_time - 0.5 * effects.exposure_s));
            end_from_mid.push_back(from_mid(row_time + 0.5 * effects.exposure_s));
          }
        }
        const double gain = AutoExposureGain(effects, exposure_seed, capture);
        if (image_effects) {
          fmt::format_to(std::back_inserter(exposure_csv), "{},{},{:.6f},{}\n", t,
                         rec.image_capture_times[f], gain, effects.exposure_s);
        }
        const std::uint64_t noise_seed =
            HashCombine(cfg.seed, kTagImageNoise, static_cast<std::uint64_t>(i), f);
        auto encode = [frame, image_path, depth_path, &progress, &cfg, image_effects, blur,
                       begin_from_mid, end_from_mid, gain, noise_seed, &intrinsics, &rays]() {
          if (image_effects) {
            const cv::Mat sharp = frame->first;
            frame->first = ExposeAndQuantise(blur ? MotionBlur(sharp, frame->second, intrinsics,
                                                               rays, begin_from_mid, end_from_mid)
                                                  : sharp,
                                             gain, cfg.image, noise_seed);
          }
          if (cfg.image.jpeg_quality > 0) {
            EncodeJpeg(frame->first, cfg.image.jpeg_quality, image_path);
          } else {
            EncodePng(frame->first, image_path);
          }
          if (cfg.ground_truth.depth) EncodePng(DepthToMillimetres(frame->second), depth_path);
          progress.Add();
        };
        if (!parallel) {
          encode();
          continue;
        }
        slots.acquire();
        group.run([encode, &slots, &failed] {
          struct Release {
            std::counting_semaphore<>* s;
            ~Release() { s->release(); }
          } release{&slots};
          try {
            encode();
          } catch (...) {
            failed = true;
            throw;
          }
        });
      }
      group.wait();  // rethrows the first failure of an encoding task
      progress.Finish();
    }
    summary.images += static_cast<std::int64_t>(entries.size());
    summary.images_seconds +=
        std::chrono::duration<double>(std::chrono::steady_clock::now() - images_start).count();

    // Sensor data and descriptions.
    io::SessionInfo info = rec.info;
    io::WriteSessionYaml(Join(session_dir, "session.yaml"), info);
    if (image_effects) WriteBuffer(Join(session_truth, "cam0_exposure.csv"), exposure_csv);
    io::CameraSensor camera;
    camera.name = "cam0";
    camera.camera = written_intrinsics;
    camera.rate_hz = cfg.camera.rate_hz;
    camera.body_from_sensor = written_body_from_camera;
    camera.height_above_ground_m = cfg.camera.height_m;
    io::WriteCameraSensorYaml(Join(session_dir, "cam0/sensor.yaml"), camera);
    io::WriteImageCsv(Join(session_dir, "cam0/data.csv"), entries);

    io::ImuSensor imu;
    imu.name = "imu0";
    imu.rate_hz = cfg.imu.rate_hz;
    imu.gyroscope_noise_density = cfg.imu.gyroscope_noise_density;
    imu.gyroscope_random_walk = cfg.imu.gyroscope_random_walk;
    imu.accelerometer_noise_density = cfg.imu.accelerometer_noise_density;
    imu.accelerometer_random_walk = cfg.imu.accelerometer_random_walk;
    imu.body_from_sensor = geometry::Rigid3::Identity();
    io::WriteImuSensorYaml(Join(session_dir, "imu0/sensor.yaml"), imu);
    io::WriteImuCsv(Join(session_dir, "imu0/data.csv"), rec.imu);

    io::MagSensor mag;
    mag.name = "mag0";
    mag.rate_hz = cfg.mag.rate_hz;
    mag.body_from_sensor = geometry::Rigid3(Eigen::Quaterniond::Identity(),
                                            cfg.mag.position_in_body + calib.mag_position);
    io::WriteMagSensorYaml(Join(session_dir, "mag0/sensor.yaml"), mag);
    io::WriteMagCsv(Join(session_dir, "mag0/data.csv"), rec.mag);

    const std::array<const GpsOptions*, 2> gps_options = {&cfg.gps0, &cfg.gps1};
    for (int g = 0; g < 2; ++g) {
      const GpsOptions& o = *gps_options[g];
      io::GpsSensor gps;
      gps.name = fmt::format("gps{}", g);
      gps.kind = o.Kind();
      gps.rate_hz = o.rate_hz;
      gps.antenna_in_body = o.antenna_in_body + calib.gps_antenna[g];
      gps.default_sigma_h = o.ReportedSigmaH();
      gps.default_sigma_v = o.ReportedSigmaV();
      io::WriteGpsSensorYaml(Join(session_dir, gps.name + "/sensor.yaml"), gps);
      io::WriteGpsCsv(Join(session_dir, gps.name + "/data.csv"), rec.gps[g]);

      fmt::memory_buffer b;
      fmt::format_to(std::back_inserter(b),
                     "#timestamp [ns],x [m],y [m],z [m],bias_x [m],bias_y [m],bias_z [m]\n");
      for (size_t k = 0; k < rec.gps[g].size(); ++k) {
        const Eigen::Vector3d& p = rec.gps_true_enu[g][k];
        const Eigen::Vector3d& bias = rec.gps_bias[g][k];
        fmt::format_to(std::back_inserter(b), "{},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f},{:.6f}\n",
                       rec.gps[g][k].t, p.x(), p.y(), p.z(), bias.x(), bias.y(), bias.z());
      }
      WriteBuffer(Join(session_truth, gps.name + "_antenna.csv"), b);
      if (o.faults.Any()) {
        // Which samples are multipath outliers or RTK float, and their extra offset (dropped
        // samples are missing from data.csv and from here).
        fmt::memory_buffer q;
        fmt::format_to(std::back_inserter(q),
                       "#timestamp [ns],fix,outlier,extra_x [m],extra_y [m],extra_z [m]\n");
        for (size_t k = 0; k < rec.gps[g].size(); ++k) {
          const GpsFault& fault = rec.gps_faults[g][k];
          fmt::format_to(std::back_inserter(q), "{},{},{},{:.6f},{:.6f},{:.6f}\n", rec.gps[g][k].t,
                         static_cast<int>(rec.gps[g][k].fix), fault.outlier ? 1 : 0,
                         fault.extra.x(), fault.extra.y(), fault.extra.z());
        }
        WriteBuffer(Join(session_truth, gps.name + "_faults.csv"), q);
      }
      summary.gps_samples += static_cast<std::int64_t>(rec.gps[g].size());
    }
    summary.imu_samples += static_cast<std::int64_t>(rec.imu.size());
    summary.mag_samples += static_cast<std::int64_t>(rec.mag.size());

    // Session ground truth: poses, biases, passes, plants.
    WriteBuffer(Join(session_truth, "cam0_poses.tum"), camera_tum);
    {
      fmt::memory_buffer body, biases;
      fmt::format_to(std::back_inserter(body),
                     "# world_from_body (body = imu0) in the field's ENU frame, at the IMU "
                     "timestamps\n# t[s] tx ty tz qx qy qz qw\n");
      fmt::format_to(std::back_inserter(biases),
                     "#timestamp [ns],bg_x [rad s^-1],bg_y [rad s^-1],bg_z [rad s^-1],"
                     "ba_x [m s^-2],ba_y [m s^-2],ba_z [m s^-2]\n");
      for (size_t k = 0; k < rec.imu.size(); ++k) {
        const Timestamp t = rec.imu[k].t;
        AppendTumLine(&body, t, traj.WorldFromBody(rec.Seconds(t)));
        const Eigen::Vector3d& bg = rec.gyro_bias[k];
        const Eigen::Vector3d& ba = rec.accel_bias[k];
        fmt::format_to(std::back_inserter(biases), "{},{:.9f},{:.9f},{:.9f},{:.9f},{:.9f},{:.9f}\n",
                       t, bg.x(), bg.y(), bg.z(), ba.x(), ba.y(), ba.z());
      }
      WriteBuffer(Join(session_truth, "body_poses.tum"), body);
      WriteBuffer(Join(session_truth, "imu_biases.csv"), biases);
    }
    {
      fmt::memory_buffer b;
      fmt::format_to(std::back_inserter(b),
                     "pass,lane,lane_x_m,direction,t_begin [ns],t_end [ns]\n");
      for (const Pass& p : traj.passes()) {
        fmt::format_to(std::back_inserter(b), "{},{},{:.4f},{},{},{}\n", p.index, p.lane, p.lane_x,
                       p.northward ? "north" : "south", rec.start + SecondsToTimestamp(p.t_begin),
                       rec.start + SecondsToTimestamp(p.t_end));
      }
      WriteBuffer(Join(session_truth, "passes.csv"), b);
    }
    if (!traj.standstills().empty()) {
      fmt::memory_buffer b;
      fmt::format_to(std::back_inserter(b), "t_begin [ns],t_end [ns]\n");
      for (const Standstill& still : traj.standstills()) {
        fmt::format_to(std::back_inserter(b), "{},{}\n",
                       rec.start + SecondsToTimestamp(still.t_begin),
                       rec.start + SecondsToTimestamp(still.t_end));
      }
      WriteBuffer(Join(session_truth, "standstills.csv"), b);
    }
    {
      fmt::memory_buffer b;
      fmt::format_to(std::back_inserter(b), "id,row,x,y,height_m,canopy_radius_m\n");
      for (const Plant& plant : world_->plants()) {
        const PlantState state = world_->StateAt(plant, rec.conditions.date);
        fmt::format_to(std::back_inserter(b), "{},{},{:.4f},{:.4f},{:.4f},{:.4f}\n", plant.id,
                       plant.row, plant.xy.x(), plant.xy.y(), state.emerged ? state.height_m : 0.0,
                       state.emerged ? state.canopy_radius_m : 0.0);
      }
      WriteBuffer(Join(session_truth, "plants.csv"), b);
    }
    if (!world_->weeds().empty()) {
      fmt::memory_buffer b;
      fmt::format_to(std::back_inserter(b), "id,strip,x,y,height_m,canopy_radius_m\n");
      for (const Weed& weed : world_->weeds()) {
        const PlantState state = world_->WeedStateAt(weed, rec.conditions.date);
        if (!state.emerged) continue;
        fmt::format_to(std::back_inserter(b), "{},{},{:.4f},{:.4f},{:.4f},{:.4f}\n", weed.id,
                       weed.strip, weed.xy.x(), weed.xy.y(), state.height_m, state.canopy_radius_m);
      }
      WriteBuffer(Join(session_truth, "weeds.csv"), b);
    }
    ++summary.sessions;
  }

  // Last: field.yaml marks the field as complete.
  io::WriteFieldYaml(Join(out_dir, "field.yaml"), field);
  summary.total_seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  return summary;
}

}  // namespace crop4d::sim
