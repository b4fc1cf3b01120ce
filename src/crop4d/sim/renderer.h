#pragma once

// Headless OpenGL 3.3 renderer of a World (EGL, surfaceless Mesa platform; DESIGN.md §6):
// textured terrain with mipmaps, procedural 3D plants, distant tree line and sky,
// Lambertian + ambient shading with sun shadows (shadow map), multisample anti-aliasing, and
// the camera's radial-tangential distortion applied to the final image. Deterministic: the
// same inputs give byte-identical images. What is smooth across a triangle (lighting, haze,
// the soil's large-scale colour, the shadow's fade) is computed per vertex; the pixels get the
// fine soil texture and the shadow-map test (shaders.h).

#include <memory>
#include <opencv2/core/mat.hpp>
#include <string>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

struct RenderOptions {
  geometry::PinholeRadTan camera;  // size, intrinsics and distortion of the output image
  int msaa_samples = 4;            // multisample anti-aliasing
  bool shadows = true;             // sun shadows (shadow map)
  int shadow_map_size = 2048;      // texels per side of the sun's shadow map
  double max_depth_m = 200.0;      // far clip plane (extended to reach the tree line)
  // Anisotropic texture filtering (1 = off); 0 = automatic: 8 on hardware GPUs, off on Mesa's
  // software rasterisers (llvmpipe's anisotropic filter costs ~100× a trilinear fetch).
  int anisotropy = 0;
  double shadow_extent_m = 24.0;  // side of the square around the view that receives shadows
  // Soil texture: texels per side (a power of two) and the ground it covers.
  int soil_texture_size = 4096;
  double soil_texture_extent_m = 4.0;
  // Trilinear filtering of the soil texture; off: bilinear in the nearest mip level (faster
  // on llvmpipe, visually the same on the noisy soil).
  bool soil_trilinear = false;
  // Plants: drawn up to this distance; levels of detail by distance, for a 500 px focal
  // length (the distances scale with the camera's fx).
  double plant_draw_distance_m = 40.0;
  double lod_full_distance_m = 1.6;
  double lod_medium_distance_m = 4.5;
  double lod_coarse_distance_m = 8.0;
  double lod_far_distance_m = 16.0;
  double tree_line_distance_m = 30.0;  // from the field's bounds to the surrounding tree line
  int mesh_cache_mb = 512;             // plant meshes kept on the GPU, least recently used go
  OptionCheck Check() const;
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

  // The time of the next frames, seconds since the session start: the leaves' sway in the wind
  // (SessionConditions::wind_sway_m) follows it.
  void SetTime(double seconds);

  // Renders the view of a camera (OpenCV camera frame, world_from_camera in ENU).
  // `bgr`: CV_8UC3, distorted like a real lens. `depth` (optional): CV_32F, the z of the
  // visible surface in the camera frame at each distorted pixel, 0 for sky.
  void Render(const geometry::Rigid3& world_from_camera, cv::Mat* bgr, cv::Mat* depth = nullptr);

  // The undistorted pinhole camera that is rendered before the distortion is applied (same
  // focal length, larger field of view).
  const geometry::PinholeRadTan& undistorted_camera() const;
  // GL_RENDERER and GL_VERSION of the context.
  const std::string& gl_description() const;
  // Triangles drawn by the last Render (terrain, plants and tree line).
  long long last_triangle_count() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace crop4d::sim
