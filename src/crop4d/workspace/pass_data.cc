#include "crop4d/workspace/pass_data.h"

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/features/feature_cache.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::vector<slam::RowPass> ReadPassList(const std::string& workspace, const std::string& session) {
  const fs::path path = Layout(workspace).PassList(session);
  std::vector<slam::RowPass> passes;
  if (!fs::exists(path)) return passes;
  io::CsvReader reader(path.string());
  io::CsvRecord record;
  while (reader.Next(&record)) {
    if (record.fields.size() < 10) {
      throw InputError(path.string(), record.line, "expected 10 columns (rerun `crop4d slam`)");
    }
    if (record.fields[0] == "pass") continue;  // the header line
    slam::RowPass p;
    p.id = std::string(record.fields[0]);
    std::int64_t row = 0, direction = 0;
    double v[5];
    bool ok =
        io::ParseInt64(record.fields[1], &row) && io::ParseInt64(record.fields[2], &direction) &&
        io::ParseInt64(record.fields[3], &p.t_begin) && io::ParseInt64(record.fields[4], &p.t_end);
    for (int k = 0; k < 5; ++k) ok = ok && io::ParseDouble(record.fields[5 + k], &v[k]);
    if (!ok || p.id.empty()) throw InputError(path.string(), record.line, "malformed pass line");
    p.row = static_cast<int>(row);
    p.direction = static_cast<int>(direction);
    p.start_world = Eigen::Vector2d(v[0], v[1]);
    p.end_world = Eigen::Vector2d(v[2], v[3]);
    p.length_m = v[4];
    passes.push_back(p);
  }
  return passes;
}

PassData LoadPassData(const std::string& workspace, const std::string& session,
                      const slam::RowPass& pass, const PassDataParts& parts) {
  PassData data;
  data.session = session;
  data.pass = pass;
  const Layout layout(workspace);
  data.folder = layout.PassDir(session, pass.id).string();
  const fs::path summary_path = layout.PassSummary(session, pass.id);
  if (!fs::exists(summary_path)) {
    throw InputError(summary_path.string() + ": missing (run `crop4d slam` first)");
  }
  {
    std::ifstream in(summary_path);
    json summary;
    try {
      summary = json::parse(in);
    } catch (const json::exception& e) {
      throw InputError(summary_path.string() + ": not valid JSON (" + e.what() + ")");
    }
    data.sensors = summary.value("sensors", "");
    data.fingerprint = summary.value("fingerprint", "");
    if (summary.contains("problem") && summary["problem"].contains("camera")) {
      data.camera = summary["problem"]["camera"].get<std::string>();
    } else {
      throw InputError(summary_path.string() +
                       ": written by an older crop4d (rerun `crop4d slam --force`)");
    }
    data.summary_json = summary.dump();
  }
  for (const io::StampedPose& p : io::ReadTum(layout.PassPoses(session, pass.id).string())) {
    data.times.push_back(p.t);
    data.poses.push_back(p.pose);
  }
  if (parts.features && data.has_camera()) {
    features::FeatureCache cache;
    std::string detail;
    const fs::path path = layout.PassFeatures(session, pass.id);
    const features::FeatureCacheStatus status =
        features::ReadFeatureCache(path.string(), &cache, &detail);
    if (status != features::FeatureCacheStatus::kOk) {
      throw InputError(path.string() + ": " + std::string(features::ToString(status)) + " (" +
                       detail + "); rerun `crop4d slam --force`");
    }
    // The cache holds every image of poses.tum that could be read, in the same order; an
    // unreadable image (left out of the cache so that a rerun tries it again) is a pose without
    // features.
    if (cache.image_keys.size() > data.times.size()) {
      throw InputError(path.string() + ": " + std::to_string(cache.image_keys.size()) +
                       " images but poses.tum has " + std::to_string(data.times.size()) +
                       " (rerun `crop4d slam --force`)");
    }
    data.features.assign(data.times.size(), features::FeatureSet{});
    std::size_t next = 0;
    for (std::size_t i = 0; i < data.times.size() && next < cache.image_keys.size(); ++i) {
      if (cache.image_keys[next] != std::to_string(data.times[i])) continue;
      data.features[i] = std::move(cache.features[next]);
      ++next;
    }
    if (next != cache.image_keys.size()) {
      throw InputError(path.string() + ": image " + cache.image_keys[next] +
                       " is not in poses.tum, or not in its order (rerun `crop4d slam --force`)");
    }
  }
  if (parts.tracks && data.has_camera()) {
    data.tracks = ReadPassTracks(layout.PassTracks(session, pass.id).string());
  }
  if (parts.tracks && parts.features && data.has_camera()) {
    for (const auto* list : {&data.tracks.landmarks, &data.tracks.cloud}) {
      for (const PassTrack& t : *list) {
        for (const features::Observation& o : t.observations) {
          if (o.image >= static_cast<int>(data.features.size()) ||
              o.feature >= static_cast<int>(data.features[o.image].size())) {
            throw InputError(layout.PassTracks(session, pass.id).string() +
                             ": an observation outside features.bin (rerun `crop4d slam --force`)");
          }
        }
      }
    }
  }
  if (parts.states) {
    const fs::path states_path = layout.PassStates(session, pass.id);
    data.states = ReadPassStates(states_path.string());
    if (data.states.size() != data.times.size()) {
      throw InputError(states_path.string() + ": " +
                       std::to_string(data.states.size()) + " states but poses.tum has " +
                       std::to_string(data.times.size()) + " (rerun `crop4d slam --force`)");
    }
  }
  return data;
}

}  // namespace crop4d::workspace
