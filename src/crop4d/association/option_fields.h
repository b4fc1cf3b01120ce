#pragma once

// The field lists of the association's option structs (core/option_fields.h): one VisitFields
// per struct, every data member in declaration order. A member added to a struct must be added
// here (the stage options test counts them).

#include <span>

#include "crop4d/association/footprint.h"
#include "crop4d/association/local_planes.h"
#include "crop4d/association/plane_warp.h"
#include "crop4d/association/prealignment.h"
#include "crop4d/association/robust_matcher.h"
#include "crop4d/association/surface_points.h"
#include "crop4d/core/option_fields.h"
#include "crop4d/features/option_fields.h"
#include "crop4d/fusion/option_fields.h"

namespace crop4d::association {

inline std::span<const fields::EnumName<RobustMatcher::PlaneFallback>> FieldEnumNames(
    RobustMatcher::PlaneFallback) {
  using P = RobustMatcher::PlaneFallback;
  static constexpr fields::EnumName<P> kNames[] = {{P::kGroundNormal, "ground-normal"},
                                                   {P::kNoWarp, "no-warp"}};
  return kNames;
}

template <class V>
void VisitFields(FootprintOptions& o, V&& visit) {
  visit("max_range_m", o.max_range_m);
  visit("samples_per_side", o.samples_per_side);
}

template <class V>
void VisitFields(PairSelectionOptions& o, V&& visit) {
  visit("footprint", o.footprint);
  visit("min_overlap", o.min_overlap);
  visit("max_pairs_per_image", o.max_pairs_per_image);
  visit("stride", o.stride);
  visit("max_axis_angle_deg", o.max_axis_angle_deg);
  visit("max_scale_change", o.max_scale_change);
  visit("view_samples", o.view_samples);
}

template <class V>
void VisitFields(SurfacePointOptions& o, V&& visit) {
  visit("num_neighbors", o.num_neighbors);
  visit("max_pixel_distance_px", o.max_pixel_distance_px);
  visit("min_sigma_m", o.min_sigma_m);
  visit("max_sigma_m", o.max_sigma_m);
  visit("min_incidence_cos", o.min_incidence_cos);
  visit("max_range_m", o.max_range_m);
}

template <class V>
void VisitFields(PlaneWarpOptions& o, V&& visit) {
  visit("descriptor_sigma", o.descriptor_sigma);
  visit("patches_per_batch", o.patches_per_batch);
  visit("map_node_spacing_px", o.map_node_spacing_px);
  visit("min_view_cosine", o.min_view_cosine);
  visit("max_area_change", o.max_area_change);
  visit("max_pyramid_level", o.max_pyramid_level);
  visit("upright", o.upright);
}

template <class V>
void VisitFields(RobustMatcher::Options& o, V&& visit) {
  visit("min_search_radius_px", o.min_search_radius_px);
  visit("search_sigmas", o.search_sigmas);
  visit("sigma_position_m", o.sigma_position_m);
  visit("sigma_rotation_rad", o.sigma_rotation_rad);
  visit("max_search_radius_px", o.max_search_radius_px);
  visit("min_depth_m", o.min_depth_m);
  visit("max_scale_ratio", o.max_scale_ratio);
  visit("warp_min_baseline_m", o.warp_min_baseline_m);
  visit("plane_fallback", o.plane_fallback);
  visit("warp", o.warp);
  visit("upright_after_warp", o.upright_after_warp);
  visit("max_ratio", o.max_ratio);
  visit("max_descriptor_distance", o.max_descriptor_distance);
  visit("same_point_radius_px", o.same_point_radius_px);
  visit("one_to_one", o.one_to_one);
  visit("verify", o.verify);
  visit("verification", o.verification);
}

template <class V>
void VisitFields(LocalPlanes::Options& o, V&& visit) {
  visit("num_neighbors", o.num_neighbors);
  visit("min_neighbors", o.min_neighbors);
  visit("max_neighbor_distance_m", o.max_neighbor_distance_m);
  visit("max_surface_variation", o.max_surface_variation);
  visit("min_spread_ratio", o.min_spread_ratio);
}

template <class V>
void VisitFields(PreAlignmentOptions& o, V&& visit) {
  visit("stride", o.stride);
  visit("radius_m", o.radius_m);
  visit("max_landmark_distance_m", o.max_landmark_distance_m);
  visit("naive", o.naive);
  visit("alignment", o.alignment);
}

}  // namespace crop4d::association
