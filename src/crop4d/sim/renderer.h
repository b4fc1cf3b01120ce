#pragma once

// Headless OpenGL 3.3 renderer of a World (EGL, surfaceless Mesa platform; DESIGN.md §6):
// textured terrain with mipmaps, procedural 3D plants, distant tree line and sky,
// Lambertian + ambient shading with sun shadows (shadow map), multisample anti-aliasing, and
// the camera's radial-tangential distortion applied to the final image. Deterministic: the
// same inputs give byte-identical images.

#include <memory>

#include <opencv2/core/mat.hpp>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

struct RenderOptions {
  geometry::PinholeRadTan camera;  // size, intrinsics and distortion of the output image
  int msaa_samples = 4;            // multisample anti-aliasing
  int shadow_map_size = 2048;      // texels per side of the sun's shadow map
  double max_depth_m = 200.0;      // far clip plane
  bool Check() const;
};

class Renderer {
 public:
  // Creates the EGL context and uploads the terrain. Throws std::runtime_error with a clear
  // message when no EGL/OpenGL 3.3 is available.
  Renderer(const World& world, const RenderOptions& options);
  ~Renderer();
  Renderer(const Renderer&) = delete;
  Renderer& operator=(const Renderer&) = delete;

  // Builds the plants of this date and the soil of this soil epoch, sets sun and sky.
  void SetSession(const SessionConditions& conditions);

  // Renders the view of a camera (OpenCV camera frame, world_from_camera in ENU).
  // `bgr`: CV_8UC3, distorted like a real lens. `depth` (optional): CV_32F, the z of the
  // visible surface in the camera frame at each distorted pixel, 0 for sky.
  void Render(const geometry::Rigid3& world_from_camera, cv::Mat* bgr, cv::Mat* depth = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace crop4d::sim
