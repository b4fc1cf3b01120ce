#pragma once

// WS/eval/metrics.json: the errors against the simulator's ground truth (`crop4d eval`, the
// run's eval step; the fields are listed in docs/cli.md). Readers get the headline figures typed
// and the whole JSON for the report's tables. Schema 1 carries no "schema" field
// (workspace/json_file.h); a file of another schema, one that is not JSON or lacks
// "crop4d_version" or "passes" throws InputError naming the file and saying to rerun
// `crop4d eval`.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>

namespace crop4d::workspace {

// Bumped whenever a field that a reader relies on changes its meaning or goes (a version above 1
// is stamped into the file).
inline constexpr int kEvalMetricsSchema = 1;

struct EvalMetrics {
  std::string crop4d_version;  // of the crop4d that evaluated
  // The headline figures, unset when not evaluated: the trajectory error of row SLAM and of the
  // fused trajectories (ATE RMSE without alignment), the fused clouds' cross-session ground
  // misalignment (pooled median) and the canopy heights' RMSE, all in metres.
  std::optional<double> pass_ate_raw_rmse_m;
  std::optional<double> fused_ate_raw_rmse_m;
  std::optional<double> fused_ground_misalignment_median_m;
  std::optional<double> canopy_rmse_m;
  // Its 95 % interval over the sites (eval/site_bootstrap.h), m: unset without one.
  std::optional<double> canopy_rmse_low_m;
  std::optional<double> canopy_rmse_high_m;
  nlohmann::json json;  // the whole file
};

// Writes `metrics` (keys in the order given) atomically, 2-space indented with a final newline.
void WriteEvalMetrics(const std::string& path, const nlohmann::ordered_json& metrics);
EvalMetrics ReadEvalMetrics(const std::string& path);

}  // namespace crop4d::workspace
