// The season report's crop results: canopy height per site, growth rates and the evaluation
// against ground truth.
// Builder methods (html_report_builder.h).

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <initializer_list>
#include <map>
#include <optional>
#include <set>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/io/dataset.h"
#include "crop4d/report/html_report_builder.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/eval_metrics.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::report::html::detail {

// ---- canopy heights ----------------------------------------------------------------------------

Section Builder::HeightsSection() {
  Section s{{"heights", "Canopy height per site", false}, ""};
  const workspace::Layout ws(ws_);
  const auto summary = ReadArtefact(
      ws.AnalysisSummary(), [](const fs::path& p) { return workspace::ReadAnalysisSummary(p); });
  const auto heights = ReadArtefact(
      ws.SiteHeights(), [](const fs::path& p) { return workspace::ReadSiteHeights(p); });
  std::optional<Csv> measured;
  if (!field_.empty()) {
    measured = ReadCsv(fs::path(field_) / "ground_truth" / "site_measurements.csv",
                       "FIELD/ground_truth/site_measurements.csv");
  }
  // The analysis ran when it left its summary or its table, even one that cannot be read.
  if (!IsFile(ws.AnalysisSummary()) && !IsFile(ws.SiteHeights())) {
    s.html = Empty(
        "Analysis has not run: no WS/analysis/summary.json or WS/analysis/site_heights.csv." +
        std::string(measured ? " The measurements of FIELD/ground_truth/site_measurements.csv "
                               "are not shown without estimates."
                             : ""));
    return s;
  }
  s.info.has_data = true;
  if (summary) s.html += AnalysisSessionsHtml(*summary);
  const fs::path plot = ws.PlotsDir() / "heights.png";
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
  if (heights) s.html += HeightsTableHtml(*heights, measured);
  if (const auto single = ReadArtefact(ws.SiteHeightsSinglePlane(), [](const fs::path& p) {
        return workspace::ReadSiteHeights(p);
      })) {
    std::vector<std::vector<std::string>> rows;
    for (const workspace::SiteHeight& r : *single) {
      std::vector<std::string> row;
      for (const std::string& c : workspace::SiteHeightCells(r)) row.push_back(E(c));
      rows.push_back(row);
    }
    std::vector<std::string> head;
    for (const std::string& c : workspace::SiteHeightsColumns()) head.push_back(E(c));
    s.html += Details("Heights above a single ground plane (the paper's simpler terrain model)",
                      Table(head, rows, "ll" + std::string(head.size(), 'r')));
  }
  return s;
}

// The sessions the analysis measured, and why sites have no height.
std::string Builder::AnalysisSessionsHtml(const workspace::AnalysisSummary& summary) const {
  std::string html;
  std::vector<std::vector<std::string>> rows;
  for (const workspace::AnalysisSessionRecord& x : summary.sessions) {
    rows.push_back({E(x.session), E(x.date), Code(x.cloud), I(static_cast<double>(x.points)),
                    I(static_cast<double>(x.plants)), Percent(x.vegetation_fraction, 2)});
  }
  if (!rows.empty()) {
    html += Table({"session", "date", "cloud", "points", "plants found", "vegetation points"}, rows,
                  "lllrrr");
  }
  if (!summary.site_notes.empty()) {
    html += "<ul class=\"notes\">";
    for (const workspace::AnalysisSiteNote& n : summary.site_notes) {
      const json note = {{"site_id", n.site_id}, {"session", n.session}, {"note", n.note}};
      html += "<li>" + E(note.dump()) + "</li>";
    }
    html += "</ul>\n";
  }
  return html;
}

// Canopy height per site and date: the estimates, and below them the heights a person measured
// where the field has them.
std::string Builder::HeightsTableHtml(const std::vector<workspace::SiteHeight>& heights,
                                      const std::optional<Csv>& measured) {
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
  for (const workspace::SiteHeight& r : heights) {
    add_site(r.site_id);
    dates.insert(r.date);
    const bool h = std::isfinite(r.height_m);
    std::string cell = h ? fmt::format("{:.3f}", r.height_m) : "<span class=\"muted\">none</span>";
    if (!h) {
      const std::string n = r.n_points >= 0 ? std::to_string(r.n_points) : std::string();
      cell += " <span class=\"muted\">(" + E(n) + " pts)</span>";
    }
    est[{r.site_id, r.date}] = cell;
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
      auto e = est.find({site, d});
      std::string cell = e != est.end() ? e->second : std::string(kDash);
      auto m = meas.find({site, d});
      if (m != meas.end()) cell += "<br><span class=\"meas\">meas. " + m->second + "</span>";
      row.push_back(cell);
    }
    rows.push_back(row);
  }
  std::string html = "<h3>Canopy height [m] per site and date</h3>\n";
  html += n_meas > 0 ? "<p>Estimates of crop4d; below them, in italics, the heights a person "
                       "measured (FIELD/ground_truth/site_measurements.csv).</p>\n"
                     : std::string(field_.empty()
                                       ? "<p class=\"muted\">No field given: no measurements.</p>\n"
                                       : "<p class=\"muted\">No measurements "
                                         "(FIELD/ground_truth/site_measurements.csv).</p>\n");
  return html + Table(head, rows, "l" + std::string(dates.size(), 'r'), "heights");
}

namespace {

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

}  // namespace

Section Builder::GrowthSection() {
  Section s{{"growth", "Growth rates", false}, ""};
  const workspace::Layout ws(ws_);
  const auto growth =
      ReadArtefact(ws.Growth(), [](const fs::path& p) { return workspace::ReadGrowth(p); });
  if (!growth) {
    s.html = Empty("No growth rates: no WS/analysis/growth.csv (crop4d analyze).");
    return s;
  }
  s.info.has_data = !growth->rows.empty();
  std::vector<std::string> head;
  std::string align;
  for (const std::string& h : workspace::GrowthColumns(*growth)) {
    head.push_back(PrettyColumn(h));
    align += (h == "site_id" || h == "status" ||
              (h.find("date") != std::string::npos && h.rfind("growth_", 0) != 0))
                 ? 'l'
                 : 'r';
  }
  std::vector<std::vector<std::string>> rows;
  for (const workspace::GrowthRow& r : growth->rows) {
    std::vector<std::string> row;
    for (const std::string& c : workspace::GrowthCells(r)) row.push_back(E(c));
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

namespace {

std::string AteCells(const json& m, const char* key) {
  return F(Num(m, {key, "rmse"}).has_value() ? std::optional<double>(1000 * *Num(m, {key, "rmse"}))
                                             : std::nullopt,
           1);
}

}  // namespace

namespace {

// The trajectory errors of row SLAM and of the 4D fusion, and the worst pass.
std::string TrajectoriesHtml(const json& m) {
  std::string html;
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
    html += "<h3>Trajectories</h3>\n";
    html += Table({"estimate", "evaluated", "poses", "ATE raw RMSE [mm]", "ATE aligned RMSE [mm]",
                   "rotation RMSE [deg]", "RPE RMSE [%]"},
                  traj, "lrrrrrr");
    if (At(m, {"overall", "worst_pass"}) != nullptr) {
      html += "<p class=\"muted\">Worst pass: " + E(Str(m, {"overall", "worst_pass", "session"})) +
              " " + E(Str(m, {"overall", "worst_pass", "pass"})) + ", ATE raw RMSE " +
              F(mm({"overall", "worst_pass", "ate_raw_rmse_m"}), 1) + " mm.</p>\n";
    }
  }
  return html;
}

// Every pass: its trajectory errors or why it could not be evaluated.
std::string PassesHtml(const json& m) {
  std::string html;
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
    html += Details(fmt::format("Every pass ({})", passes.size()),
                    Table({"session", "pass", "sensors", "poses", "ATE raw [mm]",
                           "ATE aligned [mm]", "rotation [deg]", "error"},
                          passes, "lllrrrrl"));
  }
  return html;
}

// The cross matches per method and pair type, judged against the truth.
std::string CrossMatchesHtml(const json& m) {
  std::string html;
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
      html += "<h3>Cross matches</h3>\n";
      html += Table({"method", "pair type", "pairs", "matches", "correct", "incorrect", "unknown",
                     "precision"},
                    rows, "llrrrrrr");
    }
  }
  return html;
}

// The ground of one session against the others.
std::string GroundMisalignmentHtml(const json& m) {
  std::string html;
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
      html += "<h3>Ground of one session against the others</h3>\n";
      html += Table({"clouds", "ground points", "median distance [mm]", "90th percentile [mm]",
                     "signed median [mm]"},
                    rows, "lrrrr");
    }
  }
  return html;
}

// Canopy height against the truth per method and session, and the plants of the sites.
std::string CanopyEvalHtml(const json& m) {
  std::string html;
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
      // The RMSE's 95 % interval over the sites (eval/site_bootstrap.h), when given.
      const std::optional<double> low = Num(*x, {"rmse_interval_m", "low"});
      const std::optional<double> high = Num(*x, {"rmse_interval_m", "high"});
      const std::string interval =
          low && high ? fmt::format("{:.1f}&ndash;{:.1f}", 1000 * *low, 1000 * *high) : "";
      rows.push_back({std::string(which) == "ours" ? "crop4d (terrain model)" : "single plane",
                      Code(Str(*x, {"file"})), I(Num(*x, {"num_pairs"})), F(xmm("rmse_m"), 1),
                      interval, F(xmm("bias_m"), 1), F(xmm("mae_m"), 1),
                      F(xmm("max_abs_error_m"), 1), I(Num(*x, {"num_failures"})),
                      err.empty() ? "" : "<span class=\"badt\">" + E(err) + "</span>"});
    }
    if (!rows.empty()) {
      html += "<h3>Canopy height</h3>\n";
      html += Table(
          {"estimate", "file", "site-dates", "RMSE [mm]", "RMSE, 95 % interval over the sites [mm]",
           "bias [mm]", "MAE [mm]", "max |error| [mm]",
           fmt::format("errors &gt; {:.0f} mm",
                       1000 * Num(*c, {"options", "max_error_m"}).value_or(NAN)),
           "error"},
          rows, "llrrrrrrrl");
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
        html += Details(
            "Canopy height error per session (crop4d)",
            Table({"session", "sites", "RMSE [mm]", "bias [mm]", "max |error| [mm]", "failures"},
                  srows, "lrrrrr"));
      }
    }
    // The plants of the sites (analysis/site_plants.csv against the true stems).
    if (const json* p = At(*c, {"plants"}); p != nullptr && p->is_object()) {
      auto pmm = [&](const char* k) {
        std::optional<double> v = Num(*p, {k});
        return v ? std::optional<double>(1000 * *v) : std::nullopt;
      };
      html += "<h3>Plants of the sites</h3>\n";
      html +=
          Table({"true plants", "found", "recall", "listed", "precision", "median stem offset [mm]",
                 "tops", "top RMSE [mm]", "top bias [mm]",
                 fmt::format("tops off &gt; {:.0f} mm",
                             1000 * Num(*c, {"options", "max_error_m"}).value_or(NAN))},
                {{I(Num(*p, {"true"})), I(Num(*p, {"matched"})), Percent(Num(*p, {"recall"})),
                  I(Num(*p, {"found"})), Percent(Num(*p, {"precision"})),
                  F(pmm("median_stem_offset_m"), 1), I(Num(*p, {"tops"})), F(pmm("top_rmse_m"), 1),
                  F(pmm("top_bias_m"), 1), I(Num(*p, {"top_failures"}))}},
                "rrrrrrrrrr");
    }
  }
  return html;
}

}  // namespace

Section Builder::EvalSection() {
  Section s{{"evaluation", "Evaluation against ground truth", false}, ""};
  const auto metrics = ReadArtefact(layout_.EvalMetrics(), [](const fs::path& p) {
    return workspace::ReadEvalMetrics(p.string());
  });
  if (!metrics) {
    s.html = Empty(
        "No evaluation: no WS/eval/metrics.json (crop4d eval needs a field with ground truth, "
        "e.g. a simulated one).");
    return s;
  }
  s.info.has_data = true;
  const json& m = metrics->json;
  s.html += TrajectoriesHtml(m);
  s.html += PassesHtml(m);
  s.html += CrossMatchesHtml(m);
  s.html += GroundMisalignmentHtml(m);
  s.html += CanopyEvalHtml(m);
  return s;
}

}  // namespace crop4d::report::html::detail
