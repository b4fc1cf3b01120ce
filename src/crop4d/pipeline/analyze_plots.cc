#include "crop4d/pipeline/analyze_plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/io/csv.h"
#include "crop4d/report/plots.h"

namespace crop4d::pipeline {
namespace {

double Days(Timestamp t) { return TimestampToSeconds(t) / 86400.0; }

}  // namespace

std::vector<io::SiteMeasurement> ReadSiteMeasurements(const std::string& path) {
  io::CsvReader reader(path);
  io::CsvRecord rec;
  bool header = true;
  std::vector<io::SiteMeasurement> out;
  while (reader.Next(&rec)) {
    if (header) {
      header = false;
      if (rec.fields.size() < 3 || rec.fields[0] != "site_id" || rec.fields[1] != "date" ||
          rec.fields[2] != "height_m") {
        throw InputError(path, rec.line, "expected the header site_id,date,height_m");
      }
      continue;
    }
    if (rec.fields.size() < 3) throw InputError(path, rec.line, "expected site_id,date,height_m");
    io::SiteMeasurement m;
    m.site_id = std::string(rec.fields[0]);
    if (!ParseDate(std::string(rec.fields[1]), &m.date)) {
      throw InputError(path, rec.line,
                       "not a date (YYYY-MM-DD): '" + std::string(rec.fields[1]) + "'");
    }
    if (!io::ParseDouble(rec.fields[2], &m.height_m) || !std::isfinite(m.height_m)) {
      throw InputError(path, rec.line, "not a height: '" + std::string(rec.fields[2]) + "'");
    }
    out.push_back(m);
  }
  return out;
}

std::vector<std::string> WriteHeightPlots(const std::filesystem::path& dir,
                                          const std::vector<io::Site>& sites,
                                          const std::vector<SiteResult>& results,
                                          std::size_t num_sessions,
                                          const std::string& measurements_csv) {
  CROP4D_CHECK(results.size() == sites.size() * num_sessions);
  const std::vector<io::SiteMeasurement> measured = measurements_csv.empty()
                                                        ? std::vector<io::SiteMeasurement>{}
                                                        : ReadSiteMeasurements(measurements_csv);
  std::vector<report::LinePlot> plots;
  std::vector<std::string> written;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    report::LinePlot plot;
    plot.title = sites[i].id;
    plot.x_label = "date";
    plot.y_label = "canopy height [m]";
    plot.x_is_date = true;
    plot.y_min = 0.0;
    report::PlotSeries ours, plane, ruler;
    ours.label = "crop4d (terrain model)";
    ours.color = cv::Scalar(180, 119, 31);  // blue
    plane.label = "single plane (paper)";
    plane.color = cv::Scalar(14, 127, 255);  // orange
    plane.style = report::PlotSeries::Style::kMarkersOnly;
    plane.marker = report::PlotSeries::Marker::kSquare;
    ruler.label = "measured";
    ruler.color = cv::Scalar(40, 39, 214);  // red
    ruler.style = report::PlotSeries::Style::kMarkersOnly;
    ruler.marker = report::PlotSeries::Marker::kCross;
    for (std::size_t k = 0; k < num_sessions; ++k) {
      const SiteResult& r = results[i * num_sessions + k];
      ours.x.push_back(Days(r.date));
      ours.y.push_back(r.ours.height_m);
      plane.x.push_back(Days(r.date));
      plane.y.push_back(r.single_plane.height_m);
    }
    for (const io::SiteMeasurement& m : measured) {
      if (m.site_id != sites[i].id) continue;
      ruler.x.push_back(Days(m.date));
      ruler.y.push_back(m.height_m);
    }
    plot.series = {ours, plane};
    if (!ruler.x.empty()) plot.series.push_back(ruler);
    const std::string name = "height_" + sites[i].id + ".png";
    report::WritePng((dir / name).string(), report::DrawLinePlot(plot));
    written.push_back(name);
    plots.push_back(std::move(plot));
  }
  const int columns = std::max(1, static_cast<int>(std::ceil(std::sqrt(plots.size()))));
  report::WritePng((dir / "heights.png").string(), report::DrawPlotGrid(plots, columns));
  written.insert(written.begin(), "heights.png");
  return written;
}

std::string FormatAnalyzeReport(const AnalyzeReport& report) {
  std::string s;
  if (report.sites.empty()) return "analyze: no sites\n";
  std::vector<std::string> sessions;
  for (const SiteResult& r : report.sites) {
    if (std::find(sessions.begin(), sessions.end(), r.session) == sessions.end()) {
      sessions.push_back(r.session);
    }
  }
  s += report.skipped ? "Canopy height per site [m] (up to date; DTM / single plane):\n"
                      : "Canopy height per site [m] (DTM / single plane):\n";
  s += fmt::format("{:<10}", "site");
  for (const std::string& id : sessions) s += fmt::format(" {:>15}", id);
  s += "\n";
  std::string current;
  for (const SiteResult& r : report.sites) {
    if (r.site_id != current) {
      if (!current.empty()) s += "\n";
      current = r.site_id;
      s += fmt::format("{:<10}", r.site_id);
    }
    const auto cell = [](double v) {
      return std::isfinite(v) ? fmt::format("{:.3f}", v) : "  -  ";
    };
    s += fmt::format(" {:>15}", cell(r.ours.height_m) + " / " + cell(r.single_plane.height_m));
  }
  s += "\n";
  if (!report.growth.empty()) {
    s += "Growth (logistic fit per site):\n";
    for (const SiteGrowth& g : report.growth) {
      if (g.fit.ok()) {
        s += fmt::format("  {:<10} asymptote {:.3f} m, max growth {:.1f} mm/day, rmse {:.1f} mm\n",
                         g.site_id, g.fit.curve.asymptote_m, 1000 * g.fit.curve.MaxGrowthRate(),
                         1000 * g.fit.rmse_m);
      } else {
        s += fmt::format("  {:<10} {}: {}\n", g.site_id, analysis::GrowthStatusName(g.fit.status),
                         g.fit.message);
      }
    }
  }
  if (!report.skipped) {
    s += fmt::format("analyze: {} outputs in {:.1f} s\n", report.outputs.size(), report.seconds);
  }
  return s;
}

}  // namespace crop4d::pipeline
