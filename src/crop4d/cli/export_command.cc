// crop4d export: the workspace's results in standard formats (PLY, LAS 1.4, COLMAP text, TUM,
// GeoTIFF, CSV) in a folder of their own (DESIGN.md §5; pipeline/export_stage.h,
// docs/export.md).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/pipeline/export_stage.h"
#include "crop4d/viewer/static_viewer.h"

namespace crop4d::cli {
namespace {

struct ExportArgs {
  std::string field;
  std::string workspace;
  std::string out;
  std::string viewer;  // --viewer: the static viewer folder
  std::vector<std::string> formats;
  pipeline::ExportOptions options;
};

int RunExportCommand(ExportArgs& args) {
  if (args.out.empty() && args.viewer.empty())
    throw InputError("crop4d export", 0, "nothing to write: give --out, --viewer or both");
  if (!args.out.empty() && args.field.empty())
    throw InputError("crop4d export", 0, "--out needs --field (the field's origin and sessions)");
  if (!args.viewer.empty()) {
    // The viewer as a static folder (docs/viewer.md): the page, the tiles, the report.
    viewer::ViewerDataOptions viewer_options;
    viewer_options.field = args.field;  // the analysis terrain and the declared sites
    const viewer::ViewerDataSummary summary =
        viewer::WriteStaticViewer(args.workspace, args.viewer, viewer_options);
    if (!IsQuiet()) {
      std::printf("viewer: %s (host it with any web server)\n%s", args.viewer.c_str(),
                  viewer::FormatViewerDataSummary(summary).c_str());
      std::fflush(stdout);
    }
    if (args.out.empty()) return 0;
  }
  pipeline::ExportOptions& o = args.options;
  o.formats.clear();
  for (const std::string& f : args.formats) {
    if (f == "all") {
      o.formats = pipeline::ExportFormatNames();
      break;
    }
    if (!f.empty()) o.formats.push_back(f);
  }
  std::string why;
  if (!o.Check(&why)) throw InputError("crop4d export", 0, why);
  const pipeline::ExportReport report =
      pipeline::RunExport(args.field, args.workspace, args.out, o);
  if (!IsQuiet()) {
    std::fputs(pipeline::FormatExportReport(report).c_str(), stdout);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

RunFunction SetupExport(CLI::App& app) {
  auto args = std::make_shared<ExportArgs>();
  args->formats = args->options.formats;
  app.description(
      "Export a workspace's results in standard formats (docs/export.md): PLY point clouds per "
      "session (ply/<session>_sparse.ply: the fused sparse cloud, or the row-SLAM clouds of the "
      "passes merged; ply/<session>_dense.ply), LAS 1.4 clouds in the field's UTM zone with "
      "ellipsoidal heights (las/, on request), the fused COLMAP text model (colmap/), camera "
      "trajectories (tum/<session>.tum, or tum/<session>_<pass>.tum from row SLAM), the GeoTIFF "
      "rasters and CSV tables of `crop4d analyze` (geotiff/, csv/), and OUT/export.json listing "
      "every file. A format whose inputs are missing is skipped with a warning.\n\nExamples:\n"
      "  crop4d export --workspace demo/workspace --field demo/field --out demo/export\n"
      "  crop4d export -w demo/workspace --field demo/field -o out --format ply,las "
      "--clouds dense\n"
      "  crop4d export -w demo/workspace --viewer demo/viewer   (the 4D viewer as a static site)");
  app.add_option("-w,--workspace", args->workspace, "Workspace to export")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--field", args->field,
                 "Field folder (docs/format.md): origin and sessions (needed with --out)")
      ->check(CLI::ExistingDirectory);
  app.add_option("-o,--out", args->out, "Output folder (created when missing)");
  app.add_option("--viewer", args->viewer,
                 "Also (or only) write the 4D viewer as a static folder any web server can host "
                 "(docs/viewer.md)");
  app.add_option("--format", args->formats,
                 "Formats, comma-separated: ply, las, colmap, tum, geotiff, csv, or all")
      ->delimiter(',')
      ->capture_default_str();
  app.add_option("--clouds", args->options.clouds, "Clouds written as ply and las")
      ->check(CLI::IsMember({"dense", "sparse", "both"}))
      ->capture_default_str();
  return [args] {
    args->options.show_progress = true;
    return RunExportCommand(*args);
  };
}

}  // namespace crop4d::cli
