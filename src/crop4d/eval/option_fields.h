#pragma once

// The field lists of the evaluation's option structs (core/option_fields.h): one VisitFields per
// struct, every data member in declaration order. A member added to a struct must be added here
// (the stage options test counts them).

#include "crop4d/core/option_fields.h"
#include "crop4d/eval/association_eval.h"
#include "crop4d/eval/canopy_eval.h"
#include "crop4d/eval/dense_eval.h"
#include "crop4d/eval/fused_eval.h"
#include "crop4d/eval/ground_misalignment.h"
#include "crop4d/eval/trajectory_metrics.h"
#include "crop4d/eval/truth_geometry.h"
#include "crop4d/eval/workspace_eval.h"

namespace crop4d::eval {

template <class V>
void VisitFields(TrajectoryMetricsOptions& o, V&& visit) {
  visit("rpe_distance_m", o.rpe_distance_m);
}

template <class V>
void VisitFields(TruePointOptions& o, V&& visit) {
  visit("max_edge_m", o.max_edge_m);
  visit("max_depth_m", o.max_depth_m);
}

template <class V>
void VisitFields(AssociationEvalOptions& o, V&& visit) {
  visit("max_distance_m", o.max_distance_m);
  visit("coarse_distance_m", o.coarse_distance_m);
  visit("near_depth_m", o.near_depth_m);
  visit("true_point", o.true_point);
}

template <class V>
void VisitFields(GroundSelectionOptions& o, V&& visit) {
  visit("plant_margin_m", o.plant_margin_m);
  visit("max_terrain_distance_m", o.max_terrain_distance_m);
}

template <class V>
void VisitFields(GroundMisalignmentOptions& o, V&& visit) {
  visit("radius_m", o.radius_m);
  visit("min_points", o.min_points);
  visit("max_slope_deg", o.max_slope_deg);
  visit("max_query_points", o.max_query_points);
}

template <class V>
void VisitFields(CloudSetOptions& o, V&& visit) {
  visit("selection", o.selection);
  visit("misalignment", o.misalignment);
}

template <class V>
void VisitFields(CanopyEvalOptions& o, V&& visit) {
  visit("max_error_m", o.max_error_m);
  visit("sessions", o.sessions, fields::Role::kControl);
}

template <class V>
void VisitFields(DenseEvalOptions& o, V&& visit) {
  visit("top_radius_m", o.top_radius_m);
  visit("tolerance_m", o.tolerance_m);
  visit("ground", o.ground);
}

template <class V>
void VisitFields(WorkspaceEvalOptions& o, V&& visit) {
  visit("metrics", o.metrics);
  visit("max_dt_s", o.max_dt_s);
  visit("sessions", o.sessions, fields::Role::kControl);
  visit("associations", o.associations);
  visit("association", o.association);
  visit("depth_cache_dir", o.depth_cache_dir, fields::Role::kControl);
  visit("render_depth", o.render_depth);
  visit("fused", o.fused);
  visit("clouds", o.clouds);
  visit("canopy", o.canopy);
  visit("canopy_options", o.canopy_options);
  visit("dense", o.dense);
  visit("dense_options", o.dense_options);
}

}  // namespace crop4d::eval
