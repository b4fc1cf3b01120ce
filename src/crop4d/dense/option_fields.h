#pragma once

// The field lists of the dense reconstruction's option structs (core/option_fields.h): one
// VisitFields per struct, every data member in declaration order. A member added to a struct
// must be added here (the stage options test counts them).

#include "crop4d/core/option_fields.h"
#include "crop4d/dense/ground_levels.h"
#include "crop4d/dense/height_field_stereo.h"

namespace crop4d::dense {

template <class V>
void VisitFields(HeightFieldStereo::Options& o, V&& visit) {
  visit("cell_m", o.cell_m);
  visit("tile_cells", o.tile_cells);
  visit("patch_radius", o.patch_radius);
  visit("below_ground_m", o.below_ground_m);
  visit("max_canopy_height_m", o.max_canopy_height_m);
  visit("coarse_step_m", o.coarse_step_m);
  visit("fine_half_range_m", o.fine_half_range_m);
  visit("fine_step_m", o.fine_step_m);
  visit("fine_patch_radius", o.fine_patch_radius);
  visit("max_views", o.max_views);
  visit("near_time_s", o.near_time_s);
  visit("near_time_min_green", o.near_time_min_green);
  visit("max_view_distance_m", o.max_view_distance_m);
  visit("image_margin_px", o.image_margin_px);
  visit("min_reference_separation_m", o.min_reference_separation_m);
  visit("min_views", o.min_views);
  visit("min_score", o.min_score);
  visit("min_texture", o.min_texture);
  visit("min_uniqueness", o.min_uniqueness);
  visit("top_surface_margin", o.top_surface_margin);
  visit("top_surface_min_reference_score", o.top_surface_min_reference_score);
  visit("top_surface_min_height_m", o.top_surface_min_height_m);
  visit("top_surface_min_excess_green", o.top_surface_min_excess_green);
  visit("min_neighbours", o.min_neighbours);
  visit("neighbour_tolerance_m", o.neighbour_tolerance_m);
  visit("max_blocked_rays", o.max_blocked_rays);
  visit("visibility_tolerance_m", o.visibility_tolerance_m);
  visit("cross_check_m", o.cross_check_m);
  visit("island_area_m2", o.island_area_m2);
  visit("island_max_disagreement_m", o.island_max_disagreement_m);
  visit("island_max_rise_m", o.island_max_rise_m);
  visit("island_radius_m", o.island_radius_m);
  visit("vegetation_weight", o.vegetation_weight);
  visit("highpass_sigma_px", o.highpass_sigma_px);
  visit("highpass_gain", o.highpass_gain);
  visit("load_block_m", o.load_block_m, fields::Role::kControl);
  visit("show_progress", o.show_progress, fields::Role::kControl);
}

template <class V>
void VisitFields(GroundLevels::Options& o, V&& visit) {
  visit("tile_m", o.tile_m);
  visit("quantile", o.quantile);
  visit("min_points", o.min_points);
}

template <class V>
void VisitFields(CanopyCeilingOptions& o, V&& visit) {
  visit("quantile", o.quantile);
  visit("scale", o.scale);
  visit("margin_m", o.margin_m);
  visit("min_m", o.min_m);
  visit("near_band_m", o.near_band_m);
}

}  // namespace crop4d::dense
