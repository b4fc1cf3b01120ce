#pragma once

// Reprojection factor of a landmark in one image (DESIGN.md §2.2), with fixed intrinsics
// (pinhole + radial-tangential distortion, crop4d/geometry/camera.h) and fixed extrinsics
// body_from_camera. Parameter blocks: pose[7] (world_from_body, state_layout.h) and
// point_world[3]. Meant for a robust loss (ceres::HuberLoss / CauchyLoss) and SPARSE_SCHUR with
// the landmarks eliminated first (the counterpart of GTSAM's smart factors).
//
//   X_b = Rᵀ (X − t)                      (body_from_world · X)
//   X_c = R_cb X_b + t_cb                 (camera_from_body = body_from_camera⁻¹)
//   (x, y) = (X_c/Z_c, Y_c/Z_c),  (u, v) = (fx, fy) ⊙ Distort(x, y) + (cx, cy)
//   r = ((u, v) − z) / σ_px
// Jacobians (R ← R Exp(δφ), t ← t + δt, so Rᵀ ← Exp(−δφ) Rᵀ and X_b ← X_b + [X_b]× δφ):
//   ∂X_c/∂δt = −R_cb Rᵀ,   ∂X_c/∂δφ = R_cb [X_b]×,   ∂X_c/∂X = R_cb Rᵀ
//   ∂(u,v)/∂X_c = diag(fx, fy) · DistortJacobian(x, y) · [1/Z 0 −X/Z²; 0 1/Z −Y/Z²].
// A point at or behind the camera (Z_c ≤ 1e-6 m) makes Evaluate return false: Ceres then
// rejects the step, and such observations should be removed before solving.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::slam {

class ReprojectionFactor final : public ceres::SizedCostFunction<2, 7, 3> {
 public:
  ReprojectionFactor(const geometry::PinholeRadTan& camera,
                     const geometry::Rigid3& body_from_camera, const Eigen::Vector2d& pixel,
                     double sigma_px);
  static ceres::CostFunction* Create(const geometry::PinholeRadTan& camera,
                                     const geometry::Rigid3& body_from_camera,
                                     const Eigen::Vector2d& pixel, double sigma_px = 1.0);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  geometry::PinholeRadTan camera_;
  Eigen::Matrix3d camera_from_body_rotation_;
  Eigen::Vector3d camera_from_body_translation_;
  Eigen::Vector2d pixel_;
  double inv_sigma_;
};

// The projection every reprojection factor shares: the residual ((u, v) − pixel) · inv_sigma of
// the camera-frame point `point_camera` into `residuals` and, when `d_r_d_pc` is given, its
// Jacobian ∂r/∂X_c. False (nothing written) when the point is not in front of the camera
// (Z_c ≤ 1e-6 m).
bool WhitenedReprojection(const geometry::PinholeRadTan& camera, const Eigen::Vector2d& pixel,
                          double inv_sigma, const Eigen::Vector3d& point_camera, double* residuals,
                          Eigen::Matrix<double, 2, 3>* d_r_d_pc);

// Pixel distance between the observation and the projection of point_world (for rejecting
// outliers above 10 px, DESIGN.md §2.2); +infinity when the point is not in front of the camera.
double ReprojectionError(const geometry::PinholeRadTan& camera,
                         const geometry::Rigid3& body_from_camera,
                         const geometry::Rigid3& world_from_body,
                         const Eigen::Vector3d& point_world, const Eigen::Vector2d& pixel);

}  // namespace crop4d::slam
