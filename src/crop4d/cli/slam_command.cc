// crop4d slam: multi-sensor SLAM of every row pass of every session (DESIGN.md §2.2), outputs in
// WS/sessions/<session>/rows/<pass>/ (pipeline/slam_stage.h, docs/cli.md).

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/io/csv.h"
#include "crop4d/pipeline/slam_stage.h"

namespace crop4d::cli {
namespace {

struct SlamArgs {
  std::string field;
  std::string workspace;
  std::string sensors;
  std::vector<std::string> gps_outages;  // "START:DURATION" seconds
  pipeline::SlamStageOptions options;
};

pipeline::GpsOutage ParseOutage(const std::string& text) {
  const std::size_t colon = text.find(':');
  pipeline::GpsOutage outage;
  if (colon == std::string::npos ||
      !io::ParseDouble(std::string_view(text).substr(0, colon), &outage.start_s) ||
      !io::ParseDouble(std::string_view(text).substr(colon + 1), &outage.duration_s) ||
      !(outage.duration_s > 0)) {
    throw InputError("--gps-outage", 0,
                     "expected START:DURATION in seconds (e.g. 25:15), got '" + text + "'");
  }
  return outage;
}

int RunSlam(SlamArgs& args) {
  pipeline::SlamStageOptions& o = args.options;
  if (!args.sensors.empty()) {
    o.sensors = slam::ParseSensorSet(args.sensors);
    if (!o.sensors) {
      std::string names;
      for (const std::string& n : slam::SensorSetNames()) names += (names.empty() ? "" : ", ") + n;
      throw InputError("--sensors", 0,
                       "unknown sensor set '" + args.sensors + "' (expected one of " + names + ")");
    }
  }
  for (const std::string& text : args.gps_outages) o.gps_outages.push_back(ParseOutage(text));
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d slam", 0, why);
  // The stage's own thread pools follow num_threads; its parallel loops follow this.
  std::optional<tbb::global_control> limit;
  if (o.front_end.num_threads > 0) {
    limit.emplace(tbb::global_control::max_allowed_parallelism, o.front_end.num_threads);
  }
  const auto lock = LockWorkspace(args.workspace, "crop4d slam", /*create=*/true);
  const std::vector<pipeline::PassReport> reports =
      pipeline::RunSlamStage(args.field, args.workspace, o);
  int failed = 0, skipped = 0;
  if (!IsQuiet()) {
    std::printf("%-12s %-8s %-12s %6s %9s %9s %8s  %s\n", "session", "pass", "sensors", "states",
                "landmarks", "cloud", "time [s]", "status");
  }
  for (const pipeline::PassReport& r : reports) {
    failed += r.failed ? 1 : 0;
    skipped += r.skipped ? 1 : 0;
    if (!IsQuiet()) {
      std::printf("%-12s %-8s %-12s %6d %9d %9d %8.1f  %s\n", r.session.c_str(), r.pass.id.c_str(),
                  r.sensors.c_str(), r.num_states, r.num_landmarks, r.num_cloud_points, r.seconds,
                  r.failed    ? ("FAILED: " + r.message).c_str()
                  : r.skipped ? "up to date"
                              : "ok");
    }
  }
  std::fflush(stdout);
  if (reports.empty()) {
    throw InputError(args.field, 0, "no row pass matched the selection");
  }
  spdlog::info("slam: {} passes ({} up to date, {} failed) in {}", reports.size(), skipped, failed,
               args.workspace);
  return failed > 0 ? 1 : 0;
}

}  // namespace

RunFunction SetupSlam(CLI::App& app) {
  auto args = std::make_shared<SlamArgs>();
  pipeline::SlamStageOptions& o = args->options;
  app.description(
      "Multi-sensor SLAM of every row pass (docs/cli.md#slam, docs/slam.md): the GPS track is "
      "split "
      "into row passes; per pass, SIFT features matched with the next k images, tracks, and a "
      "Ceres factor graph with reprojection (Schur-eliminated landmarks), preintegrated IMU, "
      "Gaussian-process prior and interpolated GPS factors. Writes poses.tum, landmarks.ply and "
      "summary.json to WS/sessions/<session>/rows/<pass>/; passes that are up to date are "
      "skipped.\n\nExample:\n  crop4d slam demo/field --workspace demo/ws\n  crop4d slam "
      "field --workspace ws --session 2016-06-01 --row 2 --sensors cam+imu");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace folder (created if missing)")
      ->required();
  app.add_option("--session", o.session, "Only this session (default: all)");
  app.add_option("--row", o.pass, "Only this pass: a pass id (row03, all) or a row index");
  app.add_option("--sensors", args->sensors,
                 "Sensor set: cam+imu+rtk, cam+imu+gps, cam+imu, imu+rtk (default: cam+imu+rtk "
                 "with an RTK receiver, else cam+imu+gps, else cam+imu; imu+rtk without camera)");
  app.add_option("--gps-outage", args->gps_outages,
                 "Remove GPS in START:DURATION seconds after the session's first fix "
                 "(repeatable; outage studies)");
  app.add_option("--neighbors", o.front_end.num_neighbors,
                 "Each image is matched with this many following images")
      ->capture_default_str();
  app.add_option("--min-track-length", o.front_end.tracks.min_track_length,
                 "A landmark must be seen in at least this many images")
      ->capture_default_str();
  app.add_option("--max-reprojection-error", o.optimiser.max_reprojection_error_px,
                 "Observations above this error (px) are removed before the final solve")
      ->capture_default_str();
  app.add_option("--state-rate", o.state_rate_hz, "States per second of a camera-less pass")
      ->capture_default_str();
  app.add_option("--threads", o.front_end.num_threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  app.add_option("--camera-height", o.camera_height_m,
                 "Camera's optical centre above the ground, m, measured on the rig: sets the "
                 "scale of passes without RTK (0: the camera's sensor.yaml "
                 "height_above_ground_m, if any)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_flag(
      "--no-camera-height", [&o](std::int64_t) { o.use_camera_height = false; },
      "Do not set the scale of passes from the camera height, even where sensor.yaml gives it");
  app.add_flag(
      "--no-motion-constraint", [&o](std::int64_t) { o.motion_constraint = false; },
      "No non-holonomic constraint on row passes (a rig that slides sideways)");
  app.add_option_function<std::string>(
         "--imu-noise",
         [&o](const std::string& mode) {
           if (mode != "auto" && mode != "stated") {
             throw CLI::ValidationError("--imu-noise", "expected auto or stated, got " + mode);
           }
           o.imu_noise_auto = mode == "auto";
         },
         "IMU noise: auto (inflate imu0/sensor.yaml's noise by 2, 4, 8, ... when the session's "
         "IMU + GPS fit misses the fixes by more than 1.5 sigmas) or stated (as sensor.yaml "
         "says; a warning only)")
      ->default_str("auto");
  app.add_option_function<std::string>(
         "--passes",
         [&o](const std::string& mode) {
           const std::optional<pipeline::PassMode> parsed = pipeline::ParsePassMode(mode);
           if (!parsed) {
             throw CLI::ValidationError("--passes", "expected auto, rows or whole, got " + mode);
           }
           o.pass_mode = *parsed;
         },
         "How a session is cut: auto (row passes where the drive has rows, declared or clearly "
         "found; else one trajectory), rows (every straight pass along the rows' axis), whole "
         "(one trajectory in windows of at most --max-window seconds)")
      ->default_str("auto");
  app.add_option("--max-window", o.max_window_s,
                 "A session processed as one trajectory is cut into windows of at most this "
                 "many seconds, overlapping by 15 s")
      ->capture_default_str()
      ->check(CLI::Range(30.0, 1e6));
  app.add_flag(
      "--no-standstill", [&o](std::int64_t) { o.standstills = false; },
      "Do not detect standstills (zero velocity, one pose while the rig stands still)");
  app.add_flag(
      "--no-image-weighting", [&o](std::int64_t) { o.optimiser.image_weighting.enabled = false; },
      "Every image's keypoints weigh the same (default: images less sharp than their "
      "neighbours, from blur or exposure, get a larger reprojection sigma)");
  app.add_flag("--force", o.force, "Recompute passes that are up to date");
  return [args] {
    args->options.optimiser.num_threads = args->options.front_end.num_threads;
    return RunSlam(*args);
  };
}

}  // namespace crop4d::cli
