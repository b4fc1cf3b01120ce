// The terminal summary of `crop4d run` (FormatRunSummary, season_run.h): the stages' table, what
// was skipped or degraded, the headline figures of WS/eval/metrics.json and where the report is.

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <optional>

#include "crop4d/core/error.h"
#include "crop4d/pipeline/season_run.h"
#include "crop4d/workspace/eval_metrics.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

namespace fs = std::filesystem;

namespace {

// A length in metres as centimetres, "n/a" when the metrics do not have it.
std::string Cm(const std::optional<double>& metres) {
  return metres ? fmt::format("{:.2f} cm", 100.0 * *metres) : "n/a";
}

// The headline figures of WS/eval/metrics.json; "" when there is no such file, a line saying why
// when it cannot be read.
std::string EvalHeadlines(const workspace::Layout& layout) {
  const fs::path path = layout.EvalMetrics();
  std::error_code ec;
  if (!fs::exists(path, ec)) return "";
  workspace::EvalMetrics m;
  try {
    m = workspace::ReadEvalMetrics(path.string());
  } catch (const InputError& e) {
    return fmt::format("\nevaluation metrics not read: {}\n", e.what());
  }
  std::string out = "\n";
  out += fmt::format("trajectory error (ATE RMSE, no alignment): row SLAM {}, fused {}\n",
                     Cm(m.pass_ate_raw_rmse_m), Cm(m.fused_ate_raw_rmse_m));
  out += fmt::format("cross-session ground misalignment (fused, median): {}\n",
                     Cm(m.fused_ground_misalignment_median_m));
  out += fmt::format("canopy height RMSE: {}", Cm(m.canopy_rmse_m));
  if (m.canopy_rmse_m && m.canopy_rmse_low_m && m.canopy_rmse_high_m) {
    out += fmt::format(" (95 % interval over the sites {:.2f}-{:.2f} cm)",
                       100.0 * *m.canopy_rmse_low_m, 100.0 * *m.canopy_rmse_high_m);
  }
  out += "\n";
  return out;
}

}  // namespace

std::string FormatRunSummary(const RunResult& result) {
  const RunRecord& r = result.record;
  std::string out =
      fmt::format("{:<10} {:<11} {:>9} {:>8} {:>9} {:>6} {:>11} {:>7}\n", "stage", "status",
                  "time [s]", "CPU [s]", "peak [MB]", "done", "up to date", "failed");
  double total = 0, total_cpu = 0, peak = 0;
  auto number = [](double v, int decimals) {
    return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : std::string("-");
  };
  for (const StageRecord& s : r.stages) {
    total += s.seconds;
    if (std::isfinite(s.cpu_seconds)) total_cpu += s.cpu_seconds;
    if (std::isfinite(s.peak_rss_mb)) peak = std::max(peak, s.peak_rss_mb);
    out += fmt::format("{:<10} {:<11} {:>9.1f} {:>8} {:>9} {:>6} {:>11} {:>7}\n", s.name, s.status,
                       s.seconds, number(s.cpu_seconds, 1), number(s.peak_rss_mb, 0), s.done,
                       s.skipped, s.failed);
  }
  out += fmt::format("{:<10} {:<11} {:>9.1f} {:>8.1f} {:>9.0f}\n", "total",
                     r.complete ? "complete" : "incomplete", total, total_cpu, peak);
  if (!r.skipped.empty()) {
    out += fmt::format("\nskipped or degraded ({}):\n", r.skipped.size());
    for (const SkippedItem& s : r.skipped) {
      std::string what = s.session;
      if (!s.item.empty()) what += (what.empty() ? "" : "/") + s.item;
      out += fmt::format("  {:<9} {:<28} {}\n", s.stage, what.empty() ? "-" : what, s.reason);
    }
  }
  const workspace::Layout layout(r.workspace);
  out += EvalHeadlines(layout);
  const fs::path report = layout.Report();
  if (fs::exists(report)) out += fmt::format("\nreport: {}\n", report.string());
  return out;
}

}  // namespace crop4d::pipeline
