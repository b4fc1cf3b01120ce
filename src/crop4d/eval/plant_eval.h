#pragma once

// Evaluation of the plants that `crop4d analyze` found at each site, against a synthetic field's
// plants. Files read:
//
//   WS/analysis/site_plants.csv                the plants of each site and their tops
//       site_id,plant,x_m,y_m,session,date,top_m
//       (x_m, y_m: the stem, field ENU metres; an empty top_m: not seen in that session)
//   FIELD/field.yaml                           the sites (centre and radius)
//   FIELD/ground_truth/<session>/plants.csv    the true stems and heights per session
//
// A true plant belongs to a site when its stem lies within the site's radius and it has emerged
// (height > 0) in the latest session evaluated. Found plants are matched one to one with the true
// plants of their site, nearest pairs first, within max_stem_offset_m. Then, for every matched
// plant and session with a top and a true height: top error = top − true height.

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/workspace/analysis_tables.h"

namespace crop4d::eval {

// One row of WS/analysis/site_plants.csv and its reader: the analyze stage's table,
// schema-checked (workspace/analysis_tables.h).
using SitePlantRow = workspace::SitePlantRow;
using workspace::ReadSitePlants;

struct PlantEvalOptions {
  // A found plant matches a true one within this distance of its stem, m.
  double max_stem_offset_m = 0.06;
  // A plant's top is a failure when its |error| exceeds this, m.
  double max_top_error_m = 0.04;
  // Evaluate only these sessions (empty: all).
  std::vector<std::string> sessions;

  OptionCheck Check() const;
};

// One site's true and found plants.
struct SitePlantCounts {
  std::string site_id;
  int num_true = 0;     // true plants in the site
  int num_found = 0;    // plants the analysis found there
  int num_matched = 0;  // one-to-one within max_stem_offset_m
};

struct PlantEval {
  std::string file;           // relative to the workspace: analysis/site_plants.csv
  std::string truth_session;  // whose plants.csv decides which plants exist
  PlantEvalOptions options;
  std::vector<SitePlantCounts> sites;  // sites of field.yaml with rows in site_plants.csv
  int num_true = 0, num_found = 0, num_matched = 0;
  int num_sites_unknown = 0;  // site ids of site_plants.csv that field.yaml does not define
  double recall = std::numeric_limits<double>::quiet_NaN();                // matched / true
  double precision = std::numeric_limits<double>::quiet_NaN();             // matched / found
  double median_stem_offset_m = std::numeric_limits<double>::quiet_NaN();  // of the matched
  // Tops of the matched plants over every session with a top and a true height.
  int num_tops = 0;
  double top_rmse_m = std::numeric_limits<double>::quiet_NaN();
  double top_bias_m = std::numeric_limits<double>::quiet_NaN();
  int num_top_failures = 0;  // |error| > max_top_error_m
};

// Evaluates WS/analysis/site_plants.csv against the field. Returns false with `why` (one line)
// when the file, field.yaml's sites or the true plants are not there: the part is skipped.
// Throws InputError for malformed files.
bool EvaluateSitePlants(const std::string& workspace, const std::string& field,
                        const PlantEvalOptions& options, PlantEval* eval, std::string* why);

// Two lines for people: plants found and matched, and the tops' errors.
std::string FormatPlantTable(const PlantEval& eval);

}  // namespace crop4d::eval
