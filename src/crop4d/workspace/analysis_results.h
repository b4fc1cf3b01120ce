#pragma once

// The analyze stage's results (analysis/site_series.h) as the rows of its tables
// (analysis_tables.h), and back: the one place that maps one onto the other.

#include <string>
#include <vector>

#include "crop4d/analysis/site_series.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

// site_heights.csv (`ours`) or site_heights_single_plane.csv: one row per result.
std::vector<SiteHeight> SiteHeightRows(const std::vector<analysis::SiteResult>& results, bool ours);

// site_plants.csv: one row per plant and session, in the order of `results` (site-major); no
// top where the plant was not seen (or, with another canopy top than plant tops, not measured).
std::vector<SitePlantRow> SitePlantRows(const std::vector<analysis::SiteResult>& results);

// growth.csv: the fits, and per consecutive pair of `sessions` (date order) the interval's rate
// when both ends have a height; days counted from the first session.
GrowthTable GrowthRows(const std::vector<analysis::SiteGrowth>& growth,
                       const std::vector<analysis::SeasonSession>& sessions);

// The results of an earlier run read back from site_heights.csv and
// site_heights_single_plane.csv (the heights, cover, volume and counts; no stems or tops), in
// the order of site_heights.csv. Throws InputError as the readers do.
std::vector<analysis::SiteResult> ReadSiteResults(const Layout& ws);

}  // namespace crop4d::workspace
