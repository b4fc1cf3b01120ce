#include "crop4d/workspace/stage_summary.h"

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/workspace/json_file.h"

namespace crop4d::workspace {

using json = nlohmann::json;

void WriteVersionedJson(const std::string& path, json summary, int schema) {
  summary["schema"] = schema;
  io::WriteFileAtomic(path, summary.dump(2) + "\n");
}

json ReadVersionedJson(const std::string& path, int schema, const std::string& rerun) {
  return ReadJsonOfSchema(path, schema, rerun, SchemaField::kRequired);
}

namespace {

// Runs `read` on the parsed summary; a missing or mistyped field is an InputError on `path`.
template <typename F>
void Fields(const std::string& path, const std::string& rerun, F read) {
  try {
    read();
  } catch (const json::exception& e) {
    throw InputError(path, 0,
                     std::string("a missing or mistyped field (") + e.what() + "); rerun `" +
                         rerun + " --force`");
  }
}

}  // namespace

void WriteFusedSummary(const std::string& path, json summary) {
  WriteVersionedJson(path, std::move(summary), kFusedSummarySchema);
}

FusedSummary ReadFusedSummary(const std::string& path) {
  const std::string rerun = "crop4d fuse";
  FusedSummary s;
  s.json = ReadVersionedJson(path, kFusedSummarySchema, rerun);
  Fields(path, rerun, [&] {
    s.fingerprint = s.json.at("fingerprint").get<std::string>();
    s.sessions = s.json.at("sessions").get<std::vector<std::string>>();
    const json& joint = s.json.at("joint");
    s.passes = joint.at("passes").get<int>();
    s.landmarks = joint.at("landmarks").get<int>();
    s.shared_landmarks = joint.at("shared_landmarks").get<int>();
    s.reprojection_rms_px = joint.at("reprojection_rms_px").get<double>();
    s.converged = joint.at("converged").get<bool>();
    for (const json& pass : s.json.at("passes")) {
      FusedPassSummary p{pass.at("session").get<std::string>(), pass.at("pass").get<std::string>(),
                         std::nullopt};
      if (pass.contains("time_offset_s")) p.time_offset_s = pass.at("time_offset_s").get<double>();
      s.pass_list.push_back(std::move(p));
    }
  });
  return s;
}

void WriteDenseSummary(const std::string& path, json summary) {
  WriteVersionedJson(path, std::move(summary), kDenseSummarySchema);
}

DenseSummary ReadDenseSummary(const std::string& path) {
  const std::string rerun = "crop4d densify";
  DenseSummary s;
  s.json = ReadVersionedJson(path, kDenseSummarySchema, rerun);
  Fields(path, rerun, [&] {
    s.fingerprint = s.json.at("fingerprint").get<std::string>();
    s.session = s.json.at("session").get<std::string>();
    s.poses = s.json.at("poses").get<int>();
    s.views = s.json.at("views").get<int>();
    s.points = s.json.at("points").get<std::int64_t>();
  });
  return s;
}

}  // namespace crop4d::workspace
