#pragma once

// The field lists of row SLAM's option structs (core/option_fields.h): one VisitFields per
// struct, every data member in declaration order. A member added to a struct must be added here
// (the stage options test counts them).

#include <span>

#include "crop4d/core/option_fields.h"
#include "crop4d/slam/camera_height_scale.h"
#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/image_quality.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/slam/sensor_set.h"
#include "crop4d/slam/session_solve.h"
#include "crop4d/slam/standstill.h"
#include "crop4d/slam/triangulation.h"
#include "crop4d/slam/visual_initialisation.h"

namespace crop4d::slam {

// The names of ToString(SensorSet).
inline std::span<const fields::EnumName<SensorSet>> FieldEnumNames(SensorSet) {
  static const fields::EnumName<SensorSet> kNames[] = {
      {SensorSet::kCamImuRtk, ToString(SensorSet::kCamImuRtk)},
      {SensorSet::kCamImuGps, ToString(SensorSet::kCamImuGps)},
      {SensorSet::kCamImu, ToString(SensorSet::kCamImu)},
      {SensorSet::kImuRtk, ToString(SensorSet::kImuRtk)},
      {SensorSet::kCamRtk, ToString(SensorSet::kCamRtk)},
      {SensorSet::kCamGps, ToString(SensorSet::kCamGps)}};
  return kNames;
}

template <class V>
void VisitFields(RowPassSegmenter::Options& o, V&& visit) {
  visit("row_spacing_m", o.row_spacing_m);
  visit("velocity_window_s", o.velocity_window_s);
  visit("min_velocity_window_s", o.min_velocity_window_s);
  visit("max_velocity_window_s", o.max_velocity_window_s);
  visit("heading_tolerance_rad", o.heading_tolerance_rad);
  visit("min_speed_mps", o.min_speed_mps);
  visit("min_length_m", o.min_length_m);
  visit("max_join_gap_s", o.max_join_gap_s);
  visit("refine_max_noise_m", o.refine_max_noise_m);
  visit("row_axis_rad", o.row_axis_rad);
  visit("lateral_origin_m", o.lateral_origin_m);
  visit("max_row_distance_m", o.max_row_distance_m);
  visit("relative_matching_noise_m", o.relative_matching_noise_m);
  visit("antenna_in_body_xy", o.antenna_in_body_xy);
  visit("min_row_time_fraction", o.min_row_time_fraction);
  visit("min_row_passes", o.min_row_passes);
  visit("max_row_step", o.max_row_step);
  visit("require_row_structure", o.require_row_structure);
}

template <class V>
void VisitFields(StateInitialiser::Options& o, V&& visit) {
  visit("gps_half_window_s", o.gps_half_window_s);
  visit("gravity_half_window_s", o.gravity_half_window_s);
  visit("min_speed_for_course", o.min_speed_for_course);
  visit("alignment_window_s", o.alignment_window_s);
  visit("alignment_step_s", o.alignment_step_s);
  visit("alignment_min_horizontal_change", o.alignment_min_horizontal_change);
  visit("gravity", o.gravity);
}

template <class V>
void VisitFields(VisualInitialisationOptions& o, V&& visit) {
  visit("min_correspondences", o.min_correspondences);
  visit("ransac_threshold_px", o.ransac_threshold_px);
  visit("ransac_confidence", o.ransac_confidence);
  visit("min_inlier_fraction", o.min_inlier_fraction);
  visit("min_step_m", o.min_step_m);
  visit("min_usable_fraction", o.min_usable_fraction);
}

template <class V>
void VisitFields(TriangulationOptions& o, V&& visit) {
  visit("min_parallax_deg", o.min_parallax_deg);
  visit("max_reprojection_error_px", o.max_reprojection_error_px);
  visit("min_depth_m", o.min_depth_m);
  visit("max_depth_m", o.max_depth_m);
  visit("refine_iterations", o.refine_iterations);
}

template <class V>
void VisitFields(GpPriorFactor::Options& o, V&& visit) {
  visit("qc_translation", o.qc_translation);
  visit("qc_rotation", o.qc_rotation);
}

template <class V>
void VisitFields(StandstillOptions& o, V&& visit) {
  visit("window_s", o.window_s);
  visit("mean_change_sigmas", o.mean_change_sigmas);
  visit("gyro_floor", o.gyro_floor);
  visit("accel_floor", o.accel_floor);
  visit("max_gravity_error", o.max_gravity_error);
  visit("max_image_motion_px", o.max_image_motion_px);
  visit("max_gps_speed", o.max_gps_speed);
  visit("min_duration_s", o.min_duration_s);
  visit("sigma_velocity", o.sigma_velocity);
  visit("sigma_rate", o.sigma_rate);
  visit("sigma_translation", o.sigma_translation);
  visit("sigma_rotation", o.sigma_rotation);
}

template <class V>
void VisitFields(CameraHeightOptions& o, V&& visit) {
  visit("max_excess_green", o.max_excess_green);
  visit("max_lateral_m", o.max_lateral_m);
  visit("quantile", o.quantile);
  visit("min_points", o.min_points);
  visit("sigma_relative", o.sigma_relative);
  visit("max_scale_change", o.max_scale_change);
  visit("triangulation", o.triangulation);
}

template <class V>
void VisitFields(RowOptimiser::Options& o, V&& visit) {
  visit("reprojection_sigma_px", o.reprojection_sigma_px);
  visit("reprojection_loss_scale", o.reprojection_loss_scale);
  visit("max_reprojection_error_px", o.max_reprojection_error_px);
  visit("min_observations", o.min_observations);
  visit("triangulation", o.triangulation);
  visit("max_outliers_per_track", o.max_outliers_per_track);
  visit("gps_loss_scale", o.gps_loss_scale);
  visit("gps_gate_chi2", o.gps_gate_chi2);
  visit("gp", o.gp);
  visit("bias_prior_sigma_gyro", o.bias_prior_sigma_gyro);
  visit("bias_prior_sigma_accel", o.bias_prior_sigma_accel);
  visit("anchor_sigma_position", o.anchor_sigma_position);
  visit("anchor_sigma_rotation", o.anchor_sigma_rotation);
  visit("anchor_sigma_velocity", o.anchor_sigma_velocity);
  visit("motion_constraint_sigma", o.motion_constraint_sigma);
  visit("level_prior_sigma_rad", o.level_prior_sigma_rad);
  visit("max_imu_gap_s", o.max_imu_gap_s);
  visit("standstill", o.standstill);
  visit("image_weighting", o.image_weighting);
  visit("max_iterations", o.max_iterations);
  visit("iterative_schur", o.iterative_schur);
  visit("max_linear_iterations", o.max_linear_iterations);
  visit("function_tolerance", o.function_tolerance);
  visit("num_threads", o.num_threads, fields::Role::kControl);
  visit("camera_height", o.camera_height);
  visit("estimate_time_offset", o.estimate_time_offset);
  visit("time_offset_prior_sigma_s", o.time_offset_prior_sigma_s);
  visit("max_abs_time_offset_s", o.max_abs_time_offset_s);
}

template <class V>
void VisitFields(ImageWeightOptions& o, V&& visit) {
  visit("enabled", o.enabled);
  visit("window", o.window);
  visit("max_sigma_scale", o.max_sigma_scale);
}

template <class V>
void VisitFields(ImuPreintegration::Options& o, V&& visit) {
  visit("gyro_noise_density", o.gyro_noise_density);
  visit("accel_noise_density", o.accel_noise_density);
  visit("gyro_random_walk", o.gyro_random_walk);
  visit("accel_random_walk", o.accel_random_walk);
  visit("gravity", o.gravity);
  visit("covariance_regularisation", o.covariance_regularisation);
}

template <class V>
void VisitFields(ForwardAxisOptions& o, V&& visit) {
  visit("min_turn_rate_rad_s", o.min_turn_rate_rad_s);
  visit("min_speed_m_s", o.min_speed_m_s);
  visit("min_states", o.min_states);
}

template <class V>
void VisitFields(SessionSolveOptions& o, V&& visit) {
  visit("state_rate_hz", o.state_rate_hz);
  visit("imu_noise_auto", o.imu_noise_auto);
  visit("initialisation", o.initialisation);
  visit("optimiser", o.optimiser);
  visit("forward_axis", o.forward_axis);
}

}  // namespace crop4d::slam
