#pragma once

// The rigid transform between the frames of two passes from the same ground points as each pass
// placed them: a rotation about the vertical and a translation (4 degrees of freedom — roll and
// pitch are observed by gravity in every pass; heading and position are what a metre-level GPS
// gets wrong). RANSAC on pairs of correspondences (two points fix the yaw and the translation),
// then a least-squares refit on the inliers: the yaw of the 2D Procrustes problem in the
// horizontal plane (Umeyama, PAMI 1991, without scale) and the mean vertical offset.
//
// Used before association (to bound the search when the passes' GPS is poor) and before the
// joint 4D solve (so that landmarks shared by passes can be triangulated at all).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::fusion {

struct PassAlignmentOptions {
  // A correspondence is an inlier when the aligned points are closer than this, m.
  double inlier_threshold_m = 0.1;
  int ransac_iterations = 500;
  // Fewer inliers than this: no alignment.
  int min_inliers = 12;
  // Pairs of correspondences closer than this horizontally do not fix the yaw, m.
  double min_sample_distance_m = 0.5;
  std::uint32_t seed = 1;

  OptionCheck Check() const;
};

struct PassAlignment {
  bool ok = false;
  // Maps a point of pass a's frame to pass b's frame: b ≈ b_from_a · a.
  geometry::Rigid3 b_from_a;
  int num_inliers = 0;
  // RMS distance of the inliers after the refit, m.
  double rms_m = 0;
};

// `points_a[i]` and `points_b[i]` are one ground point as placed by pass a and pass b.
PassAlignment AlignPasses4Dof(const std::vector<Eigen::Vector3d>& points_a,
                              const std::vector<Eigen::Vector3d>& points_b,
                              const PassAlignmentOptions& options = {});

// A ground point as one pass placed it, and the centre of the camera that observed it there.
struct ObservedPoint {
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  Eigen::Vector3d camera = Eigen::Vector3d::Zero();
};

// AlignPasses4Dof on the correspondences whose two points both lie within `max_range_m` of the
// camera that observed them (lists of different sizes: std::invalid_argument). Distant points (the
// tree line, scenery beyond the field) are triangulated from baselines of a few metres, so they are
// metres off along their viewing rays; two passes driven along the same line misplace them alike,
// and they can outvote the near ground with a transform that is metres wrong in the field. On the
// demo field's cam+imu+gps passes, the tree line alone decided 5 of the 8 cross-session
// pre-alignments checked: the 4 across the rain, where no near ground matches, and one that
// it put 1.5-2 m wrong (bench/RESULTS.md, "Association and 4D fusion").
PassAlignment AlignPasses4DofNear(const std::vector<ObservedPoint>& a,
                                  const std::vector<ObservedPoint>& b, double max_range_m,
                                  const PassAlignmentOptions& options = {});

}  // namespace crop4d::fusion
