#include "crop4d/workspace/analysis_results.h"

#include <cmath>
#include <limits>
#include <map>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/core/timestamp.h"

namespace crop4d::workspace {

std::vector<SiteHeight> SiteHeightRows(const std::vector<analysis::SiteResult>& results,
                                       bool ours) {
  std::vector<SiteHeight> rows;
  for (const analysis::SiteResult& r : results) {
    const analysis::SiteCanopy& c = ours ? r.ours : r.single_plane;
    rows.push_back(
        {r.site_id, r.session, FormatDate(r.date), c.height_m, c.cover, c.volume_m3, c.n_points});
  }
  return rows;
}

std::vector<SitePlantRow> SitePlantRows(const std::vector<analysis::SiteResult>& results) {
  std::vector<SitePlantRow> rows;
  for (const analysis::SiteResult& r : results) {
    for (std::size_t n = 0; n < r.stems.size(); ++n) {
      const double top = n < r.ours.plant_tops.size() ? r.ours.plant_tops[n]
                                                      : std::numeric_limits<double>::quiet_NaN();
      rows.push_back({r.site_id, static_cast<int>(n + 1), r.stems[n].x(), r.stems[n].y(), r.session,
                      FormatDate(r.date), top});
    }
  }
  return rows;
}

GrowthTable GrowthRows(const std::vector<analysis::SiteGrowth>& growth,
                       const std::vector<analysis::SeasonSession>& sessions) {
  GrowthTable table;
  if (sessions.empty()) return table;
  const Timestamp day0 = sessions.front().date;
  for (std::size_t k = 0; k + 1 < sessions.size(); ++k) {
    table.intervals.push_back(GrowthIntervalName(sessions[k].id, sessions[k + 1].id));
  }
  for (const analysis::SiteGrowth& g : growth) {
    const analysis::GrowthFit& f = g.fit;
    GrowthRow row;
    row.site_id = g.site_id;
    row.status = analysis::GrowthStatusName(f.status);
    row.n = f.num_points;
    if (f.ok()) {
      row.asymptote_m = f.curve.asymptote_m;
      row.rate_per_day = f.curve.rate_per_day;
      row.midpoint_date =
          FormatDate(day0 + static_cast<Timestamp>(std::llround(f.curve.midpoint_day * 86400.0)) *
                                1'000'000'000LL);
      row.max_growth_m_per_day = f.curve.MaxGrowthRate();
      row.rmse_m = f.rmse_m;
    }
    for (std::size_t k = 0; k + 1 < sessions.size(); ++k) {
      const double from = DurationSeconds(day0, sessions[k].date) / 86400.0;
      const double to = DurationSeconds(day0, sessions[k + 1].date) / 86400.0;
      double rate = std::numeric_limits<double>::quiet_NaN();
      for (const analysis::GrowthInterval& in : f.intervals) {
        if (std::abs(in.day_from - from) < 1e-6 && std::abs(in.day_to - to) < 1e-6) {
          rate = in.rate_m_per_day;
        }
      }
      row.interval_rates.push_back(rate);
    }
    table.rows.push_back(std::move(row));
  }
  return table;
}

std::vector<analysis::SiteResult> ReadSiteResults(const Layout& ws) {
  std::map<std::pair<std::string, std::string>, analysis::SiteResult> by_key;
  std::vector<std::pair<std::string, std::string>> order;
  for (const bool ours : {true, false}) {
    const std::filesystem::path path = ours ? ws.SiteHeights() : ws.SiteHeightsSinglePlane();
    if (!std::filesystem::exists(path)) continue;
    for (const SiteHeight& h : ReadSiteHeights(path)) {
      const auto key = std::make_pair(h.site_id, h.session);
      if (!by_key.count(key)) order.push_back(key);
      analysis::SiteResult& r = by_key[key];
      r.site_id = h.site_id;
      r.session = h.session;
      if (!h.date.empty() && !ParseDate(h.date, &r.date)) {
        throw InputError(path.string(), h.line, "not a date (YYYY-MM-DD): '" + h.date + "'");
      }
      analysis::SiteCanopy& c = ours ? r.ours : r.single_plane;
      c.height_m = h.height_m;
      c.cover = h.cover;
      c.volume_m3 = h.volume_m3;
      c.n_points = h.n_points >= 0 ? static_cast<int>(h.n_points) : 0;
    }
  }
  std::vector<analysis::SiteResult> out;
  for (const auto& key : order) out.push_back(by_key[key]);
  return out;
}

}  // namespace crop4d::workspace
