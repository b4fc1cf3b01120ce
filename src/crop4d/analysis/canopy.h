#pragma once

// Canopy measurements of one session's registered cloud (DESIGN.md §2.6): per measurement site
// the canopy height, cover and volume, and a canopy height model (CHM) raster.
//
// Heights are above a ground function (the DTM of analysis/terrain.h, or the paper's plane of a
// site). A point is canopy when the colour test calls it vegetation (analysis/vegetation.h) and
// it lies at least `min_height_m` above the ground (green soil, moss and noise do not make a
// canopy), or when it lies at least `min_height_any_colour_m` above the ground whatever its
// colour (colour combined with height above the terrain). Points are binned into square cells of
// `cell_m`; a cell's canopy height is the highest canopy point in it (0 for a cell with only ground
// points), so the statistics below weigh the area of the canopy, not the density of the cloud,
// which varies with texture and distance.
//
// At a site (centre, radius; io::Site):
//   cover      canopy cells / cells with points, within the radius;
//   volume_m3  mean canopy height of the cells with points × the site's area (holes of a sparse
//              cloud count as their surroundings);
//   height_m   the canopy top: with kPlantTops (default) and the site's plant stems
//              (analysis/plants.h), the mean over the plants whose stems lie in the site of each
//              plant's top, the highest canopy within `top_radius_m` of its stem — what a person
//              with a ruler measures, plant by plant; without stems, or with kCrownPeaks, the
//              mean height of the crown tops in the site — the cells that are the highest canopy
//              within `crown_radius_m` around them, and not lower than `min_peak_fraction` of the
//              site's highest canopy; with kQuantile, the `top_quantile` quantile of the canopy
//              cells' heights.
// A site without points, or with fewer than `min_canopy_cells` canopy cells, has no height (NaN)
// and a note that says why; its cover is still reported when it has points.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "crop4d/analysis/terrain.h"
#include "crop4d/core/option_check.h"
#include "crop4d/io/dataset.h"

namespace crop4d::analysis {

// One session's cloud, ready for analysis.
struct SessionCloud {
  std::string session;                              // session id
  std::vector<Eigen::Vector3d> points;              // ENU metres
  std::vector<std::array<std::uint8_t, 3>> colors;  // RGB, one per point
  std::vector<std::uint8_t> is_vegetation;          // one per point (vegetation.h)

  GroundCloud AsGround() const { return {&points, &is_vegetation}; }
  // The points at `positions`, in that order, with their colours and flags.
  SessionCloud Take(const std::vector<std::size_t>& positions) const;
};

// The ground height at (x, y), NaN where unknown.
using GroundFunction = std::function<double(double x, double y)>;

enum class CanopyTop { kPlantTops, kCrownPeaks, kQuantile };
// "plant-tops", "crown-peaks", "quantile".
const char* CanopyTopName(CanopyTop top);

struct CanopyOptions {
  // Vegetation points (by colour) are canopy at least this high above the ground, metres.
  double min_height_m = 0.02;
  // Points this high above the ground are canopy whatever their colour, metres: in a dense
  // cloud a cell between leaves takes the leaf's height but the colour of the soil seen through
  // the gap, and shaded leaves lose their green; nothing but plants stands this far above the
  // terrain model (its residuals are a few millimetres).
  double min_height_any_colour_m = 0.04;
  // Whether a point of vegetation flag `vegetation` at height `h` above the ground is canopy.
  bool IsCanopy(bool vegetation, double h) const {
    return h >= (vegetation ? min_height_m : min_height_any_colour_m);
  }
  // Side of the cells that points are binned into, metres.
  double cell_m = 0.02;
  // How the canopy top of a site is computed (see the header comment).
  CanopyTop top = CanopyTop::kPlantTops;
  // kPlantTops: a plant's top is the `plant_top_quantile` quantile of the canopy cells within
  // this radius of its stem, metres: the stem found early is a few centimetres off the top
  // (island centroids, leaning plants). On the demo's dense clouds 5 / 8 / 10 / 12 cm gave 30 /
  // 21 / 18 / 17 mm RMSE; on clouds of the true meshes a larger radius reaches the neighbours'
  // leaves (8 / 10 cm: 10–13 / 11–14 mm), hence 8 cm.
  double top_radius_m = 0.08;
  // kPlantTops: 1 takes the highest cell. Lower values discount one noisy cell, but the top of a
  // plant covers few cells of a dense cloud (0.9: 37 mm RMSE on the demo against 18 mm).
  double plant_top_quantile = 1.0;
  // kPlantTops, across sessions: plants grow, so a plant's top is searched no higher than its top
  // in the next session plus this, m (negative: off). A false match that floats above a plant in
  // one session is then not taken for its top. Where a crop really shrinks between sessions
  // (lodging after a storm, wilting), set it to that loss or turn it off. On six fields only one
  // site/session changed, with 3 or 5 cm (bench/RESULTS.md, crop analysis).
  double max_shrink_m = 0.05;
  // kCrownPeaks: a crown top is the highest canopy within this radius, metres (about half the
  // distance between neighbouring plants' tops).
  double crown_radius_m = 0.08;
  // kCrownPeaks: crown tops lower than this fraction of the site's highest canopy are not
  // counted (leaves of a neighbouring plant's skirt, noise near the ground).
  double min_peak_fraction = 0.5;
  // kQuantile: quantile of the canopy cells' heights.
  double top_quantile = 0.95;
  // A site needs this many canopy cells for a height.
  int min_canopy_cells = 3;

  OptionCheck Check() const;
};

struct SiteCanopy {
  double height_m = 0.0;   // canopy top above the ground; NaN: no estimate (see note)
  double cover = 0.0;      // canopy cells / cells with points; NaN without points
  double volume_m3 = 0.0;  // NaN without points
  int n_points = 0;        // canopy points within the site
  int n_cells = 0;         // cells with points within the site
  int n_canopy_cells = 0;  // of which canopy
  int n_peaks = 0;         // plant tops (kPlantTops) or crown tops (kCrownPeaks) averaged
  int n_lowered = 0;       // plant tops lowered to their bound (max_tops)
  std::string note;        // why there is no height, empty otherwise
  // kPlantTops with stems: each stem's top, in the order of the stems (NaN: outside the site or
  // not seen).
  std::vector<double> plant_tops;
};

// Measures one site of one session's cloud above `ground`; `stems` (ENU xy, any extent; may be
// null) are the plants' stems for kPlantTops. `max_tops` (null, or one per stem; NaN: none)
// bounds each plant's top above the ground: canopy cells above it are left out of the plant's
// top unless no other cell remains (see CanopyOptions::max_shrink_m).
SiteCanopy MeasureSite(const SessionCloud& cloud, const GroundFunction& ground,
                       const io::Site& site, const CanopyOptions& options,
                       const std::vector<Eigen::Vector2d>* stems = nullptr,
                       const std::vector<double>* max_tops = nullptr);

// The half side of the square around a site's centre whose points MeasureSite reads, metres.
double SiteReach(const io::Site& site, const CanopyOptions& options);

// The points of `cloud` (with their colours and vegetation flags, in their order) within
// SiteReach of any of `sites`' centres: MeasureSite and FitSiteGroundPlane give on them what
// they give on the whole cloud, so a session's sites can be kept while its cloud is freed.
// Their positions in `cloud` into `taken` when not null.
SessionCloud SitePoints(const SessionCloud& cloud, const std::vector<io::Site>& sites,
                        const CanopyOptions& options, std::vector<std::size_t>* taken = nullptr);

// The canopy height model of a session over `num_cells` raster cells, `cell_of` giving the cell
// of an ENU xy (−1 outside the raster): per cell the highest canopy point above `ground`, 0 where
// the cell holds only ground points, NaN where it holds none (or the ground is unknown there).
std::vector<float> CanopyHeightModel(
    const SessionCloud& cloud, const GroundFunction& ground, std::size_t num_cells,
    const std::function<std::ptrdiff_t(const Eigen::Vector2d&)>& cell_of,
    const CanopyOptions& options);

// Adds `cloud` to a canopy height model made so (`chm`: NaN where no point was added yet):
// each cell keeps a maximum, so adding the parts of a cloud, each point once, gives the model
// of the whole cloud.
void AddToCanopyHeightModel(const SessionCloud& cloud, const GroundFunction& ground,
                            const std::function<std::ptrdiff_t(const Eigen::Vector2d&)>& cell_of,
                            const CanopyOptions& options, std::vector<float>* chm);

// The same on the nodes of `grid` (the cell of a node spans ± half a cell around it).
std::vector<float> CanopyHeightModel(const SessionCloud& cloud, const TerrainModel& terrain,
                                     const GridSpec& grid, const CanopyOptions& options);

}  // namespace crop4d::analysis
