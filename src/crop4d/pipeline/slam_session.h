#pragma once

// One session as the slam stage (slam_stage.h) solves it: its streams, the sensor set, the GPS
// receivers with the outages applied, the forward axis (the IMU's mounting) and the session-wide
// IMU + GPS solve, and the cut of its drive into passes. Internal to the slam stage.

#include <Eigen/Core>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/slam/sensor_set.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::pipeline {

// Everything one session's passes share. Filled in place by OpenSlamSession (the initialiser
// points into it), so neither copied nor moved.
struct SessionContext {
  SessionContext() = default;
  SessionContext(const SessionContext&) = delete;
  SessionContext& operator=(const SessionContext&) = delete;

  const io::Session* session = nullptr;
  // The camera's image folder relative to the field folder (measurements.bin; empty without a
  // camera).
  std::string image_folder;
  // The session's streams; `imu` is always set (empty for a sensor set without an IMU).
  slam::SessionStreams streams;
  slam::SensorSet sensors = slam::SensorSet::kCamImuRtk;
  // The receiver the GPS factors use, its fixes outside the outages (unset: a set without GPS).
  std::optional<slam::GpsStream> factor_gps;
  // The best track (segmentation, anchors, standstills), outages applied.
  slam::GpsStream best_gps;
  bool has_best_gps = false;
  // The receiver the initialisation follows (the factors' one, or the best for cam+imu).
  slam::GpsStream init_gps;
  // Whether the forward axis was estimated (not the fallback).
  bool forward_axis_estimated = false;
  // The session-wide IMU + GPS solution (empty when not run).
  std::vector<slam::RowState> session_states;
  std::unique_ptr<slam::StateInitialiser> initialiser;
  // Size and modification time of the session's data files (part of each pass's fingerprint).
  std::string data_stamp;
  // The factor on imu0/sensor.yaml's noise that the session's IMU + GPS fit asked for (1: the
  // stated noise fits; slam/session_solve.h).
  double imu_noise_factor = 1.0;
};

// Opens the session for row SLAM: its streams, the sensor set (SlamStageOptions::sensors or the
// best the session provides), the GPS with the outages applied, and the initialiser (forward axis
// from the best track, refined by the session solve where a precise receiver allows one). Throws
// InputError for a sensor set the session cannot provide or receivers without a single fix.
void OpenSlamSession(const io::Field& field, const io::Session& session,
                     const SlamStageOptions& options, SessionContext* ctx);

// The session's passes (SlamStageOptions::pass_mode): the row passes of the best GPS track, else
// the whole drive in windows of at most max_window_s; one pass without GPS.
std::vector<slam::RowPass> SessionPasses(const io::Field& field, const SlamStageOptions& options,
                                         const SessionContext& ctx);

// The camera's height above the ground in effect: --camera-height, else the camera's sensor.yaml
// (height_above_ground_m), else 0 (unknown or not to be used).
double CameraHeight(const SlamStageOptions& options, const slam::SessionStreams& streams);

// Whether a quarter of the fixes have a horizontal sigma of at most session_solve_max_sigma_m: a
// receiver precise enough for the session solve, the standstill test and the scale.
bool PreciseFixes(const SlamStageOptions& options, const std::vector<slam::GpsFixWorld>& fixes);

}  // namespace crop4d::pipeline
