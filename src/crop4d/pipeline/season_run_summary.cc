// The terminal summary of `crop4d run` (FormatRunSummary, season_run.h): the stages' table, what
// was skipped or degraded, the headline figures of WS/eval/metrics.json and where the report is.

#include <fmt/format.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "crop4d/pipeline/season_run.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A length in metres as centimetres, "n/a" when the metrics do not have it.
std::string Cm(const json& j) {
  return j.is_number() ? fmt::format("{:.2f} cm", 100.0 * j.get<double>()) : "n/a";
}

}  // namespace

std::string FormatRunSummary(const RunResult& result) {
  const RunRecord& r = result.record;
  std::string out = fmt::format("{:<10} {:<11} {:>9} {:>6} {:>11} {:>7}\n", "stage", "status",
                                "time [s]", "done", "up to date", "failed");
  double total = 0;
  for (const StageRecord& s : r.stages) {
    total += s.seconds;
    out += fmt::format("{:<10} {:<11} {:>9.1f} {:>6} {:>11} {:>7}\n", s.name, s.status, s.seconds,
                       s.done, s.skipped, s.failed);
  }
  out += fmt::format("{:<10} {:<11} {:>9.1f}\n", "total", r.complete ? "complete" : "incomplete",
                     total);
  if (!r.skipped.empty()) {
    out += fmt::format("\nskipped or degraded ({}):\n", r.skipped.size());
    for (const SkippedItem& s : r.skipped) {
      std::string what = s.session;
      if (!s.item.empty()) what += (what.empty() ? "" : "/") + s.item;
      out += fmt::format("  {:<9} {:<28} {}\n", s.stage, what.empty() ? "-" : what, s.reason);
    }
  }
  const workspace::Layout layout(r.workspace);
  const fs::path metrics = layout.EvalMetrics();
  if (std::ifstream in(metrics); in) {
    const json m = json::parse(in, nullptr, false);
    if (m.is_object()) {
      out += "\n";
      const json fused = m.value("/fused/overall/ate_raw_m/rmse"_json_pointer, json());
      const json passes = m.value("/overall/ate_raw_m/rmse"_json_pointer, json());
      const json misalign =
          m.value("/ground_misalignment/fused/pooled/median_m"_json_pointer, json());
      const json canopy = m.value("/canopy/ours/rmse_m"_json_pointer, json());
      out += fmt::format("trajectory error (ATE RMSE, no alignment): row SLAM {}, fused {}\n",
                         Cm(passes), Cm(fused));
      out += fmt::format("cross-session ground misalignment (fused, median): {}\n", Cm(misalign));
      out += fmt::format("canopy height RMSE: {}\n", Cm(canopy));
    }
  }
  const fs::path report = layout.Report();
  if (fs::exists(report)) out += fmt::format("\nreport: {}\n", report.string());
  return out;
}

}  // namespace crop4d::pipeline
