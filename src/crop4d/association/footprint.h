#pragma once

// Which images of two row passes see the same ground (DESIGN.md §2.3: only neighbours are
// matched). The ground footprint of an image is the part of a horizontal ground plane that it
// sees: the image border is sampled, each border pixel unprojected through the lens distortion
// and its ray intersected with the plane z = ground_z. The reference camera looks forward and
// down with the horizon in view, so rays near the top of the image meet the ground far away or
// never; the footprint is therefore clipped to a horizontal range around the camera (where
// features are dense enough to match), which also keeps it bounded. The clipped region (a
// view frustum's trace on a plane, intersected with a disc) is convex, and it is stored as a
// convex polygon in world xy.
//
// The overlap of two footprints is the area of their intersection divided by the smaller area:
// 1 when one contains the other (the same view), 0 when they are disjoint. Image pairs are
// scored by default by the view overlap instead (ViewOverlap: the share of each image's ground
// pixels that the other sees at a comparable scale), which, unlike the area overlap, pairs
// cameras facing each other from adjacent rows at a distance where they can match; footprints
// then only pre-select the candidates.
//
//   std::vector<ImagePair> pairs =
//       SelectImagePairs(poses_a, poses_b, camera_a, camera_b, ground_z, PairSelectionOptions{});

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::association {

struct FootprintOptions {
  // The footprint ends at this horizontal distance from the camera, metres.
  double max_range_m = 6.0;
  // Border pixels sampled on each side of the image (corners included once); the range circle
  // is sampled at 8× as many azimuths.
  int samples_per_side = 16;

  OptionCheck Check() const;
};

// A convex polygon of world xy, counter-clockwise; empty when the camera sees no ground (or is
// below the ground plane).
struct Footprint {
  std::vector<Eigen::Vector2d> polygon;
  Eigen::AlignedBox2d bounds;  // empty box when the polygon is empty
  double area_m2 = 0;

  bool empty() const { return polygon.size() < 3 || area_m2 <= 0; }
};

// The footprint of a camera at `world_from_camera` on the plane z = ground_z.
Footprint GroundFootprint(const geometry::PinholeRadTan& camera,
                          const geometry::Rigid3& world_from_camera, double ground_z,
                          const FootprintOptions& options = FootprintOptions());

// Intersection area / smaller area, in [0, 1]; 0 when either footprint is empty.
double FootprintOverlap(const Footprint& a, const Footprint& b);

// An image of pass a and an image of pass b that see the same ground.
struct ImagePair {
  std::int32_t image_a = -1;
  std::int32_t image_b = -1;
  // The view overlap, or the footprint overlap (PairSelectionOptions::max_scale_change = 0).
  double overlap = 0;

  bool operator==(const ImagePair&) const = default;
};

struct PairSelectionOptions {
  FootprintOptions footprint;
  // Smallest overlap of a pair (view overlap, or footprint overlap; see max_scale_change).
  double min_overlap = 0.3;
  // At most this many images of pass b per image of pass a, the best by overlap.
  int max_pairs_per_image = 1;
  // Use every stride-th image of pass a (0, stride, 2·stride, ...).
  int stride = 1;
  // Largest angle between the two optical axes, degrees (180: no limit). Views of the same
  // ground from opposite directions (adjacent rows driven back and forth) overlap as much as
  // views from one direction; this excludes them when the descriptors are not expected to
  // survive such a change.
  double max_axis_angle_deg = 180.0;
  // How pairs are scored. > 0: by the view overlap (ViewOverlap), ground points counting as
  // shared only when their distances from the two cameras differ by at most this factor (so
  // that the same ground has a comparable scale in both images; the footprints then only
  // pre-select the candidates). 0: by the footprint overlap.
  double max_scale_change = 1.5;
  // Pixel samples across each image's width for the view overlap (rows in proportion).
  int view_samples = 24;

  OptionCheck Check() const;
};

// The view overlap of two images: the smaller of the shares of each image's view of the ground
// that the other sees at a comparable scale. The share of image a: a grid of `view_samples` ×
// (view_samples · height / width) pixels of image a is intersected with the plane z = ground_z;
// the ground points within footprint.max_range_m of camera a count, and the share is the
// fraction of them that project into image b (in front of it, through a regular part of its
// lens model) with distances from the two camera centres within a factor max_scale_change (no
// scale condition when it is 0). Symmetric, in [0, 1]; 1 for the same view; 0 when a camera
// sees no ground. Taking the smaller share keeps a camera behind the other, which sees all of
// its ground and more, from scoring 1.
//
// Unlike the footprint overlap it counts ground by image area (where features are) rather than
// by ground area, and it leaves out ground that the two cameras see at very different
// distances. Two cameras facing each other from adjacent rows see the same ground strip
// between them; the footprint overlap is largest when they are as far apart as the footprint
// range allows, and the ground near either camera, where most of its features are, is then far
// from and tiny in the other image, whereas the view overlap picks cameras about twice the
// feature distance apart, which see the strip between them at the same scale.
double ViewOverlap(const geometry::PinholeRadTan& camera_a,
                   const geometry::Rigid3& world_from_camera_a,
                   const geometry::PinholeRadTan& camera_b,
                   const geometry::Rigid3& world_from_camera_b, double ground_z,
                   const PairSelectionOptions& options = {});

// For each used image of pass a, the images of pass b that overlap it (view overlap, or
// footprint overlap when max_scale_change = 0) by at least min_overlap, best first, at most
// max_pairs_per_image; sorted by (image_a, decreasing overlap, image_b). Footprints and ground
// views are computed once per image, and only pairs whose footprint bounding boxes meet are
// scored (a uniform grid over pass b's boxes). Deterministic.
std::vector<ImagePair> SelectImagePairs(const std::vector<geometry::Rigid3>& poses_a,
                                        const std::vector<geometry::Rigid3>& poses_b,
                                        const geometry::PinholeRadTan& camera_a,
                                        const geometry::PinholeRadTan& camera_b, double ground_z,
                                        const PairSelectionOptions& options = {});

}  // namespace crop4d::association
