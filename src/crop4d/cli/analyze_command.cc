// crop4d analyze: canopy height per site and session, cover, volume, growth curves, terrain and
// canopy height rasters (DESIGN.md §2.6); outputs in WS/analysis/ (pipeline/analyze_stage.h,
// docs/analysis.md).

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/pipeline/analyze_stage.h"

namespace crop4d::cli {
namespace {

struct AnalyzeArgs {
  std::string field;
  std::string workspace;
  std::string top = "plant-tops";
  std::string index = "exg";
  double vegetation_threshold = -1.0;
  bool single_session_terrain = false;
  int threads = 0;
  pipeline::AnalyzeStageOptions options;
};

int RunAnalyze(AnalyzeArgs& args) {
  pipeline::AnalyzeStageOptions& o = args.options;
  if (args.top == "plant-tops") {
    o.canopy.top = analysis::CanopyTop::kPlantTops;
  } else if (args.top == "crown-peaks") {
    o.canopy.top = analysis::CanopyTop::kCrownPeaks;
  } else if (args.top == "quantile") {
    o.canopy.top = analysis::CanopyTop::kQuantile;
  } else {
    throw InputError("--canopy-top", 0,
                     "expected plant-tops, crown-peaks or quantile, got '" + args.top + "'");
  }
  if (args.index == "exg") {
    o.vegetation.index = analysis::GreennessIndex::kExG;
  } else if (args.index == "exgr") {
    o.vegetation.index = analysis::GreennessIndex::kExGR;
  } else {
    throw InputError("--greenness", 0, "expected exg or exgr, got '" + args.index + "'");
  }
  if (args.vegetation_threshold >= 0.0) o.vegetation.threshold = args.vegetation_threshold;
  o.terrain.use_later_sessions = !args.single_session_terrain;
  if (o.cloud != "auto" && o.cloud != "dense" && o.cloud != "sparse") {
    throw InputError("--cloud", 0, "expected auto, dense or sparse, got '" + o.cloud + "'");
  }
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d analyze", 0, why);
  std::optional<tbb::global_control> limit;
  if (args.threads > 0) {
    limit.emplace(tbb::global_control::max_allowed_parallelism, args.threads);
  }
  const auto lock = LockWorkspace(args.workspace, "crop4d analyze", /*create=*/false);
  const pipeline::AnalyzeReport report = pipeline::RunAnalyzeStage(args.field, args.workspace, o);
  if (!IsQuiet()) {
    std::fputs(pipeline::FormatAnalyzeReport(report).c_str(), stdout);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

RunFunction SetupAnalyze(CLI::App& app) {
  auto args = std::make_shared<AnalyzeArgs>();
  pipeline::AnalyzeStageOptions& o = args->options;
  app.description(
      "Crop analysis (docs/analysis.md): vegetation by colour, a terrain model that follows beds "
      "and furrows, canopy height, cover and volume per site and session — above the terrain "
      "model and, for comparison, above the paper's single plane per site — logistic growth "
      "curves, and terrain and canopy height GeoTIFFs in the field's UTM zone. Uses the dense "
      "clouds of `crop4d densify` when they exist, else the sparse clouds of `crop4d fuse`. "
      "Writes WS/analysis/; skipped when its inputs have not changed.\n\nExample:\n  crop4d "
      "analyze demo/field --workspace demo/workspace");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace with fused (or dense) clouds")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--sites", o.sites_file,
                 "Sites CSV (site_id,x,y,radius_m in ENU metres, or site_id,lat,lon,radius_m); "
                 "default: the sites of field.yaml")
      ->check(CLI::ExistingFile);
  app.add_option("--cloud", o.cloud, "Clouds to analyse: auto (dense when present), dense, sparse")
      ->capture_default_str();
  app.add_option("--greenness", args->index, "Colour index of vegetation: exg or exgr")
      ->capture_default_str();
  app.add_option("--vegetation-threshold", args->vegetation_threshold,
                 "Fixed threshold of the colour index (default: automatic, Otsu)");
  app.add_option("--terrain-cell", o.terrain.cell_m, "Terrain model node spacing, m")
      ->capture_default_str();
  app.add_option("--terrain-radius", o.terrain.fit_radius_m,
                 "Radius of each terrain node's local surface fit, m")
      ->capture_default_str();
  app.add_option("--ground-filter-window", o.terrain.ground_filter.window_m,
                 "Soil-coloured points above the opening of the ground with this window are not "
                 "ground (wider than a row's canopy; 0: no filter), m")
      ->check(CLI::Range(0.0, 100.0))
      ->capture_default_str();
  app.add_option("--ground-filter-height", o.terrain.ground_filter.max_height_m,
                 "... when more than this above it, m")
      ->check(CLI::Range(0.001, 10.0))
      ->capture_default_str();
  app.add_flag("--first-session-terrain", args->single_session_terrain,
               "Build the terrain from the earliest session only (no later ground points)");
  app.add_option("--min-canopy-height", o.canopy.min_height_m,
                 "Vegetation lower than this above the terrain is not canopy, m")
      ->capture_default_str();
  app.add_option("--min-canopy-height-any-colour", o.canopy.min_height_any_colour_m,
                 "Points this high above the terrain are canopy whatever their colour, m")
      ->capture_default_str();
  app.add_option("--canopy-top", args->top,
                 "Canopy top statistic of a site: plant-tops (mean of the tops of the plants "
                 "found at the site), crown-peaks (mean of the crown tops) or quantile")
      ->capture_default_str();
  app.add_option(
         "--top-radius", o.canopy.top_radius_m,
         "plant-tops: a plant's top is the highest canopy within this radius of its stem, m")
      ->capture_default_str();
  app.add_option("--plant-top-quantile", o.canopy.plant_top_quantile,
                 "plant-tops: quantile of the canopy cells within --top-radius that is the top")
      ->capture_default_str();
  app.add_option("--max-shrink", o.canopy.max_shrink_m,
                 "plant-tops: a plant's top is searched no higher than its top in the next "
                 "session plus this, m (plants grow; negative: off)")
      ->capture_default_str();
  app.add_option("--plant-min-cells", o.plants.min_cells,
                 "Smallest island of canopy that is a plant, in cells of --plant-cell")
      ->capture_default_str();
  app.add_option("--plant-cell", o.plants.cell_m, "Cell of the plant detection mask, m")
      ->capture_default_str();
  app.add_option("--plant-min-prominence", o.plants.min_prominence_m,
                 "An island of canopy is split into two plants where the lower top rises at "
                 "least this much above the saddle between them, m...")
      ->capture_default_str();
  app.add_option("--plant-min-prominence-fraction", o.plants.min_prominence_fraction,
                 "...and at least this fraction of its own height")
      ->capture_default_str();
  app.add_option("--plant-max-row-offset", o.plants.max_row_offset_m,
                 "Where field.yaml declares rows, plants farther than this from every row's "
                 "centre line (weeds, noise between the rows) count at no site, m (0: off)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--crown-radius", o.canopy.crown_radius_m,
                 "crown-peaks: a crown top is the highest canopy within this radius, m")
      ->capture_default_str();
  app.add_option("--top-quantile", o.canopy.top_quantile, "quantile: the quantile (0..1]")
      ->capture_default_str();
  app.add_option("--lone-point-radius", o.lone_point_radius_m,
                 "Dense clouds: a point without another point within this radius is a false match "
                 "and left out, m (0: keep every point)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1.0));
  app.add_option("--tile", o.tile_m,
                 "Each session's cloud is read in tiles of this length along the analysed area, "
                 "so that it is never held whole, m (0: one tile)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--raster-cell", o.raster_cell_m, "Cell of the GeoTIFF rasters, m")
      ->capture_default_str();
  app.add_flag(
      "--no-rasters", [&o](std::int64_t) { o.write_rasters = false; },
      "Do not write the GeoTIFF rasters");
  app.add_flag(
      "--no-plots", [&o](std::int64_t) { o.write_plots = false; }, "Do not write the plots");
  app.add_option("--threads", args->threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  app.add_flag("--force", o.force, "Analyse again even when the inputs have not changed");
  return [args] { return RunAnalyze(*args); };
}

}  // namespace crop4d::cli
