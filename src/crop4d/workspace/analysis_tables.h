#pragma once

// The analyze stage's tables in WS/analysis/ (Layout::SiteHeights, SiteHeightsSinglePlane,
// SitePlants, Growth): one writer and one reader per table, shared by the analyze stage (writes,
// and reads back for an up-to-date run), `crop4d eval`, the report and the viewer.
//
//   site_heights.csv, site_heights_single_plane.csv
//       site_id,session,date,height_m,cover,volume_m3,n_points
//       (height_m, cover, volume_m3 empty where there is no estimate; n_points empty: unknown)
//   site_plants.csv
//       site_id,plant,x_m,y_m,session,date,top_m      (top_m empty: the plant was not seen)
//   growth.csv
//       site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n
//       then one column growth_<earlier>_<later>_m_per_day per consecutive pair of sessions
//
// Schema version: the tables of schema 1 (kAnalysisTablesSchema) start with exactly the header
// above. A later schema starts with the comment line "# crop4d schema N" before its header, so
// that this crop4d can tell it apart. Reading a file of another schema (that comment with
// another N, or another header) throws an InputError naming the file and asking to rerun
// `crop4d analyze`; so does a malformed or truncated file (naming the line). Numbers are written
// with fixed decimals (heights 4, cover 3, volume 5, rates 5, positions 3), so a table written,
// read and written again is the same bytes.

#include <cstdint>
#include <filesystem>
#include <istream>
#include <limits>
#include <string>
#include <vector>

namespace crop4d::workspace {

inline constexpr int kAnalysisTablesSchema = 1;

// One row of site_heights.csv or site_heights_single_plane.csv (and of the field's
// site_truth.csv, which eval reads into the same type: cover, volume and n_points unknown).
struct SiteHeight {
  std::string site_id;
  std::string session;
  std::string date;                                             // YYYY-MM-DD; may be empty
  double height_m = std::numeric_limits<double>::quiet_NaN();   // NaN: no estimate
  double cover = std::numeric_limits<double>::quiet_NaN();      // 0..1
  double volume_m3 = std::numeric_limits<double>::quiet_NaN();  // m³
  std::int64_t n_points = -1;                                   // -1: unknown
  std::int64_t line = 0;                                        // 1-based line when read
};

// One row of site_plants.csv: a plant of a site in one session.
struct SitePlantRow {
  std::string site_id;
  int plant = 0;  // 1, 2, ... within the site
  double x_m = 0.0, y_m = 0.0;
  std::string session;
  std::string date;                                         // YYYY-MM-DD; may be empty
  double top_m = std::numeric_limits<double>::quiet_NaN();  // NaN: not seen
  std::int64_t line = 0;
};

// One row of growth.csv: a site's growth fit (analysis/growth.h). The curve's numbers are NaN
// and midpoint_date empty unless status is "fitted".
struct GrowthRow {
  std::string site_id;
  std::string status;  // analysis::GrowthStatusName
  double asymptote_m = std::numeric_limits<double>::quiet_NaN();
  double rate_per_day = std::numeric_limits<double>::quiet_NaN();
  std::string midpoint_date;  // YYYY-MM-DD
  double max_growth_m_per_day = std::numeric_limits<double>::quiet_NaN();
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  int n = 0;  // observations fitted
  // The growth rate of each session interval (GrowthTable::intervals), m/day; NaN: none.
  std::vector<double> interval_rates;
  std::int64_t line = 0;
};

struct GrowthTable {
  // The consecutive pairs of sessions in date order, one column each, named
  // GrowthIntervalName(earlier, later) (the column is growth_<name>_m_per_day).
  std::vector<std::string> intervals;
  std::vector<GrowthRow> rows;
};

// "<earlier>_<later>".
std::string GrowthIntervalName(const std::string& earlier, const std::string& later);

// The header of each table (schema 1), as a list of column names.
std::vector<std::string> SiteHeightsColumns();
std::vector<std::string> SitePlantsColumns();
std::vector<std::string> GrowthColumns(const GrowthTable& table);

// The cells of one row as the writer writes them (the report shows the tables as written).
std::vector<std::string> SiteHeightCells(const SiteHeight& row);
std::vector<std::string> GrowthCells(const GrowthRow& row);

// The whole file's text (header line, one line per row); and the same written atomically.
std::string SiteHeightsText(const std::vector<SiteHeight>& rows);
std::string SitePlantsText(const std::vector<SitePlantRow>& rows);
std::string GrowthText(const GrowthTable& table);
void WriteSiteHeights(const std::filesystem::path& path, const std::vector<SiteHeight>& rows);
void WriteSitePlants(const std::filesystem::path& path, const std::vector<SitePlantRow>& rows);
void WriteGrowth(const std::filesystem::path& path, const GrowthTable& table);

// Readers. Beside the schema check they throw InputError (file and line) for a missing file, a
// truncated last line, a row with the wrong number of fields, an empty site_id or session, a
// date not YYYY-MM-DD, a value that is not a finite number (an empty cell is NaN where the
// writer leaves cells empty), a repeated key ((site_id, session); (site_id, plant, session);
// site_id) and, in site_plants.csv, a plant that moves between sessions. `name` stands for the
// file in messages.
std::vector<SiteHeight> ReadSiteHeights(const std::filesystem::path& path);
std::vector<SiteHeight> ReadSiteHeights(std::istream& in, const std::string& name);
std::vector<SitePlantRow> ReadSitePlants(const std::filesystem::path& path);
std::vector<SitePlantRow> ReadSitePlants(std::istream& in, const std::string& name);
GrowthTable ReadGrowth(const std::filesystem::path& path);
GrowthTable ReadGrowth(std::istream& in, const std::string& name);

}  // namespace crop4d::workspace
