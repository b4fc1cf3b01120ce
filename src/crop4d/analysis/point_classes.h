#pragma once

// The ASPRS classes of a cloud's points as the analysis separates the ground from the vegetation
// (docs/analysis.md): above the terrain model by the canopy rule (CanopyOptions::IsCanopy:
// vegetation by colour at min_height_m, any colour at min_height_any_colour_m) → vegetation,
// 3/4/5 by height (io::AsprsVegetationClass); otherwise → ground (2). Unclassified (1): points
// outside the terrain model or where it has no height, more than kBelowTerrainM below it, and the
// lone points the analysis leaves out of a dense cloud (analysis/lone_points.h).

#include <cstddef>
#include <map>
#include <string>

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/las.h"
#include "crop4d/io/ply.h"

namespace crop4d::analysis {

// A point this far below the terrain model is not ground (a false match below the soil), m.
inline constexpr double kBelowTerrainM = 0.10;

// What the analysis used to separate ground and vegetation.
struct PointClassRule {
  io::GeoTiffRaster dtm;  // the terrain model, ellipsoidal heights (the LAS z convention)
  GreennessIndex index = GreennessIndex::kExG;
  CanopyOptions canopy;  // min_height_m, min_height_any_colour_m
  double lone_point_radius_m = 0.0;
  std::map<std::string, double> thresholds;  // the vegetation threshold of each session analysed
};

// Sets the class of `points` (the LAS points of `cloud`, in its order, in the DTM's CRS) by
// `rule`; `threshold`: the session's vegetation threshold; `dense`: the cloud is a dense cloud
// (its lone points are left unclassified).
void ClassifyPoints(const PointClassRule& rule, double threshold, bool dense,
                    const io::PlyPointCloud& cloud, io::LasPoint* points);

}  // namespace crop4d::analysis
