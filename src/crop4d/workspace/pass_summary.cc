#include "crop4d/workspace/pass_summary.h"

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::workspace {

using json = nlohmann::json;

void WritePassSummary(const std::string& path, json summary) {
  summary["schema"] = kPassSummarySchema;
  io::WriteFileAtomic(path, summary.dump(2) + "\n");
}

PassSummary ReadPassSummary(const std::string& path) {
  if (!std::filesystem::exists(path)) {
    throw InputError(path, 0, "missing (run `crop4d slam` first)");
  }
  std::ifstream in(path);
  PassSummary s;
  try {
    s.json = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(path, 0,
                     std::string("not valid JSON (") + e.what() + "); rerun `crop4d slam --force`");
  }
  const json schema = s.json.is_object() ? s.json.value("schema", json()) : json();
  if (!schema.is_number_integer() || schema.get<int>() != kPassSummarySchema) {
    throw InputError(path, 0,
                     "written by another crop4d version (schema " +
                         (schema.is_null() ? std::string("none") : schema.dump()) +
                         ", this crop4d reads " + std::to_string(kPassSummarySchema) +
                         "); rerun `crop4d slam --force`");
  }
  try {
    s.sensors = s.json.at("sensors").get<std::string>();
    s.fingerprint = s.json.at("fingerprint").get<std::string>();
    s.trust = s.json.value("trust", std::vector<std::string>{});
    s.longest_imu_gap_s = s.json.value("longest_imu_gap_s", 0.0);
    const json back_end = s.json.value("back_end", json::object());
    if (back_end.contains("time_offset_s") && !back_end.at("time_offset_s").is_null()) {
      s.time_offset_s = back_end.at("time_offset_s").get<double>();
    }
  } catch (const json::exception& e) {
    throw InputError(
        path, 0,
        std::string("a missing or mistyped field (") + e.what() + "); rerun `crop4d slam --force`");
  }
  s.problem = PassPriorsFromJson(s.json.value("problem", json()), path);
  return s;
}

}  // namespace crop4d::workspace
