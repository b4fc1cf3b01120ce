#pragma once

// The season report (docs/report.md): one self-contained HTML file (inline CSS, images embedded as
// data: URIs, an inline SVG field map, no external resource) that a person opens in a browser.
//
//   HtmlReportResult r = WriteHtmlReport("demo/workspace", "demo/field", "", {});
//   // r.path == "demo/workspace/report.html"
//
// Sections, in page order: the run (per-stage status and timings from WS/run.json, or summed from
// the stages' summary.json files without it), what was skipped, the field map (rows, sites and
// each session's trajectory), row SLAM, associations, 4D fusion, dense clouds, the cross-section
// figure, canopy height per site and date (with the measurements of
// FIELD/ground_truth/site_measurements.csv), growth, and the evaluation against ground truth
// (WS/eval/metrics.json). Every input is optional: a section without data says so in one line,
// and a file that cannot be read is named in "What was skipped or degraded" with the reason; the
// report never fails because a stage has not run.
//
// The page carries a tiny inline script (its only JavaScript) that marks a successful load on
// <html> (data-report-loaded="yes") and counts errors (data-js-errors, data-js-last-error): a
// JavaScript error or a resource that failed to load. scripts/check-report.sh checks these in
// a headless browser.

#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::report {

struct HtmlReportOptions {
  // Title of the page; empty: "crop4d season report: <field name>" (or the workspace's folder
  // name without a field).
  std::string title;
  // The cross-section figure: a slice across row `cross_section_row` of field.yaml (default: the
  // middle row), at the row's middle, `thickness` wide and ±`half_length` long. Needs a field
  // with rows, and clouds (fused or row SLAM). false: left out (the slowest part: it reads the
  // sessions' clouds).
  bool cross_section = true;
  std::optional<int> cross_section_row;
  double cross_section_thickness_m = 0.1;
  double cross_section_half_length_m = 1.5;
  // Draw a session's dense cloud (WS/dense/<session>.ply) when it has one (slower: reads the
  // whole cloud), else its fused cloud (WS/fused/<session>/sparse.ply), else the union of its
  // row SLAM clouds.
  bool cross_section_dense = true;
  // Field map size, pixels: at most this wide and this tall (equal scale on both axes).
  int map_max_width_px = 900;
  int map_max_height_px = 760;
  // Trajectory points drawn per session on the map (evenly thinned beyond).
  int map_max_points_per_session = 4000;

  // Positive finite thickness and half-length, map sizes in [100, 10000], points ≥ 2.
  OptionCheck Check() const;
};

// A section of the report.
struct HtmlReportSection {
  std::string id;     // the anchor of the section (e.g. "field-map")
  std::string title;  // its heading
  bool has_data = false;
};

struct HtmlReportResult {
  std::string path;  // the file written
  std::size_t bytes = 0;
  std::vector<HtmlReportSection> sections;  // in page order
  // What the report could not read or show, one line each (also listed in the page, with the
  // items that WS/run.json records as skipped).
  std::vector<std::string> skipped;
};

// Writes the report of `workspace` (with the field folder `field_folder`, may be empty: no rows,
// sites, measurements) to `output_html` (empty: WS/report.html), atomically (io/atomic_file.h).
// Throws InputError when the workspace folder does not exist, or when the file cannot be
// written; anything wrong inside the workspace or field is reported in the page instead.
// `options` must pass Check() (CHECK).
HtmlReportResult WriteHtmlReport(const std::string& workspace, const std::string& field_folder,
                                 const std::string& output_html,
                                 const HtmlReportOptions& options = {});

// The report as a string (what WriteHtmlReport writes); `result` (if not null) receives the
// sections and skipped lines (its path and bytes are left empty).
std::string BuildHtmlReport(const std::string& workspace, const std::string& field_folder,
                            const HtmlReportOptions& options, HtmlReportResult* result = nullptr);

// Standard base64 (RFC 4648, with padding) of `bytes`.
std::string Base64Encode(const std::string& bytes);

// `text` with & < > " ' replaced by character references, for HTML text and attribute values.
std::string HtmlEscape(const std::string& text);

}  // namespace crop4d::report
