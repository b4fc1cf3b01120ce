#pragma once

// SIFT descriptors of image I1's keypoints as they would look from camera C2, for the robust
// data association (DESIGN.md §2.3; Dong et al., IROS 2017). Around a landmark the scene
// is taken to be the local plane nᵀY = d (camera C1 frame); the plane induces the homography
// between the two normalised image planes (Hartley & Zisserman, Multiple View Geometry, 2nd ed.,
// §13.1, eq. 13.2, written for the plane nᵀY = d instead of nᵀY + d = 0):
//   y2 ~ H y1,   H = R21 + t21 nᵀ / d,
// with Y2 = R21 Y1 + t21 (camera_b_from_camera_a); in pixels, K2 H K1⁻¹ is the paper's
// H = K2 (R12 − t12 nᵀ/d) K1⁻¹. Pixels pass through each camera's distortion on the way.
//
// Instead of warping all of I1, only a small patch per keypoint is built, directly at the
// resolution its descriptor needs:
//   1. the keypoint (x1, size s1, angle θ1) is transferred to I2: x2 = h(x1), and the local
//      Jacobian J = ∂x2/∂x1 (central differences) gives its size s2 = s1 √|det J| and its
//      orientation: gradients transform by J⁻ᵀ, so the dominant gradient direction
//      (cos θ1, sin θ1) becomes J⁻ᵀ (cos θ1, sin θ1);
//   2. the patch is a square of I2's (distorted) pixel grid around x2, resampled so that the
//      keypoint has the fixed size s0 = 2σ (σ = descriptor_sigma): patch pixel p is I2 pixel
//      x2 + (s2 / s0)(p − c). Each patch pixel is mapped to I1 exactly at the nodes of a coarse
//      grid (undistort in C2 → ray ∩ plane → project into C1 → distort) and bilinearly between
//      them, then I1 is sampled with cv::remap from the level of its Gaussian pyramid whose
//      pixels are about the size of a patch pixel's footprint (so that shrinking does not
//      alias);
//   3. the patches are laid out side by side in a mosaic, the mosaic is blurred to σ (one 8-bit
//      Gaussian, cheaper than OpenCV's float one) and described by one call of OpenCV's
//      cv::SIFT::compute per batch, with every keypoint at octave 0, layer 0 (packed octave word
//      0; OpenCV unpacks octave = word & 255, layer = (word >> 8) & 255) and a SIFT instance whose
//      base blur is the assumed camera blur 0.5: OpenCV then builds a single octave without
//      upsampling, its base image is the mosaic itself, and each descriptor is computed at scale
//      s0 / 2 = σ on an image blurred to σ — the relation of blur to size of a keypoint SIFT
//      detected itself (Lowe, IJCV 2004, §3, §6). Patches are wide enough that the descriptor
//      window (4×4 cells of 3σ, rotated: radius 3σ·√2·(4 + 1)/2 in OpenCV) and the blur never
//      reach the neighbouring patch.
// The descriptors are then directly comparable with I2's cached 8-bit SIFT descriptors.
//
// Thread-safe: one call uses no shared state (its own cv::SIFT instance).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace cv {
class Mat;
}  // namespace cv

namespace crop4d::association {

// The transfer of pixels between two distorted images through a plane nᵀY = d of camera a's
// frame.
class PlaneTransfer {
 public:
  // `normal_in_a` need not be unit; `offset` = nᵀY for any point Y of the plane (non-zero: a
  // plane through camera a's centre is seen edge-on).
  PlaneTransfer(const geometry::PinholeRadTan& camera_a, const geometry::PinholeRadTan& camera_b,
                const geometry::Rigid3& camera_b_from_camera_a, const Eigen::Vector3d& normal_in_a,
                double offset);

  // Where pixel_a of image a appears in image b; false when the ray misses the plane in front of
  // both cameras or the lens model cannot be inverted.
  bool AToB(const Eigen::Vector2d& pixel_a, Eigen::Vector2d* pixel_b) const;
  // The inverse transfer.
  bool BToA(const Eigen::Vector2d& pixel_b, Eigen::Vector2d* pixel_a) const;
  // The homography between normalised image planes, y_b ~ H y_a.
  const Eigen::Matrix3d& H() const { return b_from_a_; }

 private:
  const geometry::PinholeRadTan* camera_a_;
  const geometry::PinholeRadTan* camera_b_;
  Eigen::Vector3d normal_over_offset_;  // n / d: a point Y of camera a's frame is on the plane
                                        // when (n/d)ᵀY = 1
  Eigen::Matrix3d b_from_a_;
  Eigen::Matrix3d a_from_b_;
  bool identity_ = false;  // the same camera at the same pose: pixels map onto themselves
};

struct PlaneWarpOptions {
  // Gaussian scale σ of the keypoints in the patches, patch pixels: the keypoint size is 2σ and
  // the patch is blurred to σ. 1.6 is SIFT's base scale (Lowe 2004); smaller values give smaller
  // patches (cheaper: the cost grows with σ²) and coarser descriptors.
  double descriptor_sigma = 1.6;
  // Patches per cv::SIFT::compute call. A patch is ≈ (30σ)² pixels and OpenCV's pyramid takes
  // ≈ 26 bytes per mosaic pixel (60 kB per patch at σ = 1.6); 64–128 patches per call were
  // fastest on a 640×480 pair (fewer calls vs. a mosaic that stays in cache).
  int patches_per_batch = 128;
  // The patch-to-I1 map is exact every this many patch pixels and bilinear in between.
  int map_node_spacing_px = 8;
  // A warp is refused when a viewing ray meets the plane at a grazing angle: |cos| of the angle
  // between the ray and the normal below this, in either camera.
  double min_view_cosine = 0.1;
  // A warp is refused when it changes the keypoint's area by more than this factor (either way).
  double max_area_change = 16.0;
  // Coarsest level of I1's Gaussian pyramid used for sampling.
  int max_pyramid_level = 5;
  // Describe every patch at angle 0 of I2's pixel grid ("upright") instead of at the transferred
  // orientation of I1's keypoint. The warp already brings I1's neighbourhood into I2's frame, so
  // the descriptor needs no rotation invariance; what SIFT's orientation assignment adds is its
  // instability: the dominant gradient direction of a blob-like keypoint flips between peaks of
  // similar height from one image to the other. Upright descriptors are compared with upright
  // descriptors of I2's keypoints (ComputeUprightDescriptors).
  bool upright = false;

  OptionCheck Check() const;
};

// One keypoint of I1 to describe as seen from C2, on the plane nᵀY = d of camera a's frame.
struct WarpRequest {
  std::int32_t feature = -1;
  Eigen::Vector3d normal_in_a = Eigen::Vector3d::UnitZ();
  double offset = 0;
};

// The keypoint of I1 transferred into I2.
struct WarpedKeypoint {
  // False when the warp was refused (grazing plane, failed transfer, extreme scale change); the
  // descriptor row is then zero.
  bool valid = false;
  Eigen::Vector2d pixel_b = Eigen::Vector2d::Zero();  // distorted pixel in I2
  float size_b = 0;                                   // SIFT size in I2, pixels
  float angle_b = 0;                                  // SIFT angle in I2, degrees [0, 360)
  int pyramid_level = 0;                              // I1 pyramid level sampled
};

struct PlaneWarpInput {
  const geometry::PinholeRadTan* camera_a = nullptr;
  const geometry::PinholeRadTan* camera_b = nullptr;
  geometry::Rigid3 camera_b_from_camera_a;
  // I1's features (pixel coordinates at the camera's resolution) and I1 itself, 8-bit grey,
  // BGR or BGRA. The image may be smaller than the camera's resolution (e.g. the downscaled
  // image the features were extracted from): its scale is taken from width / camera width.
  const features::FeatureSet* features_a = nullptr;
  const cv::Mat* image_a = nullptr;
};

// The warped keypoints of `requests`, in order, and their descriptors (row-major,
// requests.size() × 128, zero rows for refused warps) in `descriptors`.
std::vector<WarpedKeypoint> ComputeWarpedDescriptors(const PlaneWarpInput& input,
                                                     const std::vector<WarpRequest>& requests,
                                                     const PlaneWarpOptions& options,
                                                     std::vector<std::uint8_t>* descriptors);

// Descriptors of keypoints `indices` of an image at angle 0 of its own pixel grid, at their own
// position and size, computed exactly as the warped ones (the same patches, blur and SIFT
// instance, through the identity transfer), so that an upright warped descriptor of I1 and an
// upright descriptor of I2 differ only by what the images show. Row k of `descriptors` belongs to
// indices[k]; the returned flags say which were described (a keypoint whose patch cannot be
// built has a zero row and false).
std::vector<bool> ComputeUprightDescriptors(const geometry::PinholeRadTan& camera,
                                            const features::FeatureSet& features,
                                            const cv::Mat& image,
                                            const std::vector<std::int32_t>& indices,
                                            const PlaneWarpOptions& options,
                                            std::vector<std::uint8_t>* descriptors);

}  // namespace crop4d::association
