#include "crop4d/eval/plant_eval.h"

#include <fmt/format.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <string_view>
#include <tuple>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/eval/ground_misalignment.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Matches the found plants of each site (first row of each plant, in the file's order of sites)
// with the true plants of `last` within the site, nearest pairs first, one to one; counts them
// into `eval`. Returns (site, plant) → index of its true plant in `last`.
std::map<std::pair<std::string, int>, std::size_t> MatchSitePlants(
    const std::vector<SitePlantRow>& rows, const std::vector<PlantFootprint>& last,
    const std::map<std::string, const io::Site*>& site_by_id, const PlantEvalOptions& options,
    PlantEval* eval) {
  std::map<std::string, std::vector<std::pair<int, Eigen::Vector2d>>> found;
  std::vector<std::string> site_order;
  for (const SitePlantRow& r : rows) {
    auto& list = found[r.site_id];
    if (list.empty()) site_order.push_back(r.site_id);
    if (std::none_of(list.begin(), list.end(), [&](const auto& p) { return p.first == r.plant; })) {
      list.emplace_back(r.plant, Eigen::Vector2d(r.x_m, r.y_m));
    }
  }
  std::map<std::pair<std::string, int>, std::size_t> matched;
  std::vector<double> offsets;
  for (const std::string& id : site_order) {
    const auto site = site_by_id.find(id);
    if (site == site_by_id.end()) {
      ++eval->num_sites_unknown;
      continue;
    }
    SitePlantCounts counts;
    counts.site_id = id;
    std::vector<std::size_t> inside;
    for (std::size_t i = 0; i < last.size(); ++i) {
      if (last[i].height_m > 0.0 &&
          (last[i].xy - site->second->center_enu).norm() <= site->second->radius_m) {
        inside.push_back(i);
      }
    }
    const auto& plants = found[id];
    counts.num_true = static_cast<int>(inside.size());
    counts.num_found = static_cast<int>(plants.size());
    // Nearest pairs first, one to one.
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;  // distance, found, true
    for (std::size_t a = 0; a < plants.size(); ++a) {
      for (const std::size_t t : inside) {
        const double d = (plants[a].second - last[t].xy).norm();
        if (d <= options.max_stem_offset_m) pairs.emplace_back(d, a, t);
      }
    }
    std::sort(pairs.begin(), pairs.end());
    std::set<std::size_t> used_found, used_true;
    for (const auto& [d, a, t] : pairs) {
      if (used_found.count(a) || used_true.count(t)) continue;
      used_found.insert(a);
      used_true.insert(t);
      matched[{id, plants[a].first}] = t;
      offsets.push_back(d);
    }
    counts.num_matched = static_cast<int>(used_found.size());
    eval->num_true += counts.num_true;
    eval->num_found += counts.num_found;
    eval->num_matched += counts.num_matched;
    eval->sites.push_back(counts);
  }
  if (eval->num_true > 0) eval->recall = static_cast<double>(eval->num_matched) / eval->num_true;
  if (eval->num_found > 0) {
    eval->precision = static_cast<double>(eval->num_matched) / eval->num_found;
  }
  if (!offsets.empty()) {
    const auto mid = offsets.begin() + offsets.size() / 2;
    std::nth_element(offsets.begin(), mid, offsets.end());
    eval->median_stem_offset_m = *mid;
  }
  return matched;
}

// Tops: the matched plant's true height in each session (the same stem in that session's
// plants.csv) against its top.
void JudgeTops(const std::vector<SitePlantRow>& rows,
               const std::map<std::pair<std::string, int>, std::size_t>& matched,
               const std::vector<PlantFootprint>& last,
               const std::map<std::string, std::vector<PlantFootprint>>& truth,
               const PlantEvalOptions& options, PlantEval* eval) {
  double sum = 0.0, sum2 = 0.0;
  for (const SitePlantRow& r : rows) {
    const auto m = matched.find({r.site_id, r.plant});
    if (m == matched.end() || std::isnan(r.top_m) || !truth.count(r.session)) continue;
    const Eigen::Vector2d stem = last[m->second].xy;
    for (const PlantFootprint& p : truth.at(r.session)) {
      if ((p.xy - stem).norm() > 1e-3 || p.height_m <= 0.0) continue;
      const double e = r.top_m - p.height_m;
      sum += e;
      sum2 += e * e;
      ++eval->num_tops;
      if (std::abs(e) > options.max_top_error_m) ++eval->num_top_failures;
      break;
    }
  }
  if (eval->num_tops > 0) {
    eval->top_bias_m = sum / eval->num_tops;
    eval->top_rmse_m = std::sqrt(sum2 / eval->num_tops);
  }
}

}  // namespace

OptionCheck PlantEvalOptions::Check() const {
  OptionChecker c;
  c.Greater("max_stem_offset_m", max_stem_offset_m, 0.0)
      .Greater("max_top_error_m", max_top_error_m, 0.0);
  return c.Result();
}

bool EvaluateSitePlants(const std::string& workspace, const std::string& field,
                        const PlantEvalOptions& options, PlantEval* eval, std::string* why) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateSitePlants");
  const workspace::Layout ws(workspace);
  const std::string file = ws.SitePlants().lexically_relative(ws.root()).generic_string();
  std::error_code ec;
  if (!fs::is_regular_file(ws.SitePlants(), ec)) {
    *why = "no " + file + " in the workspace (written by crop4d analyze)";
    return false;
  }
  std::vector<SitePlantRow> rows = ReadSitePlants(ws.SitePlants());
  if (!options.sessions.empty()) {
    std::erase_if(rows, [&](const SitePlantRow& r) {
      return std::find(options.sessions.begin(), options.sessions.end(), r.session) ==
             options.sessions.end();
    });
  }
  // Sessions by date (then id), those with true plants only.
  std::map<std::pair<std::string, std::string>, std::string> by_date;
  for (const SitePlantRow& r : rows) by_date[{r.date, r.session}] = r.session;
  std::vector<std::string> sessions;
  std::map<std::string, std::vector<PlantFootprint>> truth;
  for (const auto& [key, session] : by_date) {
    const fs::path plants = fs::path(field) / "ground_truth" / session / "plants.csv";
    if (!fs::is_regular_file(plants, ec)) continue;
    truth[session] = ReadPlantsCsv(plants.string());
    sessions.push_back(session);
  }
  if (sessions.empty()) {
    *why = "no ground_truth/<session>/plants.csv in the field for the sessions of " + file;
    return false;
  }
  if (!fs::is_regular_file(fs::path(field) / "field.yaml", ec)) {
    *why = "no field.yaml in the field (the sites)";
    return false;
  }
  const io::Field field_info(field);
  std::map<std::string, const io::Site*> site_by_id;
  for (const io::Site& s : field_info.info().sites) site_by_id[s.id] = &s;

  *eval = PlantEval();
  eval->file = file;
  eval->options = options;
  eval->truth_session = sessions.back();
  const std::vector<PlantFootprint>& last = truth[eval->truth_session];

  // (site, plant) → index of the true plant in `last`.
  const std::map<std::pair<std::string, int>, std::size_t> matched =
      MatchSitePlants(rows, last, site_by_id, options, eval);
  JudgeTops(rows, matched, last, truth, options, eval);
  return true;
}

std::string FormatPlantTable(const PlantEval& e) {
  const auto percent = [](double v) {
    return std::isfinite(v) ? fmt::format("{:.0f} %", 100.0 * v) : std::string("-");
  };
  const auto cm = [](double v, bool sign) {
    if (!std::isfinite(v)) return std::string("-");
    return sign ? fmt::format("{:+.2f} cm", 100.0 * v) : fmt::format("{:.2f} cm", 100.0 * v);
  };
  std::string out = fmt::format(
      "plants of the sites ({}; true plants of {} with a stem in a site): {} of {} found within "
      "{:g} cm (recall {}), {} of {} found match a true plant (precision {}), median stem "
      "offset {}\n",
      e.file, e.truth_session, e.num_matched, e.num_true, 100.0 * e.options.max_stem_offset_m,
      percent(e.recall), e.num_matched, e.num_found, percent(e.precision),
      cm(e.median_stem_offset_m, false));
  out += fmt::format(
      "plant tops of the matched plants, all sessions: {} tops, RMSE {}, bias {}, {} off by "
      "more than {:g} cm\n",
      e.num_tops, cm(e.top_rmse_m, false), cm(e.top_bias_m, true), e.num_top_failures,
      100.0 * e.options.max_top_error_m);
  if (e.num_sites_unknown > 0) {
    out += fmt::format("({} sites of {} are not in field.yaml: not evaluated)\n",
                       e.num_sites_unknown, e.file);
  }
  return out;
}

}  // namespace crop4d::eval
