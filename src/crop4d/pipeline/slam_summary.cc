// A slam pass's summary.json (slam_summary.h): fingerprint, up-to-date check and its parts.

#include "crop4d/pipeline/slam_summary.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/version.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/stream_coverage.h"
#include "crop4d/workspace/pass_measurements.h"
#include "crop4d/workspace/pass_priors.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// Bumped whenever the stage's method changes its results, so that outputs of an older method
// are not taken as up to date.
constexpr int kSlamStageRevision = 11;

// An IMU gap longer than this inside a pass is warned about, s: far longer than the sample
// spacing (6 ms at 167 Hz), an outage rather than timing jitter.
constexpr double kImuGapWarnSeconds = 0.5;
// A pass with a GPS outage longer than this is flagged (its drift over the gap is the IMU's and
// the camera's), s.
constexpr double kGpsGapFlagSeconds = 2.0;
// A camera pass with fewer landmarks than this in its final solve is flagged camera_unused (a
// cam+gps pass of the demo field keeps 190-1140).
constexpr int kMinLandmarksForCamera = 20;

// The files of a pass that the later stages read, as recorded in its summary (those written).
std::vector<std::string> PassOutputs(const workspace::Layout& layout, const std::string& session,
                                     const std::string& pass) {
  std::vector<std::string> out;
  for (const fs::path& file :
       {layout.PassPoses(session, pass), layout.PassStates(session, pass),
        layout.PassMeasurements(session, pass), layout.PassInitialPoses(session, pass),
        layout.PassTracks(session, pass), layout.PassLandmarks(session, pass)}) {
    if (fs::exists(file)) out.push_back(file.filename().string());
  }
  return out;
}

// summary.json's "back_end": the row optimiser's counts, fit and cost.
json BackEndJson(const slam::RowOptimiser::Summary& s) {
  return {{"imu_factors", s.num_imu_factors},
          {"imu_gaps", s.num_imu_gaps},
          {"gps_factors", s.num_gps_factors},
          // Fixes dropped by the outlier gate (slam.gps_gate_chi2; 0 with the gate off).
          {"gps_rejected", s.num_gps_rejected},
          {"still_intervals", s.num_still_intervals},
          {"gps_normalised_rms", s.gps_normalised_rms},
          {"gps_normalised_rms_horizontal", s.gps_normalised_rms_horizontal},
          {"tracks", s.num_tracks},
          {"landmarks_triangulated", s.num_landmarks_triangulated},
          {"landmarks", s.num_landmarks_final},
          {"observations", s.num_observations},
          {"rejected_observations", s.num_rejected_observations},
          {"reprojection_rms_px", s.reprojection_rms_px},
          // Images whose keypoints were down-weighted for their sharpness (slam.image_weighting)
          // and the largest factor on their reprojection sigma.
          {"downweighted_images", s.num_downweighted_images},
          {"max_image_sigma_scale", s.max_image_sigma_scale},
          {"initial_cost", s.initial_cost},
          {"final_cost", s.final_cost},
          {"iterations", s.iterations},
          {"converged", s.converged},
          // Capture instant − image stamp, s (null: not estimated).
          {"time_offset_s", s.time_offset_estimated ? json(s.time_offset_s) : json()}};
}

// summary.json's "initialisation": the forward axis, the states without GPS, the visual guess.
json InitialisationJson(const PassInitialisation& init) {
  const Eigen::Vector3d& axis = init.summary.forward_axis_body;
  return {{"forward_axis_body", {axis.x(), axis.y(), axis.z()}},
          {"states_heading_from_gyro", init.summary.num_states_heading_from_gyro},
          {"states_without_gps", init.summary.num_states_without_gps},
          {"from_images", init.visual.applied},
          {"image_pairs_used", init.visual.visual_steps},
          {"heading_change_deg", init.visual.heading_change_deg}};
}

// Without GPS, the heading and the origin are set by convention (not observed), and the position
// drifts with the distance travelled, unless the rig never moved.
void FlagNoGps(const std::string& where, const std::vector<bool>& still, json* flags) {
  flags->push_back("heading_by_convention");
  flags->push_back("origin_by_convention");
  const bool moved = std::find(still.begin(), still.end(), false) != still.end() || still.empty();
  if (moved) {
    flags->push_back("drift_without_gps");
    spdlog::warn(
        "{}: no GPS: heading and origin are set by convention and the position drifts with "
        "the distance travelled (docs/slam.md, \"Without GPS\")",
        where);
  } else {
    spdlog::info("{}: no GPS: heading and origin set by convention; the rig stood still", where);
  }
}

// What the pass's estimate cannot be trusted for (summary.json "trust", docs/slam.md), each also
// a warning.
json TrustFlags(const SessionContext& ctx, const slam::RowPass& pass,
                const std::vector<bool>& still, const json& summary) {
  json flags = json::array();
  const std::string where = ctx.session->id() + "/" + pass.id;
  if (!ctx.has_best_gps) {
    FlagNoGps(where, still, &flags);
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
  // A solve whose outlier gate rejected most of the fixes has left the GPS track: its misfit
  // is the divergence's, not the noise's (season_quality.h degrades its session).
  const int fixes = summary.at("back_end").value("gps_factors", 0);
  const int rejected = summary.at("back_end").value("gps_rejected", 0);
  const double misfit = summary.at("back_end").value("gps_normalised_rms", 0.0);
  if (LeftGpsTrack(fixes, rejected, QualityOptions{}.max_gps_rejected_share)) {
    flags.push_back("gps_rejected");
    spdlog::warn(
        "{}: the solve rejected {} of its {} GPS fixes as outliers: it has left the GPS track "
        "(a wrong initial heading, or a receiver far off); its poses are not trusted "
        "(docs/slam.md, trust flags)",
        where, rejected, fixes);
  } else if (misfit > slam::kNoiseMisfit) {
    flags.push_back("noise_misfit");
    spdlog::warn(
        "{}: the solve misses the GPS fixes by {:.2f} times their sigmas: the stated noise of "
        "the sensors (or the fixes' sigmas) does not fit this recording",
        where, misfit);
  }
  return flags;
}

}  // namespace

std::string PassFingerprint(const json& options, const slam::RowPass& pass, std::size_t num_states,
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

bool PassUpToDate(const workspace::Layout& layout, const std::string& session,
                  const std::string& pass, const std::string& fingerprint, bool needs_cloud) {
  const std::string folder = layout.PassDir(session, pass).string();
  const fs::path summary_path = layout.PassSummary(session, pass);
  for (const fs::path& file : {layout.PassPoses(session, pass), layout.PassStates(session, pass),
                               layout.PassMeasurements(session, pass)}) {
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

json PassSummaryHeader(const PassJob& job, const std::string& fingerprint,
                       const json& options_json) {
  const slam::RowPass& pass = job.pass;
  json summary;
  summary["session"] = job.session();
  summary["pass"] = pass.id;
  summary["row"] = pass.row;
  summary["direction"] = pass.direction;
  summary["t_begin_ns"] = pass.t_begin;
  summary["t_end_ns"] = pass.t_end;
  summary["sensors"] = slam::ToString(job.ctx.sensors);
  summary["pose_frame"] = job.streams.camera != nullptr ? "camera" : "body";
  summary["fingerprint"] = fingerprint;
  summary["options"] = options_json;
  return summary;
}

void RecordSensorGaps(const PassJob& job, json* summary) {
  const std::vector<Timestamp>& times = job.times;
  const std::string& session = job.session();
  const std::string& pass = job.pass.id;
  if (const slam::ImuStream* imu = job.streams.imu) {
    // An IMU outage inside the pass is bridged by the camera and the GP prior only: recorded
    // for the session's grade (season_quality.h).
    std::vector<Timestamp> imu_times;
    imu_times.reserve(imu->samples.size());
    for (const slam::ImuSample& sample : imu->samples) imu_times.push_back(sample.timestamp);
    const slam::TimeGaps gaps =
        slam::FindTimeGaps(imu_times, times.front(), times.back(), kImuGapWarnSeconds);
    if (gaps.count_over > 0) {
      spdlog::warn(
          "{}/{}: {} gap(s) without IMU samples longer than {:.1f} s inside the pass, the "
          "longest {:.1f} s",
          session, pass, gaps.count_over, kImuGapWarnSeconds, gaps.longest_s);
    }
    (*summary)["longest_imu_gap_s"] = gaps.longest_s;
  }
  if (const slam::GpsStream* gps = job.streams.gps) {
    // Warn about GPS outages inside the pass (the IMU and the camera bridge them).
    std::vector<Timestamp> fix_times;
    fix_times.reserve(gps->fixes.size());
    for (const slam::GpsFixWorld& fix : gps->fixes) fix_times.push_back(fix.t);
    const slam::TimeGaps gaps =
        slam::FindTimeGaps(fix_times, times.front(), times.back(), kGpsGapFlagSeconds);
    if (gaps.count_over > 0) {
      const char* bridge = job.streams.imu == nullptr ? "the camera and the GP prior bridge them"
                           : job.streams.camera != nullptr ? "the IMU and the camera bridge them"
                                                           : "the IMU bridges them";
      spdlog::warn(
          "{}/{}: {} gap(s) without a GPS fix longer than {:.0f} s inside the pass, the "
          "longest {:.1f} s; {}",
          session, pass, gaps.count_over, kGpsGapFlagSeconds, gaps.longest_s, bridge);
    }
    (*summary)["longest_gps_gap_s"] = gaps.longest_s;
    (*summary)["gps_gaps"] = gaps.count_over;
  }
}

void RecordPassProblem(const PassJob& job, const slam::RowOptimiser::Input& input,
                       const std::vector<bool>& still, const slam::RowOptimiser::Summary& s,
                       json* summary) {
  const PassStreams& streams = job.streams;
  workspace::PassPriors p;
  p.camera = streams.camera != nullptr ? streams.camera->sensor.name : "";
  p.imu = streams.imu != nullptr ? streams.imu->sensor.name : "";
  p.use_imu = streams.imu != nullptr;
  p.level_up_body = input.level_up_body;
  p.gps = streams.gps != nullptr ? streams.gps->sensor.name : "";
  for (const GpsOutage& g : job.options.gps_outages) {
    p.gps_outages.emplace_back(g.start_s, g.duration_s);
  }
  p.imu_noise_factor = job.ctx.imu_noise_factor;
  p.anchor_state = input.anchor_state;
  p.anchor_sigma_velocity = input.anchor_sigma_velocity;
  p.still_intervals = workspace::StillRanges(still);
  p.forward_axis_body = input.forward_axis_body;
  p.bias_prior_mean = input.bias_prior_mean;
  p.bias_prior_sigma = input.bias_prior_sigma;
  if (s.length_prior_m > 0) {
    p.length_prior = std::make_pair(s.length_prior_m, s.length_prior_sigma_m);
  }
  (*summary)["problem"] = workspace::ToJson(p);
}

void WritePassMeasurementsFile(const PassJob& job) {
  const PassStreams& streams = job.streams;
  workspace::WritePassMeasurements(
      job.layout.PassMeasurements(job.session(), job.pass.id).string(),
      workspace::SelectPassMeasurements(streams.camera, streams.imu, streams.gps, job.times,
                                        job.times.front(), job.times.back(), job.ctx.image_folder));
}

void RecordSolve(const PassJob& job, const PassInitialisation& init, int num_images,
                 const slam::RowOptimiser::Input& input, const slam::RowOptimiser::Summary& s,
                 json* summary) {
  (*summary)["states"] = s.num_states;
  (*summary)["images"] = num_images;
  (*summary)["initialisation"] = InitialisationJson(init);
  (*summary)["back_end"] = BackEndJson(s);
  if (s.time_offset_estimated) {
    spdlog::info("{}/{}: camera-IMU time offset {:+.1f} ms (capture instant - image stamp)",
                 job.session(), job.pass.id, 1e3 * s.time_offset_s);
  }
  if (input.camera_height_m) {
    // The soil's depth below the camera before the rescale, and the scale it set (1: too few
    // soil landmarks to measure it).
    (*summary)["camera_height"] = {{"height_m", *input.camera_height_m},
                                   {"soil_depth_m", s.soil_depth_m},
                                   {"soil_points", s.soil_points},
                                   {"scale", s.camera_height_scale}};
  }
}

void WritePassSummaryJson(const PassJob& job, const std::vector<bool>& still,
                          const slam::RowOptimiser::Summary& s, const PassSeconds& seconds,
                          json summary) {
  summary["trust"] = TrustFlags(job.ctx, job.pass, still, summary);
  summary["seconds"] = {
      {"front_end", seconds.front_end},       {"initialisation", seconds.initialisation},
      {"inertial_solve", s.inertial_seconds}, {"triangulation", s.triangulation_seconds},
      {"full_solve", s.full_solve_seconds},   {"final_solve", s.final_solve_seconds},
      {"outputs", seconds.outputs},           {"total", seconds.total}};
  const std::string& session = job.session();
  workspace::RecordOutputs(&summary, job.layout.PassDir(session, job.pass.id),
                           PassOutputs(job.layout, session, job.pass.id));
  workspace::WritePassSummary(job.layout.PassSummary(session, job.pass.id).string(),
                              std::move(summary));
}

}  // namespace crop4d::pipeline
