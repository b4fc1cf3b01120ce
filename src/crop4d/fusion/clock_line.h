#pragma once

// One camera clock per session: the passes' camera–IMU time offsets on one line over time.
//
// Each pass of the joint problem has its own time offset td
// (slam/time_offset_reprojection_factor.h), because the camera's clock drifts against the IMU's:
// over a session of ten minutes a drift of 20 ppm moves td by 12 ms. But the drift of a quartz
// clock is steady over a session, so the passes' offsets lie on one line, td(t) = offset + drift (t
// - t_ref). A pass that sees little of its own td — a short pass, a pass whose GPS was in RTK float
// — then borrows it from the other passes of its session: each pass's td is tied to the line by a
// factor of standard deviation sigma (what the clock may stray from a straight line between passes,
// and the capture instant from the stamp), and the line's two parameters are solved with the rest
// of the joint problem.

#include <ceres/ceres.h>

#include <array>
#include <optional>
#include <string>
#include <vector>

namespace crop4d::fusion {

// The factor (td - offset - drift_per_ks * dt_ks) / sigma on a pass's td (1 parameter, s) and a
// clock line [offset s, drift s per 1000 s]; dt_ks is the pass's time since t_ref in units of
// 1000 s, so that both of the line's parameters are of the size of a time offset.
class ClockLineFactor {
 public:
  ClockLineFactor(double dt_ks, double sigma_s) : dt_ks_(dt_ks), sigma_s_(sigma_s) {}

  template <typename T>
  bool operator()(const T* td, const T* line, T* residual) const {
    residual[0] = (td[0] - line[0] - line[1] * T(dt_ks_)) / T(sigma_s_);
    return true;
  }

  static ceres::CostFunction* Create(double dt_ks, double sigma_s) {
    return new ceres::AutoDiffCostFunction<ClockLineFactor, 1, 1, 2>(
        new ClockLineFactor(dt_ks, sigma_s));
  }

 private:
  double dt_ks_;
  double sigma_s_;
};

// A clock line as solved: td(t) = offset_s + drift * (t - t_ref), t in seconds.
struct ClockLine {
  std::string clock;  // the passes' clock (Pass::clock: their session)
  std::vector<int> passes;
  double t_ref_s = 0.0;
  double offset_s = 0.0;
  double drift = 0.0;  // s per s (ppm × 1e-6)
};

// The least-squares line through (times_ks[i], offsets_s[i]) as [offset, drift per 1000 s]; the
// mean offset and no drift when the times do not spread. Two points at least.
std::optional<std::array<double, 2>> FitClockLine(const std::vector<double>& times_ks,
                                                  const std::vector<double>& offsets_s);

}  // namespace crop4d::fusion
