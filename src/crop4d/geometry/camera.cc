#include "crop4d/geometry/camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>

namespace crop4d::geometry {
namespace {

// Gauss-Newton stops when the residual |Distort(xy) − xy_d| falls below this (normalised
// image units, i.e. ~1e-9 px for a 1000 px focal length), relative to max(1, |xy_d|).
constexpr double kUndistortTolerance = 1e-13;
constexpr int kUndistortMaxIterations = 50;

}  // namespace

OptionCheck PinholeRadTan::Check() const {
  OptionChecker c;
  c.Greater("width", width, 0)
      .Greater("height", height, 0)
      .Finite("fx", fx)
      .Greater("fx", fx, 0.0)
      .Finite("fy", fy)
      .Greater("fy", fy, 0.0)
      .Finite("cx", cx)
      .Finite("cy", cy)
      .Finite("k1", k1)
      .Finite("k2", k2)
      .Finite("p1", p1)
      .Finite("p2", p2)
      .Finite("k3", k3);
  return c.Result();
}

Eigen::Matrix3d PinholeRadTan::K() const {
  Eigen::Matrix3d k;
  k << fx, 0.0, cx,  //
      0.0, fy, cy,   //
      0.0, 0.0, 1.0;
  return k;
}

Eigen::Vector2d PinholeRadTan::Distort(const Eigen::Vector2d& xy) const {
  // OpenCV documentation, "Camera Calibration and 3D Reconstruction" (the formula in
  // camera.h's header comment), with s1..s4 and k4..k6 zero.
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return {x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x),
          y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y};
}

Eigen::Matrix2d PinholeRadTan::DistortJacobian(const Eigen::Vector2d& xy) const {
  // Derivative of Distort (OpenCV formula above), with ∂r²/∂x = 2x, ∂r²/∂y = 2y and
  // d(radial)/d(r²) = k1 + 2 k2 r² + 3 k3 r⁴:
  //   ∂xd/∂x = radial + 2x² radial' + 2 p1 y + 6 p2 x
  //   ∂xd/∂y = 2xy radial' + 2 p1 x + 2 p2 y
  //   ∂yd/∂x = 2xy radial' + 2 p1 x + 2 p2 y
  //   ∂yd/∂y = radial + 2y² radial' + 6 p1 y + 2 p2 x
  const double x = xy.x();
  const double y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  const double dradial = k1 + r2 * (2.0 * k2 + 3.0 * k3 * r2);
  const double cross = 2.0 * x * y * dradial + 2.0 * p1 * x + 2.0 * p2 * y;
  Eigen::Matrix2d J;
  J << radial + 2.0 * x * x * dradial + 2.0 * p1 * y + 6.0 * p2 * x, cross,  //
      cross, radial + 2.0 * y * y * dradial + 6.0 * p1 * y + 2.0 * p2 * x;
  return J;
}

bool PinholeRadTan::IsRegularRoot(const Eigen::Vector2d& xy) const {
  // Inside the region where the lens model is valid the distortion is orientation-preserving
  // (det J > 0) and does not flip points through the centre (radial factor > 0). Past the fold
  // of a strong barrel lens either fails, e.g. for k1 = −0.28, k2 = 0 the spurious root of
  // r (1 + k1 r²) = 0.9 at r ≈ −2.3 has det J > 0 but a negative radial factor.
  const double r2 = xy.squaredNorm();
  const double radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3));
  return radial > 0.0 && DistortJacobian(xy).determinant() > 0.0;
}

bool PinholeRadTan::Undistort(const Eigen::Vector2d& xy_distorted, Eigen::Vector2d* xy) const {
  // Gauss-Newton (here Newton, the system being square) on r(xy) = Distort(xy) − xy_d, started
  // at xy_d: xy ← xy − J(xy)⁻¹ r(xy) (Nocedal & Wright, "Numerical Optimization", 2nd ed.,
  // §11.1).
  // A root beyond the fold of a barrel lens (where the distortion maps back inwards) is
  // rejected, as is a diverging iteration.
  if (!xy_distorted.allFinite()) return false;
  const double tolerance = kUndistortTolerance * std::max(1.0, xy_distorted.norm());
  Eigen::Vector2d estimate = xy_distorted;
  for (int iteration = 0; iteration < kUndistortMaxIterations; ++iteration) {
    const Eigen::Vector2d residual = Distort(estimate) - xy_distorted;
    const Eigen::Matrix2d J = DistortJacobian(estimate);
    const double det = J.determinant();
    if (!residual.allFinite() || !std::isfinite(det)) return false;
    if (residual.norm() <= tolerance) {
      if (!IsRegularRoot(estimate)) return false;
      *xy = estimate;
      return true;
    }
    if (std::abs(det) < 1e-12) return false;
    estimate -= J.inverse() * residual;
  }
  // Allow a residual slightly above the tolerance if the iteration stalled at round-off.
  const Eigen::Vector2d residual = Distort(estimate) - xy_distorted;
  if (residual.norm() <= 1e3 * tolerance && IsRegularRoot(estimate)) {
    *xy = estimate;
    return true;
  }
  return false;
}

bool PinholeRadTan::Project(const Eigen::Vector3d& point_in_camera, Eigen::Vector2d* pixel) const {
  // Pinhole projection then distortion, u = fx xd + cx, v = fy yd + cy (OpenCV documentation,
  // "Camera Calibration and 3D Reconstruction").
  const double z = point_in_camera.z();
  if (!(z > 0.0) || !point_in_camera.allFinite()) return false;
  const Eigen::Vector2d xd = Distort(point_in_camera.head<2>() / z);
  *pixel = Eigen::Vector2d(fx * xd.x() + cx, fy * xd.y() + cy);
  return true;
}

bool PinholeRadTan::Unproject(const Eigen::Vector2d& pixel, Eigen::Vector3d* ray) const {
  // Inverse of Project: K⁻¹ then Undistort.
  const Eigen::Vector2d xd((pixel.x() - cx) / fx, (pixel.y() - cy) / fy);
  Eigen::Vector2d xy;
  if (!Undistort(xd, &xy)) return false;
  *ray = Eigen::Vector3d(xy.x(), xy.y(), 1.0);
  return true;
}

bool PinholeRadTan::IsInImage(const Eigen::Vector2d& pixel, double margin) const {
  // OpenCV pixel convention: integer coordinates are pixel centres, so the image covers
  // [−0.5, width − 0.5] × [−0.5, height − 0.5].
  return pixel.x() >= margin - 0.5 && pixel.x() <= width - 0.5 - margin &&
         pixel.y() >= margin - 0.5 && pixel.y() <= height - 0.5 - margin;
}

}  // namespace crop4d::geometry
