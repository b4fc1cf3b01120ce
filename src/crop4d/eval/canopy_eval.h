#pragma once

// Evaluation of canopy heights per site and session (DESIGN.md §2 step 6, §8) against the
// field's ground truth. Files read:
//
//   WS/analysis/site_heights.csv               our method (crop4d analyze)
//   WS/analysis/site_heights_single_plane.csv  the paper's single ground plane (Dong et al.
//                                              2017), optional
//       site_id,session,date,height_m,cover,volume_m3,n_points
//       (date YYYY-MM-DD; an empty height_m: no estimate for that site and session)
//   FIELD/ground_truth/site_truth.csv          the true canopy height
//       site_id,session,date,height_m
//
// The estimates are read with the workspace's reader (workspace/analysis_tables.h); the truth's
// columns are found by their name in the header line (the first line; a leading '#' is
// allowed), other columns ignored. Estimates and truth are joined on (site_id, session).
// error = estimate - truth. A truth row without an estimate row, or with an empty (or "nan")
// estimate height, is missing. Malformed files throw InputError naming the file and line.

#include <cmath>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/eval/plant_eval.h"
#include "crop4d/eval/site_bootstrap.h"
#include "crop4d/workspace/analysis_tables.h"

namespace crop4d::eval {

// One row of site_heights.csv or site_truth.csv (the truth without cover, volume and count).
using SiteHeight = workspace::SiteHeight;

// Reads WS/analysis/site_heights*.csv: the analyze stage's table, schema-checked
// (workspace/analysis_tables.h).
using workspace::ReadSiteHeights;

// Reads FIELD/ground_truth/site_truth.csv: required columns site_id, session, height_m;
// optional date. A row with an empty height_m is skipped (not measured). Throws InputError (file
// and line) for a missing file or column, a row with the wrong number of fields, an empty site_id
// or session, a date not YYYY-MM-DD, a height that is not a finite number, and a repeated
// (site_id, session).
std::vector<SiteHeight> ReadSiteTruth(const std::string& path);

struct CanopyEvalOptions {
  // A pair whose |error| exceeds this is a failure (as is a missing estimate), m.
  double max_error_m = 0.04;
  // Evaluate only these sessions (empty: all).
  std::vector<std::string> sessions;

  OptionCheck Check() const;
};

// One truth row and its estimate.
struct CanopyPair {
  std::string site_id, session, date;  // date from the truth (else the estimate)
  double truth_m = 0.0;
  double estimate_m = std::numeric_limits<double>::quiet_NaN();  // NaN: missing
  double error_m = std::numeric_limits<double>::quiet_NaN();     // estimate - truth
  std::int64_t n_points = -1;                                    // of the estimate

  bool missing() const { return std::isnan(estimate_m); }
};

// Error statistics over the pairs with an estimate; NaN when there is none.
struct CanopyErrorStats {
  int num_truth = 0;    // truth rows (pairs + missing)
  int num_pairs = 0;    // with an estimate
  int num_missing = 0;  // without an estimate
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  double bias_m = std::numeric_limits<double>::quiet_NaN();  // mean of estimate - truth
  double mae_m = std::numeric_limits<double>::quiet_NaN();   // mean |estimate - truth|
  double max_abs_error_m = std::numeric_limits<double>::quiet_NaN();
  int num_failures = 0;  // |error| > max_error_m, plus the missing
};

struct CanopySessionEval {
  std::string session, date;
  CanopyErrorStats stats;
};

// One method (one estimate file) against the truth.
struct CanopyMethodEval {
  std::string method;  // "ours", "single_plane"
  std::string file;    // the estimate file (relative to the workspace in a workspace eval)
  // Why the method could not be evaluated (a malformed file); the rest is empty then.
  std::string error;
  std::vector<CanopyPair> pairs;  // every truth row, by session then site (natural order)
  CanopyErrorStats overall;
  // The 95 % interval of overall.rmse_m over the sites (site_bootstrap.h): how far the RMSE
  // would move on another draw of as many sites.
  BootstrapInterval rmse_interval;
  // The pair with the largest |error| (index into pairs); -1 when no pair has an estimate.
  int worst = -1;
  // Indices into pairs of the failures (|error| > max_error_m, or missing), in pair order.
  std::vector<int> failures;
  std::vector<CanopySessionEval> sessions;  // by session (natural order)
  int num_without_truth = 0;  // estimate rows (selected sessions) with no truth row: ignored

  bool ok() const { return error.empty(); }
};

// The pairs' errors, for the bootstrap (site_bootstrap.h).
std::vector<SiteError> SiteErrors(const std::vector<CanopyPair>& pairs);

// Joins `estimates` with `truth` on (site_id, session) and computes the statistics.
CanopyMethodEval EvaluateCanopyHeights(const std::vector<SiteHeight>& estimates,
                                       const std::vector<SiteHeight>& truth,
                                       const CanopyEvalOptions& options = {});

// The canopy section of a workspace evaluation.
struct CanopyEval {
  std::string truth_file;  // relative to the field: ground_truth/site_truth.csv
  CanopyEvalOptions options;
  std::vector<CanopyMethodEval> methods;  // "ours", then "single_plane" when its file exists
  // The plants of the sites (WS/analysis/site_plants.csv, plant_eval.h; tops judged by
  // options.max_error_m), when the file and the true plants are there...
  std::optional<PlantEval> plants;
  // ...else why not (one line).
  std::string plants_skipped;
};

// Evaluates WS/analysis/site_heights.csv ("ours") and, when it exists,
// WS/analysis/site_heights_single_plane.csv ("single_plane") against
// FIELD/ground_truth/site_truth.csv. Returns false with `why` set (one line) when
// site_heights.csv or the truth file does not exist: the section is skipped. A malformed
// estimate file is that method's error; a malformed truth file is every method's error. The
// plants of the sites are evaluated too (EvaluateSitePlants); a malformed file skips them with
// the error in plants_skipped.
bool EvaluateWorkspaceCanopy(const std::string& workspace, const std::string& field,
                             const CanopyEvalOptions& options, CanopyEval* eval, std::string* why);

// A table for people: per method pairs, missing, RMSE, bias, MAE, worst pair and the failure
// count; the failures (up to `max_listed` per method); then one line per session and method
// (n, missing, RMSE, bias, max |error|); then the plants of the sites (FormatPlantTable).
std::string FormatCanopyTable(const CanopyEval& eval, int max_listed = 10);

}  // namespace crop4d::eval
