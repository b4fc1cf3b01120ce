#include "crop4d/analysis/growth.h"

#include <ceres/ceres.h>
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <memory>

#include "crop4d/core/error.h"

namespace crop4d::analysis {
namespace {

// The logistic function 1 / (1 + exp(-z)) without overflow for large |z| (for Jets too: both
// branches are the same function).
template <typename T>
T Sigmoid(const T& z) {
  using std::exp;
  if (z >= T(0.0)) return T(1.0) / (T(1.0) + exp(-z));
  const T e = exp(z);
  return e / (T(1.0) + e);
}

// One observation (t, h) of the logistic curve, parameters x = (log K, log r, t0):
//
//   residual = h - K sigmoid(r (t - t0)),  K = exp(x0), r = exp(x1), t0 = x2.
//
// The logarithms keep K and r positive without constraints; all observations weigh the same
// (the height noise of a site does not depend on the height), the robust loss is set on the
// residual block.
struct LogisticResidual {
  LogisticResidual(double day, double height_m) : day(day), height_m(height_m) {}

  template <typename T>
  bool operator()(const T* const x, T* residual) const {
    using std::exp;
    const T k = exp(x[0]);
    const T r = exp(x[1]);
    residual[0] = T(height_m) - k * Sigmoid(r * (T(day) - x[2]));
    return true;
  }

  static ceres::CostFunction* Create(double day, double height_m) {
    return new ceres::AutoDiffCostFunction<LogisticResidual, 1, 3>(
        new LogisticResidual(day, height_m));
  }

  double day, height_m;
};

// Least-squares slope of height over day, m/day.
double Slope(const std::vector<GrowthObservation>& points) {
  double mt = 0.0, mh = 0.0;
  for (const GrowthObservation& p : points) {
    mt += p.day;
    mh += p.height_m;
  }
  mt /= points.size();
  mh /= points.size();
  double stt = 0.0, sth = 0.0;
  for (const GrowthObservation& p : points) {
    stt += (p.day - mt) * (p.day - mt);
    sth += (p.day - mt) * (p.height_m - mh);
  }
  return stt > 0.0 ? sth / stt : 0.0;
}

// Start (K, r, t0) for a given K: t0 where the (day-sorted) heights first cross K/2, r from the
// slope there (the logistic's slope at t0 is r K / 4).
std::array<double, 3> Start(const std::vector<GrowthObservation>& points, double k,
                            double overall_slope) {
  const double half = 0.5 * k;
  double t0 = std::numeric_limits<double>::quiet_NaN(), slope = overall_slope;
  if (points.front().height_m >= half) {
    t0 = points.front().day;
  } else {
    for (std::size_t i = 0; i + 1 < points.size(); ++i) {
      const GrowthObservation& a = points[i];
      const GrowthObservation& b = points[i + 1];
      if (a.height_m < half && b.height_m >= half && b.day > a.day) {
        t0 = a.day + (half - a.height_m) / (b.height_m - a.height_m) * (b.day - a.day);
        slope = (b.height_m - a.height_m) / (b.day - a.day);
        break;
      }
    }
  }
  if (std::isnan(t0)) {  // never reaches K/2: extrapolate the overall slope
    const GrowthObservation& last = points.back();
    t0 = last.day + (half - last.height_m) / overall_slope;
  }
  return {k, 4.0 * std::max(slope, overall_slope) / k, t0};
}

}  // namespace

double LogisticCurve::Evaluate(double day) const {
  return asymptote_m * Sigmoid(rate_per_day * (day - midpoint_day));
}

double LogisticCurve::GrowthRate(double day) const {
  const double s = Sigmoid(rate_per_day * (day - midpoint_day));
  return rate_per_day * asymptote_m * s * (1.0 - s);
}

double LogisticCurve::MaxGrowthRate() const { return 0.25 * rate_per_day * asymptote_m; }

bool LogisticCurve::valid() const {
  return std::isfinite(asymptote_m) && std::isfinite(rate_per_day) && std::isfinite(midpoint_day) &&
         asymptote_m > 0.0 && rate_per_day > 0.0;
}

const char* GrowthStatusName(GrowthFit::Status status) {
  switch (status) {
    case GrowthFit::Status::kFitted:
      return "fitted";
    case GrowthFit::Status::kTooFewPoints:
      return "too_few_points";
    case GrowthFit::Status::kNotConverged:
      return "not_converged";
    case GrowthFit::Status::kNotGrowing:
      return "not_growing";
  }
  return "?";
}

OptionCheck GrowthOptions::Check() const {
  OptionChecker c;
  c.Finite("robust_loss_m", robust_loss_m)
      .AtLeast("robust_loss_m", robust_loss_m, 0.0)
      .AtLeast("max_iterations", max_iterations, 1)
      .Finite("max_asymptote_factor", max_asymptote_factor)
      .AtLeast("max_asymptote_factor", max_asymptote_factor, 1.0)
      .Finite("max_rate_per_day", max_rate_per_day)
      .Greater("max_rate_per_day", max_rate_per_day, 0.0);
  return c.Result();
}

namespace {

// The valid observations sorted by day (stable), the intervals between consecutive distinct
// days into fit->intervals; returns the number of distinct days.
int SortedObservations(const std::vector<GrowthObservation>& observations,
                       std::vector<GrowthObservation>* points, GrowthFit* fit) {
  for (const GrowthObservation& o : observations) {
    if (std::isfinite(o.day) && std::isfinite(o.height_m)) points->push_back(o);
  }
  std::stable_sort(
      points->begin(), points->end(),
      [](const GrowthObservation& a, const GrowthObservation& b) { return a.day < b.day; });
  int distinct_days = 0;
  for (std::size_t i = 0; i < points->size(); ++i) {
    if (i == 0 || (*points)[i].day > (*points)[i - 1].day) ++distinct_days;
    if (i > 0 && (*points)[i].day > (*points)[i - 1].day) {
      const GrowthObservation& a = (*points)[i - 1];
      const GrowthObservation& b = (*points)[i];
      fit->intervals.push_back(
          {a.day, b.day, a.height_m, b.height_m, (b.height_m - a.height_m) / (b.day - a.day)});
    }
  }
  return distinct_days;
}

// The best logistic fit in (log K, log r, t0) within [lower, upper] over three starts (K at
// 1.2, 2 and 3 times the highest observation): a converged one first, then the lowest cost.
// False when every start failed.
bool BestLogisticFit(const std::vector<GrowthObservation>& points, double max_height, double slope,
                     const GrowthOptions& options, const double lower[3], const double upper[3],
                     std::array<double, 3>* best, ceres::Solver::Summary* best_summary) {
  // Starts inside the bounds (a margin keeps the solver off them at the start).
  const auto inside = [&](int i, double value) {
    const double margin = 1e-3 * (upper[i] - lower[i]);
    return std::clamp(value, lower[i] + margin, upper[i] - margin);
  };
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::DENSE_QR;
  solver_options.max_num_iterations = options.max_iterations;
  solver_options.function_tolerance = 1e-12;
  solver_options.gradient_tolerance = 1e-14;
  solver_options.parameter_tolerance = 1e-12;
  solver_options.logging_type = ceres::SILENT;
  solver_options.minimizer_progress_to_stdout = false;
  solver_options.num_threads = 1;

  bool have_best = false;
  double best_cost = std::numeric_limits<double>::infinity();
  for (const double factor : {1.2, 2.0, 3.0}) {
    const double k0 = std::min(factor, options.max_asymptote_factor) * max_height;
    const std::array<double, 3> start = Start(points, k0, slope);
    double x[3] = {inside(0, std::log(start[0])), inside(1, std::log(std::max(start[1], 1e-300))),
                   inside(2, start[2])};
    ceres::Problem problem;
    for (const GrowthObservation& p : points) {
      ceres::LossFunction* loss =
          options.robust_loss_m > 0.0 ? new ceres::CauchyLoss(options.robust_loss_m) : nullptr;
      problem.AddResidualBlock(LogisticResidual::Create(p.day, p.height_m), loss, x);
    }
    for (int i = 0; i < 3; ++i) {
      problem.SetParameterLowerBound(x, i, lower[i]);
      problem.SetParameterUpperBound(x, i, upper[i]);
    }
    ceres::Solver::Summary summary;
    ceres::Solve(solver_options, &problem, &summary);
    const bool finite = std::isfinite(x[0]) && std::isfinite(x[1]) && std::isfinite(x[2]) &&
                        std::isfinite(summary.final_cost);
    if (!finite || summary.termination_type == ceres::FAILURE) continue;
    const bool converged = summary.termination_type == ceres::CONVERGENCE;
    const bool best_converged = have_best && best_summary->termination_type == ceres::CONVERGENCE;
    if (!have_best || (converged && !best_converged) ||
        (converged == best_converged && summary.final_cost < best_cost)) {
      have_best = true;
      best_cost = summary.final_cost;
      *best = {x[0], x[1], x[2]};
      *best_summary = summary;
    }
  }
  return have_best;
}

}  // namespace

GrowthFit FitGrowth(std::vector<GrowthObservation> observations, const GrowthOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "FitGrowth");
  GrowthFit fit;

  // Valid observations, by day.
  std::vector<GrowthObservation> points;
  const int distinct_days = SortedObservations(observations, &points, &fit);
  fit.num_points = static_cast<int>(points.size());
  if (distinct_days < 3) {
    fit.status = GrowthFit::Status::kTooFewPoints;
    fit.message = fmt::format(
        "{} valid observation{} on {} distinct day{}: a logistic curve needs 3 days or more",
        points.size(), points.size() == 1 ? "" : "s", distinct_days, distinct_days == 1 ? "" : "s");
    return fit;
  }

  // Days relative to the first one, for conditioning.
  const double origin = points.front().day;
  for (GrowthObservation& p : points) p.day -= origin;
  double max_height = 0.0;
  for (const GrowthObservation& p : points) max_height = std::max(max_height, p.height_m);
  const double slope = Slope(points);
  if (!(max_height > 0.0) || !(slope > 0.0)) {
    fit.status = GrowthFit::Status::kNotGrowing;
    fit.message = max_height > 0.0 ? fmt::format(
                                         "the heights do not increase (least-squares slope {:.4f} "
                                         "m/day): no growth curve",
                                         slope)
                                   : std::string("no height above 0: no growth curve");
    return fit;
  }

  // Bounds (in the parameters: log K, log r, t0). t0 within two spans of the observations.
  const double span = std::max(points.back().day, 1e-6);
  const double lower[3] = {std::log(0.5 * max_height), std::log(1e-6), -2.0 * span};
  const double upper[3] = {std::log(options.max_asymptote_factor * max_height),
                           std::log(options.max_rate_per_day), 3.0 * span};
  std::array<double, 3> best{};
  ceres::Solver::Summary best_summary;
  if (!BestLogisticFit(points, max_height, slope, options, lower, upper, &best, &best_summary)) {
    fit.status = GrowthFit::Status::kNotConverged;
    fit.message = fmt::format("the solver failed on {} observations", points.size());
    return fit;
  }

  fit.curve.asymptote_m = std::exp(best[0]);
  fit.curve.rate_per_day = std::exp(best[1]);
  fit.curve.midpoint_day = best[2] + origin;
  fit.iterations = static_cast<int>(best_summary.iterations.size());
  double sum_sq = 0.0;
  for (const GrowthObservation& p : points) {
    const double e = p.height_m - fit.curve.Evaluate(p.day + origin);
    sum_sq += e * e;
  }
  fit.rmse_m = std::sqrt(sum_sq / points.size());
  fit.asymptote_at_bound = best[0] >= upper[0] - 1e-6;
  const bool converged = best_summary.termination_type == ceres::CONVERGENCE;
  fit.status = converged ? GrowthFit::Status::kFitted : GrowthFit::Status::kNotConverged;
  fit.message = fmt::format(
      "{}{} points: K {:.3f} m{}, r {:.4f} /day, t0 day {:.1f}, max rate {:.2f} cm/day, rmse "
      "{:.2f} cm",
      converged ? "fitted "
                : "not converged after " + std::to_string(fit.iterations) + " iterations, ",
      points.size(), fit.curve.asymptote_m,
      fit.asymptote_at_bound ? " (at its bound: no plateau in the data)" : "",
      fit.curve.rate_per_day, fit.curve.midpoint_day, 100.0 * fit.curve.MaxGrowthRate(),
      100.0 * fit.rmse_m);
  return fit;
}

}  // namespace crop4d::analysis
