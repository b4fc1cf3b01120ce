#include "crop4d/analysis/site_series.h"

#include <tbb/parallel_for.h>

#include <cmath>
#include <limits>
#include <optional>

#include "crop4d/core/error.h"

namespace crop4d::analysis {

SiteSeries MeasureSiteSeries(const std::vector<SessionCloud>& clouds,
                             const std::vector<bool>& trusted,
                             const std::vector<std::vector<DetectedPlant>>& plants,
                             const GroundFunction& ground, const io::Site& site,
                             const CanopyOptions& canopy, const PlaneOptions& plane_options) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  CROP4D_CHECK(trusted.size() == clouds.size() && plants.size() == clouds.size());
  std::optional<GroundPlane> plane;
  for (std::size_t k = 0; k < clouds.size() && !plane; ++k) {
    if (!trusted[k]) continue;
    plane = FitSiteGroundPlane(clouds[k].AsGround(), site.center_enu, site.radius_m, plane_options);
  }
  const GroundFunction plane_ground = [&](double x, double y) {
    return plane ? plane->Height(x, y) : kNaN;
  };
  SiteSeries series;
  for (std::size_t k = 0; k < clouds.size() && series.stems.empty(); ++k) {
    if (!trusted[k]) continue;
    for (const DetectedPlant& p : plants[k]) {
      if ((p.stem - site.center_enu).norm() <= site.radius_m) series.stems.push_back(p.stem);
    }
  }
  series.ours.resize(clouds.size());
  series.single_plane.resize(clouds.size());
  std::vector<double> max_tops(series.stems.size(), kNaN);
  for (std::size_t k = clouds.size(); k-- > 0;) {
    SiteCanopy& ours = series.ours[k];
    ours = MeasureSite(clouds[k], ground, site, canopy, &series.stems,
                       canopy.max_shrink_m >= 0 ? &max_tops : nullptr);
    for (std::size_t n = 0; n < series.stems.size() && trusted[k] && !ours.plant_tops.empty();
         ++n) {
      if (std::isfinite(ours.plant_tops[n])) max_tops[n] = ours.plant_tops[n] + canopy.max_shrink_m;
    }
    series.single_plane[k] = MeasureSite(clouds[k], plane_ground, site, canopy, &series.stems);
    if (!plane) series.single_plane[k].note = "no ground plane at the site";
  }
  return series;
}

std::vector<SiteResult> MeasureSeasonSites(const std::vector<io::Site>& sites,
                                           const std::vector<SeasonSession>& sessions,
                                           const std::vector<SessionCloud>& clouds,
                                           const std::vector<std::vector<DetectedPlant>>& detected,
                                           const GroundFunction& ground,
                                           const CanopyOptions& canopy, const PlaneOptions& plane) {
  CROP4D_CHECK(clouds.size() == sessions.size() && detected.size() == sessions.size());
  std::vector<bool> trusted;
  for (const SeasonSession& s : sessions) trusted.push_back(s.trusted);
  std::vector<SiteResult> results(sites.size() * clouds.size());
  tbb::parallel_for(std::size_t{0}, sites.size(), [&](std::size_t i) {
    const SiteSeries series =
        MeasureSiteSeries(clouds, trusted, detected, ground, sites[i], canopy, plane);
    for (std::size_t k = 0; k < clouds.size(); ++k) {
      SiteResult& r = results[i * clouds.size() + k];
      r.site_id = sites[i].id;
      r.session = sessions[k].id;
      r.date = sessions[k].date;
      r.stems = series.stems;
      r.ours = series.ours[k];
      r.single_plane = series.single_plane[k];
    }
  });
  return results;
}

std::vector<SiteGrowth> FitSeasonGrowth(const std::vector<io::Site>& sites,
                                        const std::vector<SeasonSession>& sessions,
                                        const std::vector<SiteResult>& results,
                                        const GrowthOptions& options) {
  CROP4D_CHECK(results.size() == sites.size() * sessions.size());
  std::vector<SiteGrowth> growth;
  if (sessions.empty()) return growth;
  const Timestamp day0 = sessions.front().date;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    std::vector<GrowthObservation> obs;
    for (std::size_t k = 0; k < sessions.size(); ++k) {
      if (!sessions[k].trusted) continue;
      obs.push_back({DurationSeconds(day0, sessions[k].date) / 86400.0,
                     results[i * sessions.size() + k].ours.height_m});
    }
    growth.push_back({sites[i].id, FitGrowth(obs, options)});
  }
  return growth;
}

}  // namespace crop4d::analysis
