#include "crop4d/slam/row_passes.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>
#include <numeric>
#include <stdexcept>

#include "crop4d/core/error.h"

namespace crop4d::slam {
namespace {

// One fix in seconds since the first fix, horizontal only.
struct Fix {
  double t = 0.0;
  Eigen::Vector2d p = Eigen::Vector2d::Zero();
};

// A straight stretch of fixes [first, last] in one direction, and what the passes need of it.
struct Stretch {
  int first = 0, last = 0;
  int direction = 0;
  double t_begin = 0.0, t_end = 0.0;  // s since the first fix
  double lateral = 0.0;               // mean lateral coordinate, m
  int row = -1;
};

double Median(std::vector<double> values) {
  if (values.empty()) return 0.0;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  return values[mid];
}

// White-noise std-dev per horizontal axis from second differences of evenly spaced fixes:
// for x_k = smooth + n_k, x_{k+1} − 2 x_k + x_{k−1} has variance 6σ² (the smooth part is
// negligible on straight stretches at 5 Hz); MAD for robustness against turns and outliers.
double EstimateNoise(const std::vector<Fix>& fixes, double median_dt) {
  std::vector<double> abs_second_differences;
  for (size_t k = 1; k + 1 < fixes.size(); ++k) {
    const double dt0 = fixes[k].t - fixes[k - 1].t, dt1 = fixes[k + 1].t - fixes[k].t;
    if (std::abs(dt1 - dt0) > 0.1 * median_dt || dt0 > 1.5 * median_dt) continue;
    const Eigen::Vector2d e = fixes[k + 1].p - 2.0 * fixes[k].p + fixes[k - 1].p;
    abs_second_differences.push_back(std::abs(e.x()));
    abs_second_differences.push_back(std::abs(e.y()));
  }
  return 1.4826 * Median(std::move(abs_second_differences)) / std::sqrt(6.0);
}

// Velocity and fitted position of every fix from a least-squares line p(t) = a + v t over the
// fixes within ±window/2 (at least 3 spanning half the window, else invalid).
void FitVelocities(const std::vector<Fix>& fixes, double window, std::vector<Eigen::Vector2d>* v,
                   std::vector<Eigen::Vector2d>* p_fit, std::vector<bool>* valid) {
  const int n = static_cast<int>(fixes.size());
  v->assign(n, Eigen::Vector2d::Zero());
  p_fit->resize(n);
  valid->assign(n, false);
  int lo = 0, hi = 0;  // window [lo, hi)
  for (int i = 0; i < n; ++i) {
    (*p_fit)[i] = fixes[i].p;
    while (fixes[lo].t < fixes[i].t - 0.5 * window) ++lo;
    while (hi < n && fixes[hi].t <= fixes[i].t + 0.5 * window) ++hi;
    const int m = hi - lo;
    if (m < 3 || fixes[hi - 1].t - fixes[lo].t < 0.5 * window) continue;
    double t_mean = 0.0;
    Eigen::Vector2d p_mean = Eigen::Vector2d::Zero();
    for (int j = lo; j < hi; ++j) {
      t_mean += fixes[j].t;
      p_mean += fixes[j].p;
    }
    t_mean /= m;
    p_mean /= m;
    double stt = 0.0;
    Eigen::Vector2d stp = Eigen::Vector2d::Zero();
    for (int j = lo; j < hi; ++j) {
      const double dt = fixes[j].t - t_mean;
      stt += dt * dt;
      stp += dt * (fixes[j].p - p_mean);
    }
    (*v)[i] = stp / stt;
    (*p_fit)[i] = p_mean + (*v)[i] * (fixes[i].t - t_mean);
    (*valid)[i] = true;
  }
}

// Axis (angle mod π) of the dominant course: speed-weighted histogram of doubled angles, 1°
// bins smoothed over ±5°, peak refined by the circular mean of the doubled angles within
// ±2·tolerance of it (axial data, Mardia & Jupp 2000, §9.3.2). NaN when no fix moves.
double DominantAxis(const std::vector<Eigen::Vector2d>& v, const std::vector<bool>& valid,
                    double min_speed, double tolerance) {
  constexpr int kBins = 360;
  std::vector<double> histogram(kBins, 0.0);
  std::vector<std::pair<double, double>> doubled;  // (2θ, weight)
  for (size_t i = 0; i < v.size(); ++i) {
    const double speed = v[i].norm();
    if (!valid[i] || speed < min_speed) continue;
    double a2 = std::fmod(2.0 * std::atan2(v[i].y(), v[i].x()) + 4.0 * M_PI, 2.0 * M_PI);
    doubled.emplace_back(a2, speed);
    histogram[std::min(kBins - 1, static_cast<int>(a2 / (2.0 * M_PI) * kBins))] += speed;
  }
  if (doubled.empty()) return std::numeric_limits<double>::quiet_NaN();
  int best = 0;
  double best_value = -1.0;
  for (int b = 0; b < kBins; ++b) {
    double sum = 0.0;
    for (int d = -5; d <= 5; ++d) sum += histogram[(b + d + kBins) % kBins];
    if (sum > best_value) {
      best_value = sum;
      best = b;
    }
  }
  const double peak = (best + 0.5) * 2.0 * M_PI / kBins;
  double c = 0.0, s = 0.0;
  for (const auto& [a2, w] : doubled) {
    if (std::abs(std::remainder(a2 - peak, 2.0 * M_PI)) > 2.0 * tolerance) continue;
    c += w * std::cos(a2);
    s += w * std::sin(a2);
  }
  return 0.5 * std::atan2(s, c);
}

// Change point t₀ of the lateral offset at the end (or, mirrored, the start) of a straight
// stretch (file comment in the header, step 4): least squares of
//   l(t) = c₀ + c₁ s + c₂ s² + b₁ h + b₂ h² + b₃ h³,  s = ±(t − t₀), h = max(0, s),
// over the fixes in [t_lo − before, t_hi + after] (mirrored for a start), minimised over t₀ in
// [t_lo, t_hi]. NaN when no candidate has enough fixes on both sides.
double ChangePoint(const std::vector<Fix>& fixes, const Eigen::Vector2d& lateral_axis, double t_lo,
                   double t_hi, bool at_end) {
  constexpr double kStraightSide = 3.0, kTurnSide = 1.0, kStep = 0.05;
  const double w_lo = at_end ? t_lo - kStraightSide : t_lo - kTurnSide;
  const double w_hi = at_end ? t_hi + kTurnSide : t_hi + kStraightSide;
  std::vector<double> ts, ls;
  for (const Fix& f : fixes) {
    if (f.t < w_lo || f.t > w_hi) continue;
    ts.push_back(f.t);
    ls.push_back(lateral_axis.dot(f.p));
  }
  const int m = static_cast<int>(ts.size());
  if (m < 10) return std::numeric_limits<double>::quiet_NaN();
  const double l_mean = std::accumulate(ls.begin(), ls.end(), 0.0) / m;
  const Eigen::VectorXd y = Eigen::Map<const Eigen::VectorXd>(ls.data(), m).array() - l_mean;
  double best_t0 = std::numeric_limits<double>::quiet_NaN(), best_sse = 0.0;
  for (double t0 = t_lo; t0 <= t_hi + 1e-9; t0 += kStep) {
    Eigen::MatrixXd a(m, 6);
    int straight = 0, turn = 0;
    for (int j = 0; j < m; ++j) {
      const double s = at_end ? ts[j] - t0 : t0 - ts[j];
      const double h = std::max(0.0, s);
      (h > 0.0 ? turn : straight)++;
      a.row(j) << 1.0, s, s * s, h, h * h, h * h * h;
    }
    if (straight < 6 || turn < 4) continue;
    const Eigen::VectorXd x = a.colPivHouseholderQr().solve(y);
    const double sse = (a * x - y).squaredNorm();
    if (std::isnan(best_t0) || sse < best_sse) {
      best_sse = sse;
      best_t0 = t0;
    }
  }
  return best_t0;
}

Eigen::Vector2d InterpolatePosition(const std::vector<Fix>& fixes, double t) {
  const auto it = std::lower_bound(fixes.begin(), fixes.end(), t,
                                   [](const Fix& f, double value) { return f.t < value; });
  if (it == fixes.begin()) return fixes.front().p;
  if (it == fixes.end()) return fixes.back().p;
  const Fix& b = *it;
  const Fix& a = *(it - 1);
  const double f = (t - a.t) / (b.t - a.t);
  return a.p + f * (b.p - a.p);
}

// Whether passes found without declared rows are a field's rows: most consecutive passes lie
// on neighbouring rows (at most max_row_step apart across the axis) and overlap along it by at
// least half the shorter one, as in a boustrophedon drive over one block of rows. Straight roads
// of a drive also run along one axis, but they follow each other far apart or end to end.
bool LooksLikeRows(const std::vector<RowPass>& passes, const Eigen::Vector2d& axis,
                   const RowPassSegmenter::Options& o) {
  if (static_cast<int>(passes.size()) < o.min_row_passes) return false;
  int neighbours = 0;
  for (size_t k = 1; k < passes.size(); ++k) {
    const RowPass& a = passes[k - 1];
    const RowPass& b = passes[k];
    const double a0 = axis.dot(a.start_world), a1 = axis.dot(a.end_world);
    const double b0 = axis.dot(b.start_world), b1 = axis.dot(b.end_world);
    const double overlap =
        std::min(std::max(a0, a1), std::max(b0, b1)) - std::max(std::min(a0, a1), std::min(b0, b1));
    const double shorter = std::min(std::abs(a1 - a0), std::abs(b1 - b0));
    const bool near = std::abs(b.row - a.row) <= o.max_row_step;
    if (near && overlap >= 0.5 * shorter) ++neighbours;
  }
  return passes.size() < 2 || 2 * neighbours >= static_cast<int>(passes.size()) - 1;
}

std::string RowId(int row, int occurrence) {
  char buffer[32];
  if (occurrence <= 1) {
    std::snprintf(buffer, sizeof(buffer), "row%02d", row);
  } else {
    std::snprintf(buffer, sizeof(buffer), "row%02d_%d", row, occurrence);
  }
  return buffer;
}

using Options = RowPassSegmenter::Options;
using Summary = RowPassSegmenter::Summary;

// The GPS track as the steps of Segment see it.
struct Track {
  std::vector<Fix> fixes;  // the body origin's once the antenna offset is removed
  double median_dt = 0.0;  // between fixes, s
  double window = 0.0;     // of the velocity fits, s
  std::vector<Eigen::Vector2d> velocity, p_fit;
  std::vector<bool> valid;
  Eigen::Vector2d u = Eigen::Vector2d::UnitY();             // row axis
  Eigen::Vector2d lateral_axis = Eigen::Vector2d::UnitX();  // u turned clockwise

  int n() const { return static_cast<int>(fixes.size()); }
};

// Bad input (InputError): non-finite or non-increasing fixes, degenerate declared rows.
void CheckSegmenterInput(const std::vector<TrackPoint>& track,
                         const std::vector<io::RowDeclaration>& declared_rows) {
  for (size_t i = 0; i < track.size(); ++i) {
    if (!track[i].position_world.allFinite()) {
      throw InputError("GPS track: fix " + std::to_string(i) + " has a non-finite position");
    }
    if (i > 0 && track[i].t <= track[i - 1].t) {
      throw InputError("GPS track: times not strictly increasing at fix " + std::to_string(i));
    }
  }
  for (const io::RowDeclaration& row : declared_rows) {
    if (!row.start_enu.allFinite() || !row.end_enu.allFinite() ||
        (row.end_enu - row.start_enu).norm() < 1e-6) {
      throw InputError("declared row " + std::to_string(row.index) +
                       ": start and end must be finite and distinct");
    }
  }
}

// The answer when no row structure is found: the whole session as one pass "all".
std::vector<RowPass> WholeSession(const std::vector<TrackPoint>& track,
                                  const std::vector<Fix>& fixes, Summary* sum) {
  RowPass all;
  all.id = "all";
  all.t_begin = track.front().t;
  all.t_end = track.back().t;
  all.start_world = fixes.front().p;
  all.end_world = fixes.back().p;
  for (size_t i = 1; i < fixes.size(); ++i) all.length_m += (fixes[i].p - fixes[i - 1].p).norm();
  sum->whole_session = true;
  return std::vector<RowPass>{all};
}

// The velocity window: velocity_window_s, or when that is 0 the window that gives a course
// noise of ~0.08 rad at the typical speed (from ~5 s chords, robust to metre noise):
// σ_θ ≈ σ √12 / (√(W / Δt) v W).
double VelocityWindow(const std::vector<Fix>& fixes, double median_dt, double noise_sigma_m,
                      const Options& o) {
  double window = o.velocity_window_s;
  if (!(window <= 0.0)) return window;
  const int n = static_cast<int>(fixes.size());
  std::vector<double> chord_speeds;
  for (int i = 0, j = 0; i < n; ++i) {
    while (j < n && fixes[j].t < fixes[i].t + 5.0) ++j;
    if (j == n) break;
    chord_speeds.push_back((fixes[j].p - fixes[i].p).norm() / (fixes[j].t - fixes[i].t));
  }
  const double speed = std::max(0.5, Median(chord_speeds));
  constexpr double kCourseSigma = 0.08;
  window =
      std::pow(noise_sigma_m * std::sqrt(12.0 * median_dt) / (speed * kCourseSigma), 2.0 / 3.0);
  return std::clamp(window, o.min_velocity_window_s, o.max_velocity_window_s);
}

// Velocities and fitted positions of the fixes; with antenna_in_body_xy, the fixes are first
// moved from the antenna to the body origin with the course of the body track (fixed-point
// iteration).
void FitBodyVelocities(const Options& o, Track* t) {
  std::vector<Fix>& fixes = t->fixes;
  const int n = t->n();
  FitVelocities(fixes, t->window, &t->velocity, &t->p_fit, &t->valid);
  if (o.antenna_in_body_xy.isZero()) return;
  const std::vector<Eigen::Vector2d>& velocity = t->velocity;
  const std::vector<bool>& valid = t->valid;
  const std::vector<Fix> antenna = fixes;
  for (int iteration = 0; iteration < 3; ++iteration) {
    double heading = std::numeric_limits<double>::quiet_NaN();
    for (int i = 0; i < n; ++i) {
      if (valid[i] && velocity[i].norm() >= o.min_speed_mps) {
        heading = std::atan2(velocity[i].y(), velocity[i].x());
      } else if (std::isnan(heading)) {
        for (int j = i; j < n && std::isnan(heading); ++j) {
          if (valid[j] && velocity[j].norm() >= o.min_speed_mps) {
            heading = std::atan2(velocity[j].y(), velocity[j].x());
          }
        }
      }
      if (std::isnan(heading)) break;  // never moves: nothing to correct
      fixes[i].p = antenna[i].p - Eigen::Rotation2Dd(heading) * o.antenna_in_body_xy;
    }
    FitVelocities(fixes, t->window, &t->velocity, &t->p_fit, &t->valid);
  }
}

// The row axis, canonical in (−45°, 135°]: the declared rows' (length-weighted axial mean),
// row_axis_rad, or the dominant course of the track. NaN when none is found.
double RowAxis(const std::vector<io::RowDeclaration>& declared_rows, const Track& t,
               const Options& o, Summary* sum) {
  double axis = o.row_axis_rad;
  if (!declared_rows.empty()) {
    double c = 0.0, s = 0.0;
    for (const io::RowDeclaration& row : declared_rows) {
      const Eigen::Vector2d d = row.end_enu - row.start_enu;
      const double a2 = 2.0 * std::atan2(d.y(), d.x());
      c += d.norm() * std::cos(a2);
      s += d.norm() * std::sin(a2);
    }
    axis = 0.5 * std::atan2(s, c);
    sum->used_declared_rows = true;
  } else if (std::isnan(axis)) {
    axis = DominantAxis(t.velocity, t.valid, o.min_speed_mps, o.heading_tolerance_rad);
  }
  if (std::isnan(axis)) return axis;
  axis = std::remainder(axis, M_PI);  // (−90°, 90°]
  if (axis <= -0.25 * M_PI) axis += M_PI;
  return axis;
}

double MeanLateral(const Track& t, int first, int last) {
  double l = 0.0;
  for (int i = first; i <= last; ++i) l += t.lateral_axis.dot(t.fixes[i].p);
  return l / (last - first + 1);
}

// Runs of consecutive fixes that move along the axis (within heading_tolerance_rad, at least
// min_speed_mps) in one direction, broken at gaps of 2.5 fix intervals.
std::vector<Stretch> StraightRuns(const Track& t, const Options& o) {
  const int n = t.n();
  const double cos_tolerance = std::cos(o.heading_tolerance_rad);
  std::vector<int> straight_dir(n, 0);
  for (int i = 0; i < n; ++i) {
    const double speed = t.velocity[i].norm();
    if (!t.valid[i] || speed < o.min_speed_mps) continue;
    const double c = t.u.dot(t.velocity[i]) / speed;
    if (std::abs(c) >= cos_tolerance) straight_dir[i] = c > 0.0 ? 1 : -1;
  }
  const double break_gap = 2.5 * t.median_dt;
  std::vector<Stretch> runs;
  for (int i = 0; i < n; ++i) {
    if (straight_dir[i] == 0) continue;
    if (!runs.empty() && runs.back().last == i - 1 && runs.back().direction == straight_dir[i] &&
        t.fixes[i].t - t.fixes[i - 1].t <= break_gap) {
      runs.back().last = i;
    } else {
      Stretch run;
      run.first = run.last = i;
      run.direction = straight_dir[i];
      runs.push_back(run);
    }
  }
  return runs;
}

// Joins consecutive runs in the same direction on the same row (lateral offsets within half a
// row spacing plus their noise, no going back, at most max_join_gap_s apart), then keeps the
// stretches at least min_length_m long with their coarse times.
std::vector<Stretch> JoinRuns(const Track& t, const std::vector<Stretch>& runs, const Options& o,
                              Summary* sum) {
  const std::vector<Fix>& fixes = t.fixes;
  const double break_gap = 2.5 * t.median_dt;
  std::vector<Stretch> joined;
  for (const Stretch& run : runs) {
    if (!joined.empty()) {
      Stretch& prev = joined.back();
      const double gap = fixes[run.first].t - fixes[prev.last].t;
      const int n_prev = prev.last - prev.first + 1, n_run = run.last - run.first + 1;
      const double lateral_tolerance =
          0.5 * o.row_spacing_m + 3.0 * sum->noise_sigma_m * std::sqrt(1.0 / n_prev + 1.0 / n_run);
      const double progress = run.direction * t.u.dot(t.p_fit[run.first] - t.p_fit[prev.last]);
      if (run.direction == prev.direction && gap <= o.max_join_gap_s &&
          std::abs(MeanLateral(t, run.first, run.last) - MeanLateral(t, prev.first, prev.last)) <=
              lateral_tolerance &&
          progress >= -(1.0 + 3.0 * sum->noise_sigma_m)) {
        prev.last = run.last;
        if (gap > break_gap) ++sum->num_joined_gaps;
        continue;
      }
    }
    joined.push_back(run);
  }
  std::vector<Stretch> stretches;
  for (Stretch s : joined) {
    const double length = s.direction * t.u.dot(t.p_fit[s.last] - t.p_fit[s.first]);
    if (length < o.min_length_m) {
      ++sum->num_dropped_short;
      continue;
    }
    s.t_begin = fixes[s.first].t;
    s.t_end = fixes[s.last].t;
    stretches.push_back(s);
  }
  return stretches;
}

// The stretches' start and end times: the session's ends where a stretch runs on to them; with
// precise fixes (`refine`) the change point of the lateral offset near the coarse boundary,
// else the coarse boundary moved half a velocity window inwards.
void RefineBoundaries(const Track& t, bool refine, std::vector<Stretch>* stretches) {
  const std::vector<Fix>& fixes = t.fixes;
  const double window = t.window, median_dt = t.median_dt;
  const double session_end = fixes.back().t;
  for (size_t k = 0; k < stretches->size(); ++k) {
    Stretch& s = (*stretches)[k];
    const double coarse_begin = s.t_begin, coarse_end = s.t_end;
    const double prev_end = k > 0 ? (*stretches)[k - 1].t_end : 0.0;
    const double next_begin = k + 1 < stretches->size() ? (*stretches)[k + 1].t_begin : session_end;
    const double middle = 0.5 * (coarse_begin + coarse_end);
    // A stretch that starts (ends) within the window of the session start (end) runs on to it.
    const bool at_start = coarse_begin <= 0.5 * window + 2.0 * median_dt;
    const bool at_finish = coarse_end >= session_end - 0.5 * window - 2.0 * median_dt;
    if (at_start) {
      s.t_begin = 0.0;
    } else if (refine) {
      const double t0 = ChangePoint(fixes, t.lateral_axis, std::max(prev_end, coarse_begin - 1.0),
                                    std::min(middle, coarse_begin + 0.5 * window + 1.0), false);
      if (!std::isnan(t0)) s.t_begin = t0;
    } else {
      s.t_begin = std::min(middle, coarse_begin + 0.5 * window);
    }
    if (at_finish) {
      s.t_end = session_end;
    } else if (refine) {
      const double t0 =
          ChangePoint(fixes, t.lateral_axis, std::max(middle, coarse_end - 0.5 * window - 1.0),
                      std::min(next_begin, coarse_end + 1.0), true);
      if (!std::isnan(t0)) s.t_end = t0;
    } else {
      s.t_end = std::max(middle, coarse_end - 0.5 * window);
    }
  }
}

// The refined boundaries can move a short stretch's ends past each other (a curved road: the
// change point of the lateral offset lies anywhere inside it): measure again on the fitted
// track and drop what is now shorter than the minimum; then each stretch's lateral offset is
// the mean over its fixes between its boundaries.
void DropShortAndMeasureLateral(const Track& t, const Options& o, std::vector<Stretch>* stretches,
                                Summary* sum) {
  const std::vector<Fix>& fixes = t.fixes;
  std::erase_if(*stretches, [&](const Stretch& s) {
    const auto begin = std::lower_bound(fixes.begin(), fixes.end(), s.t_begin,
                                        [](const Fix& f, double time) { return f.t < time; });
    const auto end = std::upper_bound(fixes.begin(), fixes.end(), s.t_end,
                                      [](double time, const Fix& f) { return time < f.t; });
    const int first = static_cast<int>(begin - fixes.begin());
    const int last = static_cast<int>(end - fixes.begin()) - 1;
    const bool too_short =
        last <= first || s.direction * t.u.dot(t.p_fit[last] - t.p_fit[first]) < o.min_length_m;
    if (too_short) ++sum->num_dropped_short;
    return too_short;
  });
  for (Stretch& s : *stretches) {
    double l = 0.0;
    int count = 0;
    for (int i = 0; i < t.n(); ++i) {
      if (fixes[i].t < s.t_begin || fixes[i].t > s.t_end) continue;
      l += t.lateral_axis.dot(fixes[i].p);
      ++count;
    }
    s.lateral = count > 0 ? l / count : MeanLateral(t, s.first, s.last);
  }
}

// The declared rows sorted across the field: their lateral offsets and indices.
struct DeclaredRowOrder {
  std::vector<double> lateral;
  std::vector<int> index;
  std::vector<double> gaps;  // between neighbours (coincident ones left out)
};

DeclaredRowOrder SortDeclaredRows(const std::vector<io::RowDeclaration>& declared_rows,
                                  const Eigen::Vector2d& lateral_axis) {
  DeclaredRowOrder out;
  std::vector<std::pair<double, int>> order;
  for (const io::RowDeclaration& row : declared_rows) {
    order.emplace_back(lateral_axis.dot(0.5 * (row.start_enu + row.end_enu)), row.index);
  }
  std::sort(order.begin(), order.end());
  for (size_t j = 0; j < order.size(); ++j) {
    out.lateral.push_back(order[j].first);
    out.index.push_back(order[j].second);
    if (j > 0 && order[j].first - order[j - 1].first > 1e-6) {
      out.gaps.push_back(order[j].first - order[j - 1].first);
    }
  }
  return out;
}

// Relative row indices: consecutive passes' lateral offsets in whole spacings. With noisy fixes
// (`relative`) a turn always moves to another row.
std::vector<int> RelativeRowChain(const std::vector<Stretch>& stretches, double spacing,
                                  bool relative) {
  std::vector<int> chain(stretches.size(), 0);
  for (size_t k = 1; k < stretches.size(); ++k) {
    const double step = (stretches[k].lateral - stretches[k - 1].lateral) / spacing;
    int increment = static_cast<int>(std::lround(step));
    if (relative && stretches[k].direction != stretches[k - 1].direction) {
      increment =
          (step < 0.0 ? -1 : 1) * static_cast<int>(std::max(1L, std::lround(std::abs(step) - 0.5)));
    }
    chain[k] = chain[k - 1] + increment;
  }
  return chain;
}

// Each stretch on the declared row nearest to its centroid, none (−1) beyond max_distance.
void NearestDeclaredRows(const Track& t, const std::vector<io::RowDeclaration>& declared_rows,
                         double max_distance, std::vector<Stretch>* stretches) {
  for (Stretch& s : *stretches) {
    Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
    int count = 0;
    for (int i = 0; i < t.n(); ++i) {
      if (t.fixes[i].t < s.t_begin || t.fixes[i].t > s.t_end) continue;
      centroid += t.fixes[i].p;
      ++count;
    }
    centroid /= std::max(1, count);
    double best = std::numeric_limits<double>::infinity();
    for (const io::RowDeclaration& row : declared_rows) {
      const Eigen::Vector2d d = (row.end_enu - row.start_enu).normalized();
      const Eigen::Vector2d r = centroid - row.start_enu;
      const double distance = std::abs(d.x() * r.y() - d.y() * r.x());
      if (distance < best) {
        best = distance;
        s.row = distance <= max_distance ? row.index : -1;
      }
    }
  }
}

// One integer shift m of the relative indices onto the sorted declared rows: fewest passes
// outside the declared rows, then least squares of the lateral offsets.
void ShiftOntoDeclaredRows(const std::vector<int>& chain, const DeclaredRowOrder& declared,
                           std::vector<Stretch>* stretches) {
  const int chain_min = *std::min_element(chain.begin(), chain.end());
  const int chain_max = *std::max_element(chain.begin(), chain.end());
  const int num_declared = static_cast<int>(declared.lateral.size());
  int best_shift = 0, best_outside = 0;
  double best_sse = 0.0;
  bool first = true;
  for (int shift = -chain_max; shift <= num_declared - 1 - chain_min; ++shift) {
    int outside = 0;
    double sse = 0.0;
    for (size_t k = 0; k < stretches->size(); ++k) {
      const int j = chain[k] + shift;
      if (j < 0 || j >= num_declared) {
        ++outside;
      } else {
        sse += std::pow((*stretches)[k].lateral - declared.lateral[j], 2);
      }
    }
    if (first || outside < best_outside || (outside == best_outside && sse < best_sse)) {
      first = false;
      best_shift = shift;
      best_outside = outside;
      best_sse = sse;
    }
  }
  for (size_t k = 0; k < stretches->size(); ++k) {
    const int j = chain[k] + best_shift;
    (*stretches)[k].row = j >= 0 && j < num_declared ? declared.index[j] : -1;
  }
}

// Without declared rows: the relative indices shifted so that rows sit nearest to
// lateral_origin_m + i · spacing, or so that the leftmost pass is row 0.
void RowsFromChain(const std::vector<int>& chain, double spacing, const Options& o,
                   std::vector<Stretch>* stretches, Summary* sum) {
  const std::vector<Stretch>& s = *stretches;
  int shift = -*std::min_element(chain.begin(), chain.end());
  if (!std::isnan(o.lateral_origin_m)) {
    double offset = 0.0;
    for (size_t k = 0; k < s.size(); ++k) {
      offset += s[k].lateral - o.lateral_origin_m - chain[k] * spacing;
    }
    shift = static_cast<int>(std::lround(offset / s.size() / spacing));
    sum->row0_lateral_m = o.lateral_origin_m;
  } else {
    double offset = 0.0;
    for (size_t k = 0; k < s.size(); ++k) offset += s[k].lateral - (chain[k] + shift) * spacing;
    sum->row0_lateral_m = offset / s.size();
  }
  for (size_t k = 0; k < s.size(); ++k) (*stretches)[k].row = chain[k] + shift;
}

// The row index of every stretch (−1: on no declared row): with declared rows and precise
// fixes the nearest declared row, with noisy ones the relative indices shifted onto the
// declared rows, without declared rows the relative indices.
void AssignRows(const Track& t, const std::vector<io::RowDeclaration>& declared_rows,
                const Options& o, std::vector<Stretch>* stretches, Summary* sum) {
  const bool relative = sum->noise_sigma_m > o.relative_matching_noise_m;
  sum->relative_rows = relative;
  double spacing = o.row_spacing_m;
  DeclaredRowOrder declared;
  if (!declared_rows.empty()) {
    declared = SortDeclaredRows(declared_rows, t.lateral_axis);
    if (!declared.gaps.empty()) spacing = Median(declared.gaps);
  }
  sum->row_spacing_m = spacing;
  const std::vector<int> chain = RelativeRowChain(*stretches, spacing, relative);
  if (!declared_rows.empty() && !relative) {
    const double max_distance = o.max_row_distance_m > 0.0 ? o.max_row_distance_m : 0.5 * spacing;
    NearestDeclaredRows(t, declared_rows, max_distance, stretches);
    sum->row0_lateral_m = declared.lateral.front();
  } else if (!declared_rows.empty()) {
    ShiftOntoDeclaredRows(chain, declared, stretches);
    sum->row0_lateral_m = declared.lateral.front();
  } else {
    RowsFromChain(chain, spacing, o, stretches, sum);
  }
}

// The passes of the stretches on a row, named by row and occurrence; their ends on the track
// (precise fixes) or on the along-track line fit at the pass's mean lateral offset (noisy ones).
std::vector<RowPass> MakePasses(const Track& t, const std::vector<Stretch>& stretches, bool refine,
                                Timestamp t_first, Summary* sum) {
  const std::vector<Fix>& fixes = t.fixes;
  const Eigen::Vector2d& u = t.u;
  auto to_timestamp = [&](double seconds) { return t_first + SecondsToTimestamp(seconds); };
  std::vector<RowPass> passes;
  std::map<int, int> occurrences;
  for (const Stretch& s : stretches) {
    if (s.row < 0) {
      ++sum->num_dropped_unmatched;
      continue;
    }
    RowPass pass;
    pass.row = s.row;
    pass.direction = s.direction;
    pass.id = RowId(s.row, ++occurrences[s.row]);
    pass.t_begin = to_timestamp(s.t_begin);
    pass.t_end = to_timestamp(s.t_end);
    pass.lateral_m = s.lateral;
    if (refine) {
      pass.start_world = InterpolatePosition(fixes, s.t_begin);
      pass.end_world = InterpolatePosition(fixes, s.t_end);
    } else {
      double t_mean = 0.0, a_mean = 0.0;
      int count = 0;
      for (int i = s.first; i <= s.last; ++i) {
        t_mean += fixes[i].t;
        a_mean += u.dot(fixes[i].p);
        ++count;
      }
      t_mean /= count;
      a_mean /= count;
      double stt = 0.0, sta = 0.0;
      for (int i = s.first; i <= s.last; ++i) {
        stt += std::pow(fixes[i].t - t_mean, 2);
        sta += (fixes[i].t - t_mean) * (u.dot(fixes[i].p) - a_mean);
      }
      const double slope = stt > 0.0 ? sta / stt : 0.0;
      pass.start_world = (a_mean + slope * (s.t_begin - t_mean)) * u + s.lateral * t.lateral_axis;
      pass.end_world = (a_mean + slope * (s.t_end - t_mean)) * u + s.lateral * t.lateral_axis;
    }
    pass.length_m = std::abs(u.dot(pass.end_world - pass.start_world));
    passes.push_back(std::move(pass));
  }
  return passes;
}

}  // namespace

OptionCheck RowPassSegmenter::Options::Check() const {
  OptionChecker c;
  c.Greater("row_spacing_m", row_spacing_m, 0.0)
      .AtLeast("velocity_window_s", velocity_window_s, 0.0)
      .Greater("min_velocity_window_s", min_velocity_window_s, 0.0)
      .Require(max_velocity_window_s >= min_velocity_window_s, "max_velocity_window_s",
               "must be >= min_velocity_window_s", max_velocity_window_s)
      .Between("heading_tolerance_rad", heading_tolerance_rad, 0.0, 0.5 * M_PI)
      .Greater("min_speed_mps", min_speed_mps, 0.0)
      .Greater("min_length_m", min_length_m, 0.0)
      .AtLeast("max_join_gap_s", max_join_gap_s, 0.0)
      .AtLeast("refine_max_noise_m", refine_max_noise_m, 0.0)
      .AtLeast("max_row_distance_m", max_row_distance_m, 0.0)
      .AtLeast("relative_matching_noise_m", relative_matching_noise_m, 0.0)
      .Require(antenna_in_body_xy.allFinite(), "antenna_in_body_xy", "must be finite")
      .Require(!std::isinf(row_axis_rad), "row_axis_rad", "must be finite (or NaN: estimated)",
               row_axis_rad)
      .Require(!std::isinf(lateral_origin_m), "lateral_origin_m",
               "must be finite (or NaN: leftmost pass)", lateral_origin_m)
      .InRange("min_row_time_fraction", min_row_time_fraction, 0.0, 1.0)
      .AtLeast("min_row_passes", min_row_passes, 1)
      .AtLeast("max_row_step", max_row_step, 1);
  return c.Result();
}

RowPassSegmenter::RowPassSegmenter(Options options) : options_(options) {
  if (const OptionCheck why = options_.Check(); !why.empty()) {
    throw std::invalid_argument("RowPassSegmenter: " + why);
  }
}

std::vector<RowPass> RowPassSegmenter::Segment(const std::vector<TrackPoint>& track,
                                               const std::vector<io::RowDeclaration>& declared_rows,
                                               Summary* summary) const {
  const Options& o = options_;
  Summary local_summary;
  Summary& sum = summary != nullptr ? *summary : local_summary;
  sum = Summary();
  sum.num_points = static_cast<int>(track.size());
  CheckSegmenterInput(track, declared_rows);
  if (track.size() < 2) return {};

  Track t;
  t.fixes.resize(track.size());
  for (size_t i = 0; i < track.size(); ++i) {
    t.fixes[i].t = DurationSeconds(track.front().t, track[i].t);
    t.fixes[i].p = track[i].position_world.head<2>();
  }
  const int n = t.n();

  // ---- 1. Noise, velocity window, velocities.
  std::vector<double> dts;
  for (int i = 1; i < n; ++i) dts.push_back(t.fixes[i].t - t.fixes[i - 1].t);
  t.median_dt = Median(dts);
  sum.noise_sigma_m = EstimateNoise(t.fixes, t.median_dt);
  t.window = VelocityWindow(t.fixes, t.median_dt, sum.noise_sigma_m, o);
  sum.velocity_window_s = t.window;
  FitBodyVelocities(o, &t);

  // ---- 2. Row axis; lateral = axis turned clockwise.
  const double axis = RowAxis(declared_rows, t, o, &sum);
  if (std::isnan(axis)) return WholeSession(track, t.fixes, &sum);
  t.u = Eigen::Vector2d(std::cos(axis), std::sin(axis));
  t.lateral_axis = Eigen::Vector2d(t.u.y(), -t.u.x());
  sum.row_axis_world = t.u;
  sum.lateral_axis_world = t.lateral_axis;

  // ---- 3. Straight fixes, runs, joins, minimum length.
  const std::vector<Stretch> runs = StraightRuns(t, o);
  sum.num_straight_runs = static_cast<int>(runs.size());
  std::vector<Stretch> stretches = JoinRuns(t, runs, o, &sum);
  if (stretches.empty()) return WholeSession(track, t.fixes, &sum);

  // ---- 4. Boundaries.
  const bool refine = sum.noise_sigma_m <= o.refine_max_noise_m;
  RefineBoundaries(t, refine, &stretches);
  DropShortAndMeasureLateral(t, o, &stretches, &sum);
  if (stretches.empty()) return WholeSession(track, t.fixes, &sum);

  // ---- 5. Row indices, then the passes.
  AssignRows(t, declared_rows, o, &stretches, &sum);
  std::vector<RowPass> passes = MakePasses(t, stretches, refine, track.front().t, &sum);
  if (passes.empty()) return WholeSession(track, t.fixes, &sum);
  if (declared_rows.empty() && o.require_row_structure) {
    // A few straight stretches in a recording that is mostly something else (a walk with turns,
    // a survey) are not a row structure: the whole session is one pass.
    double in_passes = 0.0;
    for (const RowPass& p : passes) in_passes += DurationSeconds(p.t_begin, p.t_end);
    if (in_passes < o.min_row_time_fraction * t.fixes.back().t) {
      return WholeSession(track, t.fixes, &sum);
    }
    if (!LooksLikeRows(passes, t.u, o)) return WholeSession(track, t.fixes, &sum);
  }
  return passes;
}

std::vector<RowPass> WholeDriveWindows(Timestamp t_begin, Timestamp t_end,
                                       const std::vector<TrackPoint>& track, double max_window_s,
                                       double overlap_s) {
  if (!(max_window_s > overlap_s) || !(overlap_s >= 0.0) || t_end < t_begin) {
    throw std::invalid_argument("WholeDriveWindows: needs max_window_s > overlap_s >= 0");
  }
  const double duration = DurationSeconds(t_begin, t_end);
  const int count =
      duration <= max_window_s
          ? 1
          : static_cast<int>(std::ceil((duration - overlap_s) / (max_window_s - overlap_s)));
  const double length = (duration + (count - 1) * overlap_s) / count;
  // Position at t from the track (held at its ends), and the path length over [a, b].
  auto position = [&](Timestamp t) -> Eigen::Vector2d {
    if (track.empty()) return Eigen::Vector2d::Zero();
    const auto it = std::lower_bound(track.begin(), track.end(), t,
                                     [](const TrackPoint& p, Timestamp v) { return p.t < v; });
    if (it == track.begin()) return track.front().position_world.head<2>();
    if (it == track.end()) return track.back().position_world.head<2>();
    const TrackPoint& a = *(it - 1);
    const double w = DurationSeconds(a.t, t) / DurationSeconds(a.t, it->t);
    return ((1.0 - w) * a.position_world + w * it->position_world).head<2>();
  };
  auto path_length = [&](Timestamp a, Timestamp b) {
    double sum = 0.0;
    Eigen::Vector2d previous = position(a);
    for (const TrackPoint& p : track) {
      if (p.t <= a || p.t >= b) continue;
      sum += (p.position_world.head<2>() - previous).norm();
      previous = p.position_world.head<2>();
    }
    return sum + (position(b) - previous).norm();
  };
  std::vector<RowPass> windows;
  for (int k = 0; k < count; ++k) {
    RowPass pass;
    char id[32];
    std::snprintf(id, sizeof(id), "all%02d", k);
    pass.id = count == 1 ? "all" : id;
    pass.t_begin = t_begin + SecondsToTimestamp(k * (length - overlap_s));
    pass.t_end = k + 1 == count ? t_end : pass.t_begin + SecondsToTimestamp(length);
    pass.start_world = position(pass.t_begin);
    pass.end_world = position(pass.t_end);
    pass.length_m = path_length(pass.t_begin, pass.t_end);
    windows.push_back(std::move(pass));
  }
  return windows;
}

int FindPass(const std::vector<RowPass>& passes, Timestamp t) {
  const auto it =
      std::upper_bound(passes.begin(), passes.end(), t,
                       [](Timestamp value, const RowPass& p) { return value < p.t_begin; });
  if (it == passes.begin()) return -1;
  const int k = static_cast<int>(it - passes.begin()) - 1;
  return t <= passes[k].t_end ? k : -1;
}

}  // namespace crop4d::slam
