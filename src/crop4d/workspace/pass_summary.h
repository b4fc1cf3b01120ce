#pragma once

// WS/sessions/<session>/rows/<pass>/summary.json: row SLAM's record of a pass (docs/slam.md lists
// its fields). The later stages read the fields of PassSummary; the rest (the front end's and
// back end's counts, timings) stays JSON for the report. The file carries a schema version
// ("schema"): a summary of another version, one that is not JSON or lacks a field of PassSummary
// throws InputError naming the file and saying to rerun `crop4d slam --force`.

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/workspace/pass_priors.h"

namespace crop4d::workspace {

// Bumped whenever a field that a reader relies on changes its meaning or goes.
inline constexpr int kPassSummarySchema = 1;

struct PassSummary {
  std::string sensors;             // the sensor set (slam::ToString)
  std::string fingerprint;         // of the inputs and options that gave the pass's outputs
  PassPriors problem;              // summary.json's "problem"
  std::vector<std::string> trust;  // what the estimate cannot be trusted for (docs/slam.md)
  // The back end's camera-IMU time offset, s ("back_end.time_offset_s"; unset: not estimated).
  std::optional<double> time_offset_s;
  // The longest time inside the pass without an IMU sample, s ("longest_imu_gap_s"; 0 without an
  // IMU, and in summaries written before it was recorded).
  double longest_imu_gap_s = 0.0;
  nlohmann::json json;  // the whole summary
};

// Stamps the summary with kPassSummarySchema and writes it atomically (2-space indented).
void WritePassSummary(const std::string& path, nlohmann::json summary);
PassSummary ReadPassSummary(const std::string& path);

}  // namespace crop4d::workspace
