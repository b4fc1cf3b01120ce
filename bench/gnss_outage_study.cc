// GNSS outages (bench/RESULTS.md, "GNSS outages on a real walk (imu+rtk)"): a session with an IMU
// and an RTK receiver — by default the handheld walk of ../shared/data/gnss_imu_walk, imported
// into a temporary field; with --field any field (imported or simulated) — is solved by the row
// SLAM stage with the imu+rtk sensor set, once with every fix and once per outage window (GNSS
// removed from the factors and the initialisation). Printed per window: the removed RTK-fixed
// epochs against the estimated antenna track of every pass (eval/gnss_check.h): horizontal and
// 3D error at the window's last removed fix, maximum and RMS horizontal error over the window,
// RMS 3D error; and for the all-fixes run, the normalised residuals of the fixed epochs.
//
//   build/release/bench/gnss_outage_study [--field DIR [--session ID]] [--data DIR] [--work DIR]
//       [--keep] [--stated-noise] [--noise-factor F] [--walk-factor F] [--antenna X,Y,Z]
//       [--qc-translation Q] [--qc-rotation Q] [--state-rate HZ] [--windows S:D,S:D,...]
//
// Windows: seconds after the receiver's first fix, start:duration. The walk's IMU noise: the
// rig's datasheet values (the data's README), the white-noise densities times --noise-factor and
// the bias random walks times --walk-factor (defaults 1); --antenna its lever arm. With --field
// the field's own sensor.yaml files are used (those four options do not apply).

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/core/progress.h"
#include "crop4d/eval/gnss_check.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/importer.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/slam/session_streams.h"

namespace {

using namespace crop4d;
namespace fs = std::filesystem;

constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.80665;
const char* kSession = "2025-08-28";

struct Args {
  // A field to study instead of the walk, and its session (default: the first).
  std::string field;
  std::string session;
  std::string data = std::string(CROP4D_SHARED_DATA_DIR) + "/gnss_imu_walk";
  std::string work;
  bool keep = false;
  double noise_factor = 1.0;
  // Keep the stated noise (crop4d slam --imu-noise stated) instead of fitting it to the data.
  bool stated_noise = false;
  double walk_factor = 1.0;
  Eigen::Vector3d antenna = Eigen::Vector3d::Zero();
  double qc_translation = -1, qc_rotation = -1;  // < 0: the optimiser's default
  double state_rate_hz = 10.0;
  // The README's two 15 s windows, and 10 s windows at the same starts and across the
  // RTK-fixed part of the walk (fixed from 14.25 s to 88 s after the first fix).
  std::vector<pipeline::GpsOutage> windows = {{25, 15}, {70, 15}, {15, 10}, {25, 10}, {35, 10},
                                              {45, 10}, {55, 10}, {65, 10}, {70, 10}, {78, 10}};
};

std::vector<double> SplitNumbers(const std::string& text, char separator) {
  std::vector<double> out;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, separator)) out.push_back(std::stod(item));
  return out;
}

Args ParseArgs(int argc, char** argv) {
  Args a;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    auto value = [&]() -> std::string {
      if (i + 1 >= argc) throw std::invalid_argument(arg + " needs a value");
      return argv[++i];
    };
    if (arg == "--field") {
      a.field = value();
    } else if (arg == "--session") {
      a.session = value();
    } else if (arg == "--data") {
      a.data = value();
    } else if (arg == "--work") {
      a.work = value();
    } else if (arg == "--keep") {
      a.keep = true;
    } else if (arg == "--stated-noise") {
      a.stated_noise = true;
    } else if (arg == "--noise-factor") {
      a.noise_factor = std::stod(value());
    } else if (arg == "--walk-factor") {
      a.walk_factor = std::stod(value());
    } else if (arg == "--antenna") {
      const std::vector<double> v = SplitNumbers(value(), ',');
      if (v.size() != 3) throw std::invalid_argument("--antenna X,Y,Z");
      a.antenna = Eigen::Vector3d(v[0], v[1], v[2]);
    } else if (arg == "--qc-translation") {
      a.qc_translation = std::stod(value());
    } else if (arg == "--qc-rotation") {
      a.qc_rotation = std::stod(value());
    } else if (arg == "--state-rate") {
      a.state_rate_hz = std::stod(value());
    } else if (arg == "--windows") {
      a.windows.clear();
      std::stringstream in(value());
      std::string item;
      while (std::getline(in, item, ',')) {
        const std::vector<double> v = SplitNumbers(item, ':');
        if (v.size() != 2) throw std::invalid_argument("--windows S:D,S:D,...");
        a.windows.push_back({v[0], v[1]});
      }
    } else {
      throw std::invalid_argument("unknown argument " + arg);
    }
  }
  if (a.work.empty()) {
    a.work =
        (fs::temp_directory_path() / ("crop4d_gnss_outage_" + std::to_string(getpid()))).string();
  }
  return a;
}

// The walk as a crop4d field; noise from the README (gyro 0.0038 °/s/√Hz, accelerometer
// 70 µg/√Hz) times noise_factor, bias random walks (3.8e-5 °/s²/√Hz, 7 µg/√Hz) times
// walk_factor.
void ImportWalk(const Args& a, const std::string& field) {
  io::SessionImporter::Options o;
  o.field_folder = field;
  o.session_id = kSession;
  o.pos_path = a.data + "/gnss_1730_sf.pos";
  o.imu_path = a.data + "/imu_1730_sf.csv";
  o.imu.columns = io::ParseImuColumns("t,ax,ay,az,gx,gy,gz,...");
  o.imu.time_unit = io::ImuTimeUnit::kSeconds;
  o.imu.accel_unit = io::AccelUnit::kStandardGravity;
  o.imu.gyro_unit = io::GyroUnit::kRadiansPerSecond;
  o.imu_rpy_deg = Eigen::Vector3d(180, 0, -90);
  o.antenna_in_body = a.antenna;
  o.gyroscope_noise_density = a.noise_factor * 0.0038 * kPi / 180;
  o.gyroscope_random_walk = a.walk_factor * 3.8e-5 * kPi / 180;
  o.accelerometer_noise_density = a.noise_factor * 70e-6 * kG;
  o.accelerometer_random_walk = a.walk_factor * 7e-6 * kG;
  io::SessionImporter(o).Run();
}

// The RTK-fixed epochs of the session in the field frame, the first fix's time (the origin of
// the outage windows) and the receiver's antenna in the body frame.
std::vector<eval::GnssFix> FixedEpochs(const std::string& field, const std::string& id,
                                       Timestamp* first_fix, Eigen::Vector3d* antenna) {
  const io::Field f(field);
  const io::Session session = f.OpenSession(id);
  const slam::SessionStreams streams = slam::LoadSessionStreams(f, session);
  const slam::GpsStream* gps = streams.FindGps(io::GpsKind::kRtk);
  if (gps == nullptr || gps->fixes.empty()) {
    throw std::runtime_error("session " + id + " has no RTK receiver with fixes");
  }
  *first_fix = gps->fixes.front().t;
  *antenna = gps->sensor.antenna_in_body;
  std::vector<eval::GnssFix> out;
  for (const slam::GpsFixWorld& g : gps->fixes) {
    if (g.fix != io::GpsFix::kRtkFixed) continue;
    out.push_back({g.t, g.position_world, g.sigma_h, g.sigma_v});
  }
  return out;
}

// Every pass's body poses (imu+rtk), in time order.
std::vector<io::StampedPose> RunStage(const Args& a, const std::string& field,
                                      const std::string& session, const std::string& workspace,
                                      const std::vector<pipeline::GpsOutage>& outages,
                                      double* seconds) {
  pipeline::SlamStageOptions o;
  o.sensors = slam::SensorSet::kImuRtk;
  o.session = session;
  o.gps_outages = outages;
  o.state_rate_hz = a.state_rate_hz;
  o.show_progress = false;
  o.imu_noise_auto = !a.stated_noise;
  if (a.qc_translation > 0) o.optimiser.gp.qc_translation = a.qc_translation;
  if (a.qc_rotation > 0) o.optimiser.gp.qc_rotation = a.qc_rotation;
  const auto start = std::chrono::steady_clock::now();
  const std::vector<pipeline::PassReport> reports = pipeline::RunSlamStage(field, workspace, o);
  *seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  if (reports.empty()) throw std::runtime_error("the slam stage found no pass");
  std::vector<io::StampedPose> poses;
  for (const pipeline::PassReport& r : reports) {
    if (r.failed) throw std::runtime_error("pass " + r.pass.id + " failed: " + r.message);
    for (const io::StampedPose& p : io::ReadTum(r.folder + "/poses.tum")) poses.push_back(p);
  }
  // Overlapping windows of a long trajectory: each time once, in order.
  std::sort(poses.begin(), poses.end(),
            [](const io::StampedPose& x, const io::StampedPose& y) { return x.t < y.t; });
  poses.erase(
      std::unique(poses.begin(), poses.end(),
                  [](const io::StampedPose& x, const io::StampedPose& y) { return x.t == y.t; }),
      poses.end());
  return poses;
}

}  // namespace

int main(int argc, char** argv) {
  Args a;
  try {
    a = ParseArgs(argc, argv);
    spdlog::set_level(spdlog::level::err);
    Progress::SetGloballySilent(true);
    fs::create_directories(a.work);
    std::string field = a.field, session = a.session;
    if (field.empty()) {
      field = (fs::path(a.work) / "walk").string();
      ImportWalk(a, field);
      session = kSession;
    } else if (session.empty()) {
      session = io::Field(field).session_ids().at(0);
    }
    Timestamp t0 = 0;
    Eigen::Vector3d antenna;
    const std::vector<eval::GnssFix> fixes = FixedEpochs(field, session, &t0, &antenna);
    std::printf("%s/%s: %zu RTK-fixed epochs; antenna (%.3f, %.3f, %.3f) m, states %.0f Hz%s\n\n",
                field.c_str(), session.c_str(), fixes.size(), antenna.x(), antenna.y(), antenna.z(),
                a.state_rate_hz,
                a.field.empty() ? fmt::format("; IMU noise x{:.3g}, bias walk x{:.3g}",
                                              a.noise_factor, a.walk_factor)
                                      .c_str()
                                : "");

    double seconds = 0;
    {
      const std::vector<io::StampedPose> poses =
          RunStage(a, field, session, (fs::path(a.work) / "ws_all").string(), {}, &seconds);
      const std::vector<eval::GnssResidual> residuals =
          eval::CompareWithFixes(poses, fixes, antenna);
      const eval::GnssResidualStats s = eval::SummariseResiduals(residuals);
      std::printf(
          "All fixes fused (%.1f s): %d fixed epochs, horizontal RMS %.2f cm (max %.2f), "
          "3D RMS %.2f cm\n",
          seconds, s.count, 100 * s.horizontal_m.rmse, 100 * s.horizontal_m.max,
          100 * s.error_3d_m.rmse);
      std::printf(
          "  normalised residual RMS (e/sigma per axis): %.2f (E,N: %.2f), horizontal "
          "within 1/2/3 sigma: %.0f / %.0f / %.0f %% (Gaussian: 39 / 86 / 99 %%)\n\n",
          s.normalised_rms, s.normalised_rms_horizontal, 100 * s.within_sigma[0],
          100 * s.within_sigma[1], 100 * s.within_sigma[2]);
    }

    std::printf(
        "| window [s] | fixes removed | end: horizontal [cm] | end: 3D [cm] | max "
        "horizontal [cm] | RMS horizontal [cm] | RMS 3D [cm] | run [s] |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (std::size_t w = 0; w < a.windows.size(); ++w) {
      const pipeline::GpsOutage& g = a.windows[w];
      const std::vector<io::StampedPose> poses =
          RunStage(a, field, session, (fs::path(a.work) / ("ws_" + std::to_string(w))).string(),
                   {g}, &seconds);
      const std::vector<eval::GnssResidual> residuals =
          eval::CompareWithFixes(poses, fixes, antenna);
      const eval::GnssResidualStats s =
          eval::SummariseResiduals(residuals, t0 + SecondsToTimestamp(g.start_s),
                                   t0 + SecondsToTimestamp(g.start_s + g.duration_s));
      std::printf("| %g–%g (%g s) | %d | %.1f | %.1f | %.1f | %.1f | %.1f | %.1f |\n", g.start_s,
                  g.start_s + g.duration_s, g.duration_s, s.count, 100 * s.last.horizontal(),
                  100 * s.last.norm(), 100 * s.horizontal_m.max, 100 * s.horizontal_m.rmse,
                  100 * s.error_3d_m.rmse, seconds);
      std::fflush(stdout);
    }
    if (!a.keep) fs::remove_all(a.work);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "gnss_outage_study: %s\n", e.what());
    std::error_code ec;
    if (!a.keep && !a.work.empty()) fs::remove_all(a.work, ec);
    return 1;
  }
  return 0;
}
