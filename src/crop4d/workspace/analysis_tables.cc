#include "crop4d/workspace/analysis_tables.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr char kRerun[] = "rerun `crop4d analyze`";
constexpr char kGrowthPrefix[] = "growth_";
constexpr char kGrowthSuffix[] = "_m_per_day";

// `value` with `decimals` fixed decimals; empty for NaN (no estimate).
std::string Fixed(double value, int decimals) {
  return std::isfinite(value) ? fmt::format("{:.{}f}", value, decimals) : std::string();
}

std::string JoinLine(const std::vector<std::string>& cells) {
  std::string line;
  for (std::size_t i = 0; i < cells.size(); ++i) line += (i == 0 ? "" : ",") + cells[i];
  return line + "\n";
}

bool IsDate(std::string_view text) {
  if (text.size() != 10 || text[4] != '-' || text[7] != '-') return false;
  for (const int i : {0, 1, 2, 3, 5, 6, 8, 9}) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return false;
  }
  return true;
}

// Reads a table's rows after checking its schema and header; `header` decides whether the
// column names are the ones of schema 1 (and may take note of them).
class TableReader {
 public:
  TableReader(std::istream& in, std::string name) : name_(std::move(name)), csv_(in, name_) {}

  const std::string& name() const { return name_; }
  std::int64_t line() const { return record_.line; }
  const std::vector<std::string_view>& fields() const { return record_.fields; }

  // Reads the schema comment and the header line; `expected` is the header to name in messages.
  template <typename HeaderCheck>
  void ReadHeader(const std::string& expected, HeaderCheck&& matches) {
    if (!csv_.Next(&record_)) {
      throw InputError(name_, 0,
                       fmt::format("empty file: expected the header '{}'; {}", expected, kRerun));
    }
    CheckSchemaComment();
    CheckLine();
    const std::vector<std::string> names(record_.fields.begin(), record_.fields.end());
    if (!matches(names)) {
      std::string got;
      for (const std::string& n : names) got += (got.empty() ? "" : ",") + n;
      throw InputError(name_, record_.line,
                       fmt::format("the header '{}' is not the one this crop4d writes ('{}'): "
                                   "a table of another crop4d version; {}",
                                   got, expected, kRerun));
    }
    columns_ = names.size();
  }

  // The next row, checked for truncation and its number of fields; false at the end.
  bool Next() {
    if (!csv_.Next(&record_)) return false;
    CheckLine();
    if (record_.fields.size() != columns_) {
      throw InputError(
          name_, record_.line,
          fmt::format("expected {} fields, found {}", columns_, record_.fields.size()));
    }
    return true;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw InputError(name_, record_.line, what);
  }

  std::string Word(std::size_t i, const char* column) const {
    if (record_.fields[i].empty()) Fail(fmt::format("empty {}", column));
    return std::string(record_.fields[i]);
  }

  std::string Date(std::size_t i) const {
    const std::string_view text = record_.fields[i];
    if (!text.empty() && !IsDate(text)) {
      Fail(fmt::format("date '{}' is not of the form YYYY-MM-DD", text));
    }
    return std::string(text);
  }

  // A finite number; an empty cell is NaN when `may_be_empty`.
  double Number(std::size_t i, const char* column, bool may_be_empty) const {
    const std::string_view text = record_.fields[i];
    if (text.empty() && may_be_empty) return kNaN;
    double value = 0.0;
    if (!io::ParseDouble(text, &value) || !std::isfinite(value)) {
      Fail(fmt::format("{} '{}' is not a finite number", column, text));
    }
    return value;
  }

  // A count; an empty cell is -1 (unknown) when `may_be_empty`.
  std::int64_t Count(std::size_t i, const char* column, bool may_be_empty = false) const {
    if (record_.fields[i].empty() && may_be_empty) return -1;
    std::int64_t value = 0;
    if (!io::ParseInt64(record_.fields[i], &value) || value < 0) {
      Fail(fmt::format("{} '{}' is not a count", column, record_.fields[i]));
    }
    return value;
  }

 private:
  // A "# crop4d schema N" comment before the header names the schema; none is schema 1.
  void CheckSchemaComment() const {
    if (!csv_.header()) return;
    const std::string comment = *csv_.header();
    int schema = 0;
    char rest = 0;
    if (std::sscanf(comment.c_str(), " crop4d schema %d %c", &schema, &rest) == 1 &&
        schema != kAnalysisTablesSchema) {
      throw InputError(name_, csv_.header_line(),
                       fmt::format("a table of another crop4d version (schema {}; this crop4d "
                                   "reads schema {}); {}",
                                   schema, kAnalysisTablesSchema, kRerun));
    }
  }

  void CheckLine() const {
    if (csv_.too_long()) Fail("line too long");
    if (record_.unterminated) {
      Fail(fmt::format("the last line is cut short (a truncated file); {}", kRerun));
    }
  }

  std::string name_;
  io::CsvReader csv_;
  io::CsvRecord record_;
  std::size_t columns_ = 0;
};

std::string Joined(const std::vector<std::string>& names) {
  std::string text = JoinLine(names);
  text.pop_back();
  return text;
}

template <typename Reader>
auto ReadFile(const fs::path& path, Reader&& read) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, fmt::format("cannot be read; {}", kRerun));
  return read(in, path.string());
}

}  // namespace

std::vector<std::string> SiteHeightsColumns() {
  return {"site_id", "session", "date", "height_m", "cover", "volume_m3", "n_points"};
}

std::vector<std::string> SitePlantsColumns() {
  return {"site_id", "plant", "x_m", "y_m", "session", "date", "top_m"};
}

std::string GrowthIntervalName(const std::string& earlier, const std::string& later) {
  return earlier + "_" + later;
}

std::vector<std::string> GrowthColumns(const GrowthTable& table) {
  std::vector<std::string> names = {
      "site_id", "status", "asymptote_m", "rate_per_day", "midpoint_date", "max_growth_m_per_day",
      "rmse_m",  "n"};
  for (const std::string& interval : table.intervals) {
    names.push_back(kGrowthPrefix + interval + kGrowthSuffix);
  }
  return names;
}

std::vector<std::string> SiteHeightCells(const SiteHeight& r) {
  return {r.site_id,
          r.session,
          r.date,
          Fixed(r.height_m, 4),
          Fixed(r.cover, 3),
          Fixed(r.volume_m3, 5),
          r.n_points >= 0 ? std::to_string(r.n_points) : std::string()};
}

std::vector<std::string> GrowthCells(const GrowthRow& r) {
  std::vector<std::string> cells = {r.site_id,
                                    r.status,
                                    Fixed(r.asymptote_m, 4),
                                    Fixed(r.rate_per_day, 5),
                                    r.midpoint_date,
                                    Fixed(r.max_growth_m_per_day, 5),
                                    Fixed(r.rmse_m, 4),
                                    std::to_string(r.n)};
  for (const double rate : r.interval_rates) cells.push_back(Fixed(rate, 5));
  return cells;
}

std::string SiteHeightsText(const std::vector<SiteHeight>& rows) {
  std::string text = JoinLine(SiteHeightsColumns());
  for (const SiteHeight& r : rows) text += JoinLine(SiteHeightCells(r));
  return text;
}

std::string SitePlantsText(const std::vector<SitePlantRow>& rows) {
  std::string text = JoinLine(SitePlantsColumns());
  for (const SitePlantRow& r : rows) {
    text += fmt::format("{},{},{:.3f},{:.3f},{},{},{}\n", r.site_id, r.plant, r.x_m, r.y_m,
                        r.session, r.date, Fixed(r.top_m, 4));
  }
  return text;
}

std::string GrowthText(const GrowthTable& table) {
  std::string text = JoinLine(GrowthColumns(table));
  for (const GrowthRow& r : table.rows) {
    CROP4D_CHECK(r.interval_rates.size() == table.intervals.size());
    text += JoinLine(GrowthCells(r));
  }
  return text;
}

void WriteSiteHeights(const fs::path& path, const std::vector<SiteHeight>& rows) {
  io::WriteFileAtomic(path.string(), SiteHeightsText(rows));
}

void WriteSitePlants(const fs::path& path, const std::vector<SitePlantRow>& rows) {
  io::WriteFileAtomic(path.string(), SitePlantsText(rows));
}

void WriteGrowth(const fs::path& path, const GrowthTable& table) {
  io::WriteFileAtomic(path.string(), GrowthText(table));
}

std::vector<SiteHeight> ReadSiteHeights(std::istream& in, const std::string& name) {
  TableReader t(in, name);
  const std::vector<std::string> columns = SiteHeightsColumns();
  t.ReadHeader(Joined(columns), [&](const std::vector<std::string>& n) { return n == columns; });
  std::vector<SiteHeight> rows;
  std::map<std::pair<std::string, std::string>, std::int64_t> seen;
  while (t.Next()) {
    SiteHeight r;
    r.line = t.line();
    r.site_id = t.Word(0, "site_id");
    r.session = t.Word(1, "session");
    r.date = t.Date(2);
    r.height_m = t.Number(3, "height_m", true);
    r.cover = t.Number(4, "cover", true);
    r.volume_m3 = t.Number(5, "volume_m3", true);
    r.n_points = t.Count(6, "n_points", true);
    const auto [it, added] = seen.emplace(std::make_pair(r.site_id, r.session), r.line);
    if (!added) {
      t.Fail(fmt::format("site '{}' session '{}' repeated (first on line {})", r.site_id, r.session,
                         it->second));
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

std::vector<SitePlantRow> ReadSitePlants(std::istream& in, const std::string& name) {
  TableReader t(in, name);
  const std::vector<std::string> columns = SitePlantsColumns();
  t.ReadHeader(Joined(columns), [&](const std::vector<std::string>& n) { return n == columns; });
  std::vector<SitePlantRow> rows;
  std::set<std::tuple<std::string, int, std::string>> seen;
  std::map<std::pair<std::string, int>, std::pair<double, double>> stems;
  while (t.Next()) {
    SitePlantRow r;
    r.line = t.line();
    r.site_id = t.Word(0, "site_id");
    const std::int64_t plant = t.Count(1, "plant");
    if (plant < 1 || plant > 1'000'000) {
      t.Fail(fmt::format("plant '{}' is not a number 1, 2, ...", plant));
    }
    r.plant = static_cast<int>(plant);
    r.x_m = t.Number(2, "x_m", false);
    r.y_m = t.Number(3, "y_m", false);
    r.session = t.Word(4, "session");
    r.date = t.Date(5);
    r.top_m = t.Number(6, "top_m", true);
    if (!seen.emplace(r.site_id, r.plant, r.session).second) {
      t.Fail(fmt::format("site {} plant {} session {} repeated", r.site_id, r.plant, r.session));
    }
    // The writer rounds positions to millimetres: the same stem in every session.
    const auto [it, added] =
        stems.emplace(std::make_pair(r.site_id, r.plant), std::make_pair(r.x_m, r.y_m));
    if (!added &&
        (std::abs(it->second.first - r.x_m) > 1e-3 || std::abs(it->second.second - r.y_m) > 1e-3)) {
      t.Fail(fmt::format("site {} plant {} moved: ({}, {}) after ({}, {})", r.site_id, r.plant,
                         r.x_m, r.y_m, it->second.first, it->second.second));
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

GrowthTable ReadGrowth(std::istream& in, const std::string& name) {
  TableReader t(in, name);
  GrowthTable table;
  const std::vector<std::string> fixed = GrowthColumns(table);
  const std::string prefix(kGrowthPrefix), suffix(kGrowthSuffix);
  t.ReadHeader(
      Joined(fixed) + ",growth_<earlier>_<later>" + suffix + "...",
      [&](const std::vector<std::string>& names) {
        if (names.size() < fixed.size() || !std::equal(fixed.begin(), fixed.end(), names.begin())) {
          return false;
        }
        for (std::size_t i = fixed.size(); i < names.size(); ++i) {
          const std::string& n = names[i];
          if (n.size() <= prefix.size() + suffix.size() || n.rfind(prefix, 0) != 0 ||
              n.compare(n.size() - suffix.size(), suffix.size(), suffix) != 0) {
            return false;
          }
          table.intervals.push_back(
              n.substr(prefix.size(), n.size() - prefix.size() - suffix.size()));
        }
        return true;
      });
  std::set<std::string> seen;
  while (t.Next()) {
    GrowthRow r;
    r.line = t.line();
    r.site_id = t.Word(0, "site_id");
    r.status = t.Word(1, "status");
    r.asymptote_m = t.Number(2, "asymptote_m", true);
    r.rate_per_day = t.Number(3, "rate_per_day", true);
    r.midpoint_date = t.Date(4);
    r.max_growth_m_per_day = t.Number(5, "max_growth_m_per_day", true);
    r.rmse_m = t.Number(6, "rmse_m", true);
    const std::int64_t n = t.Count(7, "n");
    if (n > 1'000'000) t.Fail(fmt::format("n '{}' is not a count of sessions", n));
    r.n = static_cast<int>(n);
    for (std::size_t i = 0; i < table.intervals.size(); ++i) {
      r.interval_rates.push_back(t.Number(fixed.size() + i, "interval growth rate", true));
    }
    if (!seen.insert(r.site_id).second) t.Fail(fmt::format("site '{}' repeated", r.site_id));
    table.rows.push_back(std::move(r));
  }
  return table;
}

std::vector<SiteHeight> ReadSiteHeights(const fs::path& path) {
  return ReadFile(
      path, [](std::istream& in, const std::string& name) { return ReadSiteHeights(in, name); });
}

std::vector<SitePlantRow> ReadSitePlants(const fs::path& path) {
  return ReadFile(
      path, [](std::istream& in, const std::string& name) { return ReadSitePlants(in, name); });
}

GrowthTable ReadGrowth(const fs::path& path) {
  return ReadFile(path,
                  [](std::istream& in, const std::string& name) { return ReadGrowth(in, name); });
}

}  // namespace crop4d::workspace
