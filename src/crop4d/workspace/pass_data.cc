#include "crop4d/workspace/pass_data.h"

#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/features/feature_cache.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_summary.h"

namespace crop4d::workspace {

namespace fs = std::filesystem;

PassData LoadPassData(const std::string& workspace, const std::string& session,
                      const slam::RowPass& pass, const PassDataParts& parts) {
  PassData data;
  data.session = session;
  data.pass = pass;
  const Layout layout(workspace);
  data.folder = layout.PassDir(session, pass.id).string();
  const fs::path summary_path = layout.PassSummary(session, pass.id);
  {
    PassSummary summary = ReadPassSummary(summary_path.string());
    data.sensors = summary.sensors;
    data.fingerprint = summary.fingerprint;
    data.camera = summary.problem.camera;
    data.problem = std::move(summary.problem);
    data.time_offset_s = summary.time_offset_s;
    data.longest_imu_gap_s = summary.longest_imu_gap_s;
    data.summary_json = summary.json.dump();
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
      throw InputError(states_path.string() + ": " + std::to_string(data.states.size()) +
                       " states but poses.tum has " + std::to_string(data.times.size()) +
                       " (rerun `crop4d slam --force`)");
    }
  }
  if (parts.measurements) {
    data.measurements = ReadPassMeasurements(layout.PassMeasurements(session, pass.id).string());
    if (data.has_camera() &&
        (!data.measurements.camera || data.measurements.camera->sensor.name != data.camera)) {
      throw InputError(layout.PassMeasurements(session, pass.id).string() +
                       ": does not hold the pass's camera '" + data.camera +
                       "' (rerun `crop4d slam --force`)");
    }
  }
  return data;
}

}  // namespace crop4d::workspace
