#pragma once

// How much a canopy height RMSE can be trusted: bootstrap intervals over the sites of a field.
//
// A field has few measurement sites (the demo: 12 sites × 4 sessions), and a site's error comes
// mostly from a handful of plant tops, so the RMSE of one run moves a lot with which sites happen
// to be measured. These intervals say how far: the sites are drawn with replacement, each with all
// of its sessions (a site's errors through the season share its stems and its ground, so they are
// not independent draws), and the statistic is computed again on every draw (the percentile
// bootstrap, Efron & Tibshirani 1993, ch. 13). A fixed seed makes every interval reproducible.
//
//   SiteRmseInterval   the RMSE of one run: two runs whose RMSEs both lie inside each other's
//                      interval are not told apart by this field;
//   PairedRmseRatio    RMSE(b) / RMSE(a) of two runs on the same field, the same sites drawn for
//                      both: the site-to-site spread that both runs share cancels, so this is the
//                      test of "did the change cost accuracy?".

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::eval {

// One site in one session: estimate - truth, m (NaN: no estimate, not counted).
struct SiteError {
  std::string site_id;
  std::string session;
  double error_m = std::numeric_limits<double>::quiet_NaN();
};

struct SiteBootstrapOptions {
  // Two-sided level of the interval.
  double level = 0.95;
  // Draws of the sites.
  int resamples = 2000;
  std::uint64_t seed = 1;

  OptionCheck Check() const;
};

struct BootstrapInterval {
  double low = std::numeric_limits<double>::quiet_NaN();
  double high = std::numeric_limits<double>::quiet_NaN();
  double level = 0.0;  // two-sided, of the options that drew it
  int num_sites = 0;   // sites with at least one pair counted
  int resamples = 0;   // 0: no interval (fewer than two sites)

  bool valid() const { return resamples > 0; }
};

// The interval of the RMSE of `errors` (those with an estimate), m.
BootstrapInterval SiteRmseInterval(const std::vector<SiteError>& errors,
                                   const SiteBootstrapOptions& options = {});

struct RmseRatio {
  double rmse_a_m = std::numeric_limits<double>::quiet_NaN();
  double rmse_b_m = std::numeric_limits<double>::quiet_NaN();
  double ratio = std::numeric_limits<double>::quiet_NaN();  // rmse_b_m / rmse_a_m
  int num_pairs = 0;           // (site, session) with an estimate in both runs
  BootstrapInterval interval;  // of the ratio
};

// Compares two runs' pairs on the (site, session) that have an estimate in both.
RmseRatio PairedRmseRatio(const std::vector<SiteError>& a, const std::vector<SiteError>& b,
                          const SiteBootstrapOptions& options = {});

}  // namespace crop4d::eval
