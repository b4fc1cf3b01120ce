#pragma once

// The true 3D point that a pixel of a recorded image sees, for evaluating feature matches
// against the ground truth of a synthetic field (DESIGN.md §8):
//
//   point_world = world_from_camera_true · (Unproject(pixel) · depth(pixel))
//
// with the true camera pose of the image and the camera-z depth of the visible surface at that
// (distorted) pixel. The pose and the depth come from a TruthGeometry: SimulatedFieldTruth
// re-creates the simulator's World from FIELD/ground_truth/simulate.yaml and renders the depth
// (Renderer::Render), tests use a fake. Keypoints on a depth edge (a leaf over the soil, a
// plant's silhouette against the far field) see two surfaces at once: their true point is
// unknown, not guessed.

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::eval {

// A camera-z depth map, metres, row-major, at the pixel centres of the (distorted) image; 0
// where nothing is seen (sky) or the depth is unknown.
struct DepthImage {
  int width = 0;
  int height = 0;
  std::vector<float> z;

  bool empty() const { return z.empty(); }
  float at(int u, int v) const { return z[static_cast<std::size_t>(v) * width + u]; }
};

// Where the depth maps came from (SimulatedFieldTruth; zeros for other sources).
struct DepthSourceStats {
  std::int64_t requested = 0;    // Depth() calls
  std::int64_t from_field = 0;   // FIELD/ground_truth/<session>/cam0_depth/<t>.png (--depth)
  std::int64_t from_cache = 0;   // the evaluation's own cache of rendered maps
  std::int64_t rendered = 0;     // rendered now
  std::int64_t unavailable = 0;  // no truth pose, unknown session, or rendering disabled
  double setup_seconds = 0.0;    // World, renderer and Renderer::SetSession
  double render_seconds = 0.0;   // Renderer::Render
};

// The true geometry of every image of a synthetic field.
class TruthGeometry {
 public:
  virtual ~TruthGeometry() = default;

  // The true camera of the image at `t` of `session`: intrinsics and world_from_camera (OpenCV
  // camera frame). False when the truth has no image at `t`.
  virtual bool TrueCamera(const std::string& session, Timestamp t, geometry::PinholeRadTan* camera,
                          geometry::Rigid3* world_from_camera) = 0;

  // The depth map of that image (same size as the camera). False when it is not available.
  // Callers ask for the images of one session after another, in time order within a session:
  // a rendering source then sets each session up once.
  virtual bool Depth(const std::string& session, Timestamp t, DepthImage* depth) = 0;

  virtual DepthSourceStats stats() const { return {}; }
};

struct TruePointOptions {
  // Edge test on the 3×3 pixels around the keypoint's nearest pixel: along each of the four
  // lines through the centre (horizontal, vertical, both diagonals) the centre's depth must lie
  // within this many metres of the depth that a plane through its two neighbours gives there
  // (their harmonic mean: inverse depth is affine along an image line for a plane). A smooth
  // surface seen at a grazing angle passes (a plain span threshold would reject every distant
  // soil pixel), a step between two surfaces fails. 3 cm: leaves over soil, overlapping leaves.
  double max_edge_m = 0.03;
  // Depths beyond this are not used (the tree line; the 16-bit millimetre depth format
  // saturates at 65.5 m), m.
  double max_depth_m = 60.0;

  OptionCheck Check() const;
};

enum class TruePointStatus {
  kOk,
  kNoTruth,    // no true pose or depth map for the image
  kNoSurface,  // outside the image, or sky (zero depth) in the 3×3 neighbourhood
  kDepthEdge,  // the neighbourhood spans a depth discontinuity
};

const char* ToString(TruePointStatus status);

struct TruePointResult {
  TruePointStatus status = TruePointStatus::kNoTruth;
  Eigen::Vector3d point_world = Eigen::Vector3d::Zero();  // valid when status is kOk
  double depth_m = 0.0;                                   // camera z at the pixel

  bool ok() const { return status == TruePointStatus::kOk; }
};

// The depth at the sub-pixel position `pixel` (OpenCV convention: integer coordinates are
// pixel centres): the edge test above on the 3×3 neighbourhood of the nearest pixel, then the
// bilinear interpolation of the inverse depth of the four pixel centres around `pixel` (exact
// for a plane along the image axes). Returns kOk, kNoSurface or kDepthEdge.
TruePointStatus SampleDepth(const DepthImage& depth, const Eigen::Vector2d& pixel,
                            const TruePointOptions& options, double* depth_m);

// The true world point of `pixel` in an image with this depth map, camera and true pose.
TruePointResult TruePointInImage(const DepthImage& depth, const geometry::PinholeRadTan& camera,
                                 const geometry::Rigid3& world_from_camera,
                                 const Eigen::Vector2d& pixel, const TruePointOptions& options);

// The same, with the image's camera, pose and depth from `truth` (one image; for many pixels
// of one image use TruePointInImage with one Depth() call).
TruePointResult TruePoint(TruthGeometry& truth, const std::string& session, Timestamp t,
                          const Eigen::Vector2d& pixel, const TruePointOptions& options);

// 16-bit PNG depth in millimetres, the format of the simulator's --depth maps
// (FIELD/ground_truth/<session>/cam0_depth/<t>.png): 0 = nothing, 65535 = saturated (read back
// as 0: unknown). Read returns false when the file is missing or not such an image; Write is
// atomic and throws InputError when it cannot write.
bool ReadDepthPng(const std::string& path, DepthImage* depth);
void WriteDepthPng(const std::string& path, const DepthImage& depth);

struct SimulatedFieldTruthOptions {
  // Rendered depth maps are kept here as <dir>/<session>/<t>.png and read back on later runs;
  // empty: nothing is kept.
  std::string depth_cache_dir;
  // Render the depth maps found neither in the field (--depth) nor in the cache; off: those
  // images have no depth (their matches count as unknown).
  bool render = true;
};

// The truth of a field written by `crop4d simulate`: true camera poses from
// FIELD/ground_truth/<session>/cam0_poses.tum, the camera from ground_truth/simulate.yaml, and
// depth maps from the field's cam0_depth/ (when simulated with --depth), the cache, or rendered
// from the World that simulate.yaml re-creates (the simulator's renderer with its geometry
// options; no shadows and a small soil texture, which change colours only). The World and the
// EGL renderer are made on the first depth map that must be rendered.
class SimulatedFieldTruth : public TruthGeometry {
 public:
  // Reads simulate.yaml; throws InputError when it is missing or malformed.
  SimulatedFieldTruth(const std::string& field, const SimulatedFieldTruthOptions& options);
  ~SimulatedFieldTruth() override;
  SimulatedFieldTruth(const SimulatedFieldTruth&) = delete;
  SimulatedFieldTruth& operator=(const SimulatedFieldTruth&) = delete;

  bool TrueCamera(const std::string& session, Timestamp t, geometry::PinholeRadTan* camera,
                  geometry::Rigid3* world_from_camera) override;
  // Throws std::runtime_error when a depth map must be rendered and no EGL/OpenGL is available.
  bool Depth(const std::string& session, Timestamp t, DepthImage* depth) override;
  DepthSourceStats stats() const override;

  // The sessions of simulate.yaml in recording order, and whether it rained before each.
  const std::vector<std::string>& sessions() const;
  const std::vector<bool>& rain_before() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace crop4d::eval
