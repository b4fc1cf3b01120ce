#pragma once

// Internal to the season report (html_report.h): the Builder that reads a workspace and makes
// the page, one method per section. Its methods are defined by theme in html_report.cc (loading,
// the run, the page), html_report_map.cc (the field map), html_report_stages.cc (row SLAM,
// associations, fusion, dense clouds, the cross-section) and html_report_crop.cc (canopy
// heights, growth, the evaluation).

#include <algorithm>
#include <exception>
#include <filesystem>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset.h"
#include "crop4d/report/html_blocks.h"
#include "crop4d/report/html_report.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::report::html::detail {

// A CSV file: its header and the rows with as many fields.
struct Csv {
  std::vector<std::string> header;
  std::vector<std::vector<std::string>> rows;
  int Col(const std::string& name) const {
    for (std::size_t i = 0; i < header.size(); ++i) {
      if (header[i] == name) return static_cast<int>(i);
    }
    return -1;
  }
};

// ---- the report ------------------------------------------------------------------------------

struct MapTrack;  // html_report_map.cc
struct MapFrame;

struct Section {
  HtmlReportSection info;
  std::string html;
};

// Reads a workspace (and field folder) and makes the page, one method per section.
class Builder {
 public:
  Builder(std::string workspace, std::string field, const HtmlReportOptions& options)
      : ws_(std::move(workspace)), field_(std::move(field)), opt_(options), layout_(ws_) {}

  std::string Build(HtmlReportResult* result);

 private:
  // "WS/<path relative to the workspace>" for messages (the path itself when outside it).
  std::string RelToWs(const fs::path& p) const {
    std::error_code ec;
    const fs::path r = fs::relative(p, ws_, ec);
    if (ec || r.empty() || *r.begin() == "..") return p.string();
    return "WS/" + r.generic_string();
  }

  void Skip(const std::string& line) {
    if (std::find(skipped_.begin(), skipped_.end(), line) == skipped_.end()) {
      skipped_.push_back(line);
    }
  }

  // "WS/<file>:<line>: <what>" of an error while reading a file.
  std::string Why(const std::exception& e) const;

  // The JSON of a file; nullopt when it is missing, or (skipped, with the reason) unreadable or
  // not JSON.
  std::optional<json> ReadJson(const fs::path& p);

  std::optional<Csv> ReadCsv(const fs::path& p, const std::string& label);
  // A workspace artefact read with its typed reader (workspace/); nullopt when it is missing,
  // or (skipped, with the reader's reason) malformed or of another version.
  template <typename Read>
  auto ReadArtefact(const fs::path& p, Read&& read) -> std::optional<decltype(read(p))> {
    if (!IsFile(p)) return std::nullopt;
    try {
      return read(p);
    } catch (const InputError& e) {
      Skip(Why(e) + "; left out");
      return std::nullopt;
    }
  }

  void LoadField();
  void ListSessions();
  std::string SessionColor(const std::string& session) const;

  Section RunSection();
  Section SkippedSection();
  // Passes whose summary.json says what row SLAM could not observe (trust flags).
  std::vector<std::vector<std::string>> UntrustedPasses();
  Section MapSection();
  std::vector<MapTrack> MapTracks();
  std::string MapTracksSvg(const MapFrame& f, const std::vector<MapTrack>& tracks) const;
  std::string MapLegend(const std::vector<MapTrack>& tracks) const;
  Section SlamSection();
  Section AssociationSection();
  Section FusionSection();
  Section DenseSection();
  Section CrossSectionSection();
  Section HeightsSection();
  std::string AnalysisSessionsHtml(const workspace::AnalysisSummary& summary) const;
  std::string HeightsTableHtml(const std::vector<workspace::SiteHeight>& heights,
                               const std::optional<Csv>& measured);
  Section GrowthSection();
  Section EvalSection();

  std::string ws_, field_;
  const HtmlReportOptions& opt_;
  workspace::Layout layout_;  // the paths of ws_
  std::optional<io::FieldInfo> field_info_;
  std::vector<std::string> sessions_;
  std::optional<json> run_;
  std::vector<std::string> skipped_;
};

}  // namespace crop4d::report::html::detail
