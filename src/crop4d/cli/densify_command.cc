// crop4d densify: dense per-session point clouds by height-field multi-view stereo from the fused
// cameras (DESIGN.md §2.5); outputs in WS/dense/ (pipeline/densify_stage.h).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/pipeline/densify_stage.h"

namespace crop4d::cli {
namespace {

struct DensifyArgs {
  std::string field;
  std::string workspace;
  std::vector<std::string> boxes;
  std::vector<std::string> near;
  pipeline::DensifyStageOptions options;
};

// "a,b[,c,d]" → numbers; InputError naming the option otherwise.
std::vector<double> ParseNumbers(const std::string& option, const std::string& text,
                                 std::size_t count) {
  std::vector<double> values;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    try {
      std::size_t used = 0;
      values.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw InputError(option, 0, "'" + text + "' is not a list of numbers");
    }
  }
  if (values.size() != count) {
    throw InputError(
        option, 0,
        "expected " + std::to_string(count) + " comma-separated numbers, got '" + text + "'");
  }
  return values;
}

int RunDensify(DensifyArgs& args) {
  pipeline::DensifyStageOptions& o = args.options;
  for (const std::string& b : args.boxes) {
    const std::vector<double> v = ParseNumbers("--box", b, 4);
    if (!(v[0] < v[2] && v[1] < v[3])) {
      throw InputError("--box", 0, "expected XMIN,YMIN,XMAX,YMAX with XMIN < XMAX, YMIN < YMAX");
    }
    o.boxes.emplace_back(Eigen::Vector2d(v[0], v[1]), Eigen::Vector2d(v[2], v[3]));
  }
  for (const std::string& p : args.near) {
    const std::vector<double> v = ParseNumbers("--near", p, 2);
    o.centers.emplace_back(v[0], v[1]);
  }
  if (!(o.stereo.cell_m >= 0.002 && o.stereo.cell_m <= 0.1)) {
    throw InputError("--cell", 0, "expected a cell size in [0.002, 0.1] m");
  }
  if (!(o.stereo.max_canopy_height_m > 0 && o.stereo.max_canopy_height_m <= 5)) {
    throw InputError("--max-canopy-height", 0, "expected a height in (0, 5] m");
  }
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d densify", 0, why);
  const auto lock = LockWorkspace(args.workspace, "crop4d densify", /*create=*/false);
  const std::vector<pipeline::DensifySessionReport> reports =
      pipeline::RunDensifyStage(args.field, args.workspace, o);
  if (!IsQuiet()) {
    std::fputs(pipeline::FormatDensifyReport(reports).c_str(), stdout);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

RunFunction SetupDensify(CLI::App& app) {
  auto args = std::make_shared<DensifyArgs>();
  pipeline::DensifyStageOptions& o = args->options;
  app.description(
      "Dense point cloud per session (DESIGN.md §2.5) by height-field multi-view stereo from the "
      "fused cameras: on a regular ENU grid over the crop rows, every cell's height is swept "
      "between bounds from the sparse cloud and scored by the normalised cross-correlation of a "
      "small ground patch in several views; confident cells become points (soil and the tops of "
      "the plants) coloured from their reference image. Writes WS/dense/<session>.ply and "
      "WS/dense/<session>.json; a session whose inputs have not changed is skipped.\n\nExamples:\n"
      "  crop4d densify demo/field --workspace demo/workspace\n"
      "  crop4d densify demo/field -w demo/workspace --session 2016-06-01 --around-sites");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace with the output of `crop4d fuse`")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--session", o.sessions, "Session to densify (repeatable; default: all fused)");
  app.add_option(
         "--cell", o.stereo.cell_m,
         "Grid cell size, m; the 5x5 matching patch spans 5 cells and must fit on a top leaflet")
      ->capture_default_str();
  app.add_option("--max-canopy-height", o.stereo.max_canopy_height_m,
                 "Highest plant top searched above the ground, m (the ceiling's upper bound)")
      ->capture_default_str();
  app.add_flag("--fixed-ceiling{false}", o.adaptive_ceiling,
               "Search up to --max-canopy-height in every session, not only up to the canopy "
               "that the session's sparse cloud shows");
  app.add_option("--margin", o.margin_m, "Margin around the crop rows of field.yaml, m")
      ->capture_default_str();
  app.add_option("--box", args->boxes,
                 "Only cells in this box XMIN,YMIN,XMAX,YMAX (ENU m; repeatable)");
  app.add_option("--near", args->near, "Only cells within --radius of this point X,Y (repeatable)");
  app.add_flag("--around-sites", o.around_sites,
               "Only cells within --radius of the sites of field.yaml");
  app.add_option("--radius", o.radius_m, "Radius for --near and --around-sites, m")
      ->capture_default_str();
  app.add_option("--max-views", o.stereo.max_views, "Images matched per tile, references included")
      ->capture_default_str();
  app.add_option("--near-time", o.stereo.near_time_s,
                 "Tiles with plants are matched in images captured within this time of their "
                 "reference, s: leaves sway in the wind (0: any time)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  app.add_option("--load-block", o.stereo.load_block_m,
                 "Tiles are matched block by block, squares of this side, m, with only the "
                 "images they select in memory (the result does not depend on it)")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--min-score", o.stereo.min_score, "Least aggregated ZNCC of a kept point (-1..1)")
      ->capture_default_str();
  app.add_option("--top-surface-margin", o.stereo.top_surface_margin,
                 "A green peak above a cell's best height, scoring at most this much less, is "
                 "taken instead: the top leaves (0: off)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 2.0));
  app.add_option("--threads", o.num_threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  app.add_flag("--force", o.force, "Densify again even when the inputs have not changed");
  return [args] { return RunDensify(*args); };
}

}  // namespace crop4d::cli
