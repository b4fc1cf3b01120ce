#include "crop4d/report/html_report.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <exception>
#include <filesystem>
#include <fstream>
#include <functional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/report/cross_section.h"
#include "crop4d/report/html_report_builder.h"
#include "crop4d/workspace/association_summary.h"
#include "crop4d/workspace/eval_metrics.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/season_quality.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::report {
namespace html::detail {
namespace {

std::string StatusBadge(const std::string& status) {
  std::string cls = "muted";
  if (status == "done" || status == "up to date" || status == "nothing to do") cls = "ok";
  if (status == "partial") cls = "warn";
  if (status == "failed") cls = "bad";
  return "<span class=\"badge " + cls + "\">" + E(status.empty() ? "?" : status) + "</span>";
}

// A stage's outputs when there is no WS/run.json: its summary files (in order; those missing are
// not counted), where each records its seconds, and what the stage made, in words.
struct DerivedStage {
  const char* name;
  std::vector<fs::path> files;
  json (*read)(const fs::path& file);  // its typed reader (workspace/), to the file's JSON
  std::optional<double> (*seconds)(const json& summary);
  // "<n> <what><plural>" (the plural ending when n != 1), or `what` alone when `plural` is null.
  const char* what;
  const char* plural;

  std::string What(int n) const {
    if (plural == nullptr) return what;
    return fmt::format("{} {}{}", n, what, n == 1 ? "" : plural);
  }
};

std::optional<double> Seconds(const json& j) { return Num(j, {"seconds"}); }
std::optional<double> TotalSeconds(const json& j) { return Num(j, {"seconds", "total"}); }
std::optional<double> TotalElseSeconds(const json& j) {
  const std::optional<double> t = TotalSeconds(j);
  return t ? t : Seconds(j);
}
std::optional<double> SecondsElseTotal(const json& j) {
  const std::optional<double> t = Seconds(j);
  return t ? t : TotalSeconds(j);
}

json PassSummaryJson(const fs::path& p) { return workspace::ReadPassSummary(p.string()).json; }
json AssociationSummaryJson(const fs::path& p) {
  return workspace::ReadAssociationSummary(p.string()).json;
}
json FusedSummaryJson(const fs::path& p) { return workspace::ReadFusedSummary(p.string()).json; }
json DenseSummaryJson(const fs::path& p) { return workspace::ReadDenseSummary(p.string()).json; }
json AnalysisSummaryJson(const fs::path& p) {
  return workspace::AnalysisSummaryJson(workspace::ReadAnalysisSummary(p));
}
json EvalMetricsJson(const fs::path& p) { return workspace::ReadEvalMetrics(p.string()).json; }

}  // namespace

// ---- loading -----------------------------------------------------------------------------------

std::string Builder::Why(const std::exception& e) const {
  if (const auto* ie = dynamic_cast<const InputError*>(&e); ie != nullptr && !ie->file().empty()) {
    return RelToWs(fs::path(ie->file())) +
           (ie->line() > 0 ? ":" + std::to_string(ie->line()) : std::string()) + ": " +
           ie->message();
  }
  return e.what();
}

std::optional<json> Builder::ReadJson(const fs::path& p) {
  if (!IsFile(p)) return std::nullopt;
  const std::optional<std::string> bytes = ReadBytes(p);
  if (!bytes) {
    Skip(RelToWs(p) + ": cannot be read; left out");
    return std::nullopt;
  }
  try {
    return json::parse(*bytes);
  } catch (const std::exception& e) {
    Skip(RelToWs(p) + ": not valid JSON (" + e.what() + "); left out");
    return std::nullopt;
  }
}

std::optional<Csv> Builder::ReadCsv(const fs::path& p, const std::string& label) {
  if (!IsFile(p)) return std::nullopt;
  std::ifstream in(p);
  if (!in) {
    Skip(label + ": cannot be read; left out");
    return std::nullopt;
  }
  Csv csv;
  std::string line;
  std::int64_t n = 0;
  std::vector<std::string_view> fields;
  int bad = 0;
  while (std::getline(in, line)) {
    ++n;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    if (line.find_first_not_of(" \t") == std::string::npos) continue;
    io::SplitCsvLine(line, ',', &fields);
    std::vector<std::string> row(fields.begin(), fields.end());
    if (csv.header.empty()) {
      if (!row.empty() && !row[0].empty() && row[0][0] == '#') row[0].erase(0, 1);
      csv.header = row;
      continue;
    }
    if (line[0] == '#') continue;
    if (row.size() != csv.header.size()) {
      if (++bad <= 3) {
        Skip(fmt::format("{}:{}: {} columns where the header has {}; line left out", label, n,
                         row.size(), csv.header.size()));
      }
      continue;
    }
    csv.rows.push_back(std::move(row));
  }
  if (bad > 3) Skip(fmt::format("{}: {} more malformed lines left out", label, bad - 3));
  if (csv.header.empty()) {
    Skip(label + ": empty file; left out");
    return std::nullopt;
  }
  return csv;
}

void Builder::LoadField() {
  if (field_.empty()) return;
  const fs::path yaml = fs::path(field_) / "field.yaml";
  if (!IsFile(yaml)) {
    Skip("FIELD/field.yaml (" + yaml.string() +
         "): not found; the map has no rows or sites, and there is no cross-section");
    return;
  }
  try {
    field_info_ = io::ReadFieldYaml(yaml.string());
  } catch (const std::exception& e) {
    Skip(std::string("FIELD/field.yaml: ") + e.what() + "; rows, sites and session order left out");
  }
}

void Builder::ListSessions() {
  std::set<std::string> seen;
  if (field_info_) {
    for (const std::string& s : field_info_->sessions) {
      if (seen.insert(s).second) sessions_.push_back(s);
    }
  }
  std::vector<std::string> extra;
  auto add = [&](const std::string& s) {
    if (!s.empty() && seen.insert(s).second) extra.push_back(s);
  };
  for (const std::string& session : layout_.SessionFolders()) add(session);
  for (const std::string& session : layout_.FusedSessionFolders()) {
    if (IsFile(layout_.FusedPoses(session)) || IsFile(layout_.FusedSparse(session))) add(session);
  }
  for (const std::string& session : layout_.DenseSummarySessions()) add(session);
  std::sort(extra.begin(), extra.end());
  sessions_.insert(sessions_.end(), extra.begin(), extra.end());
}

std::string Builder::SessionColor(const std::string& session) const {
  const auto it = std::find(sessions_.begin(), sessions_.end(), session);
  if (it == sessions_.end()) return "#777777";
  return Hex(report::SessionColor(static_cast<int>(it - sessions_.begin()),
                                  static_cast<int>(sessions_.size())));
}

// ---- run ---------------------------------------------------------------------------------------

Section Builder::RunSection() {
  Section s{{"run", "Run and timings", false}, ""};
  std::string& h = s.html;
  if (run_ && run_->is_object()) {
    s.info.has_data = true;
    const json& r = *run_;
    const std::optional<bool> complete = Bool(r, {"complete"});
    std::vector<std::pair<std::string, std::string>> kv = {
        {"crop4d version", E(Str(r, {"crop4d_version"}))},
        {"started", E(Str(r, {"started"}))},
        {"finished",
         Str(r, {"finished"}).empty() ? std::string("not finished") : E(Str(r, {"finished"}))},
        {"complete", complete ? (*complete ? StatusBadge("done")
                                           : std::string("<span class=\"badge warn\">no</span>"))
                              : std::string(kDash)},
        {"threads", I(Num(r, {"threads"}))},
    };
    h += KeyValues(kv);
    std::vector<std::vector<std::string>> rows;
    double total = 0;
    bool any_time = false;
    if (const json* stages = At(r, {"stages"}); stages != nullptr && stages->is_array()) {
      for (const json& st : *stages) {
        std::string messages;
        if (const json* m = At(st, {"messages"}); m != nullptr && m->is_array()) {
          for (const json& line : *m) {
            if (!messages.empty()) messages += "<br>";
            messages += E(line.is_string() ? line.get<std::string>() : line.dump());
          }
        }
        const std::optional<double> secs = Num(st, {"seconds"});
        if (secs) {
          total += *secs;
          any_time = true;
        }
        rows.push_back({E(Str(st, {"name"})), StatusBadge(Str(st, {"status"})), Duration(secs),
                        I(Num(st, {"done"})), I(Num(st, {"skipped"})), I(Num(st, {"failed"})),
                        messages});
      }
    }
    if (any_time) {
      rows.push_back({"<b>total</b>", "", "<b>" + Duration(total) + "</b>", "", "", "", ""});
    }
    h += rows.empty() ? Empty("WS/run.json lists no stage.")
                      : Table({"stage", "status", "time", "done", "skipped", "failed", "messages"},
                              rows, "llrrrrl");
    return s;
  }

  // No run record: what each stage's own files say.
  h += Empty(
      "WS/run.json not found (the workspace was not made by <code>crop4d run</code>): status and "
      "timings below come from the stages' own summary files (time: the sum over their items).");
  std::vector<fs::path> slam_files, dense_files;
  for (const std::string& session : layout_.SessionFolders()) {
    for (const std::string& pass : layout_.PassFolders(session)) {
      slam_files.push_back(layout_.PassSummary(session, pass));
    }
  }
  for (const std::string& session : layout_.DenseSummarySessions()) {
    dense_files.push_back(layout_.DenseSummary(session));
  }
  const DerivedStage stages[] = {
      {"slam", slam_files, PassSummaryJson, TotalSeconds, "row pass", "es"},
      {"associate", workspace::AssociationSummaries(layout_), AssociationSummaryJson, Seconds,
       "pass pair", "s"},
      {"fuse", {layout_.FusedSummary()}, FusedSummaryJson, TotalSeconds, "joint problem", nullptr},
      {"densify", dense_files, DenseSummaryJson, TotalElseSeconds, "session", "s"},
      {"analyze",
       {layout_.AnalysisSummary()},
       AnalysisSummaryJson,
       SecondsElseTotal,
       "canopy heights, growth",
       nullptr},
      {"eval",
       {layout_.EvalMetrics()},
       EvalMetricsJson,
       Seconds,
       "metrics against ground truth",
       nullptr},
  };
  std::vector<std::vector<std::string>> rows;
  double total = 0;
  for (const DerivedStage& d : stages) {
    int items = 0;
    double seconds = 0;
    bool any_seconds = false;
    for (const fs::path& f : d.files) {
      if (auto j = ReadArtefact(f, d.read)) {
        ++items;
        if (auto t = d.seconds(*j)) {
          seconds += *t;
          any_seconds = true;
        }
      }
    }
    if (items > 0) s.info.has_data = true;
    total += seconds;
    rows.push_back({E(d.name), StatusBadge(items > 0 ? "done" : "not run"),
                    any_seconds ? Duration(seconds) : std::string(kDash),
                    items > 0 ? E(d.What(items)) : std::string(kDash)});
  }
  rows.push_back({"<b>total</b>", "", "<b>" + Duration(total) + "</b>", ""});
  h += Table({"stage", "status", "time (sum)", "outputs"}, rows, "llrl");
  return s;
}

// ---- skipped ---------------------------------------------------------------------------------

// One row per pass whose summary.json carries trust flags: session, pass, the flags, what they
// mean for the estimate.
std::vector<std::vector<std::string>> Builder::UntrustedPasses() {
  static const std::pair<const char*, const char*> kMeaning[] = {
      {"heading_by_convention", "no GPS: the heading is a convention, not a measurement"},
      {"origin_by_convention", "no GPS: the origin is the first body position"},
      {"drift_without_gps", "no GPS: the position drifts with the distance travelled"},
      {"gps_gap", "a GPS outage of more than 2 s inside the pass"},
      {"noise_misfit", "the solve misses the GPS fixes by more than 1.5 sigmas"},
      {"scale_from_metre_gps",
       "no IMU, no precise receiver, no camera height: scale and heading from metre-level fixes"},
      {"camera_unused",
       "fewer than 20 landmarks in the solve: the poses are the motion model's and the GPS's"},
  };
  std::vector<std::vector<std::string>> rows;
  std::vector<fs::path> summaries;
  for (const std::string& session : layout_.SessionFolders()) {
    for (const std::string& pass : layout_.PassFolders(session)) {
      if (fs::exists(layout_.PassSummary(session, pass))) {
        summaries.push_back(layout_.PassSummary(session, pass));
      }
    }
  }
  std::sort(summaries.begin(), summaries.end());
  for (const fs::path& path : summaries) {
    const auto summary = ReadArtefact(
        path, [](const fs::path& p) { return workspace::ReadPassSummary(p.string()); });
    if (!summary || summary->trust.empty()) continue;
    std::string flags, meaning;
    for (const std::string& name : summary->trust) {
      flags += (flags.empty() ? "" : ", ") + name;
      for (const auto& [key, text] : kMeaning) {
        if (name == key) meaning += (meaning.empty() ? "" : "; ") + std::string(text);
      }
    }
    rows.push_back({E(Str(summary->json, {"session"})), E(Str(summary->json, {"pass"})), E(flags),
                    E(meaning)});
  }
  return rows;
}

Section Builder::SkippedSection() {
  Section s{{"skipped", "What was skipped or degraded", false}, ""};
  std::string& h = s.html;
  std::vector<std::vector<std::string>> rows;
  if (run_) {
    if (const json* sk = At(*run_, {"skipped"}); sk != nullptr && sk->is_array()) {
      for (const json& it : *sk) {
        rows.push_back({E(Str(it, {"stage"})), E(Str(it, {"session"})), E(Str(it, {"item"})),
                        E(Str(it, {"reason"}))});
      }
    }
  }
  if (!rows.empty()) {
    h += "<h3>By the pipeline (WS/run.json)</h3>\n";
    h += Table({"stage", "session", "item", "reason"}, rows, "llll", "skips");
  } else if (run_) {
    h += Empty("The run skipped nothing (WS/run.json).");
  } else {
    h += Empty(
        "No run record (WS/run.json): what the stages skipped is not known here; their logs "
        "say.");
  }
  // The sessions' grades (fuse writes them whether or not `crop4d run` ran).
  std::vector<std::vector<std::string>> degraded;
  bool any_trusted = true;
  if (const auto quality = ReadArtefact(layout_.FusedQuality(), [](const fs::path& p) {
        return workspace::ReadSeasonQuality(p.string());
      })) {
    any_trusted = quality->any_trusted;
    for (const workspace::SessionGrade* g : quality->Degraded()) {
      std::string reasons;
      for (const std::string& r : g->reasons) reasons += (reasons.empty() ? "" : "; ") + r;
      degraded.push_back({E(g->session), E(reasons)});
    }
  }
  if (!degraded.empty()) {
    h += "<h3>Degraded sessions (WS/fused/quality.json)</h3>\n";
    h += Table({"session", "why"}, degraded, "ll", "skips");
    h += "<p>" +
         std::string(any_trusted
                         ? "Each was registered onto the trusted sessions without moving them, and "
                           "is left out of their terrain, plant stems and growth curves; its own "
                           "heights are shown but deserve less trust."
                         : "No session is trusted: all were fused and analysed together.") +
         "</p>\n";
  }
  // What row SLAM could not observe in each pass (summary.json "trust", docs/slam.md).
  const std::vector<std::vector<std::string>> untrusted = UntrustedPasses();
  if (!untrusted.empty()) {
    h += "<h3>What row SLAM could not observe (WS/sessions/&lt;session&gt;/rows/&lt;pass&gt;/"
         "summary.json)</h3>\n";
    h += Table({"session", "pass", "flags", "meaning"}, untrusted, "llll", "skips");
  }
  if (!skipped_.empty()) {
    h += "<h3>By this report</h3>\n<ul class=\"skips\">\n";
    for (const std::string& line : skipped_) h += "<li>" + E(line) + "</li>\n";
    h += "</ul>\n";
  } else {
    h += Empty("The report read every input it found.");
  }
  s.info.has_data = !rows.empty() || !degraded.empty() || !untrusted.empty() || !skipped_.empty();
  return s;
}

// ---- page --------------------------------------------------------------------------------------

constexpr const char* kStyle = R"css(
:root { --fg:#1d2327; --muted:#667; --line:#dde1e4; --accent:#2f6f4f; --bg:#fff; }
* { box-sizing: border-box; }
body { margin:0; font:15px/1.5 system-ui,-apple-system,"Segoe UI",Roboto,"DejaVu Sans",sans-serif;
       color:var(--fg); background:#f4f5f2; }
main { max-width:1140px; margin:0 auto; padding:24px 28px 48px; background:var(--bg); }
h1 { font-size:1.7em; margin:0 0 4px; color:var(--accent); }
h2 { font-size:1.3em; margin:36px 0 10px; padding-bottom:4px; border-bottom:2px solid var(--line); }
h3 { font-size:1.05em; margin:18px 0 6px; }
p { margin:6px 0 10px; }
.sub { color:var(--muted); margin:0 0 12px; }
nav { margin:12px 0 4px; font-size:.92em; }
nav a { display:inline-block; margin:2px 10px 2px 0; color:var(--accent); text-decoration:none; }
nav a.nodata { color:var(--muted); }
table { border-collapse:collapse; margin:8px 0 14px; font-size:.9em; }
th, td { padding:4px 10px; border-bottom:1px solid var(--line); text-align:left; vertical-align:top; }
thead th { background:#eef2ee; border-bottom:2px solid #c9d3c9; }
tbody tr:nth-child(even) { background:#fafbfa; }
td.num, th.num { text-align:right; font-variant-numeric:tabular-nums; }
table.kv th { font-weight:600; background:none; color:#333; }
table.heights td { white-space:nowrap; }
.meas { font-style:italic; color:#b5561b; font-size:.92em; }
.empty { color:var(--muted); font-style:italic; }
.muted { color:var(--muted); }
.badge { display:inline-block; padding:0 8px; border-radius:9px; font-size:.85em; }
.badge.ok { background:#dcefe1; color:#1f5e35; }
.badge.warn { background:#fbecd0; color:#7a4b00; }
.badge.bad { background:#f8d7d5; color:#8a1c14; }
.badge.muted { background:#eceeef; color:#556; }
.warnt { color:#8a5a00; } .badt { color:#a0231a; }
ul.skips li { margin:2px 0; }
details { margin:6px 0 12px; } summary { cursor:pointer; color:var(--accent); }
figure { margin:10px 0; } figure img { max-width:100%; height:auto; border:1px solid var(--line); }
figcaption { color:var(--muted); font-size:.9em; }
code { font-size:.92em; background:#f1f3f1; padding:0 3px; border-radius:3px; }
td code { white-space:nowrap; }
.mapbox { display:flex; flex-wrap:wrap; gap:24px; align-items:flex-start; }
svg.map { background:#fff; font-family:inherit; }
svg.map .grid { stroke:#e3e0d6; stroke-width:1; }
svg.map .tick { font-size:10px; fill:#777; }
svg.map .row { stroke:#8c6d46; stroke-width:4; stroke-opacity:.35; stroke-linecap:round; }
svg.map .label { font-size:10px; fill:#555; }
svg.map .track polyline { fill:none; stroke-width:1.6; stroke-opacity:.85; stroke-linejoin:round; }
svg.map .site { fill:#d9534f; fill-opacity:.12; stroke:#b52b27; stroke-width:1.2; }
svg.map .site-label { font-size:9px; fill:#8a1c14; }
svg.map .scale line { stroke:#222; stroke-width:2; } svg.map .scale text { font-size:11px; }
svg.map .north path { fill:#222; } svg.map .north text { font-size:11px; font-weight:600; }
.legend { min-width:240px; font-size:.92em; } .legend h3 { margin-top:0; }
.legend div { margin:3px 0; }
.swatch { display:inline-block; width:14px; height:14px; border-radius:3px; margin-right:6px;
          vertical-align:-2px; }
.swatch.rowsw { background:#8c6d46; opacity:.45; } .swatch.sitesw { background:#f2cdcb;
          border:1px solid #b52b27; border-radius:7px; }
footer { margin-top:40px; color:var(--muted); font-size:.85em; }
)css";

// The page's only JavaScript: marks a completed load and records errors on <html>, for
// scripts/check-report.sh (and anyone curious).
constexpr const char* kScript = R"js(
(function () {
  var d = document.documentElement;
  d.setAttribute('data-js-errors', '0');
  function record(message) {
    d.setAttribute('data-js-errors', String(Number(d.getAttribute('data-js-errors')) + 1));
    d.setAttribute('data-js-last-error', String(message).slice(0, 300));
  }
  window.addEventListener('error', function (e) {
    var t = e.target;
    record(e.message || ('failed to load ' + ((t && (t.src || t.href)) || 'a resource')));
  }, true);
  window.addEventListener('unhandledrejection', function (e) { record('unhandled: ' + e.reason); });
  window.addEventListener('load', function () { d.setAttribute('data-report-loaded', 'yes'); });
})();
)js";

std::string Builder::Build(HtmlReportResult* result) {
  LoadField();
  ListSessions();
  run_ = ReadJson(layout_.RunRecord());
  if (run_ && !run_->is_object()) {
    Skip("WS/run.json: not a JSON object; left out");
    run_.reset();
  }

  std::vector<std::function<Section()>> makers = {
      [&] { return RunSection(); },          [&] { return MapSection(); },
      [&] { return SlamSection(); },         [&] { return AssociationSection(); },
      [&] { return FusionSection(); },       [&] { return DenseSection(); },
      [&] { return CrossSectionSection(); }, [&] { return HeightsSection(); },
      [&] { return GrowthSection(); },       [&] { return EvalSection(); },
  };
  const char* titles[] = {"Run and timings", "Field map",
                          "Row SLAM",        "Associations",
                          "4D fusion",       "Dense clouds",
                          "Cross-section",   "Canopy height per site",
                          "Growth rates",    "Evaluation against ground truth"};
  const char* ids[] = {"run",   "field-map",     "slam",    "associations", "fusion",
                       "dense", "cross-section", "heights", "growth",       "evaluation"};
  std::vector<Section> sections;
  for (std::size_t i = 0; i < makers.size(); ++i) {
    try {
      sections.push_back(makers[i]());
    } catch (const std::exception& e) {
      Skip(std::string(titles[i]) + ": could not be made (" + e.what() + ")");
      sections.push_back(
          {{ids[i], titles[i], false}, Empty("This section could not be made: " + E(e.what()))});
    }
  }
  sections.insert(sections.begin() + 1, SkippedSection());

  const std::string field_name =
      field_info_ ? field_info_->name : fs::path(ws_).lexically_normal().filename().string();
  const std::string title = opt_.title.empty()
                                ? "crop4d season report: " + (field_name.empty() ? ws_ : field_name)
                                : opt_.title;
  std::string h;
  h.reserve(1 << 20);
  h += "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n";
  h += "<meta name=\"viewport\" content=\"width=device-width, initial-scale=1\">\n";
  h += "<meta name=\"generator\" content=\"crop4d " + E(kVersion) + "\">\n";
  h += "<title>" + E(title) + "</title>\n<script>" + std::string(kScript) + "</script>\n";
  h += "<style>" + std::string(kStyle) + "</style>\n</head>\n<body>\n<main>\n";
  h += "<h1>" + E(title) + "</h1>\n";
  std::string session_list;
  for (const std::string& s : sessions_) {
    session_list += "<span class=\"swatch\" style=\"background:" + SessionColor(s) + "\"></span>" +
                    E(s) + " &nbsp; ";
  }
  h += "<p class=\"sub\">Workspace " + Code(ws_) +
       (field_.empty() ? std::string(", no field folder given") : ", field " + Code(field_)) +
       " &middot; generated " + E(NowIsoUtc()) + " by crop4d " + E(kVersion) + "</p>\n";
  h += "<p>" + std::to_string(sessions_.size()) + " session" + (sessions_.size() == 1 ? "" : "s") +
       ": " + (sessions_.empty() ? std::string("none found") : session_list) + "</p>\n";
  // The 4D viewer serves this report at <viewer>/ws/report.html (`crop4d view`, `crop4d export
  // --viewer`): the link back to it is shown only there, since opened as a file the page has no
  // viewer next to it.
  h += "<p class=\"sub\">4D viewer of these clouds: <code>crop4d view " + E(ws_) +
       "</code> <a id=\"viewer-link\" href=\"../index.html\" hidden>open the 4D viewer</a></p>\n"
       "<script>if (/\\/ws\\/report\\.html$/.test(location.pathname)) "
       "document.getElementById('viewer-link').hidden = false;</script>\n";
  h += "<nav>";
  for (const Section& s : sections) {
    h += "<a href=\"#" + s.info.id + "\"" + (s.info.has_data ? "" : " class=\"nodata\"") + ">" +
         E(s.info.title) + "</a>";
  }
  h += "</nav>\n";
  for (const Section& s : sections) {
    h += "<section id=\"" + s.info.id + "\">\n<h2>" + E(s.info.title) + "</h2>\n" + s.html +
         "</section>\n";
  }
  h += "<footer>Regenerate with <code>crop4d report --workspace " + E(ws_) +
       (field_.empty() ? "" : " --field " + E(field_)) +
       "</code>. One self-contained file: images are embedded, nothing is loaded from the "
       "network.</footer>\n";
  h += "</main>\n</body>\n</html>\n";

  if (result != nullptr) {
    result->sections.clear();
    for (const Section& s : sections) result->sections.push_back(s.info);
    result->skipped = skipped_;
  }
  return h;
}

}  // namespace html::detail

OptionCheck HtmlReportOptions::Check() const {
  OptionChecker c;
  c.Finite("cross_section_thickness_m", cross_section_thickness_m)
      .Greater("cross_section_thickness_m", cross_section_thickness_m, 0.0)
      .Finite("cross_section_half_length_m", cross_section_half_length_m)
      .Greater("cross_section_half_length_m", cross_section_half_length_m, 0.0)
      .InRange("map_max_width_px", map_max_width_px, 100, 10000)
      .InRange("map_max_height_px", map_max_height_px, 100, 10000)
      .AtLeast("map_max_points_per_session", map_max_points_per_session, 2);
  return c.Result();
}

std::string Base64Encode(const std::string& bytes) {
  static const char* kTable = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((bytes.size() + 2) / 3 * 4);
  std::size_t i = 0;
  const auto* b = reinterpret_cast<const unsigned char*>(bytes.data());
  for (; i + 3 <= bytes.size(); i += 3) {
    const unsigned v = (b[i] << 16) | (b[i + 1] << 8) | b[i + 2];
    out += kTable[(v >> 18) & 63];
    out += kTable[(v >> 12) & 63];
    out += kTable[(v >> 6) & 63];
    out += kTable[v & 63];
  }
  if (i + 1 == bytes.size()) {
    const unsigned v = b[i] << 16;
    out += kTable[(v >> 18) & 63];
    out += kTable[(v >> 12) & 63];
    out += "==";
  } else if (i + 2 == bytes.size()) {
    const unsigned v = (b[i] << 16) | (b[i + 1] << 8);
    out += kTable[(v >> 18) & 63];
    out += kTable[(v >> 12) & 63];
    out += kTable[(v >> 6) & 63];
    out += '=';
  }
  return out;
}

std::string HtmlEscape(const std::string& text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string BuildHtmlReport(const std::string& workspace, const std::string& field_folder,
                            const HtmlReportOptions& options, HtmlReportResult* result) {
  CROP4D_CHECK_OPTIONS(options, "BuildHtmlReport");
  if (!html::IsDir(workspace)) {
    throw InputError(workspace, 0, "the workspace folder does not exist");
  }
  html::detail::Builder builder(workspace, field_folder, options);
  return builder.Build(result);
}

HtmlReportResult WriteHtmlReport(const std::string& workspace, const std::string& field_folder,
                                 const std::string& output_html, const HtmlReportOptions& options) {
  HtmlReportResult result;
  const std::string html = BuildHtmlReport(workspace, field_folder, options, &result);
  result.path = output_html.empty() ? workspace::Layout(workspace).Report().string() : output_html;
  io::WriteFileAtomic(result.path, html);
  result.bytes = html.size();
  return result;
}

}  // namespace crop4d::report
