#pragma once

// The crop analysis stage (`crop4d analyze`, DESIGN.md §2.6): what the user came for — how tall
// the crop is at each site on each date, and how fast it grows.
//
// Inputs: every session with a registered cloud in the workspace, the dense cloud
// WS/dense/<session>.ply when it exists, else the fused sparse cloud
// WS/fused/<session>/sparse.ply (any registered coloured PLY clouds in the field's ENU frame
// work); the sites of field.yaml or of a sites file; the measurements of
// FIELD/ground_truth/site_measurements.csv for the plots when present.
//
// Each session's cloud is read a tile of the analysed area at a time (pipeline/analyze_tiles.h):
// its memory follows a tile, and the results are those of whole sessions.
//
// Steps (library analysis/):
//   1. vegetation by colour in each session (ExG, Otsu threshold; analysis/vegetation.h);
//   2. the terrain model from the earliest session's ground, refined with later sessions' ground
//      that the vegetation does not cover (analysis/terrain.h), over the sites and rows;
//   3. per site and session: canopy height, cover, volume (analysis/canopy.h), above the DTM and,
//      for comparison, above the paper's single RANSAC plane per site;
//   4. per site: a logistic growth curve and the growth rate of every session interval
//      (analysis/growth.h);
//   5. rasters and plots.
//
// Outputs in WS/analysis/ (all written atomically):
//   site_heights.csv               site_id,session,date,height_m,cover,volume_m3,n_points
//                                  (height_m empty where there is no estimate)
//   site_heights_single_plane.csv  the same above the paper's plane per site
//   growth.csv                     per site: status, asymptote_m, rate_per_day, midpoint_date,
//                                  max_growth_m_per_day, rmse_m, n, then one column
//                                  growth_<from>_<to>_m_per_day per session interval
//   dtm.tif                        the terrain, ellipsoidal height [m], UTM zone of the field
//   chm_<session>.tif              canopy height above the terrain [m], 0 on bare ground
//   chm_change_<earlier>_<later>.tif   the canopy height change between consecutive sessions
//                                  (dates in order): chm(later) − chm(earlier) [m], nodata where
//                                  either has none; metadata: both sessions and dates
//                                  (all rasters Cloud-Optimized GeoTIFFs, io/geotiff.h)
//   plots/heights.png              canopy height versus date, one panel per site, with the
//                                  measured heights when present
//   plots/height_<site>.png        the same, one site per figure
//   summary.json                   per-session cloud and vegetation statistics, terrain summary,
//                                  options, times and a fingerprint of the inputs: an unchanged
//                                  workspace is not analysed again (unless `force`).

#include <string>
#include <vector>

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/growth.h"
#include "crop4d/analysis/plants.h"
#include "crop4d/analysis/site_series.h"
#include "crop4d/analysis/sites.h"
#include "crop4d/analysis/terrain.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"

namespace crop4d::pipeline {

struct AnalyzeStageOptions {
  // Sites file (CSV: site_id,x,y,radius_m in ENU metres, or site_id,lat,lon,radius_m); empty:
  // the sites of field.yaml.
  std::string sites_file;
  // Which clouds: "auto" (dense when present, else sparse), "dense" or "sparse".
  std::string cloud = "auto";
  analysis::VegetationOptions vegetation;
  analysis::TerrainOptions terrain;
  analysis::CanopyOptions canopy;
  analysis::PlantDetectionOptions plants;
  analysis::PlaneOptions plane;
  analysis::GrowthOptions growth;
  // A point of a dense cloud without another point within this radius (3D) is a false match
  // floating alone and is left out of the analysis (analysis/lone_points.h), metres; 0 keeps
  // every point. Sparse clouds are kept whole (their points are centimetres apart).
  double lone_point_radius_m = 0.05;
  // Each session's cloud is read a tile of the analysed area at a time, strips of at most this
  // length across the area's longer side (pipeline/analyze_tiles.h), metres; 0: one tile. The
  // results do not depend on it (to rounding); the memory follows a tile, and every tile reads
  // a few decimetres around it as well.
  double tile_m = 5.0;
  // Cell of the canopy height and terrain rasters, metres.
  double raster_cell_m = 0.02;
  // The analysed area: the rows of field.yaml and the sites, widened by this margin, metres.
  double margin_m = 1.0;
  bool write_rasters = true;
  bool write_plots = true;
  bool force = false;

  OptionCheck Check() const;
};

struct AnalyzeSessionReport {
  std::string session;
  Timestamp date = 0;
  std::string cloud_path;  // the cloud analysed
  bool dense = false;
  std::size_t points = 0;              // within the analysed area, lone points left out
  std::size_t lone_points = 0;         // left out (AnalyzeStageOptions::lone_point_radius_m)
  std::size_t plants = 0;              // plants found (analysis/plants.h)
  std::size_t plant_tops_lowered = 0;  // tops bounded by the next session's (max_shrink_m)
  analysis::VegetationClassification vegetation;  // `index` and flags cleared after use
};

// One site in one session; a site's growth (analysis/site_series.h).
using SiteResult = analysis::SiteResult;
using SiteGrowth = analysis::SiteGrowth;

struct AnalyzeReport {
  bool skipped = false;  // up to date
  std::vector<AnalyzeSessionReport> sessions;
  analysis::TerrainSummary terrain;
  std::vector<SiteResult> sites;  // site-major, sessions in date order
  std::vector<SiteGrowth> growth;
  std::vector<std::string> outputs;  // files written, relative to the workspace
  double seconds = 0.0;
};

// Runs the stage. Throws InputError for a field or workspace that cannot be read (no registered
// clouds: run `crop4d fuse` first; no sites; a damaged cloud or sites file).
AnalyzeReport RunAnalyzeStage(const std::string& field_folder, const std::string& workspace,
                              const AnalyzeStageOptions& options);

// The per-site height table (sites × sessions, ours and the single-plane method) and the growth
// fits, for the terminal.
std::string FormatAnalyzeReport(const AnalyzeReport& report);

// Reads a sites file (see AnalyzeStageOptions::sites_file; analysis/sites.h).
using analysis::ReadSitesCsv;

}  // namespace crop4d::pipeline
