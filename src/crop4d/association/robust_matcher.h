#pragma once

// Data association between two images of different row passes (another row and/or another
// session), the paper's robust method (Dong et al., "4D Crop Monitoring", IROS 2017;
// DESIGN.md §2.3), and the naive baseline it is compared with.
//
// Robust, for images I1 (pass a, with landmarks L1 from row SLAM) and I2 (pass b), both posed
// in one world frame:
//   1. back-projection bounded search: each landmark of L1 seen in I1 is projected into I2 with
//      the SLAM poses; only I2's features inside a square box around the projection are
//      candidates. The box's half-size follows the pose uncertainty: a position error σp at
//      depth z moves the projection by fx·σp/z pixels and a rotation error σr by fx·σr, so
//        r = min_search_radius_px + search_sigmas · (fx·σp/z + fx·σr + fx·σd·sin θ/z),
//      where the last term is for a point known only to σd along I1's ray (a surface point,
//      surface_points.h; 0 for a landmark): moved along that ray, it moves in I2 by fx·σd·sin θ/z,
//      θ the angle between the rays of C1 and C2 to it;
//   2. when the baseline between C1 and C2 exceeds 0.5 m, the landmark's descriptor is computed
//      on I1 warped by the homography its local plane induces (plane_warp.h), the plane being
//      fitted to the landmark's neighbours in L1 (local_planes.h); a poor fit falls back to the
//      ground plane (or to the unwarped descriptor). Below the baseline, I1's own descriptor is
//      used. The warped patch already lies in I2's frame, so by default (upright_after_warp) it
//      is described at angle 0 of I2's pixel grid and compared with I2's candidates described
//      the same way (plane_warp.h, PlaneWarpOptions::upright) rather than with their cached
//      descriptors, whose orientation SIFT assigned in I2 alone: on the demo field, of the
//      keypoint pairs across rows that lie within 2 cm of each other and met in a search box,
//      more than half had orientations more than 30° apart, and their descriptors did not match;
//   3. the candidate with the smallest descriptor distance is kept when it is distinctive: the
//      best distance is below max_ratio times the best distance of a candidate at another place
//      (Lowe's ratio test within the box; a second keypoint at the same place, e.g. SIFT's
//      second orientation, is not a rival); optionally also within a scale ratio of the size the
//      keypoint should have in I2; each feature of I2 keeps its best landmark only;
//   4. the matches of the pair are verified with 8-point RANSAC on the fundamental matrix, on
//      undistorted pixels (features::EstimateEpipolarGeometry, as PairMatcher).
//
// Naive: FLANN nearest neighbours over the whole images, Lowe's ratio test, mutual check and
// 8-point RANSAC — features::PairMatcher's steps, with each image undistorted by its own camera.
//
// Threading: Match works on one pair in the calling thread (OpenCV may use its TBB pool inside
// cv::SIFT::compute). It is const and keeps no state, so concurrent calls on different pairs (the
// caller's parallel loop over pairs) are safe.

#include <Eigen/Core>
#include <cstdint>
#include <numbers>
#include <vector>

#include "crop4d/association/local_planes.h"
#include "crop4d/association/plane_warp.h"
#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/features/matcher.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace cv {
class Mat;
}  // namespace cv

namespace crop4d::association {

// A landmark of pass a seen in image I1.
struct LandmarkObservation {
  // The observing feature: an index into I1's FeatureSet.
  std::int32_t feature = -1;
  // The landmark's position, world frame.
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  // The landmark's id in pass a (its index into the pass's landmarks, and into LocalPlanes when
  // those were built from the same positions); −1 for a surface point (surface_points.h).
  std::int32_t landmark = -1;
  // Uncertainty of the position along camera a's ray, m: 0 for a triangulated landmark, the
  // local surface's depth spread for a surface point. The search box grows by the parallax it
  // makes in I2.
  double sigma_along_ray_m = 0;
};

// A match between feature `feature_a` of I1 and feature `feature_b` of I2.
struct LandmarkMatch {
  std::int32_t feature_a = -1;
  std::int32_t feature_b = -1;
  // L2 distance of the 8-bit SIFT descriptors that decided the match (the warped one for a warped
  // landmark).
  float distance = 0;
  // The landmark of pass a, −1 for the naive method.
  std::int32_t landmark = -1;

  bool operator==(const LandmarkMatch&) const = default;
};

struct AssociationStats {
  // Landmarks given.
  int num_landmarks = 0;
  // Landmarks that project inside I2, in front of C2.
  int num_projected = 0;
  // Projected landmarks with at least one candidate in their box.
  int num_with_candidates = 0;
  // Candidates examined (descriptor distances computed), summed over the landmarks. For the naive
  // method: I1's features times I2's features.
  std::int64_t num_candidates = 0;
  // Warped descriptors computed, and warps refused (grazing plane, extreme scale change; the
  // unwarped descriptor was used instead).
  int num_warped = 0;
  int num_warps_refused = 0;
  // Landmarks whose local plane fit was poor (ground normal or no warp used instead).
  int num_plane_fallbacks = 0;
  // Keypoints of I2 described upright (the candidates of the warped landmarks).
  int num_upright_b = 0;
  // Matches before RANSAC (after the distance, distinctiveness and one-to-one checks).
  int num_putative = 0;
  // Matches after RANSAC: the returned matches.
  int num_inliers = 0;
  // Whether RANSAC found a fundamental matrix with at least min_num_inliers inliers (always true
  // when verification is off and there are matches).
  bool verified = false;
  // Distance between the camera centres, metres (0 for the naive method).
  double baseline_m = 0;
  // Wall time of the call.
  double seconds = 0;
};

struct AssociationResult {
  // Verified matches, ordered by feature_a.
  std::vector<LandmarkMatch> matches;
  AssociationStats stats;
};

// One image pair. Pointers are borrowed for the call.
struct RobustPairInput {
  // I1, of pass a.
  const geometry::PinholeRadTan* camera_a = nullptr;
  geometry::Rigid3 world_from_camera_a;
  const features::FeatureSet* features_a = nullptr;
  const std::vector<LandmarkObservation>* landmarks_a = nullptr;
  // Local planes of pass a's landmark cloud, built once per pass (nullptr: every landmark takes
  // the plane fallback).
  const LocalPlanes* planes = nullptr;
  // I1 itself (8-bit grey, BGR or BGRA, at the camera's resolution or reduced, e.g. the image the
  // features were extracted from); read only when the baseline calls for a warp (nullptr or
  // empty: no warp).
  const cv::Mat* image_a = nullptr;
  // I2, of pass b.
  const geometry::PinholeRadTan* camera_b = nullptr;
  geometry::Rigid3 world_from_camera_b;
  const features::FeatureSet* features_b = nullptr;
  // I2 itself (as image_a); read only when a warp is used with upright_after_warp, to describe
  // I2's candidates upright (nullptr or empty: the warped descriptors are compared with I2's
  // cached ones, at the transferred orientation).
  const cv::Mat* image_b = nullptr;
};

class RobustMatcher {
 public:
  enum class PlaneFallback {
    // Warp with the ground plane through the landmark (normal world +z).
    kGroundNormal,
    // Use the landmark's unwarped descriptor.
    kNoWarp,
  };

  struct Options {
    // --- Bounded search: box half-size (pixels of I2)
    //     min_search_radius_px + search_sigmas·(fx·sigma_position_m/depth + fx·sigma_rotation_rad).
    double min_search_radius_px = 8.0;
    double search_sigmas = 3.0;
    // Relative position uncertainty of the two cameras and the landmark (RTK-grade poses), m.
    double sigma_position_m = 0.03;
    // Relative attitude uncertainty of the two cameras, rad (0.3°).
    double sigma_rotation_rad = 0.3 * std::numbers::pi / 180.0;
    // Cap on the half-size, pixels.
    double max_search_radius_px = 100.0;
    // Landmarks nearer than this to C2 (depth) are not searched, m.
    double min_depth_m = 0.1;
    // A candidate's SIFT size must be within this factor of the size the landmark's keypoint
    // should have in I2 (predicted by the warp, or by the depth ratio without a warp); 0: no
    // scale check.
    double max_scale_ratio = 2.0;

    // --- Warp
    // Warp I1 when the baseline between the cameras exceeds this, m (the paper's 0.5 m). 0:
    // always; infinity: never.
    double warp_min_baseline_m = 0.5;
    // What replaces a poor local plane fit.
    PlaneFallback plane_fallback = PlaneFallback::kGroundNormal;
    PlaneWarpOptions warp;
    // Compare warped descriptors upright with upright descriptors of I2's candidates (needs
    // RobustPairInput::image_b); false: at the transferred orientation with I2's cached ones.
    bool upright_after_warp = true;

    // --- Decision
    // Distinctiveness: best distance < max_ratio · best distance of a candidate elsewhere.
    double max_ratio = 0.8;
    // Largest accepted descriptor distance (L2 of the 8-bit descriptors, whose norm is ≈ 512).
    double max_descriptor_distance = 300.0;
    // Candidates closer than this to the best one are the same place, not rivals, pixels.
    double same_point_radius_px = 2.0;
    // Each feature of I2 keeps only its best (smallest distance) landmark.
    bool one_to_one = true;

    // --- Verification: 8-point RANSAC on F (undistorted pixels, Sampson distance in pixels).
    bool verify = true;
    features::EpipolarVerificationOptions verification;

    OptionCheck Check() const;
  };

  explicit RobustMatcher(Options options);

  AssociationResult Match(const RobustPairInput& input) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

// The naive baseline on two whole images: FLANN (or exhaustive) nearest neighbours, Lowe's ratio
// test, mutual check, 8-point RANSAC — the steps and options of features::PairMatcher, with
// each image's keypoints undistorted by its own camera. Matches carry landmark −1.
AssociationResult NaiveMatch(const geometry::PinholeRadTan& camera_a,
                             const features::FeatureSet& features_a,
                             const geometry::PinholeRadTan& camera_b,
                             const features::FeatureSet& features_b,
                             const features::PairMatcher::Options& options);
// The same with descriptor indices built once per image and reused across pairs.
AssociationResult NaiveMatch(const geometry::PinholeRadTan& camera_a,
                             const features::FeatureSet& features_a,
                             const features::DescriptorIndex& index_a,
                             const geometry::PinholeRadTan& camera_b,
                             const features::FeatureSet& features_b,
                             const features::DescriptorIndex& index_b,
                             const features::PairMatcher::Options& options);

}  // namespace crop4d::association
