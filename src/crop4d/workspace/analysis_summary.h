#pragma once

// WS/analysis/summary.json (Layout::AnalysisSummary): the analyze stage's record of a complete
// run, written last; read by the stage itself (up to date?), `crop4d export` (the options and
// thresholds that classify the LAS points) and the report.
//
// Schema 1 (kAnalysisSummarySchema) has no "schema" key; a later schema writes "schema": N. A
// summary of another schema, or one that is not JSON or lacks a field, is an InputError naming
// the file and asking to rerun `crop4d analyze`.

#include <array>
#include <cstddef>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

inline constexpr int kAnalysisSummarySchema = 1;

struct AnalysisSessionRecord {
  std::string session;
  std::string date;   // YYYY-MM-DD
  std::string cloud;  // the cloud analysed, relative to the workspace
  bool dense = false;
  std::size_t points = 0;       // within the analysed area, lone points left out
  std::size_t lone_points = 0;  // left out
  std::size_t plants = 0;       // plants found
  std::size_t plant_tops_lowered = 0;
  double vegetation_fraction = 0.0;  // of the points
  double vegetation_threshold = 0.0;
  double vegetation_separability = 0.0;
  bool vegetation_threshold_automatic = false;
};

struct AnalysisTerrainRecord {
  std::size_t nodes = 0, nodes_fitted = 0, nodes_filled = 0;
  std::size_t ground_points_first = 0, ground_points_later = 0;
  double residual_scale_m = 0.0;
  double seconds = 0.0;
};

// Why a site has no height in a session.
struct AnalysisSiteNote {
  std::string site_id, session, note;
};

struct AnalysisSummary {
  std::string fingerprint;  // of the inputs and options: an unchanged workspace is up to date
  std::string version;      // of crop4d
  nlohmann::json options;   // the stage's options, as the stage writes them
  std::array<double, 2> area_min{0.0, 0.0}, area_max{0.0, 0.0};  // the analysed area, ENU m
  std::vector<AnalysisSessionRecord> sessions;                   // date order
  nlohmann::json quality;  // the season quality the stage used
  AnalysisTerrainRecord terrain;
  std::vector<AnalysisSiteNote> site_notes;
  std::vector<std::string> outputs;  // files written, relative to the workspace
  double seconds = 0.0;
};

// The summary as JSON (without the record of the output files).
nlohmann::json AnalysisSummaryJson(const AnalysisSummary& summary);

// Writes Layout::AnalysisSummary atomically, with the size and hash of every output
// (stage_files.h RecordOutputs).
void WriteAnalysisSummary(const Layout& ws, const AnalysisSummary& summary);

AnalysisSummary ReadAnalysisSummary(const std::filesystem::path& path);
// From parsed JSON; `name` stands for the file in messages.
AnalysisSummary AnalysisSummaryFromJson(const nlohmann::json& j, const std::string& name);

}  // namespace crop4d::workspace
