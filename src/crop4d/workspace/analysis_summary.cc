#include "crop4d/workspace/analysis_summary.h"

#include <fmt/format.h>

#include <fstream>
#include <limits>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr char kRerun[] = "rerun `crop4d analyze`";

// A number the writer may have written as null (NaN: e.g. no threshold without points).
double Real(const json& x, const char* key) {
  const json& v = x.at(key);
  return v.is_null() ? std::numeric_limits<double>::quiet_NaN() : v.get<double>();
}

}  // namespace

json AnalysisSummaryJson(const AnalysisSummary& s) {
  json j;
  j["fingerprint"] = s.fingerprint;
  j["version"] = s.version;
  j["options"] = s.options;
  j["area_enu"] = {{"min", s.area_min}, {"max", s.area_max}};
  for (const AnalysisSessionRecord& r : s.sessions) {
    j["sessions"].push_back({{"session", r.session},
                             {"date", r.date},
                             {"cloud", r.cloud},
                             {"dense", r.dense},
                             {"points", r.points},
                             {"lone_points", r.lone_points},
                             {"plants", r.plants},
                             {"plant_tops_lowered", r.plant_tops_lowered},
                             {"vegetation_fraction", r.vegetation_fraction},
                             {"vegetation_threshold", r.vegetation_threshold},
                             {"vegetation_separability", r.vegetation_separability},
                             {"vegetation_threshold_automatic", r.vegetation_threshold_automatic}});
  }
  j["quality"] = s.quality;
  const AnalysisTerrainRecord& t = s.terrain;
  j["terrain"] = {{"nodes", t.nodes},
                  {"nodes_fitted", t.nodes_fitted},
                  {"nodes_filled", t.nodes_filled},
                  {"ground_points_first", t.ground_points_first},
                  {"ground_points_later", t.ground_points_later},
                  {"residual_scale_m", t.residual_scale_m},
                  {"seconds", t.seconds}};
  json notes = json::array();
  for (const AnalysisSiteNote& n : s.site_notes) {
    notes.push_back({{"site_id", n.site_id}, {"session", n.session}, {"note", n.note}});
  }
  j["site_notes"] = notes;
  j["outputs"] = s.outputs;
  j["seconds"] = s.seconds;
  return j;
}

void WriteAnalysisSummary(const Layout& ws, const AnalysisSummary& summary) {
  json j = AnalysisSummaryJson(summary);
  std::vector<std::string> written;  // relative to the analysis folder
  for (const std::string& path : summary.outputs) {
    written.push_back((ws.root() / path).lexically_relative(ws.AnalysisDir()).generic_string());
  }
  RecordOutputs(&j, ws.AnalysisDir(), written);
  io::WriteFileAtomic(ws.AnalysisSummary().string(), j.dump(2) + "\n");
}

AnalysisSummary AnalysisSummaryFromJson(const json& j, const std::string& name) {
  const int schema = j.is_object() ? j.value("schema", kAnalysisSummarySchema) : 0;
  if (schema != kAnalysisSummarySchema) {
    throw InputError(name, 0,
                     fmt::format("a summary of another crop4d version (schema {}; this crop4d "
                                 "reads schema {}); {}",
                                 schema, kAnalysisSummarySchema, kRerun));
  }
  try {
    AnalysisSummary s;
    s.fingerprint = j.at("fingerprint").get<std::string>();
    s.version = j.at("version").get<std::string>();
    s.options = j.at("options");
    s.area_min = j.at("area_enu").at("min").get<std::array<double, 2>>();
    s.area_max = j.at("area_enu").at("max").get<std::array<double, 2>>();
    for (const json& x : j.value("sessions", json::array())) {
      AnalysisSessionRecord r;
      r.session = x.at("session").get<std::string>();
      r.date = x.at("date").get<std::string>();
      r.cloud = x.at("cloud").get<std::string>();
      r.dense = x.at("dense").get<bool>();
      r.points = x.at("points").get<std::size_t>();
      r.lone_points = x.at("lone_points").get<std::size_t>();
      r.plants = x.at("plants").get<std::size_t>();
      r.plant_tops_lowered = x.at("plant_tops_lowered").get<std::size_t>();
      r.vegetation_fraction = Real(x, "vegetation_fraction");
      r.vegetation_threshold = Real(x, "vegetation_threshold");
      r.vegetation_separability = Real(x, "vegetation_separability");
      r.vegetation_threshold_automatic = x.at("vegetation_threshold_automatic").get<bool>();
      s.sessions.push_back(std::move(r));
    }
    s.quality = j.at("quality");
    const json& t = j.at("terrain");
    s.terrain = {t.at("nodes").get<std::size_t>(),
                 t.at("nodes_fitted").get<std::size_t>(),
                 t.at("nodes_filled").get<std::size_t>(),
                 t.at("ground_points_first").get<std::size_t>(),
                 t.at("ground_points_later").get<std::size_t>(),
                 Real(t, "residual_scale_m"),
                 Real(t, "seconds")};
    for (const json& n : j.at("site_notes")) {
      s.site_notes.push_back({n.at("site_id").get<std::string>(),
                              n.at("session").get<std::string>(), n.at("note").get<std::string>()});
    }
    s.outputs = j.at("outputs").get<std::vector<std::string>>();
    s.seconds = Real(j, "seconds");
    return s;
  } catch (const json::exception& e) {
    throw InputError(
        name, 0, fmt::format("not an analysis summary of this crop4d ({}); {}", e.what(), kRerun));
  }
}

AnalysisSummary ReadAnalysisSummary(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, fmt::format("cannot be read; {}", kRerun));
  json j;
  try {
    j = json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(path.string(), 0,
                     fmt::format("not JSON, or cut short ({}); {}", e.what(), kRerun));
  }
  return AnalysisSummaryFromJson(j, path.string());
}

}  // namespace crop4d::workspace
