#pragma once

// Pinhole camera with radial-tangential distortion, the OpenCV / Kalibr "radtan" model
// (DESIGN.md §3). Camera frame: x right, y down, z forward. For a point (X, Y, Z), Z > 0:
//   x = X/Z, y = Y/Z, r² = x² + y²
//   radial = 1 + k1 r² + k2 r⁴ + k3 r⁶
//   xd = x radial + 2 p1 x y + p2 (r² + 2x²)
//   yd = y radial + p1 (r² + 2y²) + 2 p2 x y
//   u = fx xd + cx,  v = fy yd + cy
// (OpenCV documentation, "Camera Calibration and 3D Reconstruction".)

#include <Eigen/Core>

#include "crop4d/core/option_check.h"

namespace crop4d::geometry {

struct PinholeRadTan {
  int width = 0;
  int height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
  double k1 = 0, k2 = 0, p1 = 0, p2 = 0, k3 = 0;

  // Valid intrinsics: positive size and focal lengths, finite coefficients.
  OptionCheck Check() const;
  Eigen::Matrix3d K() const;

  // Normalised undistorted (x, y) to normalised distorted (xd, yd).
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy) const;
  // Inverse of Distort by Gauss-Newton on the 2x2 Jacobian (converges to < 1e-12 in a few
  // iterations inside the image for realistic lenses). Returns false if it did not converge.
  bool Undistort(const Eigen::Vector2d& xy_distorted, Eigen::Vector2d* xy) const;
  // 2x2 Jacobian d(Distort)/d(xy).
  Eigen::Matrix2d DistortJacobian(const Eigen::Vector2d& xy) const;
  // Whether xy lies where the distortion is a valid, locally invertible lens model: positive
  // radial factor and det(DistortJacobian) > 0. Undistort rejects roots that fail this (the
  // spurious solutions past the fold of a strong barrel lens).
  bool IsRegularRoot(const Eigen::Vector2d& xy) const;

  // Camera-frame point to distorted pixel. Returns false when Z <= 0.
  bool Project(const Eigen::Vector3d& point_in_camera, Eigen::Vector2d* pixel) const;
  // Pixel to the ray through it, normalised so that z = 1. Returns false if undistortion
  // failed to converge.
  bool Unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray) const;

  // Whether a pixel lies inside the image, with `margin` pixels kept free at the border. OpenCV
  // pixel convention: integer coordinates are pixel centres, so the image spans
  // [−0.5, width − 0.5] × [−0.5, height − 0.5].
  bool IsInImage(const Eigen::Vector2d& pixel, double margin = 0.0) const;
};

}  // namespace crop4d::geometry
