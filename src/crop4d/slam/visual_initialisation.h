#pragma once

// The initial guess of a pass without an IMU, from its images (docs/slam.md, "Rigs without an
// IMU").
//
// With an IMU the initial states come from integrating it between GPS fixes; without one they
// come from the GPS track alone: positions from local line fits of the fixes, the heading from
// their course, the rig level. A metre-level receiver over a few metres of row gives courses tens
// of degrees off and steps of the wrong length, and from such poses the landmarks cannot be
// triangulated at all (measured on the demo field's 2016-07-13 row02, cam+gps: 0 of 307 tracks,
// so the solve had no camera factor and came out rotated by 74°).
//
// Consecutive images see the same soil and plants, so their relative rotation and the direction
// of their translation follow from the essential matrix of their shared tracks (five-point
// algorithm in RANSAC, cv::findEssentialMat; the cheirality check of cv::recoverPose picks the
// solution). Chained over the pass these give the shape of the trajectory up to its scale and
// placement; the GPS guess gives the rest:
//   - each step's length is the GPS guess's (its speed; the solve and the camera height refine
//     the scale later),
//   - the chain is tilted so that the rig's up axis points up on average over the pass (the
//     level assumption of the tilt prior), and turned about the vertical so that its horizontal
//     displacement from first to last state has the GPS guess's direction,
//   - and shifted so that its mean position is the GPS guess's.
// A step without a usable essential matrix (too few shared tracks, a standstill) keeps the
// previous rotation and direction. When too few steps are usable the GPS guess is returned as it
// is.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_optimiser.h"

namespace crop4d::slam {

struct VisualInitialisationOptions {
  // Tracks two consecutive images need in common for their essential matrix.
  int min_correspondences = 30;
  // RANSAC inlier threshold, px (converted with the camera's focal length).
  double ransac_threshold_px = 1.0;
  double ransac_confidence = 0.999;
  // The share of the correspondences that must be inliers passing the cheirality check.
  double min_inlier_fraction = 0.5;
  // A GPS-guess step shorter than this is a standstill: its translation direction is not
  // observable and its rotation is kept, m.
  double min_step_m = 0.02;
  // Below this share of usable steps the GPS guess is kept.
  double min_usable_fraction = 0.5;

  OptionCheck Check() const;
};

// The motion between image k and k + 1, in the frame of camera k.
struct ImagePairMotion {
  bool ok = false;
  // Rotation of camera k + 1 in the frame of camera k (camera_k_from_camera_k+1).
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  // Unit direction of camera k + 1's centre in the frame of camera k.
  Eigen::Vector3d direction = Eigen::Vector3d::Zero();
  int correspondences = 0;
  int inliers = 0;
};

// The essential-matrix motion of every pair of consecutive images (num_images − 1 entries); the
// tracks' observation indices are image indices.
std::vector<ImagePairMotion> ConsecutiveImageMotions(const geometry::PinholeRadTan& camera,
                                                     const std::vector<LandmarkTrack>& tracks,
                                                     int num_images,
                                                     const VisualInitialisationOptions& options);

struct VisualInitialisationSummary {
  int steps = 0;         // intervals between states
  int visual_steps = 0;  // intervals whose rotation and direction came from the images
  bool applied = false;  // false: the GPS guess was kept
  // Heading of the first state: the GPS guess's minus the result's, degrees in (−180, 180].
  double heading_change_deg = 0;
};

// The states of `gps_guess` (one per image, in image order) with the rotations, the shape and
// the velocities from the images as described above; biases are kept. `up_body` is the body axis
// that points up when the rig is level.
std::vector<RowState> VisualInitialGuess(const std::vector<RowState>& gps_guess,
                                         const geometry::PinholeRadTan& camera,
                                         const geometry::Rigid3& body_from_camera,
                                         const std::vector<LandmarkTrack>& tracks,
                                         const Eigen::Vector3d& up_body,
                                         const VisualInitialisationOptions& options,
                                         VisualInitialisationSummary* summary = nullptr);

}  // namespace crop4d::slam
