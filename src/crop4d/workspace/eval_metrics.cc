#include "crop4d/workspace/eval_metrics.h"

#include "crop4d/io/atomic_file.h"
#include "crop4d/workspace/json_file.h"

namespace crop4d::workspace {

using json = nlohmann::json;

namespace {

// The number at `pointer`; unset when it is missing or null.
std::optional<double> NumberAt(const json& j, const char* pointer) {
  const json v = j.value(json::json_pointer(pointer), json());
  if (v.is_null()) return std::nullopt;
  return v.get<double>();
}

}  // namespace

void WriteEvalMetrics(const std::string& path, const nlohmann::ordered_json& metrics) {
  static_assert(kEvalMetricsSchema == 1, "stamp \"schema\" into the file from schema 2 on");
  io::WriteFileAtomic(path, metrics.dump(2) + "\n");
}

EvalMetrics ReadEvalMetrics(const std::string& path) {
  const std::string rerun = "crop4d eval";
  EvalMetrics m;
  m.json = ReadJsonOfSchema(path, kEvalMetricsSchema, rerun);
  ReadFields(path, rerun, [&] {
    m.crop4d_version = m.json.at("crop4d_version").get<std::string>();
    (void)m.json.at("passes").get<json::array_t>();  // throws unless an array
    m.pass_ate_raw_rmse_m = NumberAt(m.json, "/overall/ate_raw_m/rmse");
    m.fused_ate_raw_rmse_m = NumberAt(m.json, "/fused/overall/ate_raw_m/rmse");
    m.fused_ground_misalignment_median_m =
        NumberAt(m.json, "/ground_misalignment/fused/pooled/median_m");
    m.canopy_rmse_m = NumberAt(m.json, "/canopy/ours/rmse_m");
    m.canopy_rmse_low_m = NumberAt(m.json, "/canopy/ours/rmse_interval_m/low");
    m.canopy_rmse_high_m = NumberAt(m.json, "/canopy/ours/rmse_interval_m/high");
  });
  return m;
}

}  // namespace crop4d::workspace
