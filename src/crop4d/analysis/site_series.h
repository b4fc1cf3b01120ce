#pragma once

// The canopy of one site through the season: each session measured with what the others tell
// about the site (DESIGN.md §2.6).
//
//   - the site's plants (stems) are those found at the site in the earliest session that has
//     any: later, the leaf clusters of grown plants would pass for plants;
//   - each plant's top bounds its top in the session before, plus CanopyOptions::max_shrink_m
//     (plants grow; a point floating above a young plant is not its top); measured latest
//     session first, so that every bound is known when it is needed. max_shrink_m < 0: no bound;
//   - the paper's single ground plane (Dong et al. 2017) is fitted in the earliest session with
//     enough soil at the site, and every session is measured above it too, alone.
//
// A session that is not trusted (a degraded session, pipeline/season_quality.h) is measured,
// but never sets the stems, the plane or a bound.

#include <vector>

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/growth.h"
#include "crop4d/analysis/plants.h"
#include "crop4d/analysis/terrain.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"

namespace crop4d::analysis {

struct SiteSeries {
  std::vector<Eigen::Vector2d> stems;    // the site's plants (ENU xy), the same in every session
  std::vector<SiteCanopy> ours;          // per session, above `ground`
  std::vector<SiteCanopy> single_plane;  // per session, above the site's plane (a note without)
};

// `clouds` in date order, `trusted` and `plants` (DetectPlants over the whole area) one per
// cloud.
SiteSeries MeasureSiteSeries(const std::vector<SessionCloud>& clouds,
                             const std::vector<bool>& trusted,
                             const std::vector<std::vector<DetectedPlant>>& plants,
                             const GroundFunction& ground, const io::Site& site,
                             const CanopyOptions& canopy, const PlaneOptions& plane);

// One site in one session, as the analyze stage reports and writes it.
struct SiteResult {
  std::string site_id;
  std::string session;
  Timestamp date = 0;
  SiteCanopy ours;          // above the DTM
  SiteCanopy single_plane;  // above the paper's plane
  // The site's plants (stems, ENU xy; analysis/plants.h), the same in every session; their tops
  // are ours.plant_tops.
  std::vector<Eigen::Vector2d> stems;
};

struct SiteGrowth {
  std::string site_id;
  GrowthFit fit;
};

// A session of the season: its id, date and whether it is trusted (see above).
struct SeasonSession {
  std::string id;
  Timestamp date = 0;
  bool trusted = true;
};

// Every site in every session: MeasureSiteSeries per site. `clouds` hold each session's points
// at the sites at least (SitePoints), `plants` its plants (DetectPlants over the
// analysed area, or PlantRaster, then PlantsOnRows). Site-major: result
// i * sessions.size() + k is site i in session k.
std::vector<SiteResult> MeasureSeasonSites(const std::vector<io::Site>& sites,
                                           const std::vector<SeasonSession>& sessions,
                                           const std::vector<SessionCloud>& clouds,
                                           const std::vector<std::vector<DetectedPlant>>& plants,
                                           const GroundFunction& ground,
                                           const CanopyOptions& canopy, const PlaneOptions& plane);

// A growth curve per site (FitGrowth) over the trusted sessions' heights above the DTM, days
// since the first session; `results` as MeasureSeasonSites returns them.
std::vector<SiteGrowth> FitSeasonGrowth(const std::vector<io::Site>& sites,
                                        const std::vector<SeasonSession>& sessions,
                                        const std::vector<SiteResult>& results,
                                        const GrowthOptions& options);

}  // namespace crop4d::analysis
