#pragma once

// Growth curves (DESIGN.md §2.6): the canopy height of one site over the season, fitted with a
// logistic curve
//
//   h(t) = K / (1 + exp(-r (t - t0)))
//
// (K the asymptotic height, m; r the relative growth rate, 1/day; t0 the day of fastest
// growth, where h = K/2 and dh/dt = r K / 4), the classic model of determinate plant growth
// (Verhulst 1838; e.g. Paine et al., "How to fit nonlinear plant growth models and calculate
// growth rates", Methods Ecol. Evol. 3(2), 2012). Fitted by robust non-linear least squares
// with Ceres; the growth rate per interval between consecutive observations is reported too.

#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::analysis {

struct GrowthObservation {
  double day = 0.0;                                            // time, days (any origin)
  double height_m = std::numeric_limits<double>::quiet_NaN();  // NaN: missing (skipped)
};

struct LogisticCurve {
  double asymptote_m = std::numeric_limits<double>::quiet_NaN();   // K, m
  double rate_per_day = std::numeric_limits<double>::quiet_NaN();  // r, 1/day
  double midpoint_day = std::numeric_limits<double>::quiet_NaN();  // t0, day (same origin)

  // h(day), m (NaN when the curve is not set).
  double Evaluate(double day) const;
  // dh/dt(day), m/day.
  double GrowthRate(double day) const;
  // The largest growth rate, r K / 4 at t0, m/day.
  double MaxGrowthRate() const;
  bool valid() const;
};

// Growth between two consecutive valid observations.
struct GrowthInterval {
  double day_from = 0.0, day_to = 0.0;
  double height_from_m = 0.0, height_to_m = 0.0;
  double rate_m_per_day = 0.0;  // (height_to - height_from) / (day_to - day_from)
};

struct GrowthFit {
  enum class Status {
    kFitted,        // `curve` holds the fit
    kTooFewPoints,  // fewer than 3 valid observations on distinct days: no curve
    kNotConverged,  // the solver failed or hit max_iterations; `curve` is its last iterate
    kNotGrowing,    // the heights do not increase over the season (least-squares slope <= 0,
                    // or no height above 0): no curve
  };
  Status status = Status::kTooFewPoints;
  std::string message;  // for people: what was fitted, or why not
  LogisticCurve curve;
  // RMS of h_i - curve(t_i) over the valid observations (plain, not robust), m; NaN without
  // a curve.
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  int num_points = 0;  // valid observations (finite day and height)
  // The asymptote ended on its bound (GrowthOptions::max_asymptote_factor x the largest
  // height): the data do not show the plateau, K (and the curve beyond the last observation)
  // is not determined by them.
  bool asymptote_at_bound = false;
  int iterations = 0;  // solver iterations (of the best start)
  // Between consecutive valid observations sorted by day (pairs on the same day skipped);
  // reported whatever the status.
  std::vector<GrowthInterval> intervals;

  bool ok() const { return status == Status::kFitted; }
};

// "fitted", "too_few_points", "not_converged", "not_growing".
const char* GrowthStatusName(GrowthFit::Status status);

struct GrowthOptions {
  // Scale of the Cauchy loss on the height residuals, m: residuals well above it (outliers,
  // a mis-registered session) lose their pull. 0: plain least squares.
  double robust_loss_m = 0.02;
  // Solver iterations per start (Levenberg-Marquardt).
  int max_iterations = 200;
  // Upper bound of the asymptote K, as a multiple of the largest observed height. Before the
  // plateau (e.g. 4 sessions of a growing crop) K is poorly determined and least squares may
  // run it to infinity, the curve turning exponential; 3x bounds the extrapolation to a
  // plausible crop height while leaving a curve with its inflection past the last observation
  // free to interpolate the data. (K is bounded below by half the largest height.)
  double max_asymptote_factor = 3.0;
  // Upper bound of r, 1/day: 2/day goes from 12% to 88% of K in two days, a step at any
  // realistic sampling; it keeps a step-like series finite.
  double max_rate_per_day = 2.0;

  OptionCheck Check() const;
};

// Fits the logistic curve to the valid observations (finite day and height; any order) and
// lists the intervals. Initialisation from the data: K = 1.2 x the largest height, t0 where
// the heights cross K/2 (linear interpolation), r = 4 x the slope there / K; two more starts
// at K = 2x and 3x the largest height (each clamped to the bounds); the start with the lowest
// robust cost wins. Expected failures are statuses, not exceptions. Options must pass Check()
// (CHECK).
GrowthFit FitGrowth(std::vector<GrowthObservation> observations, const GrowthOptions& options = {});

}  // namespace crop4d::analysis
