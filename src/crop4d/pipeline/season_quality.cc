#include "crop4d/pipeline/season_quality.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <nlohmann/json.hpp>

#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {
namespace {

using json = nlohmann::json;

std::string PositioningWords(Positioning p) {
  switch (p) {
    case Positioning::kRtk:
      return "RTK";
    case Positioning::kGps:
      return "a metre-level GPS";
    case Positioning::kNone:
      return "no GPS";
  }
  return "";
}

// The positioning that at least half of the sessions reach (the sessions' own positioning is
// the worst of their passes).
Positioning Standard(const std::vector<Positioning>& sessions) {
  for (Positioning level : {Positioning::kRtk, Positioning::kGps}) {
    const auto reach = std::count_if(sessions.begin(), sessions.end(),
                                     [level](Positioning p) { return p >= level; });
    if (2 * reach >= static_cast<std::ptrdiff_t>(sessions.size())) return level;
  }
  return Positioning::kNone;
}

}  // namespace

PassFacts PassFactsOf(const std::string& session, const std::string& pass,
                      const workspace::PassSummary& summary) {
  PassFacts f;
  f.session = session;
  f.pass = pass;
  f.sensors = summary.sensors;
  f.positioning = PositioningOf(f.sensors);
  f.longest_imu_gap_s = summary.longest_imu_gap_s;
  if (summary.json.contains("back_end")) {
    const nlohmann::json& back_end = summary.json.at("back_end");
    f.gps_fixes = back_end.value("gps_factors", 0);
    f.gps_rejected = back_end.value("gps_rejected", 0);
  }
  return f;
}

OptionCheck QualityOptions::Check() const {
  OptionChecker c;
  c.Greater("max_imu_gap_s", max_imu_gap_s, 0.0).Finite("max_imu_gap_s", max_imu_gap_s);
  c.InRange("max_gps_rejected_share", max_gps_rejected_share, 0.0, 1.0);
  return c.Result();
}

SeasonQuality GradeSeason(const std::vector<PassFacts>& passes, const QualityOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "GradeSeason");
  SeasonQuality q;
  std::map<std::string, std::size_t> index;
  std::vector<Positioning> positioning;
  std::vector<std::string> sensors;  // of the worst-positioned pass
  for (const PassFacts& p : passes) {
    auto [it, inserted] = index.emplace(p.session, q.sessions.size());
    if (inserted) {
      q.sessions.push_back({p.session, true, {}});
      positioning.push_back(p.positioning);
      sensors.push_back(p.sensors);
    } else if (p.positioning < positioning[it->second]) {
      positioning[it->second] = p.positioning;
      sensors[it->second] = p.sensors;
    }
  }
  q.standard = Standard(positioning);
  const auto at_standard = std::count_if(positioning.begin(), positioning.end(),
                                         [&](Positioning p) { return p >= q.standard; });
  for (std::size_t s = 0; s < q.sessions.size(); ++s) {
    if (positioning[s] >= q.standard) continue;
    q.sessions[s].reasons.push_back(fmt::format(
        "positioned with {} ({}) while {} of {} sessions have {}", PositioningWords(positioning[s]),
        sensors[s], at_standard, q.sessions.size(), PositioningWords(q.standard)));
  }
  for (const PassFacts& p : passes) {
    if (p.longest_imu_gap_s <= options.max_imu_gap_s) continue;
    q.sessions[index.at(p.session)].reasons.push_back(
        fmt::format("pass {}: no IMU sample for {:.1f} s (more than {:.1f} s)", p.pass,
                    p.longest_imu_gap_s, options.max_imu_gap_s));
  }
  for (const PassFacts& p : passes) {
    if (!LeftGpsTrack(p.gps_fixes, p.gps_rejected, options.max_gps_rejected_share)) continue;
    q.sessions[index.at(p.session)].reasons.push_back(fmt::format(
        "pass {}: row SLAM rejected {} of its {} GPS fixes as outliers (more than {:.0f} %): its "
        "solve left the GPS track",
        p.pass, p.gps_rejected, p.gps_fixes, 100 * options.max_gps_rejected_share));
  }
  for (SessionGrade& g : q.sessions) g.trusted = g.reasons.empty();
  q.any_trusted = std::any_of(q.sessions.begin(), q.sessions.end(),
                              [](const SessionGrade& g) { return g.trusted; });
  return q;
}

std::string SeasonQualityPath(const std::string& workspace) {
  return workspace::Layout(workspace).FusedQuality().string();
}

SeasonQuality ReadSeasonQuality(const std::string& workspace) {
  return workspace::ReadSeasonQuality(SeasonQualityPath(workspace));
}

}  // namespace crop4d::pipeline
