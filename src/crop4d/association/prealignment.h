#pragma once

// What association needs of two passes' geometry before the bounded search (DESIGN.md §2.3):
// the height of the ground under a pass (the plane the image footprints are cut on), and the
// pre-alignment of one pass onto another whose poses a metre-level GPS placed.
//
// Pre-alignment: the poses may be metres off, so footprint overlap cannot choose the image
// pairs. Instead every `stride`-th image of pass a is matched by the naive method (whole
// images: robust_matcher.h NaiveMatch) with the images of pass b within `radius_m` that face
// the same way, sampled kPassBSamplingFactor times denser. The matched features that are cloud
// points of both passes are the same ground point as each pass placed it; their 4-DOF alignment
// (fusion/pass_alignment.h, points within `max_landmark_distance_m` of both cameras only)
// maps pass a's frame onto pass b's.

#include <Eigen/Core>
#include <functional>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/features/matcher.h"
#include "crop4d/fusion/pass_alignment.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::association {

// Pass b's images are sampled this many times denser than pass a's: each sampled image of a
// then has an image of b close to its own viewpoint (the naive matcher needs nearly the same
// view) even where b was driven faster or its poses are off along the row, while the number of
// image pairs stays a third of matching every image of b.
inline constexpr int kPassBSamplingFactor = 3;

struct PreAlignmentOptions {
  // Every `stride`-th image of pass a is matched (every max(1, stride / kPassBSamplingFactor)-th
  // of pass b).
  int stride = 9;
  // Image pairs whose cameras are at most this far apart horizontally, m (and face the same
  // way: optical axes less than 90° apart).
  double radius_m = 5.0;
  // Only points within this range of both cameras align the passes, m: the ground and crop the
  // bounded search will match, not the distant tree line.
  double max_landmark_distance_m = 5.0;
  features::PairMatcher::Options naive;
  fusion::PassAlignmentOptions alignment;

  // Empty when the options are valid, else which option is wrong and why.
  OptionCheck Check() const;
};

// A pass as the pre-alignment sees it. The pointers must outlive the call.
struct PreAlignmentPass {
  const geometry::PinholeRadTan* camera = nullptr;
  // world_from_camera of each image, in the pass's own frame.
  const std::vector<geometry::Rigid3>* poses = nullptr;
  // The features of each image.
  const std::vector<features::FeatureSet>* features = nullptr;
  // The pass's cloud point (its frame) observed by feature `feature` of image `image`, if any.
  std::function<std::optional<Eigen::Vector3d>(int image, int feature)> cloud_point;
};

// The image pairs (image of a, image of b) the pre-alignment matches.
std::vector<std::pair<int, int>> PreAlignmentImagePairs(
    const std::vector<geometry::Rigid3>& poses_a, const std::vector<geometry::Rigid3>& poses_b,
    const PreAlignmentOptions& options);

// The 4-DOF transform from pass a's frame to pass b's (b_from_a; not ok when too few ground
// points were matched). The naive matches run in parallel (TBB: the caller's arena decides
// the threads); the result does not depend on the threads.
fusion::PassAlignment PreAlignPasses(const PreAlignmentPass& a, const PreAlignmentPass& b,
                                     const PreAlignmentOptions& options);

// A low quantile of a pass's cloud heights (kGroundQuantile): the ground under the plants.
inline constexpr double kGroundQuantile = 0.25;
// Without cloud points, the ground is taken this far below the pass's first camera, m: the
// reference rig's camera height (sim/sim_config.h CameraConfig::height_m).
inline constexpr double kFallbackCameraHeightM = 1.5;

// The height of the ground under a pass from its cloud point heights (the kGroundQuantile
// quantile), else kFallbackCameraHeightM below `first_camera_z`, else 0 (no cloud, no camera).
double GroundHeight(std::vector<double> cloud_heights, std::optional<double> first_camera_z);

}  // namespace crop4d::association
