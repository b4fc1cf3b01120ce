#pragma once

// What the stages after row SLAM read of a row pass from the workspace (slam_stage.h lists the
// files): the pass list of a session, and per pass its poses, features, tracks and summary.
// Missing or damaged files throw InputError naming the file and saying to rerun `crop4d slam`.

#include <optional>
#include <string>
#include <vector>

#include "crop4d/features/feature_extractor.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/workspace/pass_files.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_measurements.h"
#include "crop4d/workspace/pass_priors.h"

namespace crop4d::workspace {

struct PassData {
  std::string session;
  slam::RowPass pass;
  std::string folder;
  // From summary.json (pass_summary.h): the sensor set, the camera's name (empty without), the
  // fingerprint, the problem's priors and the whole summary as JSON text.
  std::string sensors;
  std::string camera;
  std::string fingerprint;
  PassPriors problem;
  // Row SLAM's camera-IMU time offset, s (unset: not estimated).
  std::optional<double> time_offset_s;
  double longest_imu_gap_s = 0.0;
  std::string summary_json;
  // Row SLAM's world_from_camera at every image (poses.tum; world_from_body without camera).
  std::vector<Timestamp> times;
  std::vector<geometry::Rigid3> poses;
  // Loaded on request: the features of every image (features.bin, in the order of `times`), the
  // tracks (tracks.bin), the full states (states.csv), the measurements row SLAM solved with
  // (measurements.bin).
  std::vector<features::FeatureSet> features;
  PassTracks tracks;
  std::vector<slam::RowState> states;
  PassMeasurements measurements;

  bool has_camera() const { return !camera.empty(); }
  std::string label() const { return session + "/" + pass.id; }
};

struct PassDataParts {
  bool features = false;
  bool tracks = false;
  bool states = false;
  bool measurements = false;
};

PassData LoadPassData(const std::string& workspace, const std::string& session,
                      const slam::RowPass& pass, const PassDataParts& parts);

}  // namespace crop4d::workspace
