#pragma once

// The field lists of the stages' option structs and of `crop4d run`'s configuration
// (core/option_fields.h), and from them the options each stage records in its summary.json and
// fingerprint: every field that changes what the stage computes (fields::Role::kResult), nested
// structs included, so that changing any of them reruns the stage. The kControl fields (which
// sessions or passes, threads, progress, force, cache paths) are left out: they change how or
// which part of the stage runs, not its results.
//
// A member added to an option struct must be added to its VisitFields (here, or in the
// option_fields.h of its module); the stage options test fails until it is.

#include <Eigen/Core>
#include <nlohmann/json.hpp>
#include <span>
#include <string>
#include <vector>

#include "crop4d/analysis/option_fields.h"
#include "crop4d/association/option_fields.h"
#include "crop4d/core/option_fields.h"
#include "crop4d/dense/option_fields.h"
#include "crop4d/eval/option_fields.h"
#include "crop4d/features/option_fields.h"
#include "crop4d/fusion/option_fields.h"
#include "crop4d/pipeline/analyze_stage.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/pipeline/run_config.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/slam/option_fields.h"

namespace crop4d::pipeline {

// The names of ToString(PassMode) (the configuration file's `slam.passes`).
inline std::span<const fields::EnumName<PassMode>> FieldEnumNames(PassMode) {
  static const fields::EnumName<PassMode> kNames[] = {
      {PassMode::kAuto, ToString(PassMode::kAuto)},
      {PassMode::kRows, ToString(PassMode::kRows)},
      {PassMode::kWhole, ToString(PassMode::kWhole)}};
  return kNames;
}

template <class V>
void VisitFields(GpsOutage& o, V&& visit) {
  visit("start_s", o.start_s);
  visit("duration_s", o.duration_s);
}

template <class V>
void VisitFields(SlamStageOptions& o, V&& visit) {
  using fields::Role;
  visit("session", o.session, Role::kControl);
  visit("pass", o.pass, Role::kControl);
  visit("passes_only", o.passes_only, Role::kControl);
  visit("sensors", o.sensors);
  visit("camera", o.camera);
  visit("imu", o.imu);
  visit("gps_outages", o.gps_outages);
  visit("state_rate_hz", o.state_rate_hz);
  visit("session_state_rate_hz", o.session_state_rate_hz);
  visit("session_solve_max_sigma_m", o.session_solve_max_sigma_m);
  visit("session_bias_sigma_gyro", o.session_bias_sigma_gyro);
  visit("session_bias_sigma_accel", o.session_bias_sigma_accel);
  visit("front_end", o.front_end);
  visit("passes", o.passes);
  visit("pass_mode", o.pass_mode);
  visit("max_window_s", o.max_window_s);
  visit("window_overlap_s", o.window_overlap_s);
  visit("initialisation", o.initialisation);
  visit("visual_initialisation", o.visual_initialisation);
  visit("optimiser", o.optimiser);
  visit("cloud", o.cloud);
  visit("motion_constraint", o.motion_constraint);
  visit("standstills", o.standstills);
  visit("imu_noise_auto", o.imu_noise_auto);
  visit("camera_height_m", o.camera_height_m);
  visit("use_camera_height", o.use_camera_height);
  visit("force", o.force, Role::kControl);
  visit("show_progress", o.show_progress, Role::kControl);
}

template <class V>
void VisitFields(AssociateStageOptions& o, V&& visit) {
  using fields::Role;
  visit("method", o.method);
  // Which pass pairs are matched, not how: a pair's associations do not depend on them.
  visit("session", o.session, Role::kControl);
  visit("pair", o.pair, Role::kControl);
  visit("same_session", o.same_session, Role::kControl);
  visit("cross_session", o.cross_session, Role::kControl);
  visit("session_gap", o.session_gap, Role::kControl);
  visit("image_pairs", o.image_pairs);
  visit("min_track_length", o.min_track_length);
  visit("max_landmark_distance_m", o.max_landmark_distance_m);
  visit("surface_points", o.surface_points);
  visit("surface", o.surface);
  visit("robust", o.robust);
  visit("naive", o.naive);
  visit("prealign", o.prealign);
  visit("imprecise_sigma_position_m", o.imprecise_sigma_position_m);
  visit("prealign_stride", o.prealign_stride);
  visit("prealign_radius_m", o.prealign_radius_m);
  visit("prealigned_sigma_position_m", o.prealigned_sigma_position_m);
  visit("alignment", o.alignment);
  visit("num_threads", o.num_threads, Role::kControl);
  visit("force", o.force, Role::kControl);
  visit("show_progress", o.show_progress, Role::kControl);
}

template <class V>
void VisitFields(QualityOptions& o, V&& visit) {
  visit("max_imu_gap_s", o.max_imu_gap_s);
  visit("max_gps_rejected_share", o.max_gps_rejected_share);
}

template <class V>
void VisitFields(FuseStageOptions& o, V&& visit) {
  visit("method", o.method);
  visit("full", o.full);
  visit("full_sweeps", o.full_sweeps);
  visit("one_problem", o.one_problem);
  visit("window_sessions", o.window_sessions);
  visit("max_matches_per_image_pair", o.max_matches_per_image_pair);
  visit("optimiser", o.optimiser);
  visit("blocks", o.blocks);
  visit("ground_ties", o.ground_ties);
  visit("ground_tie_max_matches", o.ground_tie_max_matches);
  visit("ground_tie", o.ground_tie);
  visit("cloud", o.cloud);
  visit("write_colmap", o.write_colmap);
  visit("quality", o.quality);
  visit("force", o.force, fields::Role::kControl);
}

template <class V>
void VisitFields(DensifyStageOptions& o, V&& visit) {
  using fields::Role;
  visit("sessions", o.sessions, Role::kControl);
  visit("camera", o.camera);
  visit("margin_m", o.margin_m);
  visit("boxes", o.boxes);
  visit("centers", o.centers);
  visit("around_sites", o.around_sites);
  visit("radius_m", o.radius_m);
  visit("stereo", o.stereo);
  visit("ground", o.ground);
  visit("adaptive_ceiling", o.adaptive_ceiling);
  visit("ceiling", o.ceiling);
  visit("num_threads", o.num_threads, Role::kControl);
  visit("force", o.force, Role::kControl);
  visit("show_progress", o.show_progress, Role::kControl);
}

template <class V>
void VisitFields(AnalyzeStageOptions& o, V&& visit) {
  visit("sites_file", o.sites_file);
  visit("cloud", o.cloud);
  visit("vegetation", o.vegetation);
  visit("terrain", o.terrain);
  visit("canopy", o.canopy);
  visit("plants", o.plants);
  visit("plane", o.plane);
  visit("growth", o.growth);
  visit("lone_point_radius_m", o.lone_point_radius_m);
  visit("tile_m", o.tile_m);
  visit("raster_cell_m", o.raster_cell_m);
  visit("margin_m", o.margin_m);
  visit("write_rasters", o.write_rasters);
  visit("write_plots", o.write_plots);
  visit("force", o.force, fields::Role::kControl);
}

// The whole configuration of `crop4d run`; its keys (run_config_keys.cc) are bound to these
// fields by their dotted paths ("slam.front_end.num_neighbors").
template <class V>
void VisitFields(RunConfig& o, V&& visit) {
  visit("threads", o.threads, fields::Role::kControl);
  visit("densify", o.densify);
  visit("eval", o.eval);
  visit("report", o.report);
  visit("slam", o.slam);
  visit("associate", o.associate);
  visit("fuse", o.fuse);
  visit("densify_options", o.densify_options);
  visit("analyze", o.analyze);
  visit("eval_options", o.eval_options);
}

// What each stage records as its options (summary.json "options") and hashes into its
// fingerprint: every kResult field, with the values the stage resolved in place of the options'
// (the sensor set of the session, the association method of this run, the disc centres with the
// field's sites).

inline nlohmann::json SlamOptionsJson(const SlamStageOptions& options, slam::SensorSet sensors) {
  nlohmann::json j = fields::OptionsToJson(options);
  j["sensors"] = fields::ValueToJson(sensors);
  return j;
}

inline nlohmann::json AssociateOptionsJson(const AssociateStageOptions& options,
                                           const std::string& method) {
  nlohmann::json j = fields::OptionsToJson(options);
  j["method"] = method;
  return j;
}

inline nlohmann::json FuseOptionsJson(const FuseStageOptions& options) {
  return fields::OptionsToJson(options);
}

inline nlohmann::json DensifyOptionsJson(const DensifyStageOptions& options,
                                         const std::vector<Eigen::Vector2d>& centers) {
  nlohmann::json j = fields::OptionsToJson(options);
  j["centers"] = fields::ValueToJson(centers);
  return j;
}

inline nlohmann::json AnalyzeOptionsJson(const AnalyzeStageOptions& options) {
  return fields::OptionsToJson(options);
}

}  // namespace crop4d::pipeline
