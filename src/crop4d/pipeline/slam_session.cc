// One session as the slam stage solves it (slam_session.h): the sensor set, the GPS receivers
// with the outages applied, the forward axis and the session-wide IMU + GPS solve, and the
// session's passes.

#include "crop4d/pipeline/slam_session.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/stream_coverage.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

slam::SensorSet ChooseSensorSet(const SlamStageOptions& options,
                                const slam::SessionStreams& streams) {
  const bool has_camera = streams.camera.has_value() && !streams.camera->images.empty();
  const bool has_rtk = streams.FindGps(io::GpsKind::kRtk) != nullptr;
  const bool has_standard = streams.FindGps(io::GpsKind::kStandard) != nullptr;
  const bool has_imu = streams.imu && !streams.imu->samples.empty();
  if (!has_imu && (!options.sensors || slam::Describe(*options.sensors).imu)) {
    // Without an IMU only the camera with GPS remains.
    if (options.sensors) {
      throw InputError(streams.session_id, 0,
                       std::string("--sensors ") + slam::ToString(*options.sensors) +
                           " needs an IMU with samples; this session has none (try cam+rtk or "
                           "cam+gps)");
    }
    if (has_camera && (has_rtk || has_standard)) {
      return has_rtk ? slam::SensorSet::kCamRtk : slam::SensorSet::kCamGps;
    }
    throw InputError(streams.session_id, 0,
                     "row SLAM needs an IMU, or a camera with a GPS receiver; this session has " +
                         std::string(has_camera ? "a camera but no GPS fix" : "no camera") +
                         " and no IMU samples");
  }
  if (!options.sensors) {
    if (has_camera) {
      return has_rtk        ? slam::SensorSet::kCamImuRtk
             : has_standard ? slam::SensorSet::kCamImuGps
                            : slam::SensorSet::kCamImu;
    }
    if (has_rtk) return slam::SensorSet::kImuRtk;
    throw InputError(streams.session_id, 0,
                     "no camera and no RTK receiver: no sensor set of row SLAM applies");
  }
  const slam::SensorSetInfo info = slam::Describe(*options.sensors);
  if (info.camera && !has_camera) {
    throw InputError(streams.session_id, 0,
                     std::string("--sensors ") + slam::ToString(*options.sensors) +
                         " needs a camera with images; this session has none (try imu+rtk)");
  }
  if (info.gps && streams.FindGps(info.gps_kind) == nullptr) {
    throw InputError(streams.session_id, 0,
                     std::string("--sensors ") + slam::ToString(*options.sensors) + " needs a " +
                         (info.gps_kind == io::GpsKind::kRtk ? "RTK" : "standard") +
                         " GPS receiver with fixes; this session has none");
  }
  return *options.sensors;
}

// Size and modification time of the session's data files: a changed recording invalidates the
// outputs of its passes.
std::string DataStamp(const io::Session& session) {
  std::ostringstream out;
  std::error_code ec;
  for (const auto& entry : fs::directory_iterator(session.folder(), ec)) {
    const fs::path csv = entry.path() / "data.csv";
    if (!fs::exists(csv, ec)) continue;
    out << entry.path().filename().string() << ':' << fs::file_size(csv, ec) << ':'
        << fs::last_write_time(csv, ec).time_since_epoch().count() << ';';
  }
  return out.str();
}

// The span of a session processed as one trajectory: from its first to its last image with a
// camera, else the IMU's span.
slam::RowPass WholeSessionSpan(const slam::SessionStreams& streams, bool camera) {
  slam::RowPass pass;
  pass.id = "all";
  if (camera && streams.camera && !streams.camera->images.empty()) {
    pass.t_begin = streams.camera->images.front().t;
    pass.t_end = streams.camera->images.back().t;
  } else {
    pass.t_begin = streams.imu->samples.front().timestamp;
    pass.t_end = streams.imu->samples.back().timestamp;
  }
  return pass;
}

// One IMU + GPS solve over the whole session (slam/session_solve.h) with the receiver `gps`.
// Its attitudes in turns refine the forward axis (the IMU's mounting on the vehicle); with
// keep_states, its states also become the passes' initial guess and bias prior.
void SolveSession(const SlamStageOptions& options, SessionContext* ctx, const slam::GpsStream& gps,
                  bool keep_states) {
  const auto start = Clock::now();
  slam::SessionSolveOptions solve;
  solve.state_rate_hz = options.session_state_rate_hz;
  solve.imu_noise_auto = options.imu_noise_auto;
  solve.initialisation = options.initialisation;
  solve.optimiser = options.optimiser;
  const slam::SessionSolveResult result =
      slam::SolveSession(*ctx->streams.imu, gps, ctx->initialiser->forward_axis(), solve);
  if (result.states.empty()) return;
  if (result.stated_misfit > slam::kNoiseMisfit) {
    spdlog::warn(
        "session {}: the IMU + GPS fit misses the GPS fixes by {:.2f} times their sigmas: the "
        "IMU noise of {}/sensor.yaml is overconfident for this recording{}",
        ctx->session->id(), result.stated_misfit, ctx->streams.imu->sensor.name,
        options.imu_noise_auto ? "" : " (--imu-noise auto would inflate it)");
    if (options.imu_noise_auto) {
      ctx->imu_noise_factor = result.imu_noise_factor;
      spdlog::info(
          "session {}: IMU noise x{:g} (white noise and bias walks): the GPS residuals are "
          "{:.2f} times their sigmas (were {:.2f})",
          ctx->session->id(), result.imu_noise_factor, result.final_misfit, result.stated_misfit);
    }
  }
  if (keep_states) ctx->session_states = result.states;
  if (result.forward_axis) {
    const Eigen::Vector3d& axis = result.forward_axis->axis_body;
    ctx->initialiser->set_forward_axis(axis);
    ctx->forward_axis_estimated = true;
    spdlog::info(
        "session {}: IMU + GPS solve over {} states in {:.1f} s; forward axis ({:.3f}, "
        "{:.3f}, {:.3f}) from {} states in turns",
        ctx->session->id(), result.states.size(), SecondsSince(start), axis.x(), axis.y(), axis.z(),
        result.forward_axis->num_states);
  } else {
    spdlog::info("session {}: IMU + GPS solve over {} states in {:.1f} s", ctx->session->id(),
                 result.states.size(), SecondsSince(start));
  }
}

// The initialiser with the forward axis of the best GPS track (RTK when there is one; the body x
// axis without turns or without an IMU).
void InitialiseFromBestTrack(const SlamStageOptions& options,
                             const slam::StateInitialiser::Options& init_options,
                             SessionContext* ctx) {
  const slam::SensorSetInfo info = slam::Describe(ctx->sensors);
  slam::StateInitialiser best(options.initialisation, *ctx->streams.imu, &ctx->best_gps);
  slam::StateInitialiser::Summary s;
  const Eigen::Vector3d axis = best.EstimateForwardAxis(ctx->best_gps.sensor.antenna_in_body, &s);
  if (!info.imu) {
    spdlog::info("session {}: no IMU: the body x axis is taken as forward, body z as up",
                 ctx->session->id());
  } else if (s.forward_axis_fallback) {
    spdlog::warn(
        "session {}: the motion has no turns to align the IMU with the GPS track; "
        "assuming the body x axis points forward",
        ctx->session->id());
  } else {
    spdlog::info(
        "session {}: forward axis in the body frame ({:.3f}, {:.3f}, {:.3f}) from "
        "{} windows",
        ctx->session->id(), axis.x(), axis.y(), axis.z(), s.num_alignment_windows);
  }
  ctx->initialiser =
      std::make_unique<slam::StateInitialiser>(init_options, *ctx->streams.imu, &ctx->init_gps);
  ctx->initialiser->set_forward_axis(axis);
  ctx->forward_axis_estimated = !s.forward_axis_fallback;
}

// The session's initialiser: its forward axis from the best GPS track (the body x axis without
// GPS or without turns), refined by the session-wide IMU + GPS solve where a precise receiver
// allows one (whose states, with the factors' receiver, become the passes' initial guess).
void InitialiseSession(const SlamStageOptions& options, SessionContext* ctx) {
  const slam::SensorSetInfo info = slam::Describe(ctx->sensors);
  const slam::StateInitialiser::Options init_options =
      info.gps ? slam::InitialisationFor(options.initialisation, info.gps_kind)
               : options.initialisation;
  if (!ctx->has_best_gps) {
    // No GPS: the body x axis is taken as forward (it only sets the heading convention).
    ctx->initialiser =
        std::make_unique<slam::StateInitialiser>(init_options, *ctx->streams.imu, nullptr);
    spdlog::info(
        "session {}: no GPS: one pass in the local level frame of its first image (z up, x "
        "along the body x axis, origin at the body)",
        ctx->session->id());
  } else {
    InitialiseFromBestTrack(options, init_options, ctx);
  }
  // The session solve needs a precise receiver: with a metre-level one the turns do not make
  // the accelerometer bias observable, and a wrong tight bias prior does more harm than the
  // weak zero-mean one.
  if (options.session_state_rate_hz > 0 && ctx->has_best_gps && info.imu) {
    if (info.gps && PreciseFixes(options, ctx->factor_gps->fixes)) {
      SolveSession(options, ctx, ctx->init_gps, /*keep_states=*/true);
    } else if (PreciseFixes(options, ctx->best_gps.fixes)) {
      // Only the mounting calibration (forward axis) from the precise receiver; the passes
      // use nothing else of it.
      SolveSession(options, ctx, ctx->best_gps, /*keep_states=*/false);
    }
  }
}

// The receivers in use, their fixes outside the outages: the best track, the factors' receiver,
// and the one the initialisation follows.
void ChooseReceivers(const SlamStageOptions& options, SessionContext* ctx) {
  const slam::SensorSetInfo info = slam::Describe(ctx->sensors);
  if (const slam::GpsStream* best = ctx->streams.BestGps()) {
    ctx->best_gps = *best;
    ctx->best_gps.fixes = ApplyGpsOutages(best->fixes, options.gps_outages);
    ctx->has_best_gps = true;
  }
  if (info.gps) {
    ctx->factor_gps = *ctx->streams.FindGps(info.gps_kind);
    ctx->factor_gps->fixes = ApplyGpsOutages(ctx->factor_gps->fixes, options.gps_outages);
  }
  if (!ctx->has_best_gps && !ctx->session->gps_receivers().empty()) {
    // Receivers without a single fix are a broken recording, not a rig without GPS: the
    // session cannot be placed in the field with the others.
    throw InputError(ctx->session->folder(), 0,
                     "row SLAM needs GPS fixes (to find the row passes and anchor each pass in "
                     "the field frame); this session has none (a session without any GPS "
                     "receiver runs cam+imu in its own local frame)");
  }
  // Initialisation from the receiver the factors use; cam+imu anchors each pass with the best
  // receiver.
  ctx->init_gps = info.gps ? *ctx->factor_gps : ctx->best_gps;
}

}  // namespace

void OpenSlamSession(const io::Field& field, const io::Session& session,
                     const SlamStageOptions& options, SessionContext* ctx) {
  ctx->session = &session;
  ctx->streams = slam::LoadSessionStreams(field, session, options.camera, options.imu);
  if (ctx->streams.camera) {
    ctx->image_folder = fs::path(session.ImagePath(ctx->streams.camera->sensor.name, "x"))
                            .parent_path()
                            .lexically_relative(field.folder())
                            .string();
  }
  ctx->sensors = ChooseSensorSet(options, ctx->streams);
  ctx->data_stamp = DataStamp(session);
  if (!slam::Describe(ctx->sensors).imu) {
    // cam+rtk, cam+gps: the IMU is not used, even where the session has one.
    ctx->streams.imu = slam::ImuStream{};
    ctx->streams.imu->sensor.name.clear();
  }
  ChooseReceivers(options, ctx);
  InitialiseSession(options, ctx);
}

std::vector<slam::RowPass> SessionPasses(const io::Field& field, const SlamStageOptions& options,
                                         const SessionContext& ctx) {
  const std::string& id = ctx.session->id();
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  // Row passes from the best track (without GPS, one pass over the camera's images).
  std::vector<slam::TrackPoint> track;
  for (const slam::GpsFixWorld& fix : ctx.best_gps.fixes) {
    track.push_back({fix.t, fix.position_world});
  }
  // The segmenter follows the vehicle's reference point: the antenna's offset from it along
  // the forward axis and to the left.
  slam::RowPassSegmenter::Options pass_options = options.passes;
  {
    const Eigen::Vector3d forward = ctx.initialiser->forward_axis();
    const Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(forward).normalized();
    const Eigen::Vector3d& antenna = ctx.best_gps.sensor.antenna_in_body;
    pass_options.antenna_in_body_xy = Eigen::Vector2d(antenna.dot(forward), antenna.dot(left));
  }
  pass_options.require_row_structure = options.pass_mode != PassMode::kRows;
  slam::RowPassSegmenter::Summary seg_summary;
  std::vector<slam::RowPass> passes;
  if (ctx.has_best_gps && options.pass_mode != PassMode::kWhole) {
    passes = slam::RowPassSegmenter(pass_options).Segment(track, field.info().rows, &seg_summary);
    if (seg_summary.whole_session) {
      spdlog::warn(
          "session {}: no row structure in the GPS track; processing it as one "
          "trajectory",
          id);
    }
    if (seg_summary.num_dropped_short > 0 && !seg_summary.whole_session) {
      spdlog::info("session {}: {} straight stretches shorter than {} m left out", id,
                   seg_summary.num_dropped_short, pass_options.min_length_m);
    }
  }
  if (!ctx.has_best_gps) {
    // Without GPS each window would have its own local frame: one pass, however long.
    passes = {WholeSessionSpan(ctx.streams, info.camera)};
  } else if (passes.empty() || seg_summary.whole_session) {
    const slam::RowPass whole = WholeSessionSpan(ctx.streams, info.camera);
    passes = slam::WholeDriveWindows(whole.t_begin, whole.t_end, track, options.max_window_s,
                                     options.window_overlap_s);
    if (passes.size() > 1) {
      spdlog::info("session {}: {:.0f} s as one trajectory in {} windows of at most {:.0f} s", id,
                   TimestampToSeconds(whole.t_end - whole.t_begin), passes.size(),
                   options.max_window_s);
    }
  }
  return passes;
}

double CameraHeight(const SlamStageOptions& options, const slam::SessionStreams& streams) {
  if (!options.use_camera_height) return 0;
  if (options.camera_height_m > 0) return options.camera_height_m;
  if (streams.camera && streams.camera->sensor.height_above_ground_m) {
    return *streams.camera->sensor.height_above_ground_m;
  }
  return 0;
}

bool PreciseFixes(const SlamStageOptions& options, const std::vector<slam::GpsFixWorld>& fixes) {
  // A quarter of the fixes, not half: an RTK receiver that is in float (decimetres) for most of
  // a session still has its fixed stretches to observe the turns with, where a metre-level
  // receiver has none (the session solve weighs every fix by its own sigma).
  return slam::SigmaHQuantile(fixes, 0.25) <= options.session_solve_max_sigma_m;
}

}  // namespace crop4d::pipeline
