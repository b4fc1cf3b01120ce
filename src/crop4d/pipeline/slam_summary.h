#pragma once

// A slam pass's summary.json (workspace/pass_summary.h): its fingerprint and whether the pass's
// outputs are up to date, and its parts: the pass, the sensor gaps inside it, the problem it
// solved (the "problem" object the joint 4D problem rebuilds the pass from), the solve's counts
// and fit, the trust flags and the times per phase.

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/pipeline/slam_pass.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

// The pass's fingerprint: the crop4d version, the stage's revision, the options, the pass's span
// and state count, and the session's data files.
std::string PassFingerprint(const nlohmann::json& options, const slam::RowPass& pass,
                            std::size_t num_states, const std::string& data_stamp);

// Whether the pass's outputs exist (the cloud and tracks too when `needs_cloud`) and its
// summary.json is readable and has `fingerprint`.
bool PassUpToDate(const workspace::Layout& layout, const std::string& session,
                  const std::string& pass, const std::string& fingerprint, bool needs_cloud);

// The summary's first fields: the pass, the sensors, the pose frame, fingerprint and options.
nlohmann::json PassSummaryHeader(const PassJob& job, const std::string& fingerprint,
                                 const nlohmann::json& options_json);

// Gaps in the IMU samples and in the GPS factors' fixes inside the pass: warnings, and the
// longest of each in summary.json (the session's grade reads them, season_quality.h).
void RecordSensorGaps(const PassJob& job, nlohmann::json* summary);

// The problem the pass solved, as summary.json's "problem" (workspace/pass_priors.h): the sensors
// (job.streams: the camera and its images, the IMU, the factors' receiver with the outages
// applied), the outages, the IMU noise factor and the priors of `input` and the solve.
void RecordPassProblem(const PassJob& job, const slam::RowOptimiser::Input& input,
                       const std::vector<bool>& still, const slam::RowOptimiser::Summary& s,
                       nlohmann::json* summary);

// measurements.bin (workspace/pass_measurements.h): the camera and the pass's images, the IMU
// samples and the factors' GPS fixes (outages applied) the pass was solved with, over its states.
void WritePassMeasurementsFile(const PassJob& job);

// The solve's part of summary.json: state and image counts, the initialisation, the back end's
// counts, fit and cost, and the camera height's scale.
void RecordSolve(const PassJob& job, const PassInitialisation& init, int num_images,
                 const slam::RowOptimiser::Input& input, const slam::RowOptimiser::Summary& s,
                 nlohmann::json* summary);

// Seconds per phase of the pass.
struct PassSeconds {
  double front_end = 0, initialisation = 0, outputs = 0, total = 0;
};

// Completes summary.json (trust flags, times, the list of outputs written) and writes it.
void WritePassSummaryJson(const PassJob& job, const std::vector<bool>& still,
                          const slam::RowOptimiser::Summary& s, const PassSeconds& seconds,
                          nlohmann::json summary);

}  // namespace crop4d::pipeline
