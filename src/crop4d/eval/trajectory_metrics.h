#pragma once

// Trajectory accuracy against ground truth (DESIGN.md §8): absolute trajectory error (ATE) with
// and without an SE(3) alignment, relative pose error (RPE) per metre travelled, rotation error.
//
// Conventions (as in evo and the TUM RGB-D benchmark, Sturm et al., IROS 2012):
//   - poses are `world_from_X` (X = camera or body); estimate[k] and truth[k] are the same
//     instant (AssociateByTime makes such lists from stamped poses);
//   - ATE raw: position error p_est − p_truth in the world frame, with NO alignment: the GPS
//     fixes the world frame, so a constant offset is an error;
//   - ATE aligned: the same after the SE(3) (no scale) alignment truth_from_estimate that
//     minimises the position error (Umeyama, "Least-squares estimation of transformation
//     parameters between two point patterns", PAMI 1991);
//   - rotation error: the angle of R_truthᵀ R_est, no alignment;
//   - RPE: for each pose i, the first j with true path length s_j − s_i ≥ rpe_distance_m;
//     E = (T_i⁻¹ T_j)_est, G = (T_i⁻¹ T_j)_truth, translation error |t(G⁻¹E)| = |t_E − t_G|
//     divided by s_j − s_i (a percentage) and the angle of R_Gᵀ R_E divided by s_j − s_i
//     (degrees per metre; Geiger et al., "Are we ready for autonomous driving? The KITTI vision
//     benchmark suite", CVPR 2012, §4 — there at 100..800 m, here over a crop row).

#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/tum.h"

namespace crop4d::eval {

// ---------------------------------------------------------------------------------------------
// Association by time.

struct AssociatedPoses {
  std::vector<Timestamp> t;                // the estimate's timestamps that were kept
  std::vector<geometry::Rigid3> estimate;  // estimate at t[k]
  std::vector<geometry::Rigid3> truth;     // truth at t[k] (exact or interpolated)
  int exact = 0;                           // truth had a pose at exactly t[k]
  int interpolated = 0;                    // truth interpolated between its two neighbours
  int dropped_out_of_span = 0;  // estimate poses before the first / after the last truth pose
  int dropped_gap = 0;          // inside the span, but a neighbour is further than max_dt away

  int size() const { return static_cast<int>(t.size()); }
  int dropped() const { return dropped_out_of_span + dropped_gap; }
};

// Pairs every estimate pose with the truth at its timestamp: the truth pose with the same
// timestamp when there is one, otherwise the truth interpolated between its two neighbours
// (translation linearly, rotation by slerp: geometry::InterpolateSeparately) when both lie
// within `max_dt` of the estimate's timestamp. Estimate poses outside the truth's time span,
// or in a gap of the truth wider than that, are dropped and counted. `truth` must be strictly
// increasing in time (io::ReadTum guarantees it); `estimate` may be in any order.
AssociatedPoses AssociateByTime(const std::vector<io::StampedPose>& estimate,
                                const std::vector<io::StampedPose>& truth, Timestamp max_dt);

// ---------------------------------------------------------------------------------------------
// Metrics.

// Root mean square, mean and maximum of a set of non-negative errors.
struct ErrorStats {
  int count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double max = 0.0;

  static ErrorStats Of(const std::vector<double>& errors);
  // The stats of the union of the sets that gave `parts` (exact: the RMSE is pooled from the
  // sums of squares count·rmse²).
  static ErrorStats Pool(const std::vector<ErrorStats>& parts);
};

struct TrajectoryMetricsOptions {
  // RPE pairs (i, j): j is the first pose with true path length s_j − s_i ≥ this, m. 1 m is a
  // few plants along a row: it measures local drift, which matters for plant-level geometry,
  // and a row of 8 m already gives many pairs. 0 means the whole pass: one pair, first pose to
  // last, divided by the whole true path length (end-to-end drift).
  double rpe_distance_m = 1.0;

  OptionCheck Check() const;
};

struct TrajectoryMetrics {
  int num_poses = 0;
  double path_length_m = 0.0;  // true path length (sum of |p_{k+1} − p_k| of the truth)

  ErrorStats ate_raw_m;      // |p_est − p_truth|, m, no alignment
  ErrorStats ate_aligned_m;  // |truth_from_estimate · p_est − p_truth|, m
  // The SE(3) alignment that minimises the aligned ATE: p_truth ≈ truth_from_estimate · p_est.
  // On a straight pass (collinear positions) the rotation about the line is not observable: the
  // aligned ATE is still right, the rotation about that axis is arbitrary.
  geometry::Rigid3 truth_from_estimate;
  ErrorStats rotation_deg;  // angle of R_truthᵀ R_est, degrees, no alignment

  // RPE over the pairs described in TrajectoryMetricsOptions; count = number of pairs (0 when
  // the true path is shorter than rpe_distance_m).
  double rpe_distance_m = 0.0;         // the option used
  ErrorStats rpe_translation_percent;  // 100 · |t_E − t_G| / (s_j − s_i)
  ErrorStats rpe_rotation_deg_per_m;   // angle(R_Gᵀ R_E) / (s_j − s_i), degrees per metre
};

// Metrics of `estimate` against `truth` (same length, same instants). Fewer than 3 poses give
// num_poses and the raw errors only (no alignment: truth_from_estimate is the identity and
// ate_aligned_m is empty).
TrajectoryMetrics ComputeTrajectoryMetrics(const std::vector<geometry::Rigid3>& estimate,
                                           const std::vector<geometry::Rigid3>& truth,
                                           const TrajectoryMetricsOptions& options = {});

// The rigid transform dst_from_src minimising Σ |dst_k − dst_from_src · src_k|² (Umeyama 1991,
// without scale). At least 3 points; same count.
geometry::Rigid3 AlignSE3(const std::vector<Eigen::Vector3d>& src,
                          const std::vector<Eigen::Vector3d>& dst);

// The rotation about the world's vertical and the translation, truth_from_estimate, that take
// `estimate` to `truth` (4 degrees of freedom: both frames have z up, as a gravity-aligned frame
// and the field's ENU frame do). The heading is the one closest to every R_truth R_estᵀ (least
// squares over the poses' orientations: it is observed even while the rig stands still, when the
// positions cannot give it); the translation then matches the centroids. Same count, at least 1.
geometry::Rigid3 AlignYawTranslation(const std::vector<geometry::Rigid3>& estimate,
                                     const std::vector<geometry::Rigid3>& truth);

// How far a trajectory wanders from its first pose, the drift of a standstill: the largest
// change of the heading of `axis` (in the pose's frame; for a camera its optical axis z) projected
// on the world's horizontal plane, degrees, and the largest distance from the first position, m.
struct Wander {
  double max_heading_change_deg = 0.0;
  double max_displacement_m = 0.0;
};
Wander TrajectoryWander(const std::vector<geometry::Rigid3>& poses,
                        const Eigen::Vector3d& axis = Eigen::Vector3d::UnitZ());

// The largest angle between the world's up direction (z) seen from the estimated and from the
// true pose (roll and pitch error; heading and position ignored, so frames that differ by a
// rotation about the vertical and a shift compare), degrees. Same length.
double MaxTiltErrorDeg(const std::vector<geometry::Rigid3>& estimate,
                       const std::vector<geometry::Rigid3>& truth);

// The rotation angle of R in degrees, in [0, 180].
double RotationAngleDeg(const Eigen::Quaterniond& q);

}  // namespace crop4d::eval
