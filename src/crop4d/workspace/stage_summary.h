#pragma once

// The summaries of the fuse and densify stages (WS/fused/summary.json, WS/dense/<session>.json),
// typed for what their readers use, with the whole JSON kept for the report. Each carries a schema
// version ("schema"): a summary of another version, one that is not JSON or lacks a field of its
// struct throws InputError naming the file and saying which stage to rerun.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <vector>

namespace crop4d::workspace {

// Bumped whenever a field that a reader relies on changes its meaning or goes.
inline constexpr int kFusedSummarySchema = 1;
inline constexpr int kDenseSummarySchema = 1;

// Stamps `summary` with `schema` and writes it atomically (2-space indented, final newline).
void WriteVersionedJson(const std::string& path, nlohmann::json summary, int schema);
// Reads a JSON object written by WriteVersionedJson with `schema`; `rerun` is the command that
// writes the file (for the error messages).
nlohmann::json ReadVersionedJson(const std::string& path, int schema, const std::string& rerun);

// One pass of the joint problem ("passes"): the camera-IMU time offset it used, s (capture
// instant − image stamp), when its reprojections used one.
struct FusedPassSummary {
  std::string session, pass;
  std::optional<double> time_offset_s;
};

struct FusedSummary {
  std::string fingerprint;
  std::vector<std::string> sessions;
  // The joint problem's counts and fit ("joint").
  int passes = 0;
  int landmarks = 0;
  int shared_landmarks = 0;
  double reprojection_rms_px = 0;
  bool converged = false;
  std::vector<FusedPassSummary> pass_list;
  nlohmann::json json;
};

void WriteFusedSummary(const std::string& path, nlohmann::json summary);
FusedSummary ReadFusedSummary(const std::string& path);

struct DenseSummary {
  std::string fingerprint;
  std::string session;
  int poses = 0;
  int views = 0;
  std::int64_t points = 0;
  nlohmann::json json;
};

void WriteDenseSummary(const std::string& path, nlohmann::json summary);
DenseSummary ReadDenseSummary(const std::string& path);

}  // namespace crop4d::workspace
