#pragma once

// Reprojection factor that also refines the camera's calibration (the joint 4D problem's
// `refine_calibration`, fusion/joint_optimiser.h): the intrinsics fx, fy, cx, cy, k1, k2 and
// corrections of the camera's mounting T_BS — a rotation δ and a lever-arm shift τ (body frame)
// — shared by every image of one camera. The other distortion terms (p1, p2, k3) stay as
// calibrated.
//
// The pose at the capture instant is predicted from the state at the stamp with the pass's time
// offset td and the state's velocity and rate held for the solve, exactly as
// TimeOffsetReprojectionFactor with FixedMotion (td = 0 and held: the plain factor):
//   X_b  = Eᵀ Rᵀ (X − p − v td),  E = Exp(ω td)      (point in the body frame of the capture)
//   X_c0 = R_cb (X_b − τ) + t_cb                       (camera frame of the calibrated T_BS,
//                                                       its lever arm t_bc moved by τ)
//   X_c  = Exp(−δ) X_c0                                (body_from_camera rotation R_bc Exp(δ))
//   (x, y) = X_c / Z_c,  (u, v) = (fx, fy) ⊙ Distort_{k1,k2}(x, y) + (cx, cy),
//   r = ((u, v) − z) / σ_px.
// Jacobians beyond TimeOffsetReprojectionFactor's (which hold with ∂r/∂X_b = ∂r/∂X_c Exp(−δ) R_cb):
//   ∂X_c/∂δ = Exp(−δ) [X_c0]× Jr(−δ),   ∂X_c/∂τ = −Exp(−δ) R_cb;
//   ∂(u, v)/∂(fx, fy, cx, cy) = [x_d 0 1 0; 0 y_d 0 1];
//   ∂(u, v)/∂k1 = (fx x r², fy y r²),  ∂(u, v)/∂k2 = (fx x r⁴, fy y r⁴)   (r² = x² + y²).
// Parameter blocks: pose[7], point_world[3], td[1], intrinsics[6], rotation[3], lever_arm[3]
// (CameraCalibrationBlocks).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/time_offset_reprojection_factor.h"

namespace crop4d::slam {

// The refinable part of one camera's calibration as two parameter blocks.
struct CameraCalibrationBlocks {
  static constexpr int kIntrinsicsSize = 6;
  static constexpr int kRotationSize = 3;
  static constexpr int kLeverArmSize = 3;
  double intrinsics[kIntrinsicsSize] = {0, 0, 0, 0, 0, 0};  // fx, fy, cx, cy, k1, k2
  double rotation[kRotationSize] = {0, 0, 0};   // δ, rad: body_from_camera R = R_bc Exp(δ)
  double lever_arm[kLeverArmSize] = {0, 0, 0};  // τ, m: body_from_camera t = t_bc + τ

  // The blocks of `camera` as calibrated (δ = 0).
  static CameraCalibrationBlocks From(const geometry::PinholeRadTan& camera);
  // `nominal` with the blocks' fx, fy, cx, cy, k1, k2.
  geometry::PinholeRadTan Camera(const geometry::PinholeRadTan& nominal) const;
  // `nominal` (body_from_camera) with its rotation corrected by δ and its lever arm by τ.
  geometry::Rigid3 BodyFromCamera(const geometry::Rigid3& nominal) const;
};

class CalibratedReprojectionFactor final
    : public ceres::SizedCostFunction<2, 7, 3, 1, CameraCalibrationBlocks::kIntrinsicsSize,
                                      CameraCalibrationBlocks::kRotationSize,
                                      CameraCalibrationBlocks::kLeverArmSize> {
 public:
  // `camera` gives p1, p2, k3 and the image size; `body_from_camera` the calibrated T_BS that δ
  // and τ correct; `motion` the state's velocity and rate, held.
  CalibratedReprojectionFactor(const geometry::PinholeRadTan& camera,
                               const geometry::Rigid3& body_from_camera,
                               const Eigen::Vector2d& pixel, double sigma_px,
                               const TimeOffsetReprojectionFactor::FixedMotion& motion);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  geometry::PinholeRadTan camera_;
  Eigen::Matrix3d camera_from_body_rotation_;
  Eigen::Vector3d camera_from_body_translation_;
  Eigen::Vector2d pixel_;
  double inv_sigma_;
  TimeOffsetReprojectionFactor::FixedMotion motion_;
};

}  // namespace crop4d::slam
