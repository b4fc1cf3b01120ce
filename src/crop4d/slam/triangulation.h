#pragma once

// Multi-view triangulation of one landmark from known camera poses and pixel observations of a
// pinhole + radial-tangential camera (crop4d/geometry/camera.h).
//
// 1. Each pixel is undistorted to normalised coordinates (x_i, y_i) (PinholeRadTan::Unproject).
// 2. Linear triangulation (DLT, Hartley & Zisserman, "Multiple View Geometry", 2nd ed.,
//    §12.2): with P_i = [R_iᵀ | −R_iᵀ t_i] (camera_from_world) and rows p_iᵏ, each view gives
//      x_i p_i³ X − p_i¹ X = 0,   y_i p_i³ X − p_i² X = 0
//    for the homogeneous X; X is the right singular vector of the smallest singular value of
//    the 2N×4 matrix. For conditioning (H&Z §4.4.4) the world coordinates are first centred on
//    the mean camera centre and scaled by the mean distance to it, and each row pair is scaled
//    to unit norm.
// 3. Gauss-Newton on the reprojection error in pixels, through the distortion:
//      r_i(X) = π(R_iᵀ (X − t_i)) − z_i,   π = (fx, fy) ⊙ Distort(x, y) + (cx, cy)
//      ∂r_i/∂X = diag(fx, fy) · DistortJacobian(x, y) · [1/Z 0 −X/Z²; 0 1/Z −Y/Z²] · R_iᵀ
//    (Nocedal & Wright, "Numerical Optimization", 2nd ed., §10.3); a step that does not lower
//    the cost is halved, up to 10 times.
// 4. Checks, in this order: depth in every camera ≥ min_depth_m (kBehindCamera) and ≤
//    max_depth_m (kTooFar); parallax ≥ min_parallax_deg (kLowParallax); the reprojection error
//    of every view ≤ max_reprojection_error_px (kLargeError).
//
// Parallax is the largest angle at the point between the rays of two views. For N ≤ 30 views
// all pairs are compared; for longer tracks a two-sweep search (the view farthest in angle
// from the first one, then the view farthest from that one), which is exact for rays that turn
// monotonically along the track (a camera moving past the point) and never overestimates.
// Before the DLT the same measure on the observed bearing vectors rejects low-parallax tracks
// (including pure rotation, where the DLT has no unique solution).

#include <Eigen/Core>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::slam {

struct TriangulationOptions {
  // Smallest accepted largest angle at the point between two viewing rays (degrees).
  double min_parallax_deg = 1.0;
  // Largest accepted reprojection error of any single view after refinement (pixels).
  double max_reprojection_error_px = 2.0;
  // Smallest accepted depth (camera z) of the point in every view (metres).
  double min_depth_m = 0.05;
  // Largest accepted depth of the point in every view (metres).
  double max_depth_m = 200.0;
  // Gauss-Newton iterations after the DLT (0 keeps the linear solution).
  int refine_iterations = 5;

  OptionCheck Check() const;
};

enum class TriangulationStatus {
  kOk,
  kTooFewViews,   // Fewer than two observations.
  kLowParallax,   // Largest parallax below min_parallax_deg.
  kBehindCamera,  // Depth below min_depth_m (behind or too close) in some view.
  kTooFar,        // Depth above max_depth_m in some view.
  kLargeError,    // Reprojection error above max_reprojection_error_px in some view.
  kDegenerate,    // A pixel could not be undistorted, or the DLT gave a point at infinity.
};

const char* ToString(TriangulationStatus status);

struct TriangulationResult {
  TriangulationStatus status = TriangulationStatus::kDegenerate;
  // The estimate (meaningful from kBehindCamera on: the checks ran on it).
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();
  // Largest angle at the point between two viewing rays (see the header comment).
  double max_parallax_deg = 0.0;
  // Mean and largest pixel distance between the observations and the reprojected point.
  double mean_reprojection_error_px = 0.0;
  double max_reprojection_error_px = 0.0;
  // The view with the largest reprojection error (−1 before it is computed).
  int worst_view = -1;
  // Gauss-Newton iterations run.
  int iterations = 0;

  bool ok() const { return status == TriangulationStatus::kOk; }
};

// Triangulates one point seen in views i = 0..N−1 at `pixels[i]` (distorted pixel coordinates,
// OpenCV convention) by `camera` at pose `world_from_camera[i]`. The two vectors must have the
// same size, `camera` and `options` must pass Check() (CHECKs). Failures are statuses.
TriangulationResult TriangulatePoint(const geometry::PinholeRadTan& camera,
                                     const std::vector<geometry::Rigid3>& world_from_camera,
                                     const std::vector<Eigen::Vector2d>& pixels,
                                     const TriangulationOptions& options = {});

// TriangulatePoint, and while the result fails on the reprojection bound (kLargeError), the worst
// view is dropped and the point triangulated again: at most `max_dropped_views` times, and never
// below `min_views` views. `kept` (resized to the number of views) flags the views used by the
// returned result.
TriangulationResult TriangulateDroppingWorstViews(
    const geometry::PinholeRadTan& camera, const std::vector<geometry::Rigid3>& world_from_camera,
    const std::vector<Eigen::Vector2d>& pixels, const TriangulationOptions& options,
    int max_dropped_views, int min_views, std::vector<bool>* kept);

}  // namespace crop4d::slam
