#pragma once

// Test helper: the camera the slam tests project through.

#include "crop4d/geometry/camera.h"

namespace crop4d::slam::testing {

// A 1280×960 wide-angle lens with noticeable distortion (≈ 60 px at the image corners).
inline geometry::PinholeRadTan DistortedTestCamera() {
  geometry::PinholeRadTan camera;
  camera.width = 1280;
  camera.height = 960;
  camera.fx = 1100;
  camera.fy = 1090;
  camera.cx = 640;
  camera.cy = 480;
  camera.k1 = -0.2;
  camera.k2 = 0.05;
  camera.p1 = 1e-3;
  camera.p2 = -5e-4;
  camera.k3 = 0.01;
  return camera;
}

}  // namespace crop4d::slam::testing
