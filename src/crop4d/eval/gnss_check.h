#pragma once

// A trajectory against GNSS fixes, for real recordings that have no ground truth but an RTK
// receiver (bench/gnss_outage_study.cc, pipeline/walk_test.cc): the antenna position of the
// estimate at each fix's time against the fix.
//
//   - Consistency: with every fix fused, the residuals e = p_antenna,est(t_k) − p_fix,k should
//     match the fixes' sigmas. Normalised per axis (e_E/σ_h, e_N/σ_h, e_U/σ_v), their RMS is ≈ 1
//     for consistent sigmas (below 1 when the smoother fits the fixes it was given); the
//     horizontal error |e_EN| with per-axis σ_h is Rayleigh-distributed, so the fractions within
//     1σ_h, 2σ_h, 3σ_h are 39.3 %, 86.5 %, 98.9 % for Gaussian errors of that sigma.
//   - Outage bridging: fixes removed from the estimation over a window are compared with the
//     estimate there; the error at the last removed fix is the drift at the end of the window.
//
// The antenna position at t: at each pose p_k = t_k + R_k p_body_antenna; between the poses
// around t, a cubic Hermite spline with finite-difference tangents
// m_k = (p_{k+1} − p_{k−1}) / (t_{k+1} − t_{k−1}) (Catmull–Rom for a uniform grid; one-sided at
// the ends). For states at 10 Hz along a walk (accelerations of a few m/s²) it is within a
// millimetre of the continuous trajectory, where linear interpolation is off by a·Δt²/8 ≈ 3 mm.

#include <Eigen/Core>
#include <limits>
#include <optional>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/eval/trajectory_metrics.h"
#include "crop4d/io/tum.h"

namespace crop4d::eval {

// One GNSS fix in the world (field ENU) frame.
struct GnssFix {
  Timestamp t = 0;
  // Antenna phase centre, m.
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  // 1-sigma per horizontal axis and vertical, m.
  double sigma_h = 0.01;
  double sigma_v = 0.02;
};

// The antenna position of `trajectory` (world_from_body poses, strictly increasing times) at t
// (file comment). nullopt when t is outside the trajectory's span, or when the two poses around
// t are more than max_gap apart.
std::optional<Eigen::Vector3d> AntennaPositionAt(const std::vector<io::StampedPose>& trajectory,
                                                 const Eigen::Vector3d& p_body_antenna, Timestamp t,
                                                 Timestamp max_gap);

// Residual of one fix: estimate − fix, world frame.
struct GnssResidual {
  Timestamp t = 0;
  Eigen::Vector3d error_world = Eigen::Vector3d::Zero();
  double sigma_h = 0.01;
  double sigma_v = 0.02;

  double horizontal() const { return error_world.head<2>().norm(); }
  double norm() const { return error_world.norm(); }
};

// Residuals of every fix inside the trajectory's span (fixes outside it, or in a gap wider than
// max_gap, are left out), in the order of `fixes`.
std::vector<GnssResidual> CompareWithFixes(const std::vector<io::StampedPose>& trajectory,
                                           const std::vector<GnssFix>& fixes,
                                           const Eigen::Vector3d& p_body_antenna,
                                           Timestamp max_gap = SecondsToTimestamp(0.5));

struct GnssResidualStats {
  int count = 0;
  // |e_EN| and |e|, m.
  ErrorStats horizontal_m;
  ErrorStats error_3d_m;
  // RMS of e_E/σ_h, e_N/σ_h, e_U/σ_v over the fixes and the three axes, and of the two
  // horizontal ones only.
  double normalised_rms = 0.0;
  double normalised_rms_horizontal = 0.0;
  // Fractions of fixes with |e_EN| ≤ kσ_h, k = 1, 2, 3.
  double within_sigma[3] = {0.0, 0.0, 0.0};
  // The residual of the latest fix (the end of an outage window).
  GnssResidual last;
};

// Statistics of the residuals with begin ≤ t < end (all of them by default).
GnssResidualStats SummariseResiduals(const std::vector<GnssResidual>& residuals,
                                     Timestamp begin = std::numeric_limits<Timestamp>::min(),
                                     Timestamp end = std::numeric_limits<Timestamp>::max());

}  // namespace crop4d::eval
