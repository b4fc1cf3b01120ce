#include "crop4d/eval/canopy_eval.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <filesystem>
#include <map>
#include <optional>
#include <string_view>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/eval/natural_order.h"
#include "crop4d/io/csv.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool IsNanText(std::string_view text) {
  if (text.size() != 3) return false;
  return std::tolower(static_cast<unsigned char>(text[0])) == 'n' &&
         std::tolower(static_cast<unsigned char>(text[1])) == 'a' &&
         std::tolower(static_cast<unsigned char>(text[2])) == 'n';
}

bool IsDate(std::string_view text) {
  if (text.size() != 10 || text[4] != '-' || text[7] != '-') return false;
  for (const int i : {0, 1, 2, 3, 5, 6, 8, 9}) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return false;
  }
  return true;
}

// The column layout of one file, from its header line.
struct Columns {
  std::vector<std::string> names;
  std::int64_t line = 0;
  int site_id = -1, session = -1, date = -1, height_m = -1;

  std::string Joined() const {
    std::string out;
    for (const std::string& n : names) out += (out.empty() ? "" : ",") + n;
    return out;
  }
};

Columns ParseHeader(const std::vector<std::string>& names, std::int64_t line,
                    const std::string& file) {
  Columns c;
  c.names = names;
  c.line = line;
  for (int i = 0; i < static_cast<int>(names.size()); ++i) {
    const std::string& n = names[i];
    int* slot = n == "site_id"    ? &c.site_id
                : n == "session"  ? &c.session
                : n == "date"     ? &c.date
                : n == "height_m" ? &c.height_m
                                  : nullptr;
    if (slot != nullptr && *slot < 0) *slot = i;
  }
  const char* expected = "site_id,session,date,height_m";
  for (const auto& [index, name] :
       {std::pair{c.site_id, "site_id"}, {c.session, "session"}, {c.height_m, "height_m"}}) {
    if (index < 0) {
      throw InputError(file, line,
                       fmt::format("the header '{}' has no column '{}' (expected the header "
                                   "'{}')",
                                   c.Joined(), name, expected));
    }
  }
  return c;
}

std::vector<std::string> ToStrings(const std::vector<std::string_view>& fields) {
  return std::vector<std::string>(fields.begin(), fields.end());
}

// Reads the truth: its columns by name; a row without a height was not measured.
std::vector<SiteHeight> ReadTruthTable(const std::string& path) {
  io::CsvReader reader(path);
  io::CsvRecord record;
  std::optional<Columns> columns;
  std::vector<SiteHeight> rows;
  std::map<std::pair<std::string, std::string>, std::int64_t> seen;
  const auto number = [&](std::string_view text, const char* name, std::int64_t line) {
    if (text.empty() || IsNanText(text)) return kNaN;
    double value = 0.0;
    if (!io::ParseDouble(text, &value)) {
      throw InputError(path, line, fmt::format("{} '{}' is not a number", name, text));
    }
    if (!std::isfinite(value)) {
      throw InputError(path, line, fmt::format("{} '{}' is not finite", name, text));
    }
    return value;
  };
  while (reader.Next(&record)) {
    if (reader.too_long()) throw InputError(path, record.line, "line too long");
    if (!columns) {
      // The header: a '#' line before the data that names site_id, else the first line.
      if (reader.header() && reader.header()->find("site_id") != std::string::npos) {
        std::vector<std::string_view> names;
        io::SplitCsvLine(*reader.header(), ',', &names);
        columns = ParseHeader(ToStrings(names), reader.header_line(), path);
      } else {
        columns = ParseHeader(ToStrings(record.fields), record.line, path);
        continue;
      }
    }
    const std::vector<std::string_view>& f = record.fields;
    if (f.size() != columns->names.size()) {
      throw InputError(path, record.line,
                       fmt::format("expected {} fields ({}), found {}", columns->names.size(),
                                   columns->Joined(), f.size()));
    }
    SiteHeight row;
    row.line = record.line;
    row.site_id = std::string(f[columns->site_id]);
    row.session = std::string(f[columns->session]);
    if (row.site_id.empty()) throw InputError(path, record.line, "empty site_id");
    if (row.session.empty()) throw InputError(path, record.line, "empty session");
    if (columns->date >= 0) {
      row.date = std::string(f[columns->date]);
      if (!row.date.empty() && !IsDate(row.date)) {
        throw InputError(path, record.line,
                         fmt::format("date '{}' is not of the form YYYY-MM-DD", row.date));
      }
    }
    row.height_m = number(f[columns->height_m], "height_m", record.line);
    const auto [it, inserted] = seen.emplace(std::pair{row.site_id, row.session}, record.line);
    if (!inserted) {
      throw InputError(path, record.line,
                       fmt::format("site '{}' session '{}' repeated (first on line {})",
                                   row.site_id, row.session, it->second));
    }
    if (std::isnan(row.height_m)) continue;  // not measured
    rows.push_back(std::move(row));
  }
  if (!columns) {
    throw InputError(path, 0, "empty file: expected the header 'site_id,session,date,height_m'");
  }
  return rows;
}

CanopyErrorStats Stats(const std::vector<CanopyPair>& pairs, const std::vector<int>& indices,
                       double max_error_m) {
  CanopyErrorStats s;
  double sum = 0.0, sum_sq = 0.0, sum_abs = 0.0, max_abs = 0.0;
  for (const int i : indices) {
    const CanopyPair& p = pairs[i];
    ++s.num_truth;
    if (p.missing()) {
      ++s.num_missing;
      ++s.num_failures;
      continue;
    }
    ++s.num_pairs;
    sum += p.error_m;
    sum_sq += p.error_m * p.error_m;
    sum_abs += std::abs(p.error_m);
    max_abs = std::max(max_abs, std::abs(p.error_m));
    if (std::abs(p.error_m) > max_error_m) ++s.num_failures;
  }
  if (s.num_pairs > 0) {
    const double n = s.num_pairs;
    s.rmse_m = std::sqrt(sum_sq / n);
    s.bias_m = sum / n;
    s.mae_m = sum_abs / n;
    s.max_abs_error_m = max_abs;
  }
  return s;
}

bool Selected(const std::vector<std::string>& sessions, const std::string& session) {
  return sessions.empty() || std::find(sessions.begin(), sessions.end(), session) != sessions.end();
}

std::string Cm(double value_m, bool sign = false) {
  if (!std::isfinite(value_m)) return "-";
  return sign ? fmt::format("{:+.2f}", 100.0 * value_m) : fmt::format("{:.2f}", 100.0 * value_m);
}

}  // namespace

std::vector<SiteHeight> ReadSiteTruth(const std::string& path) { return ReadTruthTable(path); }

OptionCheck CanopyEvalOptions::Check() const {
  OptionChecker c;
  c.AtLeast("max_error_m", max_error_m, 0.0).Finite("max_error_m", max_error_m);
  return c.Result();
}

std::vector<SiteError> SiteErrors(const std::vector<CanopyPair>& pairs) {
  std::vector<SiteError> errors;
  errors.reserve(pairs.size());
  for (const CanopyPair& p : pairs) errors.push_back({p.site_id, p.session, p.error_m});
  return errors;
}

CanopyMethodEval EvaluateCanopyHeights(const std::vector<SiteHeight>& estimates,
                                       const std::vector<SiteHeight>& truth,
                                       const CanopyEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateCanopyHeights");
  CanopyMethodEval eval;
  std::map<std::pair<std::string, std::string>, const SiteHeight*> by_key;
  for (const SiteHeight& e : estimates) by_key[{e.site_id, e.session}] = &e;
  std::map<std::pair<std::string, std::string>, bool> truth_keys;
  for (const SiteHeight& t : truth) {
    if (!Selected(options.sessions, t.session)) continue;
    truth_keys[{t.site_id, t.session}] = true;
    CanopyPair p;
    p.site_id = t.site_id;
    p.session = t.session;
    p.date = t.date;
    p.truth_m = t.height_m;
    const auto found = by_key.find({t.site_id, t.session});
    if (found != by_key.end()) {
      const SiteHeight& e = *found->second;
      if (p.date.empty()) p.date = e.date;
      p.estimate_m = e.height_m;
      p.n_points = e.n_points;
      if (!p.missing()) p.error_m = p.estimate_m - p.truth_m;
    }
    eval.pairs.push_back(std::move(p));
  }
  for (const SiteHeight& e : estimates) {
    if (Selected(options.sessions, e.session) && truth_keys.count({e.site_id, e.session}) == 0) {
      ++eval.num_without_truth;
    }
  }
  std::stable_sort(eval.pairs.begin(), eval.pairs.end(),
                   [](const CanopyPair& a, const CanopyPair& b) {
                     if (a.session != b.session) return NaturalLess(a.session, b.session);
                     return NaturalLess(a.site_id, b.site_id);
                   });

  std::vector<int> all;
  for (int i = 0; i < static_cast<int>(eval.pairs.size()); ++i) {
    all.push_back(i);
    const CanopyPair& p = eval.pairs[i];
    if (p.missing() || std::abs(p.error_m) > options.max_error_m) eval.failures.push_back(i);
    if (!p.missing() &&
        (eval.worst < 0 || std::abs(p.error_m) > std::abs(eval.pairs[eval.worst].error_m))) {
      eval.worst = i;
    }
  }
  eval.overall = Stats(eval.pairs, all, options.max_error_m);
  eval.rmse_interval = SiteRmseInterval(SiteErrors(eval.pairs));
  // Per session (the pairs are sorted by session).
  for (std::size_t begin = 0; begin < eval.pairs.size();) {
    std::size_t end = begin;
    std::vector<int> indices;
    while (end < eval.pairs.size() && eval.pairs[end].session == eval.pairs[begin].session) {
      indices.push_back(static_cast<int>(end++));
    }
    CanopySessionEval s;
    s.session = eval.pairs[begin].session;
    s.date = eval.pairs[begin].date;
    s.stats = Stats(eval.pairs, indices, options.max_error_m);
    eval.sessions.push_back(std::move(s));
    begin = end;
  }
  return eval;
}

bool EvaluateWorkspaceCanopy(const std::string& workspace, const std::string& field,
                             const CanopyEvalOptions& options, CanopyEval* eval, std::string* why) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateWorkspaceCanopy");
  const workspace::Layout ws(workspace);
  const auto relative = [&](const fs::path& p) {
    return p.lexically_relative(ws.root()).generic_string();
  };
  const std::string ours = relative(ws.SiteHeights());
  const std::string single_plane = relative(ws.SiteHeightsSinglePlane());
  const fs::path truth_path = fs::path(field) / "ground_truth" / "site_truth.csv";
  std::error_code ec;
  if (!fs::is_regular_file(ws.SiteHeights(), ec)) {
    *why = fmt::format("no {} in the workspace (written by crop4d analyze)", ours);
    return false;
  }
  if (!fs::is_regular_file(truth_path, ec)) {
    *why = fmt::format("no ground_truth/site_truth.csv in the field");
    return false;
  }
  *eval = CanopyEval();
  eval->truth_file = "ground_truth/site_truth.csv";
  eval->options = options;
  std::vector<std::pair<std::string, std::string>> methods = {{"ours", ours}};
  if (fs::is_regular_file(ws.SiteHeightsSinglePlane(), ec)) {
    methods.emplace_back("single_plane", single_plane);
  }
  std::vector<SiteHeight> truth;
  std::string truth_error;
  try {
    truth = ReadSiteTruth(truth_path.string());
  } catch (const InputError& e) {
    truth_error = e.what();
  }
  for (const auto& [method, file] : methods) {
    CanopyMethodEval m;
    if (truth_error.empty()) {
      try {
        m = EvaluateCanopyHeights(ReadSiteHeights(ws.root() / file), truth, options);
      } catch (const InputError& e) {
        m = CanopyMethodEval();
        m.error = e.what();
      }
    } else {
      m.error = truth_error;
    }
    m.method = method;
    m.file = file;
    eval->methods.push_back(std::move(m));
  }
  PlantEvalOptions plant_options;
  plant_options.max_top_error_m = options.max_error_m;
  plant_options.sessions = options.sessions;
  PlantEval plants;
  try {
    if (EvaluateSitePlants(workspace, field, plant_options, &plants, &eval->plants_skipped)) {
      eval->plants = std::move(plants);
    }
  } catch (const InputError& e) {
    eval->plants_skipped = e.what();
  }
  return true;
}

std::string FormatCanopyTable(const CanopyEval& eval, int max_listed) {
  const double limit_cm = 100.0 * eval.options.max_error_m;
  std::string out = fmt::format(
      "canopy height per site and session against {} (error = estimate - truth; failure: "
      "|error| > {:g} cm or no estimate)\n",
      eval.truth_file, limit_cm);
  std::size_t w = 12;
  for (const CanopyMethodEval& m : eval.methods) w = std::max(w, m.method.size());
  const std::string fail_header = fmt::format(">{:g}cm", limit_cm);
  out += fmt::format("{:<{}}  {:>7}  {:>7}  {:>7}  {:>7}  {:>6}  {:>{}}  {}\n", "method", w,
                     "pairs", "missing", "RMSE cm", "bias cm", "MAE cm", fail_header,
                     std::max<std::size_t>(5, fail_header.size()), "worst (error cm)");
  for (const CanopyMethodEval& m : eval.methods) {
    if (!m.ok()) {
      out += fmt::format("{:<{}}  error: {}\n", m.method, w, m.error);
      continue;
    }
    const CanopyErrorStats& s = m.overall;
    const std::string worst =
        m.worst < 0 ? std::string("-")
                    : fmt::format("{} {} ({})", m.pairs[m.worst].site_id, m.pairs[m.worst].session,
                                  Cm(m.pairs[m.worst].error_m, true));
    out += fmt::format("{:<{}}  {:>7}  {:>7}  {:>7}  {:>7}  {:>6}  {:>{}}  {}\n", m.method, w,
                       fmt::format("{}/{}", s.num_pairs, s.num_truth), s.num_missing, Cm(s.rmse_m),
                       Cm(s.bias_m, true), Cm(s.mae_m), s.num_failures,
                       std::max<std::size_t>(5, fail_header.size()), worst);
  }
  // How far the RMSE would move on other sites.
  for (const CanopyMethodEval& m : eval.methods) {
    if (!m.ok() || !m.rmse_interval.valid()) continue;
    out += fmt::format(
        "{} RMSE: {:g} % interval {}-{} cm over its {} sites (bootstrap: sites drawn with "
        "replacement, each with all its sessions)\n",
        m.method, 100.0 * m.rmse_interval.level, Cm(m.rmse_interval.low), Cm(m.rmse_interval.high),
        m.rmse_interval.num_sites);
  }
  // The failures.
  for (const CanopyMethodEval& m : eval.methods) {
    if (!m.ok() || m.failures.empty()) continue;
    std::string list;
    int listed = 0;
    for (const int i : m.failures) {
      if (listed == max_listed) break;
      const CanopyPair& p = m.pairs[i];
      list += fmt::format("{}{} {} {}", listed == 0 ? "" : ", ", p.site_id, p.session,
                          p.missing() ? std::string("no estimate") : Cm(p.error_m, true));
      ++listed;
    }
    if (static_cast<int>(m.failures.size()) > listed) {
      list += fmt::format(", and {} more", m.failures.size() - listed);
    }
    out += fmt::format("{} failures: {}\n", m.method, list);
  }
  if (eval.methods.size() > 0) {
    std::size_t ws = 7;
    for (const CanopyMethodEval& m : eval.methods) {
      for (const CanopySessionEval& s : m.sessions) ws = std::max(ws, s.session.size());
    }
    out += fmt::format("{:<{}}  {:<{}}  {:>4}  {:>7}  {:>7}  {:>7}  {:>10}  {:>{}}\n", "session",
                       ws, "method", w, "n", "missing", "RMSE cm", "bias cm", "max |e| cm",
                       fail_header, std::max<std::size_t>(5, fail_header.size()));
    // Sessions in order, each method's line together.
    std::vector<std::string> sessions;
    for (const CanopyMethodEval& m : eval.methods) {
      for (const CanopySessionEval& s : m.sessions) {
        if (std::find(sessions.begin(), sessions.end(), s.session) == sessions.end()) {
          sessions.push_back(s.session);
        }
      }
    }
    std::stable_sort(sessions.begin(), sessions.end(), NaturalLess);
    for (const std::string& session : sessions) {
      for (const CanopyMethodEval& m : eval.methods) {
        for (const CanopySessionEval& s : m.sessions) {
          if (s.session != session) continue;
          out +=
              fmt::format("{:<{}}  {:<{}}  {:>4}  {:>7}  {:>7}  {:>7}  {:>10}  {:>{}}\n", s.session,
                          ws, m.method, w, s.stats.num_pairs, s.stats.num_missing,
                          Cm(s.stats.rmse_m), Cm(s.stats.bias_m, true), Cm(s.stats.max_abs_error_m),
                          s.stats.num_failures, std::max<std::size_t>(5, fail_header.size()));
        }
      }
    }
  }
  for (const CanopyMethodEval& m : eval.methods) {
    if (m.ok() && m.num_without_truth > 0) {
      out += fmt::format("{}: {} estimate rows without truth (ignored)\n", m.method,
                         m.num_without_truth);
    }
  }
  if (eval.plants) {
    out += FormatPlantTable(*eval.plants);
  } else if (!eval.plants_skipped.empty()) {
    out += "plants of the sites: not evaluated, " + eval.plants_skipped + "\n";
  }
  return out;
}

}  // namespace crop4d::eval
