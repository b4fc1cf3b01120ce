#pragma once

// Surface points: the features of an image that row SLAM did not make landmarks of, placed on the
// local surface of the landmarks seen around them, so that the robust association can project
// them into the other image too.
//
// The paper's algorithm (Dong et al., IROS 2017, Alg. 1) projects the landmarks L1 seen in I1.
// Only features that row SLAM tracked through two or more images have a landmark; on the demo
// field that leaves out a large part of the features of each image, and the naive baseline
// (whole-image matching) can match them while the landmark search cannot. The ground and the
// canopy are smooth at the scale of a few landmarks, so the feature's ray is intersected with the
// local plane (local_planes.h, the plane the homography warp uses) of its nearest landmark in the
// image, as a depth map interpolated from a sparse cloud would. The intersection is uncertain
// along the ray: its uncertainty is how far the neighbouring landmarks lie off that plane,
// measured along the ray (a feature between a leaf and the soil below it has neighbours on both,
// and one of them far off the plane), and the bounded search widens its box by the parallax
// that this makes in I2 (RobustMatcher::Options; LandmarkObservation::sigma_along_ray_m). A
// feature whose neighbours lie farther than max_sigma_m off the plane, or whose ray grazes the
// plane, gets no surface point.

#include <vector>

#include "crop4d/association/local_planes.h"
#include "crop4d/association/robust_matcher.h"
#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::association {

struct SurfacePointOptions {
  // Landmarks of the image, nearest in pixels, that place a feature (the nearest gives the
  // plane; all of them give the spread).
  int num_neighbors = 4;
  // The farthest of those must lie within this many pixels of the feature.
  double max_pixel_distance_px = 32.0;
  // Smallest and largest uncertainty along the ray, metres: the neighbours' largest distance off
  // the plane (along the ray) is clamped up to min_sigma_m, and a larger one than max_sigma_m
  // refuses the feature (a depth edge).
  double min_sigma_m = 0.02;
  double max_sigma_m = 0.15;
  // Smallest |cos| of the angle between the ray and the plane's normal (a grazing ray places the
  // point nowhere in particular).
  double min_incidence_cos = 0.2;
  // Points farther than this from the camera are left out, metres (as the landmarks are:
  // AssociateStageOptions::max_landmark_distance_m).
  double max_range_m = 5.0;

  OptionCheck Check() const;
};

// The surface points of image I1: one for every feature of `features` that no observation of
// `landmarks` (I1's landmarks, with their world positions) names, and that the options accept.
// Each has landmark −1, its position on the plane, and sigma_along_ray_m set. `planes` is the
// local-plane model of the pass's cloud (its landmark indices are those of `landmarks`).
std::vector<LandmarkObservation> SurfacePoints(const geometry::PinholeRadTan& camera,
                                               const geometry::Rigid3& world_from_camera,
                                               const features::FeatureSet& features,
                                               const std::vector<LandmarkObservation>& landmarks,
                                               const LocalPlanes& planes,
                                               const SurfacePointOptions& options);

}  // namespace crop4d::association
