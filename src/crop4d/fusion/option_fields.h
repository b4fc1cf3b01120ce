#pragma once

// The field lists of the fusion's option structs (core/option_fields.h): one VisitFields per
// struct, every data member in declaration order. A member added to a struct must be added here
// (the stage options test counts them).

#include "crop4d/core/option_fields.h"
#include "crop4d/fusion/block_solve.h"
#include "crop4d/fusion/ground_ties.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/fusion/pass_alignment.h"
#include "crop4d/slam/option_fields.h"

namespace crop4d::fusion {

template <class V>
void VisitFields(PassAlignmentOptions& o, V&& visit) {
  visit("inlier_threshold_m", o.inlier_threshold_m);
  visit("ransac_iterations", o.ransac_iterations);
  visit("min_inliers", o.min_inliers);
  visit("min_sample_distance_m", o.min_sample_distance_m);
  visit("seed", o.seed);
}

template <class V>
void VisitFields(GroundTieOptions& o, V&& visit) {
  visit("max_excess_green", o.max_excess_green);
  visit("band_half_width_m", o.band_half_width_m);
  visit("min_depth_below_camera_m", o.min_depth_below_camera_m);
  visit("segment_m", o.segment_m);
  visit("cell_along_m", o.cell_along_m);
  visit("cell_across_m", o.cell_across_m);
  visit("min_points", o.min_points);
  visit("max_heading_difference_deg", o.max_heading_difference_deg);
}

template <class V>
void VisitFields(CalibrationRefinementOptions& o, V&& visit) {
  visit("refine", o.refine);
  visit("min_cross_observations", o.min_cross_observations);
  visit("focal_sigma_px", o.focal_sigma_px);
  visit("principal_point_sigma_px", o.principal_point_sigma_px);
  visit("distortion_sigma", o.distortion_sigma);
  visit("rotation_sigma_deg", o.rotation_sigma_deg);
  visit("lever_arm_sigma_m", o.lever_arm_sigma_m);
  visit("refine_lever_arm", o.refine_lever_arm);
}

template <class V>
void VisitFields(BlockSolveOptions& o, V&& visit) {
  visit("max_observations", o.max_observations);
  visit("sweeps", o.sweeps);
}

template <class V>
void VisitFields(JointOptimiser::Options& o, V&& visit) {
  visit("row", o.row);
  visit("align_passes", o.align_passes);
  visit("precise_gps_sigma_m", o.precise_gps_sigma_m);
  visit("alignment", o.alignment);
  visit("ground_tie_sigma_across_m", o.ground_tie_sigma_across_m);
  visit("ground_tie_sigma_vertical_m", o.ground_tie_sigma_vertical_m);
  visit("ground_tie_loss_scale", o.ground_tie_loss_scale);
  visit("estimate_time_offset", o.estimate_time_offset);
  visit("clock_line_sigma_s", o.clock_line_sigma_s);
  visit("calibration", o.calibration);
}

}  // namespace crop4d::fusion
