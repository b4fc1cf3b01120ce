// crop4d report: the season report WS/report.html, one self-contained HTML file with the field
// map, per-stage statistics and timings, the cross-section figure, canopy heights, growth and
// the evaluation (report/html_report.h, docs/report.md).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/report/html_report.h"

namespace crop4d::cli {
namespace {

struct ReportArgs {
  std::string workspace;
  std::string field;
  std::string output;
  std::optional<int> row;
  bool no_cross_section = false;
  bool sparse_section = false;
  report::HtmlReportOptions options;
};

int RunReport(ReportArgs& args) {
  report::HtmlReportOptions& o = args.options;
  o.cross_section = !args.no_cross_section;
  o.cross_section_row = args.row;
  o.cross_section_dense = !args.sparse_section;
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d report", 0, why);
  const auto lock = LockWorkspace(args.workspace, "crop4d report", /*create=*/false);
  const report::HtmlReportResult result =
      report::WriteHtmlReport(args.workspace, args.field, args.output, o);
  for (const std::string& line : result.skipped) spdlog::warn("report: {}", line);
  int with_data = 0;
  for (const report::HtmlReportSection& s : result.sections) {
    if (s.has_data) {
      ++with_data;
    } else if (s.id != "skipped") {
      spdlog::info("report: section '{}' has no data", s.title);
    }
  }
  std::fprintf(stderr, "report: %d of %zu sections with data, %.1f MB, in %s\n", with_data,
               result.sections.size(), result.bytes / 1e6, result.path.c_str());
  return 0;
}

}  // namespace

RunFunction SetupReport(CLI::App& app) {
  auto args = std::make_shared<ReportArgs>();
  report::HtmlReportOptions& o = args->options;
  app.description(
      "Write the season report (docs/report.md): one self-contained HTML file (images embedded, "
      "nothing loaded from the network) with the run's per-stage status and timings, what was "
      "skipped, the field map with each session's trajectory, row SLAM, association, fusion and "
      "densification statistics, the cross-section figure, canopy height per site and date with "
      "the measurements, growth rates and, when ground truth was evaluated, the evaluation. Every "
      "input is optional: a stage that has not run leaves a one-line note.\n\nExamples:\n"
      "  crop4d report --workspace demo/workspace --field demo/field\n"
      "  crop4d report -w ws --output /tmp/season.html");
  app.add_option("-w,--workspace", args->workspace, "Workspace folder")
      ->required()
      ->check(CLI::ExistingDirectory)
      ->type_name("WS");
  app.add_option("--field", args->field,
                 "Field folder: rows and sites for the map and the cross-section, measurements "
                 "from ground_truth/site_measurements.csv")
      ->check(CLI::ExistingDirectory)
      ->type_name("FIELD");
  app.add_option("-o,--output", args->output, "The report (default: WS/report.html)")
      ->type_name("FILE.html");
  app.add_option("--title", o.title, "Page title (default: from the field's name)");
  app.add_option("--section-row", args->row,
                 "Draw the cross-section across this row of field.yaml (default: the middle row)")
      ->type_name("N");
  app.add_option("--section-thickness", o.cross_section_thickness_m,
                 "Full width of the cross-section slice, metres")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_option("--section-half-length", o.cross_section_half_length_m,
                 "The slice runs this many metres either side of the row")
      ->capture_default_str()
      ->check(CLI::PositiveNumber);
  app.add_flag("--section-sparse", args->sparse_section,
               "Draw the cross-section from the fused (or row SLAM) clouds even where a dense "
               "cloud exists (faster)");
  app.add_flag("--no-section", args->no_cross_section,
               "Leave the cross-section figure out (it reads every session's cloud)");
  return [args] { return RunReport(*args); };
}

}  // namespace crop4d::cli
