#include "crop4d/report/html_report.h"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <functional>
#include <initializer_list>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/tum.h"
#include "crop4d/report/cross_section.h"

namespace crop4d::report {
namespace {

namespace fs = std::filesystem;
using nlohmann::json;

// ---- small helpers -------------------------------------------------------------------------

std::string E(const std::string& s) { return HtmlEscape(s); }

bool IsFile(const fs::path& p) {
  std::error_code ec;
  return fs::is_regular_file(p, ec);
}

bool IsDir(const fs::path& p) {
  std::error_code ec;
  return fs::is_directory(p, ec);
}

// Entries of a folder (files or folders), sorted by name; empty when it cannot be listed.
std::vector<fs::path> ListDir(const fs::path& dir, bool folders) {
  std::vector<fs::path> out;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return out;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code ec2;
    if (folders ? it->is_directory(ec2) : it->is_regular_file(ec2)) out.push_back(it->path());
  }
  std::sort(out.begin(), out.end());
  return out;
}

std::optional<std::string> ReadBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  if (!in) return std::nullopt;
  std::ostringstream s;
  s << in.rdbuf();
  if (in.bad()) return std::nullopt;
  return s.str();
}

// The value at keys... of j, or nullptr.
const json* At(const json& j, std::initializer_list<const char*> keys) {
  const json* v = &j;
  for (const char* k : keys) {
    if (!v->is_object()) return nullptr;
    auto it = v->find(k);
    if (it == v->end()) return nullptr;
    v = &*it;
  }
  return v;
}

std::optional<double> Num(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr || !v->is_number()) return std::nullopt;
  const double d = v->get<double>();
  if (!std::isfinite(d)) return std::nullopt;
  return d;
}

std::string Str(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr) return "";
  if (v->is_string()) return v->get<std::string>();
  if (v->is_boolean()) return v->get<bool>() ? "yes" : "no";
  if (v->is_number()) return v->dump();
  return "";
}

std::optional<bool> Bool(const json& j, std::initializer_list<const char*> keys) {
  const json* v = At(j, keys);
  if (v == nullptr || !v->is_boolean()) return std::nullopt;
  return v->get<bool>();
}

const char* kDash = "&ndash;";

// Fixed decimals, or a dash.
std::string F(std::optional<double> v, int decimals) {
  if (!v) return kDash;
  return fmt::format("{:.{}f}", *v, decimals);
}

// An integer with thin-space thousands separators, or a dash.
std::string I(std::optional<double> v) {
  if (!v) return kDash;
  const long long n = std::llround(*v);
  std::string digits = std::to_string(n < 0 ? -n : n);
  std::string out;
  for (std::size_t i = 0; i < digits.size(); ++i) {
    if (i > 0 && (digits.size() - i) % 3 == 0) out += "&#8201;";
    out += digits[i];
  }
  return n < 0 ? "-" + out : out;
}

// A duration for people: "0.42 s", "17.2 s", "2 min 15 s", "1 h 03 min".
std::string Duration(std::optional<double> seconds) {
  if (!seconds) return kDash;
  const double s = *seconds;
  if (s < 10) return fmt::format("{:.2f} s", s);
  if (s < 60) return fmt::format("{:.1f} s", s);
  const long long total = std::llround(s);
  if (total < 3600) return fmt::format("{} min {:02d} s", total / 60, int(total % 60));
  return fmt::format("{} h {:02d} min", total / 3600, int((total % 3600) / 60));
}

std::string Percent(std::optional<double> fraction, int decimals = 1) {
  if (!fraction) return kDash;
  return fmt::format("{:.{}f} %", 100.0 * *fraction, decimals);
}

std::string Hex(const cv::Vec3b& bgr) {
  return fmt::format("#{:02x}{:02x}{:02x}", bgr[2], bgr[1], bgr[0]);
}

// 1, 2 or 5 × 10^k nearest above `x` (> 0).
double NiceStep(double x) {
  const double p = std::pow(10.0, std::floor(std::log10(x)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * p >= x * 0.999) return m * p;
  }
  return 10 * p;
}

std::string NowIsoUtc() {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm tm{};
  gmtime_r(&now, &tm);
  char buf[32];
  std::strftime(buf, sizeof buf, "%Y-%m-%dT%H:%M:%SZ", &tm);
  return buf;
}

// An HTML table; cells are HTML already. `align`: one letter per column, 'l' or 'r' (numbers).
std::string Table(const std::vector<std::string>& head,
                  const std::vector<std::vector<std::string>>& rows, const std::string& align,
                  const std::string& css_class = "") {
  std::string h = css_class.empty() ? "<table>" : "<table class=\"" + css_class + "\">";
  h += "<thead><tr>";
  for (std::size_t c = 0; c < head.size(); ++c) {
    h += c < align.size() && align[c] == 'r' ? "<th class=\"num\">" : "<th>";
    h += head[c] + "</th>";
  }
  h += "</tr></thead><tbody>\n";
  for (const auto& row : rows) {
    h += "<tr>";
    for (std::size_t c = 0; c < row.size(); ++c) {
      h += c < align.size() && align[c] == 'r' ? "<td class=\"num\">" : "<td>";
      h += row[c] + "</td>";
    }
    h += "</tr>\n";
  }
  return h + "</tbody></table>\n";
}

// A two-column key/value table.
std::string KeyValues(const std::vector<std::pair<std::string, std::string>>& kv) {
  std::string h = "<table class=\"kv\"><tbody>\n";
  for (const auto& [k, v] : kv) h += "<tr><th>" + k + "</th><td>" + v + "</td></tr>\n";
  return h + "</tbody></table>\n";
}

std::string Details(const std::string& summary, const std::string& body) {
  return "<details><summary>" + summary + "</summary>\n" + body + "</details>\n";
}

std::string Empty(const std::string& text) { return "<p class=\"empty\">" + text + "</p>\n"; }

std::string Code(const std::string& text) { return "<code>" + E(text) + "</code>"; }

std::string PngDataUri(const std::string& png) {
  return "data:image/png;base64," + Base64Encode(png);
}

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

std::optional<double> ParseNum(const std::string& s) {
  double v = 0;
  if (!io::ParseDouble(s, &v) || !std::isfinite(v)) return std::nullopt;
  return v;
}

// ---- the report ------------------------------------------------------------------------------

struct Section {
  HtmlReportSection info;
  std::string html;
};

class Builder {
 public:
  Builder(std::string workspace, std::string field, const HtmlReportOptions& options)
      : ws_(std::move(workspace)), field_(std::move(field)), opt_(options) {}

  std::string Build(HtmlReportResult* result);

 private:
  // "WS/<rel>" for messages, and the real path.
  std::string WsLabel(const std::string& rel) const { return "WS/" + rel; }
  fs::path WsPath(const std::string& rel) const { return fs::path(ws_) / rel; }
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
  std::string Why(const std::exception& e) const {
    if (const auto* ie = dynamic_cast<const InputError*>(&e);
        ie != nullptr && !ie->file().empty()) {
      return RelToWs(fs::path(ie->file())) +
             (ie->line() > 0 ? ":" + std::to_string(ie->line()) : std::string()) + ": " +
             ie->message();
    }
    return e.what();
  }

  std::optional<json> ReadJson(const fs::path& p) {
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

  std::optional<Csv> ReadCsv(const fs::path& p, const std::string& label);

  void LoadField();
  void ListSessions();
  std::string SessionColor(const std::string& session) const;

  Section RunSection();
  Section SkippedSection();
  Section MapSection();
  Section SlamSection();
  Section AssociationSection();
  Section FusionSection();
  Section DenseSection();
  Section CrossSectionSection();
  Section HeightsSection();
  Section GrowthSection();
  Section EvalSection();

  std::string ws_, field_;
  const HtmlReportOptions& opt_;
  std::optional<io::FieldInfo> field_info_;
  std::vector<std::string> sessions_;
  std::optional<json> run_;
  std::vector<std::string> skipped_;
};

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
  for (const fs::path& d : ListDir(WsPath("sessions"), true)) add(d.filename().string());
  for (const fs::path& d : ListDir(WsPath("fused"), true)) {
    if (IsFile(d / "poses.tum") || IsFile(d / "sparse.ply")) add(d.filename().string());
  }
  for (const fs::path& f : ListDir(WsPath("dense"), false)) {
    if (f.extension() == ".json") add(f.stem().string());
  }
  std::sort(extra.begin(), extra.end());
  sessions_.insert(sessions_.end(), extra.begin(), extra.end());
}

std::string Builder::SessionColor(const std::string& session) const {
  const auto it = std::find(sessions_.begin(), sessions_.end(), session);
  if (it == sessions_.end()) return "#777777";
  return Hex(report::SessionColor(static_cast<int>(it - sessions_.begin()),
                                  static_cast<int>(sessions_.size())));
}

std::string StatusBadge(const std::string& status) {
  std::string cls = "muted";
  if (status == "done" || status == "up to date") cls = "ok";
  if (status == "partial") cls = "warn";
  if (status == "failed") cls = "bad";
  return "<span class=\"badge " + cls + "\">" + E(status.empty() ? "?" : status) + "</span>";
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
  struct Derived {
    std::string name;
    int items = 0;
    double seconds = 0;
    bool any_seconds = false;
    std::string what;
  };
  std::vector<Derived> stages;
  {
    Derived d;
    d.name = "slam";
    for (const fs::path& sd : ListDir(WsPath("sessions"), true)) {
      for (const fs::path& pd : ListDir(sd / "rows", true)) {
        if (auto j = ReadJson(pd / "summary.json")) {
          ++d.items;
          if (auto t = Num(*j, {"seconds", "total"})) {
            d.seconds += *t;
            d.any_seconds = true;
          }
        }
      }
    }
    d.what = fmt::format("{} row pass{}", d.items, d.items == 1 ? "" : "es");
    stages.push_back(d);
  }
  {
    Derived d;
    d.name = "associate";
    for (const fs::path& md : ListDir(WsPath("associations"), true)) {
      for (const fs::path& f : ListDir(md, false)) {
        if (f.extension() != ".json" || f.filename() == "summary.json") continue;
        if (auto j = ReadJson(f)) {
          ++d.items;
          if (auto t = Num(*j, {"seconds"})) {
            d.seconds += *t;
            d.any_seconds = true;
          }
        }
      }
    }
    d.what = fmt::format("{} pass pair{}", d.items, d.items == 1 ? "" : "s");
    stages.push_back(d);
  }
  {
    Derived d;
    d.name = "fuse";
    if (auto j = ReadJson(WsPath("fused/summary.json"))) {
      d.items = 1;
      if (auto t = Num(*j, {"seconds", "total"})) {
        d.seconds = *t;
        d.any_seconds = true;
      }
      d.what = "joint problem";
    }
    stages.push_back(d);
  }
  {
    Derived d;
    d.name = "densify";
    for (const fs::path& f : ListDir(WsPath("dense"), false)) {
      if (f.extension() != ".json") continue;
      if (auto j = ReadJson(f)) {
        ++d.items;
        std::optional<double> t = Num(*j, {"seconds", "total"});
        if (!t) t = Num(*j, {"seconds"});
        if (t) {
          d.seconds += *t;
          d.any_seconds = true;
        }
      }
    }
    d.what = fmt::format("{} session{}", d.items, d.items == 1 ? "" : "s");
    stages.push_back(d);
  }
  {
    Derived d;
    d.name = "analyze";
    if (auto j = ReadJson(WsPath("analysis/summary.json"))) {
      d.items = 1;
      std::optional<double> t = Num(*j, {"seconds"});
      if (!t) t = Num(*j, {"seconds", "total"});
      if (t) {
        d.seconds = *t;
        d.any_seconds = true;
      }
      d.what = "canopy heights, growth";
    }
    stages.push_back(d);
  }
  {
    Derived d;
    d.name = "eval";
    if (auto j = ReadJson(WsPath("eval/metrics.json"))) {
      d.items = 1;
      if (auto t = Num(*j, {"seconds"})) {
        d.seconds = *t;
        d.any_seconds = true;
      }
      d.what = "metrics against ground truth";
    }
    stages.push_back(d);
  }
  std::vector<std::vector<std::string>> rows;
  double total = 0;
  for (const Derived& d : stages) {
    if (d.items > 0) s.info.has_data = true;
    total += d.seconds;
    rows.push_back({E(d.name), StatusBadge(d.items > 0 ? "done" : "not run"),
                    d.any_seconds ? Duration(d.seconds) : std::string(kDash),
                    d.items > 0 ? E(d.what) : std::string(kDash)});
  }
  rows.push_back({"<b>total</b>", "", "<b>" + Duration(total) + "</b>", ""});
  h += Table({"stage", "status", "time (sum)", "outputs"}, rows, "llrl");
  return s;
}

// ---- skipped ---------------------------------------------------------------------------------

Section Builder::SkippedSection() {
  Section s{{"skipped", "What was skipped", false}, ""};
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
  if (!skipped_.empty()) {
    h += "<h3>By this report</h3>\n<ul class=\"skips\">\n";
    for (const std::string& line : skipped_) h += "<li>" + E(line) + "</li>\n";
    h += "</ul>\n";
  } else {
    h += Empty("The report read every input it found.");
  }
  s.info.has_data = !rows.empty() || !skipped_.empty();
  return s;
}

// ---- field map -------------------------------------------------------------------------------

Section Builder::MapSection() {
  Section s{{"field-map", "Field map", false}, ""};
  struct Track {
    std::string session, source;
    std::vector<std::vector<Eigen::Vector2d>> lines;
    int poses = 0;
    double length_m = 0;
  };
  std::vector<Track> tracks;
  const auto load_tum = [&](const fs::path& p, Track* t) {
    std::vector<io::StampedPose> poses;
    try {
      poses = io::ReadTum(p.string());
    } catch (const std::exception& e) {
      Skip(Why(e) + "; left off the map");
      return;
    }
    std::vector<Eigen::Vector2d> line;
    Timestamp last = 0;
    for (const io::StampedPose& sp : poses) {
      const Eigen::Vector3d x = sp.pose.translation();
      if (!x.allFinite()) continue;
      const Eigen::Vector2d xy = x.head<2>();
      if (!line.empty() && (sp.t - last > 1'000'000'000LL || (xy - line.back()).norm() > 2.0)) {
        t->lines.push_back(std::move(line));
        line.clear();
      }
      if (!line.empty()) t->length_m += (xy - line.back()).norm();
      line.push_back(xy);
      last = sp.t;
      ++t->poses;
    }
    if (!line.empty()) t->lines.push_back(std::move(line));
  };
  for (const std::string& session : sessions_) {
    Track t;
    t.session = session;
    const fs::path fused = WsPath("fused") / session / "poses.tum";
    if (IsFile(fused)) {
      t.source = "fused";
      load_tum(fused, &t);
    } else {
      for (const fs::path& pd : ListDir(WsPath("sessions") / session / "rows", true)) {
        if (IsFile(pd / "poses.tum")) {
          t.source = "row SLAM";
          load_tum(pd / "poses.tum", &t);
        }
      }
    }
    if (t.poses > 0) tracks.push_back(std::move(t));
  }

  // Bounds of everything drawn.
  Eigen::Vector2d lo(INFINITY, INFINITY), hi(-INFINITY, -INFINITY);
  auto grow = [&](const Eigen::Vector2d& p, double r = 0) {
    lo = lo.cwiseMin(p - Eigen::Vector2d(r, r));
    hi = hi.cwiseMax(p + Eigen::Vector2d(r, r));
  };
  if (field_info_) {
    for (const io::RowDeclaration& row : field_info_->rows) {
      grow(row.start_enu);
      grow(row.end_enu);
    }
    for (const io::Site& site : field_info_->sites) grow(site.center_enu, site.radius_m);
  }
  for (const Track& t : tracks) {
    for (const auto& line : t.lines) {
      for (const Eigen::Vector2d& p : line) grow(p);
    }
  }
  if (!(lo.allFinite() && hi.allFinite())) {
    s.html = Empty(
        "Nothing to draw: no rows or sites (FIELD/field.yaml) and no trajectory (WS/fused/"
        "&lt;session&gt;/poses.tum or WS/sessions/&lt;session&gt;/rows/*/poses.tum).");
    return s;
  }
  s.info.has_data = true;
  const Eigen::Vector2d pad = (0.04 * (hi - lo)).cwiseMax(Eigen::Vector2d(0.5, 0.5));
  lo -= pad;
  hi += pad;
  const Eigen::Vector2d size = hi - lo;
  // A field much longer north-south than wide is drawn turned a quarter turn clockwise (north to
  // the right, east down), so that it fills the page's width; the north arrow shows it.
  const bool turned = size.y() > 1.6 * size.x();
  const double span_w = turned ? size.y() : size.x(), span_h = turned ? size.x() : size.y();
  const double scale = std::min(opt_.map_max_width_px / span_w, opt_.map_max_height_px / span_h);
  const double ml = 46, mr = 34, mt = 28, mb = 58;
  const double pw = span_w * scale, ph = span_h * scale;
  const double width = std::max(pw + ml + mr, 260.0), height = ph + mt + mb;
  // Pixel position of ENU (x, y).
  auto P = [&](double x, double y) {
    return turned ? Eigen::Vector2d(ml + (y - lo.y()) * scale, mt + (x - lo.x()) * scale)
                  : Eigen::Vector2d(ml + (x - lo.x()) * scale, mt + (hi.y() - y) * scale);
  };

  std::string svg = fmt::format(
      "<svg xmlns=\"http://www.w3.org/2000/svg\" class=\"map\" width=\"{:.0f}\" "
      "height=\"{:.0f}\" viewBox=\"0 0 {:.0f} {:.0f}\" role=\"img\" aria-label=\"field map\">\n"
      "<rect x=\"{:.1f}\" y=\"{:.1f}\" width=\"{:.1f}\" height=\"{:.1f}\" fill=\"#f7f5ef\" "
      "stroke=\"#ccc\"/>\n",
      width, height, width, height, ml, mt, pw, ph);
  // Grid with coordinates: east on the bottom (upright) or left (turned) edge, north on the left
  // (upright) or bottom (turned) edge.
  auto grid_line = [&](const Eigen::Vector2d& a, const Eigen::Vector2d& b, double value,
                       double step, bool on_left) {
    const int decimals = step >= 1 ? 0 : (step >= 0.1 ? 1 : 2);
    const Eigen::Vector2d at =
        on_left ? Eigen::Vector2d(ml - 4, a.y() + 3) : Eigen::Vector2d(a.x(), mt + ph + 12);
    svg += fmt::format(
        "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"grid\"/>"
        "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"{}\">{:.{}f}</text>\n",
        a.x(), a.y(), b.x(), b.y(), at.x(), at.y(), on_left ? "end" : "middle",
        std::abs(value) < 1e-9 ? 0.0 : value, decimals);
  };
  // One step per axis, about 60 px or more apart.
  const double step_x = NiceStep(std::max(size.x() / 8.0, 60.0 / scale));
  const double step_y = NiceStep(std::max(size.y() / 8.0, 60.0 / scale));
  for (double x = std::ceil(lo.x() / step_x) * step_x; x <= hi.x(); x += step_x) {
    grid_line(turned ? P(x, lo.y()) : P(x, hi.y()), turned ? P(x, hi.y()) : P(x, lo.y()), x, step_x,
              turned);
  }
  for (double y = std::ceil(lo.y() / step_y) * step_y; y <= hi.y(); y += step_y) {
    grid_line(P(lo.x(), y), P(hi.x(), y), y, step_y, !turned);
  }
  if (field_info_) {
    for (const io::RowDeclaration& row : field_info_->rows) {
      const Eigen::Vector2d a = P(row.start_enu.x(), row.start_enu.y());
      const Eigen::Vector2d b = P(row.end_enu.x(), row.end_enu.y());
      svg += fmt::format(
          "<line x1=\"{:.1f}\" y1=\"{:.1f}\" x2=\"{:.1f}\" y2=\"{:.1f}\" class=\"row\"><title>row "
          "{}</title></line>\n",
          a.x(), a.y(), b.x(), b.y(), row.index);
      // The index beyond the row's north end.
      const Eigen::Vector2d top = row.start_enu.y() > row.end_enu.y() ? row.start_enu : row.end_enu;
      const Eigen::Vector2d t =
          P(top.x(), top.y()) + (turned ? Eigen::Vector2d(6, 3) : Eigen::Vector2d(0, -5));
      svg += fmt::format(
          "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label\" text-anchor=\"{}\">{}<title>row "
          "{}</title></text>\n",
          t.x(), t.y(), turned ? "start" : "middle", row.index, row.index);
    }
  }
  for (const Track& t : tracks) {
    const std::string color = SessionColor(t.session);
    int total = 0;
    for (const auto& line : t.lines) total += static_cast<int>(line.size());
    const int stride = std::max(1, (total + opt_.map_max_points_per_session - 1) /
                                       std::max(2, opt_.map_max_points_per_session));
    svg += "<g class=\"track\" stroke=\"" + color + "\"><title>" + E(t.session) + " (" +
           E(t.source) + ")</title>\n";
    for (const auto& line : t.lines) {
      if (line.size() < 2) continue;
      std::string pts;
      for (std::size_t i = 0; i < line.size(); ++i) {
        if (i % stride != 0 && i + 1 != line.size()) continue;
        const Eigen::Vector2d q = P(line[i].x(), line[i].y());
        pts += fmt::format("{:.1f},{:.1f} ", q.x(), q.y());
      }
      svg += "<polyline points=\"" + pts + "\"/>\n";
    }
    svg += "</g>\n";
  }
  if (field_info_) {
    const std::vector<io::Site>& sites = field_info_->sites;
    for (const io::Site& site : sites) {
      const Eigen::Vector2d c = P(site.center_enu.x(), site.center_enu.y());
      const double r = std::max(2.0, site.radius_m * scale);
      svg += fmt::format(
          "<circle cx=\"{:.1f}\" cy=\"{:.1f}\" r=\"{:.1f}\" class=\"site\"><title>site {} "
          "({:.2f}, {:.2f}) m, radius {:.2f} m</title></circle>\n",
          c.x(), c.y(), r, E(site.id), site.center_enu.x(), site.center_enu.y(), site.radius_m);
      // The label right of the circle, when no other site's circle is in its way (else the
      // circle's tooltip names it).
      const double label_w = 5.5 * site.id.size() + 4;
      bool room = true;
      for (const io::Site& other : sites) {
        if (&other == &site) continue;
        const Eigen::Vector2d o = P(other.center_enu.x(), other.center_enu.y());
        const double orad = std::max(2.0, other.radius_m * scale);
        if (o.x() - orad < c.x() + r + label_w && o.x() + orad > c.x() &&
            std::abs(o.y() - c.y()) < orad + 6) {
          room = false;
        }
      }
      if (room) {
        svg += fmt::format("<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"label site-label\">{}</text>\n",
                           c.x() + r + 2, c.y() + 3, E(site.id));
      }
    }
  }
  // Scale bar (bottom left) and north arrow (top right).
  double bar = NiceStep(std::max(size.x(), size.y()) / 5.0);
  while (bar * scale > pw && bar > 1e-3) bar = NiceStep(bar / 2.5);
  const double bx = ml, by = height - 18;
  svg += fmt::format(
      "<g class=\"scale\"><line x1=\"{0:.1f}\" y1=\"{1:.1f}\" x2=\"{2:.1f}\" y2=\"{1:.1f}\"/>"
      "<line x1=\"{0:.1f}\" y1=\"{3:.1f}\" x2=\"{0:.1f}\" y2=\"{4:.1f}\"/>"
      "<line x1=\"{2:.1f}\" y1=\"{3:.1f}\" x2=\"{2:.1f}\" y2=\"{4:.1f}\"/>"
      "<text x=\"{5:.1f}\" y=\"{6:.1f}\" text-anchor=\"middle\">{7} m</text></g>\n",
      bx, by, bx + bar * scale, by - 4, by + 4, bx + bar * scale / 2, by - 7, bar);
  svg += fmt::format(
      "<g class=\"north\" transform=\"translate({:.1f},{:.1f}) rotate({})\"><path d=\"M0,-9 "
      "l-5,12 l5,-3 l5,3 z\"/><text x=\"0\" y=\"15\" text-anchor=\"middle\" "
      "transform=\"rotate({})\">N</text></g>\n",
      width - mr + 14, turned ? mt + 14.0 : 16.0, turned ? 90 : 0, turned ? -90 : 0);
  svg += fmt::format(
      "<text x=\"{:.1f}\" y=\"{:.1f}\" class=\"tick\" text-anchor=\"end\">{}</text>\n", ml + pw,
      mt + ph + 26, turned ? "north [m] (turned: north to the right, east down)" : "east [m]");
  svg += "</svg>\n";

  // Legend.
  std::string legend = "<div class=\"legend\"><h3>Sessions</h3>\n";
  if (tracks.empty()) legend += Empty("No trajectory in the workspace yet.");
  for (const Track& t : tracks) {
    legend += fmt::format(
        "<div><span class=\"swatch\" style=\"background:{}\"></span>{} <span "
        "class=\"muted\">{}, {} poses, {:.0f} m</span></div>\n",
        SessionColor(t.session), E(t.session), E(t.source), t.poses, t.length_m);
  }
  legend +=
      "<h3>Field</h3>\n<div><span class=\"swatch rowsw\"></span>crop row "
      "(field.yaml; its index at its north end)</div>\n<div><span class=\"swatch "
      "sitesw\"></span>measurement site</div>\n";
  if (!field_info_) legend += Empty("No field.yaml: rows and sites are not drawn.");
  legend +=
      "<p class=\"muted\">Hover a site, row or trajectory for its name. ENU frame of the field "
      "(x east, y north), metres" +
      std::string(field_info_ ? fmt::format("; origin {:.6f}, {:.6f}", field_info_->origin.lat_deg,
                                            field_info_->origin.lon_deg)
                              : std::string("")) +
      "</p></div>\n";
  s.html = "<div class=\"mapbox\">" + svg + legend + "</div>\n";
  return s;
}

// ---- row SLAM ----------------------------------------------------------------------------------

Section Builder::SlamSection() {
  Section s{{"slam", "Row SLAM", false}, ""};
  std::vector<std::vector<std::string>> per_session, per_pass;
  for (const std::string& session : sessions_) {
    const fs::path sd = WsPath("sessions") / session;
    if (!IsDir(sd)) continue;
    int listed = -1;
    std::vector<std::string> listed_passes;
    if (auto csv = ReadCsv(sd / "passes.csv", WsLabel("sessions/" + session + "/passes.csv"))) {
      listed = static_cast<int>(csv->rows.size());
      const int c = csv->Col("pass");
      for (const auto& row : csv->rows) {
        if (c >= 0) listed_passes.push_back(row[c]);
      }
    }
    int solved = 0, converged = 0;
    double images = 0, landmarks = 0, seconds = 0, rms_sum = 0;
    int rms_n = 0;
    std::set<std::string> have;
    for (const fs::path& pd : ListDir(sd / "rows", true)) {
      auto j = ReadJson(pd / "summary.json");
      if (!j) continue;
      ++solved;
      const std::string pass = pd.filename().string();
      have.insert(pass);
      const std::optional<bool> conv = Bool(*j, {"back_end", "converged"});
      if (conv.value_or(false)) ++converged;
      images += Num(*j, {"images"}).value_or(0);
      landmarks += Num(*j, {"back_end", "landmarks"}).value_or(0);
      seconds += Num(*j, {"seconds", "total"}).value_or(0);
      if (auto r = Num(*j, {"back_end", "reprojection_rms_px"})) {
        rms_sum += *r;
        ++rms_n;
      }
      per_pass.push_back({E(session), E(pass), I(Num(*j, {"row"})), E(Str(*j, {"direction"})),
                          E(Str(*j, {"sensors"})), I(Num(*j, {"images"})),
                          I(Num(*j, {"back_end", "landmarks"})), I(Num(*j, {"cloud", "points"})),
                          F(Num(*j, {"back_end", "reprojection_rms_px"}), 2),
                          I(Num(*j, {"back_end", "rejected_observations"})),
                          I(Num(*j, {"back_end", "gps_factors"})),
                          conv ? (*conv ? "yes" : "<span class=\"warnt\">no</span>") : kDash,
                          Duration(Num(*j, {"seconds", "total"}))});
    }
    if (solved > 0) {
      for (const std::string& p : listed_passes) {
        if (!have.count(p)) {
          Skip("slam: session " + session + ", pass " + p + ": no rows/" + p +
               "/summary.json (not solved, or it failed)");
        }
      }
    }
    per_session.push_back({E(session), listed >= 0 ? std::to_string(listed) : std::string(kDash),
                           std::to_string(solved), I(images), I(landmarks),
                           rms_n > 0 ? F(rms_sum / rms_n, 2) : std::string(kDash),
                           fmt::format("{}/{}", converged, solved),
                           solved > 0 ? Duration(seconds) : kDash});
  }
  if (per_session.empty()) {
    s.html = Empty("Row SLAM has not run: no WS/sessions/&lt;session&gt;/ folder.");
    return s;
  }
  s.info.has_data = !per_pass.empty();
  s.html +=
      "<p>One factor graph per row pass (SIFT tracks, IMU preintegration, GP motion prior, "
      "GPS).</p>\n";
  s.html += Table({"session", "passes", "solved", "images", "landmarks", "mean reproj. RMS [px]",
                   "converged", "time"},
                  per_session, "lrrrrrrr");
  if (!per_pass.empty()) {
    s.html += Details(
        fmt::format("Every pass ({})", per_pass.size()),
        Table({"session", "pass", "row", "dir", "sensors", "images", "landmarks", "cloud points",
               "reproj. RMS [px]", "rejected obs.", "GPS factors", "converged", "time"},
              per_pass, "llrrlrrrrrrlr"));
  } else {
    s.html += Empty("No pass has a summary.json yet.");
  }
  return s;
}

// ---- associations -----------------------------------------------------------------------------

Section Builder::AssociationSection() {
  Section s{{"associations", "Associations", false}, ""};
  struct Pair {
    std::string a, b, type;
    std::optional<double> matches, image_pairs, putative, seconds;
    bool prealigned = false;
  };
  std::map<std::string, std::vector<Pair>> by_method;
  std::vector<fs::path> files = ListDir(WsPath("associations"), false);
  for (const fs::path& md : ListDir(WsPath("associations"), true)) {
    for (const fs::path& f : ListDir(md, false)) files.push_back(f);
  }
  for (const fs::path& f : files) {
    if (f.extension() != ".json") continue;
    auto j = ReadJson(f);
    if (!j || At(*j, {"a"}) == nullptr || At(*j, {"b"}) == nullptr) continue;
    Pair p;
    p.a = Str(*j, {"a", "session"}) + " " + Str(*j, {"a", "pass"});
    p.b = Str(*j, {"b", "session"}) + " " + Str(*j, {"b", "pass"});
    p.type = Str(*j, {"type"});
    p.matches = Num(*j, {"matches"});
    p.image_pairs = Num(*j, {"image_pairs"});
    p.putative = Num(*j, {"putative"});
    p.seconds = Num(*j, {"seconds"});
    p.prealigned = Bool(*j, {"prealigned"}).value_or(false);
    std::string method = Str(*j, {"method"});
    if (method.empty()) method = f.parent_path().filename().string();
    by_method[method].push_back(p);
  }
  if (by_method.empty()) {
    s.html = Empty(
        "Association has not run: no WS/associations/&lt;method&gt;/&lt;a&gt;__&lt;b&gt;.json.");
    return s;
  }
  s.info.has_data = true;
  s.html +=
      "<p>Cross matches between neighbouring row passes: adjacent rows of one session, and the "
      "same row in adjacent sessions.</p>\n";
  for (const auto& [method, pairs] : by_method) {
    s.html += "<h3>Method: " + E(method) + "</h3>\n";
    double matches = 0, image_pairs = 0, seconds = 0;
    int zero = 0;
    std::map<std::string, std::vector<double>> per_type;
    std::vector<std::vector<std::string>> rows;
    for (const Pair& p : pairs) {
      matches += p.matches.value_or(0);
      image_pairs += p.image_pairs.value_or(0);
      seconds += p.seconds.value_or(0);
      if (p.matches.value_or(0) == 0) ++zero;
      per_type[p.type.empty() ? std::string("(unknown)") : p.type].push_back(p.matches.value_or(0));
      rows.push_back({E(p.a), E(p.b), E(p.type), I(p.image_pairs), I(p.putative), I(p.matches),
                      p.prealigned ? "yes" : "no", Duration(p.seconds)});
    }
    s.html += KeyValues({{"pass pairs", I(double(pairs.size()))},
                         {"pairs without a match", I(double(zero))},
                         {"cross matches", I(matches)},
                         {"image pairs matched", I(image_pairs)},
                         {"time (sum)", Duration(seconds)}});
    std::vector<std::vector<std::string>> type_rows;
    for (auto& [type, m] : per_type) {
      std::vector<double> sorted = m;
      std::sort(sorted.begin(), sorted.end());
      double sum = 0;
      int z = 0;
      for (double v : m) {
        sum += v;
        if (v == 0) ++z;
      }
      type_rows.push_back({E(type), I(double(m.size())), I(sum), I(sorted[sorted.size() / 2]),
                           I(sorted.front()), I(sorted.back()), I(double(z))});
    }
    s.html += Table(
        {"pair type", "pairs", "matches", "median per pair", "min", "max", "pairs without a match"},
        type_rows, "lrrrrrr");
    s.html += Details(fmt::format("Every pair ({})", pairs.size()),
                      Table({"pass a", "pass b", "type", "image pairs", "putative", "matches",
                             "pre-aligned", "time"},
                            rows, "lllrrrlr"));
  }
  return s;
}

// ---- fusion -------------------------------------------------------------------------------------

Section Builder::FusionSection() {
  Section s{{"fusion", "4D fusion", false}, ""};
  auto j = ReadJson(WsPath("fused/summary.json"));
  if (!j) {
    s.html = Empty("4D fusion has not run: no WS/fused/summary.json.");
    return s;
  }
  s.info.has_data = true;
  const json& f = *j;
  std::string sessions;
  if (const json* ss = At(f, {"sessions"}); ss != nullptr && ss->is_array()) {
    for (const json& x : *ss) {
      if (!sessions.empty()) sessions += ", ";
      sessions += E(x.is_string() ? x.get<std::string>() : x.dump());
    }
  }
  const std::optional<bool> conv = Bool(f, {"joint", "converged"});
  s.html += KeyValues({
      {"sessions", sessions.empty() ? std::string(kDash) : sessions},
      {"row passes", I(Num(f, {"joint", "passes"}))},
      {"states", I(Num(f, {"joint", "states"}))},
      {"landmarks (shared by passes)",
       I(Num(f, {"joint", "landmarks"})) + " (" + I(Num(f, {"joint", "shared_landmarks"})) + ")"},
      {"observations (cross)", I(Num(f, {"joint", "observations"})) + " (" +
                                   I(Num(f, {"joint", "cross_observations"})) + ")"},
      {"rejected observations (cross)", I(Num(f, {"joint", "rejected_observations"})) + " (" +
                                            I(Num(f, {"joint", "rejected_cross_observations"})) +
                                            ")"},
      {"reprojection RMS [px] (cross)", F(Num(f, {"joint", "reprojection_rms_px"}), 3) + " (" +
                                            F(Num(f, {"joint", "cross_reprojection_rms_px"}), 3) +
                                            ")"},
      {"cost, initial &rarr; final", F(Num(f, {"joint", "initial_cost"}), 1) + " &rarr; " +
                                         F(Num(f, {"joint", "final_cost"}), 1)},
      {"iterations (converged)",
       I(Num(f, {"joint", "iterations"})) + " (" +
           (conv ? (*conv ? std::string("yes")
                          : std::string("<span class=\"warnt\">no: iteration limit</span>"))
                 : std::string(kDash)) +
           ")"},
      {"cross matches read (files)", I(Num(f, {"associations", "cross_matches"})) + " (" +
                                         I(Num(f, {"associations", "files"})) + ")"},
      {"time: solve / final solve / total", Duration(Num(f, {"seconds", "solve"})) + " / " +
                                                Duration(Num(f, {"seconds", "final_solve"})) +
                                                " / " + Duration(Num(f, {"seconds", "total"}))},
  });
  std::vector<std::vector<std::string>> rows;
  if (const json* ps = At(f, {"passes"}); ps != nullptr && ps->is_array()) {
    for (const json& p : *ps) {
      std::optional<double> shift;
      if (const json* m = At(p, {"mean_shift_m"}); m != nullptr && m->is_array()) {
        double n2 = 0;
        for (const json& v : *m) n2 += v.is_number() ? v.get<double>() * v.get<double>() : 0;
        shift = 1000.0 * std::sqrt(n2);
      }
      rows.push_back({E(Str(p, {"session"})), E(Str(p, {"pass"})), I(Num(p, {"images"})),
                      F(shift, 1), F(Num(p, {"rotation_change_deg"}), 3)});
    }
  }
  if (!rows.empty()) {
    s.html +=
        Details(fmt::format("Change from row SLAM, every pass ({})", rows.size()),
                Table({"session", "pass", "images", "mean shift [mm]", "rotation change [deg]"},
                      rows, "llrrr"));
  }
  return s;
}

// ---- dense --------------------------------------------------------------------------------------

Section Builder::DenseSection() {
  Section s{{"dense", "Dense clouds", false}, ""};
  std::vector<std::vector<std::string>> rows;
  double total = 0;
  for (const fs::path& f : ListDir(WsPath("dense"), false)) {
    if (f.extension() != ".json") continue;
    auto j = ReadJson(f);
    if (!j) continue;
    std::string session = Str(*j, {"session"});
    if (session.empty()) session = f.stem().string();
    std::optional<double> secs = Num(*j, {"seconds", "total"});
    if (!secs) secs = Num(*j, {"seconds"});
    total += secs.value_or(0);
    std::optional<double> mb;
    std::error_code ec;
    const fs::path ply = f.parent_path() / (f.stem().string() + ".ply");
    const auto bytes = fs::file_size(ply, ec);
    if (!ec) mb = bytes / 1e6;
    rows.push_back({"<span class=\"swatch\" style=\"background:" + SessionColor(session) +
                        "\"></span>" + E(session),
                    I(Num(*j, {"points"})), I(Num(*j, {"images", "used"})),
                    F(Num(*j, {"images", "mean_views_per_tile"}), 1), I(Num(*j, {"tiles"})),
                    F(mb, 1), Duration(secs)});
  }
  if (rows.empty()) {
    s.html = Empty("Densification has not run: no WS/dense/&lt;session&gt;.json.");
    return s;
  }
  s.info.has_data = true;
  rows.push_back({"<b>total</b>", "", "", "", "", "", "<b>" + Duration(total) + "</b>"});
  s.html += "<p>Height-field multi-view stereo from the fused cameras.</p>\n";
  s.html +=
      Table({"session", "points", "images used", "views per tile", "tiles", "PLY [MB]", "time"},
            rows, "lrrrrrr");
  return s;
}

// ---- cross-section ------------------------------------------------------------------------------

Section Builder::CrossSectionSection() {
  Section s{{"cross-section", "Cross-section", false}, ""};
  if (!opt_.cross_section) {
    s.html = Empty("Left out (report option).");
    return s;
  }
  if (!field_info_ || field_info_->rows.empty()) {
    s.html = Empty(field_info_ ? "No cross-section: FIELD/field.yaml declares no rows."
                               : "No cross-section: it needs the field's rows (give --field).");
    return s;
  }
  const std::vector<io::RowDeclaration>& rows = field_info_->rows;
  const io::RowDeclaration* row = &rows[(rows.size() - 1) / 2];
  if (opt_.cross_section_row) {
    auto it = std::find_if(rows.begin(), rows.end(), [&](const io::RowDeclaration& r) {
      return r.index == *opt_.cross_section_row;
    });
    if (it == rows.end()) {
      Skip(fmt::format("cross-section: field.yaml has no row {}; drawn across row {}",
                       *opt_.cross_section_row, row->index));
    } else {
      row = &*it;
    }
  }
  const CrossSectionSlice slice = SliceAcrossRow(*row, std::nullopt, opt_.cross_section_thickness_m,
                                                 opt_.cross_section_half_length_m);
  // Per session: the dense cloud (only its points near the slice are kept), else the fused or
  // row SLAM cloud.
  std::vector<SessionCloud> clouds;
  int dense_count = 0;
  const Eigen::Vector2d dir = slice.direction.normalized();
  const Eigen::Vector2d left(-dir.y(), dir.x());
  for (const std::string& session : sessions_) {
    const fs::path dense = WsPath("dense") / (session + ".ply");
    if (opt_.cross_section_dense && IsFile(dense)) {
      try {
        io::PlyPointCloud all = io::ReadPly(dense.string());
        SessionCloud c{session, {}, RelToWs(dense), {RelToWs(dense)}};
        for (std::size_t i = 0; i < all.points.size(); ++i) {
          const Eigen::Vector2d d = all.points[i].head<2>() - slice.center;
          if (std::abs(d.dot(left)) <= slice.thickness_m &&
              std::abs(d.dot(dir)) <= slice.half_length_m + slice.thickness_m) {
            c.cloud.points.push_back(all.points[i]);
            if (all.colors.size() == all.points.size()) c.cloud.colors.push_back(all.colors[i]);
          }
        }
        clouds.push_back(std::move(c));
        ++dense_count;
        continue;
      } catch (const std::exception& e) {
        Skip("cross-section: " + Why(e) + "; the sparse cloud is used instead");
      }
    }
    if (!IsDir(WsPath("sessions") / session) && !IsDir(WsPath("fused") / session)) continue;
    try {
      std::vector<std::string> missing;
      std::vector<SessionCloud> one = LoadSessionClouds(ws_, {session}, &missing);
      for (SessionCloud& c : one) clouds.push_back(std::move(c));
      if (!missing.empty()) {
        Skip("cross-section: session " + session + " has no cloud; left out of the figure");
      }
    } catch (const std::exception& e) {
      Skip("cross-section: " + Why(e) + "; session " + session + " left out");
    }
  }
  if (clouds.empty()) {
    s.html = Empty(
        "No cross-section: no cloud (WS/dense/&lt;session&gt;.ply, WS/fused/&lt;session&gt;/"
        "sparse.ply or row SLAM landmarks.ply).");
    return s;
  }
  CrossSectionOptions o;
  o.slice = slice;
  o.plot_width_px = 1000;
  if (dense_count > 0) o.point_radius_px = 1;
  o.max_plot_height_px = 600;
  o.title = fmt::format("Cross-section of row {} at x = {:.2f} m, y = {:.2f} m ({:.2f} m thick)",
                        row->index, o.slice.center.x(), o.slice.center.y(), o.slice.thickness_m);
  o.along_label = "position across the row [m]";
  std::vector<io::PlyPointCloud> layers;
  std::vector<std::string> labels;
  std::string sources;
  for (SessionCloud& c : clouds) {
    sources += "<li>" + E(c.session) + ": " + E(c.source) + "</li>";
    layers.push_back(std::move(c.cloud));
    labels.push_back(c.session);
  }
  const CrossSectionFigure figure = DrawCrossSection(layers, labels, o);
  std::vector<unsigned char> png;
  if (!cv::imencode(".png", figure.image, png)) {
    Skip("cross-section: the figure could not be encoded as PNG");
    s.html = Empty("No cross-section: PNG encoding failed.");
    return s;
  }
  s.info.has_data = true;
  s.html += fmt::format(
      "<p>The paper's figure: a {:.0f} cm slice across row {}, perpendicular to it, the points of "
      "each session coloured by date (earliest dark violet, latest green); {} points of {} in the "
      "slice.</p>\n",
      100 * o.slice.thickness_m, row->index, I(double(figure.num_points)),
      dense_count == static_cast<int>(clouds.size())
          ? "the dense clouds"
          : (dense_count > 0 ? "dense and sparse clouds" : "the sparse clouds"));
  s.html += "<figure><img alt=\"cross-section\" src=\"" +
            PngDataUri(std::string(png.begin(), png.end())) + "\"></figure>\n";
  s.html += Details("Clouds read", "<ul>" + sources + "</ul>");
  return s;
}

// ---- canopy heights ----------------------------------------------------------------------------

Section Builder::HeightsSection() {
  Section s{{"heights", "Canopy height per site", false}, ""};
  auto summary = ReadJson(WsPath("analysis/summary.json"));
  auto heights = ReadCsv(WsPath("analysis/site_heights.csv"), "WS/analysis/site_heights.csv");
  std::optional<Csv> measured;
  if (!field_.empty()) {
    measured = ReadCsv(fs::path(field_) / "ground_truth" / "site_measurements.csv",
                       "FIELD/ground_truth/site_measurements.csv");
  }
  if (!summary && !heights) {
    s.html = Empty(
        "Analysis has not run: no WS/analysis/summary.json or WS/analysis/site_heights.csv." +
        std::string(measured ? " The measurements of FIELD/ground_truth/site_measurements.csv "
                               "are not shown without estimates."
                             : ""));
    return s;
  }
  s.info.has_data = true;
  if (summary) {
    std::vector<std::vector<std::string>> rows;
    if (const json* ss = At(*summary, {"sessions"}); ss != nullptr && ss->is_array()) {
      for (const json& x : *ss) {
        rows.push_back({E(Str(x, {"session"})), E(Str(x, {"date"})), Code(Str(x, {"cloud"})),
                        I(Num(x, {"points"})), I(Num(x, {"plants"})),
                        Percent(Num(x, {"vegetation_fraction"}), 2)});
      }
    }
    if (!rows.empty()) {
      s.html += Table({"session", "date", "cloud", "points", "plants found", "vegetation points"},
                      rows, "lllrrr");
    }
    if (const json* notes = At(*summary, {"site_notes"});
        notes != nullptr && notes->is_array() && !notes->empty()) {
      s.html += "<ul class=\"notes\">";
      for (const json& n : *notes) {
        s.html += "<li>" + E(n.is_string() ? n.get<std::string>() : n.dump()) + "</li>";
      }
      s.html += "</ul>\n";
    }
  }
  const fs::path plot = WsPath("analysis/plots/heights.png");
  if (IsFile(plot)) {
    if (auto png = ReadBytes(plot); png && png->size() > 8 && png->compare(1, 3, "PNG") == 0) {
      s.html +=
          "<figure><img alt=\"canopy height versus date per site\" src=\"" + PngDataUri(*png) +
          "\"><figcaption>Canopy height versus date per site (WS/analysis/plots/heights.png); "
          "measurements where a person measured.</figcaption></figure>\n";
    } else {
      Skip("WS/analysis/plots/heights.png: not a readable PNG; the plot is left out");
    }
  } else {
    s.html += Empty("No plot (WS/analysis/plots/heights.png); the table below has the numbers.");
  }
  if (heights) {
    const int cs = heights->Col("site_id"), cd = heights->Col("date"),
              ch = heights->Col("height_m"), cn = heights->Col("n_points");
    if (cs < 0 || cd < 0 || ch < 0) {
      Skip("WS/analysis/site_heights.csv: no site_id, date or height_m column; table left out");
    } else {
      std::map<std::pair<std::string, std::string>, std::string> est, meas;
      std::set<std::string> dates;
      std::vector<std::string> sites;
      std::set<std::string> site_set;
      auto add_site = [&](const std::string& id) {
        if (site_set.insert(id).second) sites.push_back(id);
      };
      if (field_info_) {
        for (const io::Site& site : field_info_->sites) add_site(site.id);
      }
      for (const auto& r : heights->rows) {
        add_site(r[cs]);
        dates.insert(r[cd]);
        const std::optional<double> h = ParseNum(r[ch]);
        std::string cell = h ? fmt::format("{:.3f}", *h) : "<span class=\"muted\">none</span>";
        if (cn >= 0 && !h) cell += " <span class=\"muted\">(" + E(r[cn]) + " pts)</span>";
        est[{r[cs], r[cd]}] = cell;
      }
      int n_meas = 0;
      if (measured) {
        const int ms = measured->Col("site_id"), md = measured->Col("date"),
                  mh = measured->Col("height_m");
        if (ms < 0 || md < 0 || mh < 0) {
          Skip(
              "FIELD/ground_truth/site_measurements.csv: no site_id, date or height_m column; "
              "measurements left out");
        } else {
          for (const auto& r : measured->rows) {
            if (auto h = ParseNum(r[mh])) {
              meas[{r[ms], r[md]}] = fmt::format("{:.3f}", *h);
              dates.insert(r[md]);
              add_site(r[ms]);
              ++n_meas;
            }
          }
        }
      }
      std::vector<std::string> head = {"site"};
      for (const std::string& d : dates) head.push_back(E(d));
      std::vector<std::vector<std::string>> rows;
      for (const std::string& site : sites) {
        std::vector<std::string> row = {E(site)};
        for (const std::string& d : dates) {
          std::string cell;
          auto e = est.find({site, d});
          cell = e != est.end() ? e->second : std::string(kDash);
          auto m = meas.find({site, d});
          if (m != meas.end()) cell += "<br><span class=\"meas\">meas. " + m->second + "</span>";
          row.push_back(cell);
        }
        rows.push_back(row);
      }
      s.html += "<h3>Canopy height [m] per site and date</h3>\n";
      s.html += n_meas > 0
                    ? "<p>Estimates of crop4d; below them, in italics, the heights a person "
                      "measured (FIELD/ground_truth/site_measurements.csv).</p>\n"
                    : std::string(field_.empty()
                                      ? "<p class=\"muted\">No field given: no measurements.</p>\n"
                                      : "<p class=\"muted\">No measurements "
                                        "(FIELD/ground_truth/site_measurements.csv).</p>\n");
      s.html += Table(head, rows, "l" + std::string(dates.size(), 'r'), "heights");
    }
  }
  if (auto single = ReadCsv(WsPath("analysis/site_heights_single_plane.csv"),
                            "WS/analysis/site_heights_single_plane.csv")) {
    std::vector<std::vector<std::string>> rows;
    for (const auto& r : single->rows) {
      std::vector<std::string> row;
      for (const std::string& c : r) row.push_back(E(c));
      rows.push_back(row);
    }
    std::vector<std::string> head;
    for (const std::string& c : single->header) head.push_back(E(c));
    s.html += Details("Heights above a single ground plane (the paper's simpler terrain model)",
                      Table(head, rows, "ll" + std::string(head.size(), 'r')));
  }
  return s;
}

// "growth_2016-06-01_2016-06-15_m_per_day" → "2016-06-01 → 2016-06-15 [m/day]", etc.
std::string PrettyColumn(std::string c) {
  std::string unit;
  auto strip = [&](const std::string& suffix, const std::string& u) {
    if (c.size() > suffix.size() &&
        c.compare(c.size() - suffix.size(), suffix.size(), suffix) == 0) {
      c.erase(c.size() - suffix.size());
      unit = u;
      return true;
    }
    return false;
  };
  strip("_m_per_day", "m/day") || strip("_per_day", "1/day") || strip("_m", "m");
  if (c.rfind("growth_", 0) == 0) {
    c.erase(0, 7);
    const auto us = c.find('_');
    if (us != std::string::npos) c = c.substr(0, us) + " &rarr; " + c.substr(us + 1);
    return c + (unit.empty() ? "" : " [" + unit + "]");
  }
  std::replace(c.begin(), c.end(), '_', ' ');
  return E(c) + (unit.empty() ? "" : " [" + unit + "]");
}

Section Builder::GrowthSection() {
  Section s{{"growth", "Growth rates", false}, ""};
  auto csv = ReadCsv(WsPath("analysis/growth.csv"), "WS/analysis/growth.csv");
  if (!csv) {
    s.html = Empty("No growth rates: no WS/analysis/growth.csv (crop4d analyze).");
    return s;
  }
  s.info.has_data = !csv->rows.empty();
  std::vector<std::string> head;
  std::string align;
  for (std::size_t i = 0; i < csv->header.size(); ++i) {
    head.push_back(PrettyColumn(csv->header[i]));
    const std::string& h = csv->header[i];
    align += (h == "site_id" || h == "status" ||
              (h.find("date") != std::string::npos && h.rfind("growth_", 0) != 0))
                 ? 'l'
                 : 'r';
  }
  std::vector<std::vector<std::string>> rows;
  for (const auto& r : csv->rows) {
    std::vector<std::string> row;
    for (const std::string& c : r) row.push_back(E(c));
    rows.push_back(row);
  }
  s.html +=
      "<p>A logistic curve fitted per site (asymptote, rate, midpoint date), and the mean growth "
      "between consecutive sessions.</p>\n";
  s.html += rows.empty() ? Empty("WS/analysis/growth.csv has no site.")
                         : Table(head, rows, align, "growth");
  return s;
}

// ---- evaluation --------------------------------------------------------------------------------

std::string AteCells(const json& m, const char* key) {
  return F(Num(m, {key, "rmse"}).has_value() ? std::optional<double>(1000 * *Num(m, {key, "rmse"}))
                                             : std::nullopt,
           1);
}

Section Builder::EvalSection() {
  Section s{{"evaluation", "Evaluation against ground truth", false}, ""};
  auto j = ReadJson(WsPath("eval/metrics.json"));
  if (!j) {
    s.html = Empty(
        "No evaluation: no WS/eval/metrics.json (crop4d eval needs a field with ground truth, "
        "e.g. a simulated one).");
    return s;
  }
  s.info.has_data = true;
  const json& m = *j;
  auto mm = [&](std::initializer_list<const char*> k) {
    std::optional<double> v = Num(m, k);
    return v ? std::optional<double>(1000 * *v) : std::nullopt;
  };
  std::vector<std::vector<std::string>> traj;
  if (At(m, {"overall"}) != nullptr) {
    traj.push_back(
        {"row SLAM (per pass)",
         I(Num(m, {"overall", "num_evaluated"})) + " / " + I(Num(m, {"overall", "num_passes"})),
         I(Num(m, {"overall", "num_poses"})), F(mm({"overall", "ate_raw_m", "rmse"}), 1),
         F(mm({"overall", "ate_aligned_m", "rmse"}), 1),
         F(Num(m, {"overall", "rotation_deg", "rmse"}), 3),
         F(Num(m, {"overall", "rpe", "translation_percent", "rmse"}), 2)});
  }
  if (At(m, {"fused", "overall"}) != nullptr) {
    traj.push_back({"4D fusion (per session)",
                    I(Num(m, {"fused", "overall", "num_evaluated"})) + " / " +
                        I(Num(m, {"fused", "overall", "num_sessions"})),
                    I(Num(m, {"fused", "overall", "num_poses"})),
                    F(mm({"fused", "overall", "ate_raw_m", "rmse"}), 1),
                    F(mm({"fused", "overall", "ate_aligned_m", "rmse"}), 1),
                    F(Num(m, {"fused", "overall", "rotation_deg", "rmse"}), 3),
                    F(Num(m, {"fused", "overall", "rpe", "translation_percent", "rmse"}), 2)});
  }
  if (!traj.empty()) {
    s.html += "<h3>Trajectories</h3>\n";
    s.html += Table({"estimate", "evaluated", "poses", "ATE raw RMSE [mm]", "ATE aligned RMSE [mm]",
                     "rotation RMSE [deg]", "RPE RMSE [%]"},
                    traj, "lrrrrrr");
    if (At(m, {"overall", "worst_pass"}) != nullptr) {
      s.html +=
          "<p class=\"muted\">Worst pass: " + E(Str(m, {"overall", "worst_pass", "session"})) +
          " " + E(Str(m, {"overall", "worst_pass", "pass"})) + ", ATE raw RMSE " +
          F(mm({"overall", "worst_pass", "ate_raw_rmse_m"}), 1) + " mm.</p>\n";
    }
  }
  std::vector<std::vector<std::string>> passes;
  if (const json* ps = At(m, {"passes"}); ps != nullptr && ps->is_array()) {
    for (const json& p : *ps) {
      const std::string err = Str(p, {"error"});
      passes.push_back(
          {E(Str(p, {"session"})), E(Str(p, {"pass"})), E(Str(p, {"sensors"})),
           I(Num(p, {"metrics", "num_poses"})),
           AteCells(At(p, {"metrics"}) ? *At(p, {"metrics"}) : json(), "ate_raw_m"),
           AteCells(At(p, {"metrics"}) ? *At(p, {"metrics"}) : json(), "ate_aligned_m"),
           F(Num(p, {"metrics", "rotation_deg", "rmse"}), 3),
           err.empty() ? "" : "<span class=\"badt\">" + E(err) + "</span>"});
    }
  }
  if (!passes.empty()) {
    s.html += Details(fmt::format("Every pass ({})", passes.size()),
                      Table({"session", "pass", "sensors", "poses", "ATE raw [mm]",
                             "ATE aligned [mm]", "rotation [deg]", "error"},
                            passes, "lllrrrrl"));
  }
  // Cross matches.
  if (const json* bm = At(m, {"association", "by_method"}); bm != nullptr && bm->is_array()) {
    std::vector<std::vector<std::string>> rows;
    for (const json& x : *bm) {
      rows.push_back({E(Str(x, {"method"})), "all", I(Num(x, {"files"})), I(Num(x, {"matches"})),
                      I(Num(x, {"correct"})), I(Num(x, {"incorrect"})), I(Num(x, {"unknown"})),
                      Percent(Num(x, {"precision"}))});
    }
    if (const json* bt = At(m, {"association", "by_type"}); bt != nullptr && bt->is_array()) {
      for (const json& x : *bt) {
        rows.push_back({E(Str(x, {"method"})), E(Str(x, {"type"})), I(Num(x, {"files"})),
                        I(Num(x, {"matches"})), I(Num(x, {"correct"})), I(Num(x, {"incorrect"})),
                        I(Num(x, {"unknown"})), Percent(Num(x, {"precision"}))});
      }
    }
    if (!rows.empty()) {
      s.html += "<h3>Cross matches</h3>\n";
      s.html += Table({"method", "pair type", "pairs", "matches", "correct", "incorrect", "unknown",
                       "precision"},
                      rows, "llrrrrrr");
    }
  }
  // Ground misalignment between sessions.
  if (const json* g = At(m, {"ground_misalignment"}); g != nullptr && g->is_object()) {
    std::vector<std::vector<std::string>> rows;
    for (const char* which : {"row_slam", "fused"}) {
      if (At(*g, {which, "pooled"}) == nullptr) continue;
      auto gmm = [&](const char* k) {
        std::optional<double> v = Num(*g, {which, "pooled", k});
        return v ? std::optional<double>(1000 * *v) : std::nullopt;
      };
      rows.push_back({std::string(which) == "fused" ? "4D fusion" : "row SLAM",
                      I(Num(*g, {which, "pooled", "count"})), F(gmm("median_m"), 1),
                      F(gmm("p90_m"), 1), F(gmm("signed_median_m"), 1)});
    }
    if (!rows.empty()) {
      s.html += "<h3>Ground of one session against the others</h3>\n";
      s.html += Table({"clouds", "ground points", "median distance [mm]", "90th percentile [mm]",
                       "signed median [mm]"},
                      rows, "lrrrr");
    }
  }
  // Canopy height.
  if (const json* c = At(m, {"canopy"}); c != nullptr && c->is_object()) {
    std::vector<std::vector<std::string>> rows;
    for (const char* which : {"ours", "single_plane"}) {
      const json* x = At(*c, {which});
      if (x == nullptr || !x->is_object()) continue;
      const std::string err = Str(*x, {"error"});
      auto xmm = [&](const char* k) {
        std::optional<double> v = Num(*x, {k});
        return v ? std::optional<double>(1000 * *v) : std::nullopt;
      };
      rows.push_back({std::string(which) == "ours" ? "crop4d (terrain model)" : "single plane",
                      Code(Str(*x, {"file"})), I(Num(*x, {"num_pairs"})), F(xmm("rmse_m"), 1),
                      F(xmm("bias_m"), 1), F(xmm("mae_m"), 1), F(xmm("max_abs_error_m"), 1),
                      I(Num(*x, {"num_failures"})),
                      err.empty() ? "" : "<span class=\"badt\">" + E(err) + "</span>"});
    }
    if (!rows.empty()) {
      s.html += "<h3>Canopy height</h3>\n";
      s.html += Table({"estimate", "file", "site-dates", "RMSE [mm]", "bias [mm]", "MAE [mm]",
                       "max |error| [mm]",
                       fmt::format("errors &gt; {:.0f} mm",
                                   1000 * Num(*c, {"options", "max_error_m"}).value_or(NAN)),
                       "error"},
                      rows, "llrrrrrrl");
    }
    if (const json* ss = At(*c, {"ours", "sessions"}); ss != nullptr && ss->is_array()) {
      std::vector<std::vector<std::string>> srows;
      for (const json& x : *ss) {
        auto xmm = [&](const char* k) {
          std::optional<double> v = Num(x, {k});
          return v ? std::optional<double>(1000 * *v) : std::nullopt;
        };
        srows.push_back({E(Str(x, {"session"})), I(Num(x, {"num_pairs"})), F(xmm("rmse_m"), 1),
                         F(xmm("bias_m"), 1), F(xmm("max_abs_error_m"), 1),
                         I(Num(x, {"num_failures"}))});
      }
      if (!srows.empty()) {
        s.html += Details(
            "Canopy height error per session (crop4d)",
            Table({"session", "sites", "RMSE [mm]", "bias [mm]", "max |error| [mm]", "failures"},
                  srows, "lrrrrr"));
      }
    }
  }
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
  run_ = ReadJson(WsPath("run.json"));
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

}  // namespace

bool HtmlReportOptions::Check() const {
  return std::isfinite(cross_section_thickness_m) && cross_section_thickness_m > 0 &&
         std::isfinite(cross_section_half_length_m) && cross_section_half_length_m > 0 &&
         map_max_width_px >= 100 && map_max_width_px <= 10000 && map_max_height_px >= 100 &&
         map_max_height_px <= 10000 && map_max_points_per_session >= 2;
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
  CROP4D_CHECK(options.Check());
  if (!IsDir(workspace)) {
    throw InputError(workspace, 0, "the workspace folder does not exist");
  }
  Builder builder(workspace, field_folder, options);
  return builder.Build(result);
}

HtmlReportResult WriteHtmlReport(const std::string& workspace, const std::string& field_folder,
                                 const std::string& output_html, const HtmlReportOptions& options) {
  HtmlReportResult result;
  const std::string html = BuildHtmlReport(workspace, field_folder, options, &result);
  result.path = output_html.empty() ? (fs::path(workspace) / "report.html").string() : output_html;
  io::WriteFileAtomic(result.path, html);
  result.bytes = html.size();
  return result;
}

}  // namespace crop4d::report
