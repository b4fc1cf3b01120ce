// One pass of the slam stage (slam_pass.h): state times, initial states, standstills, the
// row-SLAM problem and its solve, and the pass's pose outputs; the camera's part is in
// slam_pass_camera.cc, summary.json's in slam_summary.cc.

#include "crop4d/pipeline/slam_pass.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "crop4d/core/stopwatch.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/pass_standstills.h"
#include "crop4d/pipeline/slam_pass_camera.h"
#include "crop4d/pipeline/slam_summary.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/time_offset_reprojection_factor.h"
#include "crop4d/workspace/pass_files.h"

namespace crop4d::pipeline {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The gauge prior's velocity sigma of a pass that starts moving without any GPS, m/s: a ground
// vehicle's speed, i.e. no information.
constexpr double kUnknownVelocitySigma = 2.0;
// The largest scale change the camera height may make on a pass solved without an IMU.
constexpr double kMaxScaleChangeWithoutImu = 0.5;
// Without an IMU: the body axis that points up when the rig is level (the initialisation's
// convention, slam/initialisation.h).
const Eigen::Vector3d kLevelUpBody = Eigen::Vector3d::UnitZ();

// cam+imu: the best GPS only anchors the pass at one instant, its middle, where the motion is
// steady (the gauge: position, heading and velocity from a ±2 s line fit); nothing else.
void InitialiseFromAnchor(const PassJob& job, PassInitialisation* init) {
  const SessionContext& ctx = job.ctx;
  const std::vector<Timestamp>& times = job.times;
  init->anchor_state = static_cast<int>(times.size() / 2);
  const slam::StateInitialiser::Options anchor_options =
      slam::AnchorInitialisation(job.options.initialisation);
  slam::StateInitialiser anchor_initialiser(anchor_options, *ctx.streams.imu, &ctx.best_gps);
  anchor_initialiser.set_forward_axis(ctx.initialiser->forward_axis());
  const std::vector<slam::RowState> anchor = anchor_initialiser.Initialise(
      {times[init->anchor_state]}, ctx.best_gps.sensor.antenna_in_body, &init->summary);
  init->states = anchor_initialiser.InitialiseFromAnchor(anchor.front(), times);
}

// The pass's initial states (docs/slam.md, initialisation): the session solve interpolated, or
// the GPS track and the IMU, or dead reckoning from the local level frame (no GPS) or from one
// anchor (cam+imu); without an IMU the images then give its rotations.
PassInitialisation InitialStates(const PassJob& job,
                                 const std::vector<slam::LandmarkTrack>& pair_tracks) {
  const SessionContext& ctx = job.ctx;
  const std::vector<Timestamp>& times = job.times;
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  const auto start = Clock::now();
  PassInitialisation init;
  if (info.gps && !ctx.session_states.empty()) {
    // The session solution interpolated at the state times.
    for (Timestamp t : times) init.states.push_back(slam::InterpolateState(ctx.session_states, t));
    init.summary.forward_axis_body = ctx.initialiser->forward_axis();
  } else if (info.gps) {
    init.states =
        ctx.initialiser->Initialise(times, ctx.factor_gps->sensor.antenna_in_body, &init.summary);
  } else if (!ctx.has_best_gps) {
    // No GPS at all: the local level frame of the first state (docs/slam.md, "Without GPS"), at
    // rest when the pass starts with a standstill; else its velocity is left to the camera and
    // the IMU.
    init.states =
        ctx.initialiser->InitialiseFromAnchor(ctx.initialiser->LocalLevelState(times[0]), times);
  } else {
    InitialiseFromAnchor(job, &init);
  }
  const slam::CameraStream* camera = job.streams.camera;
  if (info.gps && ctx.streams.imu->samples.empty() && camera != nullptr) {
    // Without an IMU the GPS track alone gave the guess: the images give its rotations and shape
    // (slam/visual_initialisation.h), from every track of two or more images.
    init.states = slam::VisualInitialGuess(
        init.states, camera->sensor.camera, camera->sensor.body_from_sensor, pair_tracks,
        kLevelUpBody, job.options.visual_initialisation, &init.visual);
    if (!init.visual.applied) {
      spdlog::warn(
          "{}/{}: only {} of {} image pairs give their relative motion: the initial guess is "
          "the GPS track's alone",
          ctx.session->id(), job.pass.id, init.visual.visual_steps, init.visual.steps);
    }
  }
  init.seconds = SecondsSince(start);
  return init;
}

// initial_poses.tum: the initial guess, for diagnosis (same frame as poses.tum).
void WriteInitialPoses(const PassJob& job, const std::vector<slam::RowState>& initial) {
  const slam::CameraStream* camera = job.streams.camera;
  std::vector<io::StampedPose> initial_poses;
  for (const slam::RowState& state : initial) {
    initial_poses.push_back(
        {state.t, camera != nullptr ? state.nav.world_from_body * camera->sensor.body_from_sensor
                                    : state.nav.world_from_body});
  }
  io::WriteTum(job.layout.PassInitialPoses(job.session(), job.pass.id).string(), initial_poses,
               "initial guess of " + job.session() + "/" + job.pass.id + " from GPS and IMU");
}

// The pass's standstills, one flag per interval between states (empty: detection off): from
// the IMU, the image motion (a camera pass's front end, else null) and a precise GPS track;
// their spans go to summary.json.
std::vector<bool> PassStandstills(const PassJob& job, const features::FrontEnd::Result* front,
                                  json* summary) {
  const SessionContext& ctx = job.ctx;
  const std::vector<Timestamp>& times = job.times;
  const bool precise_gps = ctx.has_best_gps && PreciseFixes(job.options, ctx.best_gps.fixes);
  std::vector<bool> still = job.options.standstills
                                ? DetectPassStandstills(times, *ctx.streams.imu, front,
                                                        precise_gps ? &ctx.best_gps.fixes : nullptr,
                                                        job.options.optimiser.standstill)
                                : std::vector<bool>();
  const std::vector<slam::TimeInterval> still_spans = slam::StillSpans(times, still);
  json spans = json::array();
  for (const slam::TimeInterval& span : still_spans) {
    spans.push_back(
        {DurationSeconds(times.front(), span.begin), DurationSeconds(times.front(), span.end)});
  }
  (*summary)["standstills_s"] = spans;
  if (!still_spans.empty()) {
    double total = 0;
    for (const slam::TimeInterval& span : still_spans) total += span.seconds();
    spdlog::info("{}/{}: standing still for {:.1f} s in {} standstill{}", ctx.session->id(),
                 job.pass.id, total, still_spans.size(), still_spans.size() == 1 ? "" : "s");
  }
  return still;
}

// The optimiser's options for the pass.
slam::RowOptimiser::Options PassOptimiserOptions(const PassJob& job) {
  slam::RowOptimiser::Options op = job.options.optimiser;
  if (job.streams.imu == nullptr) {
    // The time offset is the camera's to the IMU: without one, the images' stamps are the
    // states' times (an image folder's EXIF time, as its GPS fixes').
    op.estimate_time_offset = false;
    // Without an IMU only the receiver scales the pass: a metre-level one leaves a 20 m pass
    // tens of percent off (measured on the demo field: the soil's depth asked for −20 to +28 %),
    // so the soil's depth below a camera of known height may correct more than with an IMU.
    op.camera_height.max_scale_change =
        std::max(op.camera_height.max_scale_change, kMaxScaleChangeWithoutImu);
  }
  return op;
}

// The pass's row-SLAM problem: the initial states and gauge, standstills, the camera's tracks,
// the IMU (with the session's noise factor) or a level rig, the session's bias prior, the
// camera height where nothing precise sets the scale, the motion constraint, the GPS fixes.
slam::RowOptimiser::Input PassInput(const PassJob& job, const PassInitialisation& init,
                                    const std::vector<bool>& still,
                                    const std::vector<slam::LandmarkTrack>& tracks,
                                    const std::vector<features::FeatureSet>& features,
                                    std::vector<slam::LandmarkTrack> pair_tracks) {
  const SlamStageOptions& options = job.options;
  const SessionContext& ctx = job.ctx;
  const slam::CameraStream* camera = job.streams.camera;
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  slam::RowOptimiser::Input input;
  input.initial_states = init.states;
  input.anchor_state = init.anchor_state;
  input.still_intervals = still;
  if (!ctx.has_best_gps && !(still.empty() ? false : still.front())) {
    // Without GPS a pass that starts moving has an unknown velocity.
    input.anchor_sigma_velocity = kUnknownVelocitySigma;
  }
  if (camera != nullptr) {
    input.camera = &camera->sensor.camera;
    input.body_from_camera = camera->sensor.body_from_sensor;
    input.tracks = tracks;
    input.image_sharpness = features::SharpnessOf(features);
  }
  if (const slam::ImuStream* imu = job.streams.imu) {
    input.imu_samples = &imu->samples;
    input.imu_noise = slam::ImuNoise(imu->sensor, ctx.imu_noise_factor);
    input.imu_rate_hz = imu->sensor.rate_hz;
  } else {
    input.level_up_body = kLevelUpBody;
  }
  if (!ctx.session_states.empty()) {
    input.bias_prior_mean = init.states.front().bias;
    slam::Vector6d sigma;
    sigma << Eigen::Vector3d::Constant(options.session_bias_sigma_gyro),
        Eigen::Vector3d::Constant(options.session_bias_sigma_accel);
    input.bias_prior_sigma = sigma;
  }
  // The camera height sets the scale only where nothing precise does: not with RTK factors, nor
  // for `cam+imu` anchored by an RTK velocity (measured on the demo field: RPE 0.50 % without,
  // 0.65 % with).
  const bool precise_scale =
      info.gps ? info.gps_kind == io::GpsKind::kRtk : PreciseFixes(options, ctx.best_gps.fixes);
  const double camera_height = CameraHeight(options, ctx.streams);
  if (camera_height > 0 && camera != nullptr && !precise_scale) {
    input.camera_height_m = camera_height;
    input.depth_tracks = std::move(pair_tracks);
  }
  if (options.motion_constraint && job.pass.row >= 0 && ctx.forward_axis_estimated) {
    // A row pass is driven by a vehicle: the non-holonomic constraint holds.
    input.forward_axis_body = ctx.initialiser->forward_axis();
  }
  if (const slam::GpsStream* gps = job.streams.gps) {
    input.gps_fixes = gps->fixes;
    input.p_body_antenna = gps->sensor.antenna_in_body;
  }
  return input;
}

// poses.tum: the camera's pose at each image's capture instant (the body's at the state times
// without a camera). Returns the camera poses (empty without a camera).
std::vector<geometry::Rigid3> WritePassPoses(const PassJob& job,
                                             const slam::RowOptimiser::Result& result) {
  const slam::CameraStream* camera = job.streams.camera;
  const slam::RowOptimiser::Summary& s = result.summary;
  std::vector<io::StampedPose> poses;
  std::vector<geometry::Rigid3> cameras;
  for (const slam::RowState& state : result.states) {
    // An image's pose is the camera's at its capture instant: its stamp plus the estimated
    // camera–IMU time offset, when there is one (slam/time_offset_reprojection_factor.h).
    const geometry::Rigid3 body =
        s.time_offset_estimated
            ? slam::BodyAtCapture(state.nav.world_from_body, state.nav.vel_world,
                                  state.nav.rate_body, s.time_offset_s)
            : state.nav.world_from_body;
    const geometry::Rigid3 pose =
        camera != nullptr ? body * camera->sensor.body_from_sensor : state.nav.world_from_body;
    poses.push_back({state.t, pose});
    cameras.push_back(pose);
  }
  io::WriteTum(job.layout.PassPoses(job.session(), job.pass.id).string(), poses,
               std::string(camera != nullptr ? "world_from_camera" : "world_from_body") +
                   " of session " + job.session() + ", pass " + job.pass.id + " (" +
                   slam::ToString(job.ctx.sensors) + "), field ENU frame");
  return cameras;
}

}  // namespace

PassStreams StreamsOfPass(const SessionContext& ctx) {
  PassStreams streams;
  if (slam::Describe(ctx.sensors).camera) streams.camera = &*ctx.streams.camera;
  if (!ctx.streams.imu->samples.empty()) streams.imu = &*ctx.streams.imu;
  if (ctx.factor_gps) streams.gps = &*ctx.factor_gps;
  return streams;
}

std::vector<Timestamp> PassStateTimes(const SlamStageOptions& options, const SessionContext& ctx,
                                      const slam::RowPass& pass) {
  std::vector<Timestamp> times;
  if (slam::Describe(ctx.sensors).camera) {
    for (const io::ImageEntry& e : ctx.streams.camera->images) {
      if (e.t >= pass.t_begin && e.t <= pass.t_end) times.push_back(e.t);
    }
  } else {
    const std::vector<slam::ImuSample>& imu = ctx.streams.imu->samples;
    const Timestamp begin = std::max(pass.t_begin, imu.front().timestamp);
    const Timestamp end = std::min(pass.t_end, imu.back().timestamp);
    const Timestamp step = SecondsToTimestamp(1.0 / options.state_rate_hz);
    for (Timestamp t = begin; t <= end; t += step) times.push_back(t);
  }
  return times;
}

PassOutcome RunPass(const PassJob& job, const std::string& fingerprint, const json& options_json) {
  const auto start_total = Clock::now();
  json summary = PassSummaryHeader(job, fingerprint, options_json);
  const bool has_camera = job.streams.camera != nullptr;

  // Front end; every track of two or more images (the output cloud, and in image indices the
  // visual initial guess and the soil's depth for the camera height).
  PassFrontEnd front_end;
  std::vector<features::Track> all_tracks;
  if (has_camera) {
    front_end = RunFrontEnd(job, &summary);
    all_tracks = AllTracks(front_end.front);
  }
  std::vector<slam::LandmarkTrack> pair_tracks =
      ToLandmarkTracks(all_tracks, front_end.front.features);

  const PassInitialisation init = InitialStates(job, pair_tracks);
  WriteInitialPoses(job, init.states);
  const std::vector<bool> still =
      PassStandstills(job, has_camera ? &front_end.front : nullptr, &summary);

  // Back end.
  const slam::RowOptimiser optimiser(PassOptimiserOptions(job));
  const slam::RowOptimiser::Input input = PassInput(
      job, init, still, front_end.tracks, front_end.front.features, std::move(pair_tracks));
  RecordSensorGaps(job, &summary);
  const slam::RowOptimiser::Result result = optimiser.Solve(input);
  const slam::RowOptimiser::Summary& s = result.summary;
  RecordPassProblem(job, input, still, s, &summary);

  // Outputs: poses, states, cloud, summary.
  const auto start_outputs = Clock::now();
  const std::vector<geometry::Rigid3> cameras = WritePassPoses(job, result);
  workspace::WritePassStates(job.layout.PassStates(job.session(), job.pass.id).string(),
                             result.states);
  WritePassMeasurementsFile(job);
  PassOutcome outcome;
  outcome.num_states = static_cast<int>(result.states.size());
  outcome.num_images = has_camera ? front_end.front.summary.num_images : 0;
  outcome.num_landmarks = s.num_landmarks_final;
  if (has_camera) {
    outcome.num_cloud_points =
        WritePassCloud(job, front_end, all_tracks, cameras, result, &summary);
  }
  PassSeconds seconds;
  seconds.outputs = SecondsSince(start_outputs);
  seconds.front_end = front_end.seconds;
  seconds.initialisation = init.seconds;
  RecordSolve(job, init, outcome.num_images, input, s, &summary);
  seconds.total = SecondsSince(start_total);
  WritePassSummaryJson(job, still, s, seconds, std::move(summary));
  return outcome;
}

}  // namespace crop4d::pipeline
