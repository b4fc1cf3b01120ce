#pragma once

// One pass of the slam stage (slam_stage.h): its state times, the front end on its images, the
// initial states, the standstills, the row-SLAM solve and its outputs (poses.tum, states.csv,
// initial_poses.tum, landmarks.ply, tracks.bin, summary.json). Internal to the slam stage.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/pipeline/slam_session.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/slam/session_streams.h"
#include "crop4d/slam/visual_initialisation.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

// The streams a pass is solved from (into the session's context).
struct PassStreams {
  // The camera (null: a camera-less sensor set).
  const slam::CameraStream* camera = nullptr;
  // The IMU the factors use (null: a set without an IMU).
  const slam::ImuStream* imu = nullptr;
  // The receiver the GPS factors use, its fixes outside the outages (null: a set without GPS).
  const slam::GpsStream* gps = nullptr;
};
PassStreams StreamsOfPass(const SessionContext& ctx);

// One pass being solved: what from, and where its outputs go.
struct PassJob {
  const SlamStageOptions& options;
  const SessionContext& ctx;
  const slam::RowPass& pass;
  const workspace::Layout& layout;
  // The state times: the images in the pass, or a regular grid without a camera.
  const std::vector<Timestamp>& times;
  PassStreams streams;

  const std::string& session() const { return ctx.session->id(); }
};

// The pass's state times: the images in [t_begin, t_end], or without a camera a grid at
// state_rate_hz over the IMU's samples in it.
std::vector<Timestamp> PassStateTimes(const SlamStageOptions& options, const SessionContext& ctx,
                                      const slam::RowPass& pass);

// The pass's initial states (docs/slam.md, initialisation) and how they were found.
struct PassInitialisation {
  std::vector<slam::RowState> states;
  // The state the gauge holds (cam+imu: the one the best receiver anchors).
  int anchor_state = 0;
  slam::StateInitialiser::Summary summary;
  // Without an IMU: the rotations and shape from the images.
  slam::VisualInitialisationSummary visual;
  double seconds = 0;
};

struct PassOutcome {
  int num_states = 0, num_images = 0, num_landmarks = 0, num_cloud_points = 0;
};

// Solves the pass and writes its outputs; summary.json gets `fingerprint` and `options_json`.
// Throws std::runtime_error when the pass's solve fails (no GPS course to start from, a solver
// that gives up), InputError for bad input.
PassOutcome RunPass(const PassJob& job, const std::string& fingerprint,
                    const nlohmann::json& options_json);

}  // namespace crop4d::pipeline
