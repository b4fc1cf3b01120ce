#pragma once

// The field lists of the crop analysis's option structs (core/option_fields.h): one VisitFields
// per struct, every data member in declaration order. A member added to a struct must be added
// here (the stage options test counts them).

#include <span>

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/ground_filter.h"
#include "crop4d/analysis/growth.h"
#include "crop4d/analysis/plants.h"
#include "crop4d/analysis/terrain.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/option_fields.h"

namespace crop4d::analysis {

// The names of GreennessIndexName ("ExG", "ExGR": what `crop4d export` reads back from the
// analysis summary's options).
inline std::span<const fields::EnumName<GreennessIndex>> FieldEnumNames(GreennessIndex) {
  static const fields::EnumName<GreennessIndex> kNames[] = {
      {GreennessIndex::kExG, GreennessIndexName(GreennessIndex::kExG)},
      {GreennessIndex::kExGR, GreennessIndexName(GreennessIndex::kExGR)}};
  return kNames;
}

// The names of CanopyTopName (the configuration file's `analyze.canopy_top`).
inline std::span<const fields::EnumName<CanopyTop>> FieldEnumNames(CanopyTop) {
  static const fields::EnumName<CanopyTop> kNames[] = {
      {CanopyTop::kPlantTops, CanopyTopName(CanopyTop::kPlantTops)},
      {CanopyTop::kCrownPeaks, CanopyTopName(CanopyTop::kCrownPeaks)},
      {CanopyTop::kQuantile, CanopyTopName(CanopyTop::kQuantile)}};
  return kNames;
}

template <class V>
void VisitFields(VegetationOptions& o, V&& visit) {
  visit("index", o.index);
  visit("threshold", o.threshold);
  visit("min_threshold", o.min_threshold);
  visit("min_separability", o.min_separability);
  visit("histogram_bins", o.histogram_bins);
}

template <class V>
void VisitFields(GroundFilterOptions& o, V&& visit) {
  visit("window_m", o.window_m);
  visit("cell_m", o.cell_m);
  visit("max_height_m", o.max_height_m);
}

template <class V>
void VisitFields(TerrainOptions& o, V&& visit) {
  visit("cell_m", o.cell_m);
  visit("fit_radius_m", o.fit_radius_m);
  visit("min_points", o.min_points);
  visit("min_points_per_quadrant", o.min_points_per_quadrant);
  visit("outlier_sigmas", o.outlier_sigmas);
  visit("noise_floor_m", o.noise_floor_m);
  visit("iterations", o.iterations);
  visit("ground_filter", o.ground_filter);
  visit("use_later_sessions", o.use_later_sessions);
  visit("later_tolerance_m", o.later_tolerance_m);
  visit("vegetation_clearance_m", o.vegetation_clearance_m);
  visit("max_fill_distance_m", o.max_fill_distance_m);
  visit("thin_cell_m", o.thin_cell_m);
}

template <class V>
void VisitFields(CanopyOptions& o, V&& visit) {
  visit("min_height_m", o.min_height_m);
  visit("min_height_any_colour_m", o.min_height_any_colour_m);
  visit("cell_m", o.cell_m);
  visit("top", o.top);
  visit("top_radius_m", o.top_radius_m);
  visit("plant_top_quantile", o.plant_top_quantile);
  visit("max_shrink_m", o.max_shrink_m);
  visit("crown_radius_m", o.crown_radius_m);
  visit("min_peak_fraction", o.min_peak_fraction);
  visit("top_quantile", o.top_quantile);
  visit("min_canopy_cells", o.min_canopy_cells);
}

template <class V>
void VisitFields(PlantDetectionOptions& o, V&& visit) {
  visit("cell_m", o.cell_m);
  visit("min_cells", o.min_cells);
  visit("max_area_m2", o.max_area_m2);
  visit("top_fraction", o.top_fraction);
  visit("min_prominence_m", o.min_prominence_m);
  visit("min_prominence_fraction", o.min_prominence_fraction);
  visit("min_spacing_m", o.min_spacing_m);
  visit("max_row_offset_m", o.max_row_offset_m);
}

template <class V>
void VisitFields(PlaneOptions& o, V&& visit) {
  visit("inlier_threshold_m", o.inlier_threshold_m);
  visit("iterations", o.iterations);
  visit("min_points", o.min_points);
  visit("seed", o.seed);
}

template <class V>
void VisitFields(GrowthOptions& o, V&& visit) {
  visit("robust_loss_m", o.robust_loss_m);
  visit("max_iterations", o.max_iterations);
  visit("max_asymptote_factor", o.max_asymptote_factor);
  visit("max_rate_per_day", o.max_rate_per_day);
}

}  // namespace crop4d::analysis
