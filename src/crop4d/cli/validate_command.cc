// crop4d validate FIELD: checks a field folder (docs/format.md) and reports every problem with
// its file and line. Exit code 0 when there is no error (warnings allowed), 2 otherwise.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/validator.h"

namespace crop4d::cli {
namespace {

struct ValidateArgs {
  std::string field;
  std::string json_path;
  int max_messages = 20;
  io::ValidateOptions options;
};

int RunValidate(const ValidateArgs& args) {
  io::ValidateOptions options = args.options;
  options.progress = !IsQuiet();
  const io::ValidationReport report = io::ValidateField(args.field, options);

  // Diagnostics to stderr, at most max_messages per file.
  std::map<std::string, int> shown;
  std::map<std::string, int> hidden;
  for (const io::Diagnostic& d : report.diagnostics) {
    int& count = shown[d.file];
    if (args.max_messages > 0 && count >= args.max_messages) {
      ++hidden[d.file];
      continue;
    }
    ++count;
    std::fprintf(stderr, "%s\n", d.ToString().c_str());
  }
  for (const auto& [file, count] : report.suppressed) hidden[file] += static_cast<int>(count);
  for (const auto& [file, count] : hidden) {
    std::fprintf(stderr, "note: %s: %d more problem%s not shown%s\n", file.c_str(), count,
                 count == 1 ? "" : "s",
                 args.max_messages > 0 ? " (--max-messages 0 shows all)" : "");
  }

  // The summary table, unless there is nothing to summarise (e.g. no such folder).
  if (!IsQuiet() && (report.ok() || !report.sessions.empty())) {
    std::fputs(io::FormatValidationSummary(report).c_str(), stdout);
    std::fflush(stdout);
  }
  if (!args.json_path.empty())
    io::WriteFileAtomic(args.json_path, io::ValidationReportJson(report));
  std::fprintf(stderr, "validate: %zu error%s, %zu warning%s in %s\n", report.errors,
               report.errors == 1 ? "" : "s", report.warnings, report.warnings == 1 ? "" : "s",
               args.field.c_str());
  return report.ok() ? 0 : 2;
}

}  // namespace

RunFunction SetupValidate(CLI::App& app) {
  auto args = std::make_shared<ValidateArgs>();
  app.description(
      "Check a field folder in the crop4d dataset format (docs/format.md): field.yaml, every "
      "session's session.yaml, each sensor's sensor.yaml and data.csv, and the images.\n"
      "Prints every problem as 'error|warning: FILE:LINE: message' (paths relative to FIELD) "
      "and a summary per session and sensor: sample count, mean rate, time span, gaps, "
      "skipped lines, GPS fixes, images.\n"
      "Errors: unparseable lines (column count, non-numbers), NaN/inf, timestamps not strictly "
      "increasing, empty sensor files, malformed YAML or missing required keys, listed images "
      "missing or unreadable. Warnings: gaps, rates off nominal, unknown YAML keys, images not "
      "listed, values out of physical range.\n"
      "Exit code: 0 without errors (warnings allowed), 2 when there is an error.");
  app.add_option("FIELD", args->field, "The field folder (holds field.yaml and sessions/)")
      ->required();
  app.add_option("--json", args->json_path,
                 "Also write the whole report (summary and every problem) as JSON to FILE")
      ->type_name("FILE");
  app.add_option("--session", args->options.sessions,
                 "Check only this session (repeatable; default: every session)")
      ->type_name("ID");
  app.add_flag("--decode-images", args->options.decode_images,
               "Decode every image completely (finds truncated files; slower) instead of "
               "checking file headers and sizes");
  app.add_option("--gap-periods", args->options.gap_periods,
                 "Report a gap when consecutive samples are more than this many nominal periods "
                 "apart")
      ->capture_default_str()
      ->check(CLI::Range(1.0, 1e9));
  app.add_option("--rate-tolerance", args->options.rate_tolerance,
                 "Report a mean rate further than this fraction from rate_hz")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1e3));
  app.add_option("--max-messages", args->max_messages,
                 "Print at most this many problems per file (0 = all); the JSON report and the "
                 "counts always have all")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber);
  return [args] { return RunValidate(*args); };
}

}  // namespace crop4d::cli
