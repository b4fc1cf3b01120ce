#pragma once

// Test scenes for the data association, without the simulator: a flat textured ground seen by
// the demo field's camera (640×480, fx = 280, 1.5 m above the ground, pitched 35° down, a wide
// field of view with the horizon in view), rendered through the lens distortion with
// mip-mapped texture sampling (so that the far ground does not alias) and fog towards the
// horizon. The true correspondence of any pixel is known: its ray meets the ground plane z = 0.

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <vector>

#include "crop4d/association/robust_matcher.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::association::testing {

inline constexpr double kDegree = 3.14159265358979323846 / 180.0;

// 640×480, fx = fy = 280, mild barrel distortion.
geometry::PinholeRadTan DemoCamera();

// world_from_camera of a camera at `position` whose optical axis points along `heading_rad`
// (from world +x towards +y) and `pitch_down_rad` below the horizon, without roll.
geometry::Rigid3 ForwardLookingPose(const Eigen::Vector3d& position, double heading_rad,
                                    double pitch_down_rad = 35 * kDegree);

// A small perturbation of a pose: translation by `translation_m` along a fixed direction and a
// rotation of `rotation_rad` about a fixed axis (SLAM pose error of known size).
geometry::Rigid3 Perturb(const geometry::Rigid3& pose, double translation_m, double rotation_rad);

enum class TextureKind {
  kRandom,    // soil-like noise at several scales with stones and leaves
  kPeriodic,  // one 0.96 m random tile repeated: every place has exact copies nearby
};

struct GroundTexture {
  std::vector<cv::Mat> pyramid;  // BGR, level 0 = full resolution
  double metres_per_texel = 0.006;
  // The texture covers [0, size] × [0, size] metres of world xy (mirrored beyond).
  double size_m = 12.0;
};

GroundTexture MakeGroundTexture(TextureKind kind, unsigned seed);

// The BGR image of the ground plane z = 0 (fog from fog_start_m to fog_end_m of horizontal
// range; sky above the horizon).
cv::Mat RenderGround(const GroundTexture& texture, const geometry::PinholeRadTan& camera,
                     const geometry::Rigid3& world_from_camera, double fog_start_m = 5.0,
                     double fog_end_m = 8.0);

// Where pixel's ray meets the ground z = 0, if it does within `max_range_m` (horizontal).
std::optional<Eigen::Vector3d> GroundPoint(const geometry::PinholeRadTan& camera,
                                           const geometry::Rigid3& world_from_camera,
                                           const Eigen::Vector2d& pixel, double max_range_m);

// A rendered image with its features (FeatureExtractor with the given budget).
struct View {
  geometry::Rigid3 world_from_camera;  // true pose
  cv::Mat image;
  features::FeatureSet features;
};
View MakeView(const GroundTexture& texture, const geometry::PinholeRadTan& camera,
              const geometry::Rigid3& world_from_camera, int max_num_features = 2000);

// The landmarks of a view: every feature whose ray meets the ground within max_range_m, at its
// true ground point plus Gaussian noise of `noise_m` per axis (seeded). Landmark ids are the
// indices of the returned list, and `positions` (when given) receives the positions by id.
std::vector<LandmarkObservation> GroundLandmarks(const View& view,
                                                 const geometry::PinholeRadTan& camera,
                                                 double max_range_m, double noise_m, unsigned seed,
                                                 std::vector<Eigen::Vector3d>* positions);

// Whether feature_b of view b is the true correspondence of feature_a of view a: the ground
// point of feature_a projects into b within `tolerance_px` of feature_b.
bool IsCorrectMatch(const View& a, const View& b, const geometry::PinholeRadTan& camera,
                    int feature_a, int feature_b, double tolerance_px = 3.0);

struct MatchQuality {
  int correct = 0;
  int wrong = 0;
  double precision() const { return correct + wrong > 0 ? double(correct) / (correct + wrong) : 0; }
};
MatchQuality Evaluate(const View& a, const View& b, const geometry::PinholeRadTan& camera,
                      const std::vector<LandmarkMatch>& matches, double tolerance_px = 3.0);

}  // namespace crop4d::association::testing
