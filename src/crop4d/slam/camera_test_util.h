#pragma once

// Test helpers: the camera the slam tests project through, and its mounting.

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/geometry/rotation.h"

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

// A camera looking forward along the body x axis, tilted 0.5 rad down, 1.5 m up.
inline geometry::Rigid3 TestBodyFromCamera() {
  Eigen::Matrix3d R;
  R << 0, 0, 1, -1, 0, 0, 0, -1, 0;  // camera (right, down, forward) → body (fwd, left, up)
  return geometry::Rigid3(R * geometry::ExpSO3(Eigen::Vector3d(-0.5, 0.0, 0.0)),
                          Eigen::Vector3d(0.4, 0.05, 1.5));
}

}  // namespace crop4d::slam::testing
