#include "crop4d/pipeline/slam_stage.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/pass_standstills.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/session_streams.h"
#include "crop4d/slam/time_offset_reprojection_factor.h"
#include "crop4d/slam/track_cloud.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_files.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_priors.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using nlohmann::json;

// Bumped whenever the stage's method changes its results, so that outputs of an older method
// are not taken as up to date.
constexpr int kSlamStageRevision = 10;

// The gauge prior's velocity sigma of a pass that starts moving without any GPS, m/s: a ground
// vehicle's speed, i.e. no information.
constexpr double kUnknownVelocitySigma = 2.0;

// An IMU gap longer than this inside a pass is warned about, s: far longer than the sample
// spacing (6 ms at 167 Hz), an outage rather than timing jitter.
constexpr double kImuGapWarnSeconds = 0.5;
// A pass with a GPS outage longer than this is flagged (its drift over the gap is the IMU's and
// the camera's), s.
constexpr double kGpsGapFlagSeconds = 2.0;
// The largest scale change the camera height may make on a pass solved without an IMU.
constexpr double kMaxScaleChangeWithoutImu = 0.5;
// A camera pass with fewer landmarks than this in its final solve is flagged camera_unused (a
// cam+gps pass of the demo field keeps 190-1140).
constexpr int kMinLandmarksForCamera = 20;
// Without an IMU: the body axis that points up when the rig is level (the initialisation's
// convention, slam/initialisation.h).
const Eigen::Vector3d kLevelUpBody = Eigen::Vector3d::UnitZ();

std::string Fingerprint(const json& options, const slam::RowPass& pass, std::size_t num_states,
                        const std::string& data_stamp) {
  Fnv1aHasher hasher;
  hasher.AddString(kVersion);
  hasher.Add(kSlamStageRevision);
  hasher.AddString(options.dump());
  hasher.Add(pass.t_begin);
  hasher.Add(pass.t_end);
  hasher.Add(static_cast<std::uint64_t>(num_states));
  hasher.AddString(data_stamp);
  char text[17];
  std::snprintf(text, sizeof(text), "%016llx", static_cast<unsigned long long>(hasher.hash()));
  return text;
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

bool UpToDate(const workspace::Layout& layout, const std::string& session, const std::string& pass,
              const std::string& fingerprint, bool needs_cloud) {
  const std::string folder = layout.PassDir(session, pass).string();
  const fs::path summary_path = layout.PassSummary(session, pass);
  for (const fs::path& file : {layout.PassPoses(session, pass), layout.PassStates(session, pass)}) {
    if (!fs::exists(file)) return false;
  }
  if (!fs::exists(summary_path)) return false;
  if (needs_cloud && (!fs::exists(layout.PassLandmarks(session, pass)) ||
                      !fs::exists(layout.PassTracks(session, pass)))) {
    return false;
  }
  std::string why;
  try {
    workspace::ReadPassSummary(summary_path.string());
  } catch (const InputError& e) {
    spdlog::debug("{}: solved again: {}", folder, e.what());
    return false;
  }
  if (workspace::SummaryUpToDate(summary_path, fingerprint, &why)) return true;
  spdlog::debug("{}: solved again: {}", folder, why);
  return false;
}

// The files of a pass that the later stages read, as recorded in its summary (those written).
std::vector<std::string> PassOutputs(const workspace::Layout& layout, const std::string& session,
                                     const std::string& pass) {
  std::vector<std::string> out;
  for (const fs::path& file :
       {layout.PassPoses(session, pass), layout.PassStates(session, pass),
        layout.PassInitialPoses(session, pass), layout.PassTracks(session, pass),
        layout.PassLandmarks(session, pass)}) {
    if (fs::exists(file)) out.push_back(file.filename().string());
  }
  return out;
}

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

bool PassSelected(const SlamStageOptions& options, const slam::RowPass& pass) {
  if (options.pass.empty()) return true;
  if (options.pass == pass.id) return true;
  try {
    std::size_t used = 0;
    const int row = std::stoi(options.pass, &used);
    return used == options.pass.size() && row == pass.row;
  } catch (const std::exception&) {
    return false;
  }
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

// Everything one session's passes share.
struct SessionContext {
  const io::Session* session = nullptr;
  slam::SessionStreams streams;
  slam::SensorSet sensors = slam::SensorSet::kCamImuRtk;
  // GPS used by the factors (null without) and the best track (initialisation, anchors).
  std::vector<slam::GpsFixWorld> factor_fixes;
  slam::GpsStream best_gps;
  bool has_best_gps = false;
  // The receiver the initialisation follows (the factors' one, or the best for cam+imu).
  slam::GpsStream init_gps;
  // Whether the forward axis was estimated (not the fallback).
  bool forward_axis_estimated = false;
  // The session-wide IMU + GPS solution (empty when not run).
  std::vector<slam::RowState> session_states;
  Eigen::Vector3d factor_antenna = Eigen::Vector3d::Zero();
  std::string factor_gps_name;
  std::unique_ptr<slam::StateInitialiser> initialiser;
  std::string data_stamp;
  // The factor on imu0/sensor.yaml's noise that the session's IMU + GPS fit asked for (1: the
  // stated noise fits; slam/session_solve.h).
  double imu_noise_factor = 1.0;
};

struct PassOutcome {
  int num_states = 0, num_images = 0, num_landmarks = 0, num_cloud_points = 0;
};

// A front-end track as the back end takes it: the keypoints that observe it and their mean
// colour.
slam::LandmarkTrack ToLandmarkTrack(const features::Track& track,
                                    const std::vector<features::FeatureSet>& features) {
  slam::LandmarkTrack t;
  Eigen::Vector3i color_sum = Eigen::Vector3i::Zero();
  for (const features::Observation& obs : track.observations) {
    const features::FeatureSet& f = features[obs.image];
    const features::Keypoint& kp = f.keypoints[obs.feature];
    t.observations.push_back({obs.image, Eigen::Vector2d(kp.x, kp.y)});
    if (!f.colors.empty()) {
      for (int c = 0; c < 3; ++c) color_sum(c) += f.colors[obs.feature][c];
    }
  }
  for (int c = 0; c < 3; ++c) {
    t.color[c] = static_cast<std::uint8_t>(color_sum(c) / static_cast<int>(track.size()));
  }
  return t;
}

// A track cloud as a PLY cloud with the track length and reprojection error of each point.
io::PlyPointCloud ToPly(const slam::TrackCloud& track_cloud) {
  io::PlyPointCloud cloud;
  cloud.points = track_cloud.points_world;
  cloud.colors = track_cloud.colors;
  io::PlyScalarField length{"track_length", io::PlyType::kInt32, {}};
  io::PlyScalarField error{"reprojection_error", io::PlyType::kFloat32, {}};
  length.values.assign(track_cloud.track_lengths.begin(), track_cloud.track_lengths.end());
  error.values = track_cloud.reprojection_errors_px;
  cloud.scalars = {length, error};
  return cloud;
}

// The camera's height above the ground in effect: --camera-height, else the camera's sensor.yaml
// (height_above_ground_m), else 0 (unknown or not to be used).
double CameraHeight(const SlamStageOptions& options, const slam::SessionStreams& streams) {
  if (!options.use_camera_height) return 0;
  if (options.camera_height_m > 0) return options.camera_height_m;
  if (streams.camera && streams.camera->sensor.height_above_ground_m) {
    return *streams.camera->sensor.height_above_ground_m;
  }
  return 0;
}

double MedianSigmaH(const std::vector<slam::GpsFixWorld>& fixes) {
  if (fixes.empty()) return std::numeric_limits<double>::infinity();
  std::vector<double> sigmas;
  for (const slam::GpsFixWorld& fix : fixes) sigmas.push_back(fix.sigma_h);
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

// The times in [begin, end] without an element of `sorted` (ascending): the longest, seconds,
// and how many are longer than `threshold` s.
struct Gaps {
  double longest_s = 0;
  int count_over = 0;
};
Gaps FindGaps(const std::vector<Timestamp>& sorted, Timestamp begin, Timestamp end,
              double threshold) {
  Gaps gaps;
  Timestamp previous = begin;
  auto add = [&](Timestamp t) {
    const double gap = DurationSeconds(previous, t);
    gaps.longest_s = std::max(gaps.longest_s, gap);
    if (gap > threshold) ++gaps.count_over;
    previous = t;
  };
  for (auto it = std::lower_bound(sorted.begin(), sorted.end(), begin);
       it != sorted.end() && *it <= end; ++it) {
    add(*it);
  }
  add(end);
  return gaps;
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

// What the pass's estimate cannot be trusted for (summary.json "trust", docs/slam.md), each also
// a warning. Without GPS, the heading and the origin are set by convention (not observed), and
// the position drifts with the distance travelled, unless the rig never moved.
json TrustFlags(const SessionContext& ctx, const slam::RowPass& pass,
                const std::vector<bool>& still, const json& summary) {
  json flags = json::array();
  const std::string where = ctx.session->id() + "/" + pass.id;
  if (!ctx.has_best_gps) {
    flags.push_back("heading_by_convention");
    flags.push_back("origin_by_convention");
    const bool moved = std::find(still.begin(), still.end(), false) != still.end() || still.empty();
    if (moved) {
      flags.push_back("drift_without_gps");
      spdlog::warn(
          "{}: no GPS: heading and origin are set by convention and the position drifts with "
          "the distance travelled (docs/slam.md, \"Without GPS\")",
          where);
    } else {
      spdlog::info("{}: no GPS: heading and origin set by convention; the rig stood still", where);
    }
  } else if (summary.value("longest_gps_gap_s", 0.0) > kGpsGapFlagSeconds) {
    flags.push_back("gps_gap");
  }
  // Without an IMU and without a precise receiver, only the metre-level fixes scale the pass
  // unless the camera height did (a closed canopy hides the soil).
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  const bool height_scaled =
      summary.contains("camera_height") && summary["camera_height"].value("scale", 1.0) != 1.0;
  if (!info.imu && info.gps && info.gps_kind == io::GpsKind::kStandard && !height_scaled) {
    flags.push_back("scale_from_metre_gps");
    spdlog::warn(
        "{}: no IMU and no precise receiver: only the metre-level fixes set this pass's scale "
        "and heading (errors of several percent; the camera height did not apply)",
        where);
  }
  // A camera pass whose final solve kept almost no landmark: its poses are the motion model's
  // and the GPS's, not the camera's (without an IMU: the GP prior's and the fixes' alone).
  const int landmarks = summary.at("back_end").value("landmarks", 0);
  if (info.camera && landmarks < kMinLandmarksForCamera) {
    flags.push_back("camera_unused");
    spdlog::warn(
        "{}: only {} landmarks in the solve: the camera hardly constrains this pass's poses "
        "(docs/slam.md, trust flags)",
        where, landmarks);
  }
  const double misfit = summary.at("back_end").value("gps_normalised_rms", 0.0);
  if (misfit > slam::kNoiseMisfit) {
    flags.push_back("noise_misfit");
    spdlog::warn(
        "{}: the solve misses the GPS fixes by {:.2f} times their sigmas: the stated noise of "
        "the sensors (or the fixes' sigmas) does not fit this recording",
        where, misfit);
  }
  return flags;
}

// The pass's images through the front end (features, matches, tracks; features.bin caches
// them), the tracks as the back end takes them, and the front end's part of summary.json.
struct PassFrontEnd {
  features::FrontEnd::Result front;
  std::vector<slam::LandmarkTrack> tracks;
  double seconds = 0;
};
PassFrontEnd RunFrontEnd(const SlamStageOptions& options, const SessionContext& ctx,
                         const slam::CameraStream& camera_stream, const slam::RowPass& pass,
                         const workspace::Layout& layout, const std::vector<Timestamp>& times,
                         json* summary) {
  PassFrontEnd out;
  const slam::CameraStream* camera = &camera_stream;
  auto start = Clock::now();
  features::FrontEnd::Options fe = options.front_end;
  fe.cache_path = layout.PassFeatures(ctx.session->id(), pass.id).string();
  fe.show_progress = options.show_progress;
  const features::FrontEnd front_end(fe, &camera->sensor.camera);
  std::vector<std::string> keys;
  std::vector<std::string> paths;
  for (const io::ImageEntry& e : camera->images) {
    if (e.t < times.front() || e.t > times.back()) continue;
    keys.push_back(std::to_string(e.t));
    paths.push_back(ctx.session->ImagePath(camera->sensor.name, e.filename));
  }
  out.front =
      front_end.Run(keys, [&](std::size_t i) { return cv::imread(paths[i], cv::IMREAD_COLOR); });
  if (out.front.summary.num_images_unreadable > 0) {
    spdlog::warn(
        "{}/{}: {} images could not be read (no features; the IMU and GPS carry the "
        "states there)",
        ctx.session->id(), pass.id, out.front.summary.num_images_unreadable);
  }
  for (const features::Track& track : out.front.tracks) {
    out.tracks.push_back(ToLandmarkTrack(track, out.front.features));
  }
  out.seconds = SecondsSince(start);
  (*summary)["front_end"] = {{"images", out.front.summary.num_images},
                             {"images_from_cache", out.front.summary.num_images_from_cache},
                             {"images_unreadable", out.front.summary.num_images_unreadable},
                             {"features", out.front.summary.num_features},
                             {"pairs", out.front.summary.num_pairs},
                             {"verified_pairs", out.front.summary.num_verified_pairs},
                             {"inlier_matches", out.front.summary.num_inlier_matches},
                             {"tracks", out.front.summary.tracks.num_tracks},
                             {"landmarks", out.front.summary.num_landmarks},
                             {"seconds", out.seconds}};
  return out;
}

// The pass's initial states (docs/slam.md, initialisation): the session solve interpolated, or
// the GPS track and the IMU, or dead reckoning from the local level frame (no GPS) or from one
// anchor (cam+imu: `anchor_state`); without an IMU the images then give its rotations.
std::vector<slam::RowState> InitialStates(const SlamStageOptions& options,
                                          const SessionContext& ctx, const slam::RowPass& pass,
                                          const std::vector<Timestamp>& times,
                                          const slam::CameraStream* camera,
                                          const std::vector<slam::LandmarkTrack>& pair_tracks,
                                          slam::StateInitialiser::Summary* init_summary,
                                          int* anchor_state,
                                          slam::VisualInitialisationSummary* visual_init) {
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  std::vector<slam::RowState> initial;
  if (info.gps && !ctx.session_states.empty()) {
    // The session solution interpolated at the state times.
    for (Timestamp t : times) initial.push_back(slam::InterpolateState(ctx.session_states, t));
    init_summary->forward_axis_body = ctx.initialiser->forward_axis();
  } else if (info.gps) {
    initial = ctx.initialiser->Initialise(times, ctx.factor_antenna, init_summary);
  } else if (!ctx.has_best_gps) {
    // No GPS at all: the local level frame of the first state (docs/slam.md, "Without GPS"), at
    // rest when the pass starts with a standstill; else its velocity is left to the camera and
    // the IMU.
    initial =
        ctx.initialiser->InitialiseFromAnchor(ctx.initialiser->LocalLevelState(times[0]), times);
  } else {
    // cam+imu: the best GPS only anchors the pass at one instant, its middle, where the motion
    // is steady (the gauge: position, heading and velocity from a ±2 s line fit); nothing else.
    *anchor_state = static_cast<int>(times.size() / 2);
    const slam::StateInitialiser::Options anchor_options =
        slam::AnchorInitialisation(options.initialisation);
    slam::StateInitialiser anchor_initialiser(anchor_options, *ctx.streams.imu, &ctx.best_gps);
    anchor_initialiser.set_forward_axis(ctx.initialiser->forward_axis());
    const std::vector<slam::RowState> anchor = anchor_initialiser.Initialise(
        {times[*anchor_state]}, ctx.best_gps.sensor.antenna_in_body, init_summary);
    initial = anchor_initialiser.InitialiseFromAnchor(anchor.front(), times);
  }
  if (info.gps && ctx.streams.imu->samples.empty() && camera != nullptr) {
    // Without an IMU the GPS track alone gave the guess: the images give its rotations and shape
    // (slam/visual_initialisation.h), from every track of two or more images.
    initial = slam::VisualInitialGuess(initial, camera->sensor.camera,
                                       camera->sensor.body_from_sensor, pair_tracks, kLevelUpBody,
                                       options.visual_initialisation, visual_init);
    if (!visual_init->applied) {
      spdlog::warn(
          "{}/{}: only {} of {} image pairs give their relative motion: the initial guess is "
          "the GPS track's alone",
          ctx.session->id(), pass.id, visual_init->visual_steps, visual_init->steps);
    }
  }
  return initial;
}

// summary.json's "problem": what the joint 4D problem needs to rebuild this pass's graph from
// the session's data (fuse_stage.h): the sensors, the GPS receiver and outages, and the priors.
workspace::PassPriors ProblemPriors(const SlamStageOptions& options, const SessionContext& ctx,
                                    const slam::CameraStream* camera, bool use_imu,
                                    const slam::RowOptimiser::Input& input,
                                    const std::vector<bool>& still,
                                    const slam::RowOptimiser::Summary& s) {
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  workspace::PassPriors p;
  p.camera = camera != nullptr ? camera->sensor.name : "";
  p.imu = use_imu ? ctx.streams.imu->sensor.name : "";
  p.use_imu = use_imu;
  p.level_up_body = input.level_up_body;
  p.gps = info.gps ? ctx.factor_gps_name : "";
  for (const GpsOutage& g : options.gps_outages)
    p.gps_outages.emplace_back(g.start_s, g.duration_s);
  p.imu_noise_factor = ctx.imu_noise_factor;
  p.anchor_state = input.anchor_state;
  p.anchor_sigma_velocity = input.anchor_sigma_velocity;
  p.still_intervals = workspace::StillRanges(still);
  p.forward_axis_body = input.forward_axis_body;
  p.bias_prior_mean = input.bias_prior_mean;
  p.bias_prior_sigma = input.bias_prior_sigma;
  if (s.length_prior_m > 0)
    p.length_prior = std::make_pair(s.length_prior_m, s.length_prior_sigma_m);
  return p;
}

// summary.json's "back_end": the row optimiser's counts, fit and cost.
json BackEndJson(const slam::RowOptimiser::Summary& s) {
  return {{"imu_factors", s.num_imu_factors},
          {"imu_gaps", s.num_imu_gaps},
          {"gps_factors", s.num_gps_factors},
          {"still_intervals", s.num_still_intervals},
          {"gps_normalised_rms", s.gps_normalised_rms},
          {"gps_normalised_rms_horizontal", s.gps_normalised_rms_horizontal},
          {"tracks", s.num_tracks},
          {"landmarks_triangulated", s.num_landmarks_triangulated},
          {"landmarks", s.num_landmarks_final},
          {"observations", s.num_observations},
          {"rejected_observations", s.num_rejected_observations},
          {"reprojection_rms_px", s.reprojection_rms_px},
          {"initial_cost", s.initial_cost},
          {"final_cost", s.final_cost},
          {"iterations", s.iterations},
          {"converged", s.converged},
          // Capture instant − image stamp, s (null: not estimated).
          {"time_offset_s", s.time_offset_estimated ? json(s.time_offset_s) : json()}};
}

// A camera pass's cloud (landmarks.ply: every track of two or more images triangulated from the
// final poses) and the observations behind its landmarks and cloud points (tracks.bin, for
// association and the joint 4D problem, pass_files.h). Returns the number of cloud points.
int WritePassCloud(const SlamStageOptions& options, const SessionContext& ctx,
                   const slam::RowPass& pass, const workspace::Layout& layout,
                   const slam::CameraStream* camera, const features::FrontEnd::Result& front,
                   const std::vector<slam::LandmarkTrack>& tracks,
                   const std::vector<features::Track>& all_tracks,
                   const std::vector<geometry::Rigid3>& cameras,
                   const slam::RowOptimiser::Result& result, json* summary) {
  // Every track of two or more images, triangulated from the final poses.
  std::vector<slam::LandmarkTrack> cloud_tracks;
  cloud_tracks.reserve(all_tracks.size());
  for (const features::Track& t : all_tracks) {
    cloud_tracks.push_back(ToLandmarkTrack(t, front.features));
  }
  const slam::TrackCloud track_cloud =
      slam::TriangulateTrackCloud(camera->sensor.camera, cameras, cloud_tracks, options.cloud);
  const io::PlyPointCloud cloud = ToPly(track_cloud);
  // The observations behind the optimised landmarks and behind every cloud point, for
  // association and the joint 4D problem (pass_files.h).
  workspace::PassTracks pass_tracks;
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    const features::Track& track = front.tracks[result.landmark_tracks[l]];
    workspace::PassTrack t;
    t.position_world = result.landmarks_world[l];
    t.color = tracks[result.landmark_tracks[l]].color;
    for (std::size_t o = 0; o < track.observations.size(); ++o) {
      if (result.landmark_observations_kept[l][o]) t.observations.push_back(track.observations[o]);
    }
    pass_tracks.landmarks.push_back(std::move(t));
  }
  for (std::size_t k = 0; k < track_cloud.size(); ++k) {
    pass_tracks.cloud.push_back({track_cloud.points_world[k], track_cloud.colors[k],
                                 all_tracks[track_cloud.track_indices[k]].observations});
  }
  workspace::WritePassTracks(layout.PassTracks(ctx.session->id(), pass.id).string(), pass_tracks);
  io::PlyWriteOptions ply_options;
  ply_options.comment =
      "crop4d sparse cloud of " + ctx.session->id() + "/" + pass.id + ", field ENU frame (metres)";
  io::WritePly(layout.PassLandmarks(ctx.session->id(), pass.id).string(), cloud, ply_options);
  (*summary)["cloud"] = {{"tracks", all_tracks.size()}, {"points", cloud.size()}};
  return static_cast<int>(cloud.size());
}

// Gaps in the IMU samples (over 0.5 s) and in the GPS fixes (over kGpsGapFlagSeconds) inside
// the pass: warnings, and the longest of each in summary.json (the session's grade reads them,
// season_quality.h).
void RecordSensorGaps(const SessionContext& ctx, const slam::RowPass& pass,
                      const std::vector<Timestamp>& times, const slam::CameraStream* camera,
                      bool use_imu, json* summary) {
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  const slam::ImuStream& imu = *ctx.streams.imu;
  if (use_imu) {
    // An IMU outage inside the pass is bridged by the camera and the GP prior only: recorded
    // for the session's grade (season_quality.h).
    std::vector<Timestamp> imu_times;
    imu_times.reserve(imu.samples.size());
    for (const slam::ImuSample& sample : imu.samples) imu_times.push_back(sample.timestamp);
    const Gaps gaps = FindGaps(imu_times, times.front(), times.back(), kImuGapWarnSeconds);
    if (gaps.count_over > 0) {
      spdlog::warn(
          "{}/{}: {} gap(s) without IMU samples longer than {:.1f} s inside the pass, the "
          "longest {:.1f} s",
          ctx.session->id(), pass.id, gaps.count_over, kImuGapWarnSeconds, gaps.longest_s);
    }
    (*summary)["longest_imu_gap_s"] = gaps.longest_s;
  }
  if (info.gps) {
    // Warn about GPS outages inside the pass (the IMU and the camera bridge them).
    std::vector<Timestamp> fix_times;
    fix_times.reserve(ctx.factor_fixes.size());
    for (const slam::GpsFixWorld& fix : ctx.factor_fixes) fix_times.push_back(fix.t);
    const Gaps gaps = FindGaps(fix_times, times.front(), times.back(), kGpsGapFlagSeconds);
    if (gaps.count_over > 0) {
      const char* bridge = !use_imu            ? "the camera and the GP prior bridge them"
                           : camera != nullptr ? "the IMU and the camera bridge them"
                                               : "the IMU bridges them";
      spdlog::warn(
          "{}/{}: {} gap(s) without a GPS fix longer than {:.0f} s inside the pass, the "
          "longest {:.1f} s; {}",
          ctx.session->id(), pass.id, gaps.count_over, kGpsGapFlagSeconds, gaps.longest_s, bridge);
    }
    (*summary)["longest_gps_gap_s"] = gaps.longest_s;
    (*summary)["gps_gaps"] = gaps.count_over;
  }
}

// The pass's standstills, one flag per interval between states (empty: detection off): from
// the IMU, the image motion (a camera pass's front end, else null) and a precise GPS track;
// their spans go to summary.json.
std::vector<bool> PassStandstills(const SlamStageOptions& options, const SessionContext& ctx,
                                  const slam::RowPass& pass, const std::vector<Timestamp>& times,
                                  const features::FrontEnd::Result* front, json* summary) {
  const bool precise_gps =
      ctx.has_best_gps && MedianSigmaH(ctx.best_gps.fixes) <= options.session_solve_max_sigma_m;
  std::vector<bool> still = options.standstills
                                ? DetectPassStandstills(times, *ctx.streams.imu, front,
                                                        precise_gps ? &ctx.best_gps.fixes : nullptr,
                                                        options.optimiser.standstill)
                                : std::vector<bool>();
  const std::vector<slam::TimeInterval> still_spans = slam::StillSpans(times, still);
  {
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
                   pass.id, total, still_spans.size(), still_spans.size() == 1 ? "" : "s");
    }
  }
  return still;
}

// The pass's row-SLAM problem: the initial states and gauge, standstills, the camera's tracks,
// the IMU (with the session's noise factor) or a level rig, the session's bias prior, the
// camera height where nothing precise sets the scale, the motion constraint, the GPS fixes.
slam::RowOptimiser::Input PassInput(const SlamStageOptions& options, const SessionContext& ctx,
                                    const slam::RowPass& pass, const slam::CameraStream* camera,
                                    const std::vector<slam::RowState>& initial, int anchor_state,
                                    const std::vector<bool>& still,
                                    const std::vector<slam::LandmarkTrack>& tracks,
                                    std::vector<slam::LandmarkTrack> pair_tracks) {
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  slam::RowOptimiser::Input input;
  input.initial_states = initial;
  input.anchor_state = anchor_state;
  input.still_intervals = still;
  if (!ctx.has_best_gps && !(still.empty() ? false : still.front())) {
    // Without GPS a pass that starts moving has an unknown velocity.
    input.anchor_sigma_velocity = kUnknownVelocitySigma;
  }
  if (camera != nullptr) {
    input.camera = &camera->sensor.camera;
    input.body_from_camera = camera->sensor.body_from_sensor;
    input.tracks = tracks;
  }
  const slam::ImuStream& imu = *ctx.streams.imu;
  const bool use_imu = !imu.samples.empty();
  if (use_imu) {
    input.imu_samples = &imu.samples;
    input.imu_noise = slam::ImuNoise(imu.sensor, ctx.imu_noise_factor);
    input.imu_rate_hz = imu.sensor.rate_hz;
  } else {
    input.level_up_body = kLevelUpBody;
  }
  if (!ctx.session_states.empty()) {
    input.bias_prior_mean = initial.front().bias;
    slam::Vector6d sigma;
    sigma << Eigen::Vector3d::Constant(options.session_bias_sigma_gyro),
        Eigen::Vector3d::Constant(options.session_bias_sigma_accel);
    input.bias_prior_sigma = sigma;
  }
  // The camera height sets the scale only where nothing precise does: not with RTK factors, nor
  // for `cam+imu` anchored by an RTK velocity (measured on the demo field: RPE 0.50 % without,
  // 0.65 % with).
  const bool precise_scale =
      info.gps ? info.gps_kind == io::GpsKind::kRtk
               : MedianSigmaH(ctx.best_gps.fixes) <= options.session_solve_max_sigma_m;
  const double camera_height = CameraHeight(options, ctx.streams);
  if (camera_height > 0 && camera != nullptr && !precise_scale) {
    input.camera_height_m = camera_height;
    input.depth_tracks = std::move(pair_tracks);
  }
  if (options.motion_constraint && pass.row >= 0 && ctx.forward_axis_estimated) {
    // A row pass is driven by a vehicle: the non-holonomic constraint holds.
    input.forward_axis_body = ctx.initialiser->forward_axis();
  }
  if (info.gps) {
    input.gps_fixes = ctx.factor_fixes;
    input.p_body_antenna = ctx.factor_antenna;
  }
  return input;
}

PassOutcome RunPass(const SlamStageOptions& options, SessionContext& ctx, const slam::RowPass& pass,
                    const workspace::Layout& layout, const std::string& fingerprint,
                    const json& options_json, const std::vector<Timestamp>& times) {
  const auto start_total = Clock::now();
  const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
  json summary;
  summary["session"] = ctx.session->id();
  summary["pass"] = pass.id;
  summary["row"] = pass.row;
  summary["direction"] = pass.direction;
  summary["t_begin_ns"] = pass.t_begin;
  summary["t_end_ns"] = pass.t_end;
  summary["sensors"] = slam::ToString(ctx.sensors);
  summary["pose_frame"] = info.camera ? "camera" : "body";
  summary["fingerprint"] = fingerprint;
  summary["options"] = options_json;

  // Front end.
  const slam::CameraStream* camera = info.camera ? &*ctx.streams.camera : nullptr;
  PassFrontEnd front_end;
  if (camera != nullptr) {
    front_end = RunFrontEnd(options, ctx, *camera, pass, layout, times, &summary);
  }
  const features::FrontEnd::Result& front = front_end.front;
  const std::vector<slam::LandmarkTrack>& tracks = front_end.tracks;
  const double front_end_seconds = front_end.seconds;

  // Every track of two or more images: the output cloud, and the soil's depth for the camera
  // height.
  std::vector<features::Track> all_tracks;
  if (camera != nullptr) {
    features::TrackBuilder::Options tb;
    tb.min_track_length = 2;
    std::vector<int> num_features;
    for (const features::FeatureSet& f : front.features) {
      num_features.push_back(static_cast<int>(f.size()));
    }
    all_tracks = features::TrackBuilder(tb).Build(num_features, front.pairs);
  }
  // The same tracks in image indices: the visual initial guess and the soil's depth use them.
  std::vector<slam::LandmarkTrack> pair_tracks;
  for (const features::Track& track : all_tracks) {
    pair_tracks.push_back(ToLandmarkTrack(track, front.features));
  }

  // Initial states.
  auto start = Clock::now();
  slam::StateInitialiser::Summary init_summary;
  int anchor_state = 0;
  slam::VisualInitialisationSummary visual_init;
  const std::vector<slam::RowState> initial = InitialStates(
      options, ctx, pass, times, camera, pair_tracks, &init_summary, &anchor_state, &visual_init);
  const double init_seconds = SecondsSince(start);
  {
    // The initial guess, for diagnosis (same frame as poses.tum).
    std::vector<io::StampedPose> initial_poses;
    for (const slam::RowState& state : initial) {
      initial_poses.push_back(
          {state.t, camera != nullptr ? state.nav.world_from_body * camera->sensor.body_from_sensor
                                      : state.nav.world_from_body});
    }
    io::WriteTum(layout.PassInitialPoses(ctx.session->id(), pass.id).string(), initial_poses,
                 "initial guess of " + ctx.session->id() + "/" + pass.id + " from GPS and IMU");
  }

  // Standstills: from the IMU, the image motion and a precise GPS track.
  const std::vector<bool> still =
      PassStandstills(options, ctx, pass, times, camera != nullptr ? &front : nullptr, &summary);

  // Back end.
  slam::RowOptimiser::Options op = options.optimiser;
  if (ctx.streams.imu->samples.empty()) {
    // Without an IMU only the receiver scales the pass: a metre-level one leaves a 20 m pass
    // tens of percent off (measured on the demo field: the soil's depth asked for −20 to +28 %),
    // so the soil's depth below a camera of known height may correct more than with an IMU.
    op.camera_height.max_scale_change =
        std::max(op.camera_height.max_scale_change, kMaxScaleChangeWithoutImu);
  }
  const slam::RowOptimiser optimiser(op);
  slam::RowOptimiser::Input input = PassInput(options, ctx, pass, camera, initial, anchor_state,
                                              still, tracks, std::move(pair_tracks));
  const bool use_imu = !ctx.streams.imu->samples.empty();
  RecordSensorGaps(ctx, pass, times, camera, use_imu, &summary);
  const slam::RowOptimiser::Result result = optimiser.Solve(input);
  const slam::RowOptimiser::Summary& s = result.summary;
  summary["problem"] =
      workspace::ToJson(ProblemPriors(options, ctx, camera, use_imu, input, still, s));

  // Outputs: poses, cloud, summary.
  start = Clock::now();
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
  io::WriteTum(layout.PassPoses(ctx.session->id(), pass.id).string(), poses,
               std::string(camera != nullptr ? "world_from_camera" : "world_from_body") +
                   " of session " + ctx.session->id() + ", pass " + pass.id + " (" +
                   slam::ToString(ctx.sensors) + "), field ENU frame");

  workspace::WritePassStates(layout.PassStates(ctx.session->id(), pass.id).string(), result.states);

  PassOutcome outcome;
  outcome.num_states = static_cast<int>(result.states.size());
  outcome.num_images = camera != nullptr ? front.summary.num_images : 0;
  outcome.num_landmarks = s.num_landmarks_final;
  if (camera != nullptr) {
    outcome.num_cloud_points = WritePassCloud(options, ctx, pass, layout, camera, front, tracks,
                                              all_tracks, cameras, result, &summary);
  }
  const double output_seconds = SecondsSince(start);

  summary["states"] = s.num_states;
  summary["images"] = outcome.num_images;
  summary["initialisation"] = {
      {"forward_axis_body",
       {init_summary.forward_axis_body.x(), init_summary.forward_axis_body.y(),
        init_summary.forward_axis_body.z()}},
      {"states_heading_from_gyro", init_summary.num_states_heading_from_gyro},
      {"states_without_gps", init_summary.num_states_without_gps},
      {"from_images", visual_init.applied},
      {"image_pairs_used", visual_init.visual_steps},
      {"heading_change_deg", visual_init.heading_change_deg}};
  summary["back_end"] = BackEndJson(s);
  if (s.time_offset_estimated) {
    spdlog::info("{}/{}: camera-IMU time offset {:+.1f} ms (capture instant - image stamp)",
                 ctx.session->id(), pass.id, 1e3 * s.time_offset_s);
  }
  if (input.camera_height_m) {
    // The soil's depth below the camera before the rescale, and the scale it set (1: too few
    // soil landmarks to measure it).
    summary["camera_height"] = {{"height_m", *input.camera_height_m},
                                {"soil_depth_m", s.soil_depth_m},
                                {"soil_points", s.soil_points},
                                {"scale", s.camera_height_scale}};
  }
  summary["trust"] = TrustFlags(ctx, pass, still, summary);
  summary["seconds"] = {{"front_end", front_end_seconds},
                        {"initialisation", init_seconds},
                        {"inertial_solve", s.inertial_seconds},
                        {"triangulation", s.triangulation_seconds},
                        {"full_solve", s.full_solve_seconds},
                        {"final_solve", s.final_solve_seconds},
                        {"outputs", output_seconds},
                        {"total", SecondsSince(start_total)}};
  const std::string& session = ctx.session->id();
  workspace::RecordOutputs(&summary, layout.PassDir(session, pass.id),
                           PassOutputs(layout, session, pass.id));
  workspace::WritePassSummary(layout.PassSummary(session, pass.id).string(), summary);
  return outcome;
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
    // The forward axis from the best track (RTK when there is one).
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
  // The session solve needs a precise receiver: with a metre-level one the turns do not make
  // the accelerometer bias observable, and a wrong tight bias prior does more harm than the
  // weak zero-mean one.
  if (options.session_state_rate_hz > 0 && ctx->has_best_gps && info.imu) {
    if (info.gps && MedianSigmaH(ctx->factor_fixes) <= options.session_solve_max_sigma_m) {
      SolveSession(options, ctx, ctx->init_gps, /*keep_states=*/true);
    } else if (MedianSigmaH(ctx->best_gps.fixes) <= options.session_solve_max_sigma_m) {
      // Only the mounting calibration (forward axis) from the precise receiver; the passes
      // use nothing else of it.
      SolveSession(options, ctx, ctx->best_gps, /*keep_states=*/false);
    }
  }
}

}  // namespace

std::vector<slam::GpsFixWorld> ApplyGpsOutages(const std::vector<slam::GpsFixWorld>& fixes,
                                               const std::vector<GpsOutage>& outages) {
  if (outages.empty() || fixes.empty()) return fixes;
  std::vector<slam::GpsFixWorld> kept;
  const Timestamp t0 = fixes.front().t;
  for (const slam::GpsFixWorld& fix : fixes) {
    const double s = DurationSeconds(t0, fix.t);
    bool dropped = false;
    for (const GpsOutage& g : outages) dropped |= s >= g.start_s && s < g.start_s + g.duration_s;
    if (!dropped) kept.push_back(fix);
  }
  return kept;
}

std::string SlamStageOptions::Check() const {
  for (const GpsOutage& g : gps_outages) {
    if (!(g.duration_s > 0)) return "gps_outages: a duration must be > 0";
    if (!std::isfinite(g.start_s)) return "gps_outages: a start must be a finite time";
  }
  if (!(state_rate_hz > 0)) return "state_rate_hz: must be > 0";
  if (!(session_state_rate_hz >= 0)) return "session_state_rate_hz: must be >= 0 (0: off)";
  if (!(session_solve_max_sigma_m >= 0)) return "session_solve_max_sigma_m: must be >= 0";
  if (!(session_bias_sigma_gyro > 0)) return "session_bias_sigma_gyro: must be > 0";
  if (!(session_bias_sigma_accel > 0)) return "session_bias_sigma_accel: must be > 0";
  if (!(camera_height_m >= 0) || !std::isfinite(camera_height_m)) {
    return "camera_height_m: must be >= 0 and finite (0: from sensor.yaml)";
  }
  if (!(window_overlap_s >= 0)) return "window_overlap_s: must be >= 0";
  if (!(max_window_s > window_overlap_s)) return "max_window_s: must be > window_overlap_s";
  // The nested options of the modules (their fields are documented in docs/slam.md).
  if (const std::string why = front_end.Check(); !why.empty()) return "front_end." + why;
  if (const std::string why = passes.Check(); !why.empty()) return "passes." + why;
  if (const std::string why = initialisation.Check(); !why.empty()) return "initialisation." + why;
  if (const std::string why = visual_initialisation.Check(); !why.empty()) {
    return "visual_initialisation." + why;
  }
  if (const std::string why = optimiser.Check(); !why.empty()) return "optimiser." + why;
  if (const std::string why = cloud.Check(); !why.empty()) return "cloud." + why;
  return {};
}

const char* ToString(PassMode mode) {
  switch (mode) {
    case PassMode::kAuto:
      return "auto";
    case PassMode::kRows:
      return "rows";
    case PassMode::kWhole:
      return "whole";
  }
  return "?";
}

std::optional<PassMode> ParsePassMode(const std::string& text) {
  for (PassMode mode : {PassMode::kAuto, PassMode::kRows, PassMode::kWhole}) {
    if (text == ToString(mode)) return mode;
  }
  return std::nullopt;
}

std::string PassFolder(const std::string& workspace, const std::string& session,
                       const std::string& pass_id) {
  return workspace::Layout(workspace).PassDir(session, pass_id).string();
}

std::vector<PassReport> RunSlamStage(const std::string& field_folder, const std::string& workspace,
                                     const SlamStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("slam." + why);
  const io::Field field(field_folder);
  const workspace::Layout layout(workspace);
  std::vector<std::string> sessions = field.session_ids();
  if (!options.session.empty()) {
    if (std::find(sessions.begin(), sessions.end(), options.session) == sessions.end()) {
      throw InputError(field_folder, 0, "no session '" + options.session + "' in this field");
    }
    sessions = {options.session};
  }
  std::vector<PassReport> reports;
  for (const std::string& id : sessions) {
    const io::Session session = field.OpenSession(id);
    SessionContext ctx;
    ctx.session = &session;
    ctx.streams = slam::LoadSessionStreams(field, session, options.camera, options.imu);
    ctx.sensors = ChooseSensorSet(options, ctx.streams);
    ctx.data_stamp = DataStamp(session);
    const slam::SensorSetInfo info = slam::Describe(ctx.sensors);
    if (!info.imu) {
      // cam+rtk, cam+gps: the IMU is not used, even where the session has one.
      ctx.streams.imu = slam::ImuStream{};
      ctx.streams.imu->sensor.name.clear();
    }
    if (const slam::GpsStream* best = ctx.streams.BestGps()) {
      ctx.best_gps = *best;
      ctx.best_gps.fixes = ApplyGpsOutages(best->fixes, options.gps_outages);
      ctx.has_best_gps = true;
    }
    if (info.gps) {
      const slam::GpsStream* gps = ctx.streams.FindGps(info.gps_kind);
      ctx.factor_fixes = ApplyGpsOutages(gps->fixes, options.gps_outages);
      ctx.factor_antenna = gps->sensor.antenna_in_body;
      ctx.factor_gps_name = gps->sensor.name;
    }
    if (!ctx.has_best_gps && !session.gps_receivers().empty()) {
      // Receivers without a single fix are a broken recording, not a rig without GPS: the
      // session cannot be placed in the field with the others.
      throw InputError(session.folder(), 0,
                       "row SLAM needs GPS fixes (to find the row passes and anchor each pass in "
                       "the field frame); this session has none (a session without any GPS "
                       "receiver runs cam+imu in its own local frame)");
    }
    // Initialisation from the receiver the factors use; cam+imu anchors each pass with the best
    // receiver.
    ctx.init_gps = ctx.best_gps;
    if (info.gps) {
      ctx.init_gps = *ctx.streams.FindGps(info.gps_kind);
      ctx.init_gps.fixes = ctx.factor_fixes;
    }
    InitialiseSession(options, &ctx);

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
    workspace::WritePassList(layout.PassList(id).string(), passes);
    spdlog::info("session {}: {} passes, sensors {}", id, passes.size(),
                 slam::ToString(ctx.sensors));
    json options_json = SlamOptionsJson(options, ctx.sensors);
    // The height in effect, so that a change of the option or of sensor.yaml solves again.
    options_json["camera_height_m"] = CameraHeight(options, ctx.streams);

    for (const slam::RowPass& pass : passes) {
      if (!PassSelected(options, pass)) continue;
      PassReport report;
      report.session = id;
      report.pass = pass;
      report.sensors = slam::ToString(ctx.sensors);
      report.folder = layout.PassDir(id, pass.id).string();
      const auto start = Clock::now();
      // State times: the images in the pass, or a regular grid without a camera.
      std::vector<Timestamp> times;
      if (info.camera) {
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
      if (times.size() < 2) {
        report.failed = true;
        report.message = "fewer than 2 states in the pass";
        spdlog::warn("{}/{}: {}", id, pass.id, report.message);
        reports.push_back(report);
        continue;
      }
      const std::string fingerprint = Fingerprint(options_json, pass, times.size(), ctx.data_stamp);
      if (!options.force && UpToDate(layout, id, pass.id, fingerprint, info.camera)) {
        report.skipped = true;
        report.num_states = static_cast<int>(times.size());
        report.message = "up to date";
        spdlog::info("{}/{}: up to date, skipped", id, pass.id);
        reports.push_back(report);
        continue;
      }
      try {
        const PassOutcome outcome =
            RunPass(options, ctx, pass, layout, fingerprint, options_json, times);
        report.num_states = outcome.num_states;
        report.num_images = outcome.num_images;
        report.num_landmarks = outcome.num_landmarks;
        report.num_cloud_points = outcome.num_cloud_points;
      } catch (const InputError&) {
        throw;  // bad input stops the stage with its file and line
      } catch (const std::runtime_error& e) {
        // An expected failure of this pass's solve (no GPS course to start from, a solver that
        // gives up): the pass fails, the others go on. Programmer errors (std::logic_error,
        // std::invalid_argument of a violated precondition) are not caught.
        report.failed = true;
        report.message = e.what();
        spdlog::error("{}/{}: {}", id, pass.id, e.what());
      }
      report.seconds = SecondsSince(start);
      if (!report.failed) {
        spdlog::info("{}/{}: {} states, {} landmarks, {} cloud points, {:.1f} s", id, pass.id,
                     report.num_states, report.num_landmarks, report.num_cloud_points,
                     report.seconds);
      }
      reports.push_back(report);
    }
  }
  return reports;
}

}  // namespace crop4d::pipeline
