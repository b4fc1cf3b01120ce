#include "crop4d/fusion/camera_refinement.h"

#include <ceres/normal_prior.h>

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <numbers>
#include <stdexcept>

namespace crop4d::fusion {
namespace {

bool SameCalibration(const RigCamera& rig, const slam::RowOptimiser::Input& pass) {
  return SameIntrinsics(rig.camera, *pass.camera) &&
         rig.body_from_camera.Matrix() == pass.body_from_camera.Matrix();
}

double Radians(double degrees) { return degrees * std::numbers::pi / 180.0; }

}  // namespace

bool SameIntrinsics(const geometry::PinholeRadTan& a, const geometry::PinholeRadTan& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.k1 == b.k1 && a.k2 == b.k2 && a.p1 == b.p1 &&
         a.p2 == b.p2 && a.k3 == b.k3;
}

OptionCheck CalibrationRefinementOptions::Check() const {
  OptionChecker c;
  c.AtLeast("min_cross_observations", min_cross_observations, 0)
      .Greater("focal_sigma_px", focal_sigma_px, 0.0)
      .Greater("principal_point_sigma_px", principal_point_sigma_px, 0.0)
      .Greater("distortion_sigma", distortion_sigma, 0.0)
      .Greater("rotation_sigma_deg", rotation_sigma_deg, 0.0)
      .Greater("lever_arm_sigma_m", lever_arm_sigma_m, 0.0);
  return c.Result();
}

std::vector<RigCamera> GroupPassesByCamera(const std::vector<slam::RowOptimiser::Input>& passes,
                                           const std::vector<bool>& apart) {
  if (!apart.empty() && apart.size() != passes.size()) {
    throw std::invalid_argument("GroupPassesByCamera: apart does not match the passes");
  }
  const auto is_apart = [&](std::size_t p) { return !apart.empty() && apart[p]; };
  std::vector<RigCamera> cameras;
  std::vector<bool> camera_apart;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (passes[p].camera == nullptr) continue;
    RigCamera* match = nullptr;
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      if (camera_apart[c] == is_apart(p) && SameCalibration(cameras[c], passes[p])) {
        match = &cameras[c];
      }
    }
    if (match == nullptr) {
      cameras.push_back({{}, *passes[p].camera, passes[p].body_from_camera});
      camera_apart.push_back(is_apart(p));
      match = &cameras.back();
    }
    match->passes.push_back(static_cast<int>(p));
  }
  return cameras;
}

void AddCalibrationPriors(const CalibrationRefinementOptions& options, const RigCamera& camera,
                          slam::CameraCalibrationBlocks* blocks, ceres::Problem* problem) {
  // No image of the camera in the problem: nothing observes its calibration.
  if (!problem->HasParameterBlock(blocks->intrinsics)) return;
  constexpr int kI = slam::CameraCalibrationBlocks::kIntrinsicsSize;
  const slam::CameraCalibrationBlocks written = slam::CameraCalibrationBlocks::From(camera.camera);
  Eigen::Matrix<double, kI, 1> sqrt_information;
  sqrt_information << 1.0 / options.focal_sigma_px, 1.0 / options.focal_sigma_px,
      1.0 / options.principal_point_sigma_px, 1.0 / options.principal_point_sigma_px,
      1.0 / options.distortion_sigma, 1.0 / options.distortion_sigma;
  problem->AddResidualBlock(
      new ceres::NormalPrior(sqrt_information.asDiagonal().toDenseMatrix(),
                             Eigen::Map<const Eigen::Matrix<double, kI, 1>>(written.intrinsics)),
      nullptr, blocks->intrinsics);
  problem->AddResidualBlock(
      new ceres::NormalPrior(Eigen::Matrix3d::Identity() / Radians(options.rotation_sigma_deg),
                             Eigen::Vector3d::Zero()),
      nullptr, blocks->rotation);
  if (!options.refine_lever_arm) {
    problem->SetParameterBlockConstant(blocks->lever_arm);
    return;
  }
  problem->AddResidualBlock(
      new ceres::NormalPrior(Eigen::Matrix3d::Identity() / options.lever_arm_sigma_m,
                             Eigen::Vector3d::Zero()),
      nullptr, blocks->lever_arm);
}

double RefinedCalibration::RotationChangeDeg() const {
  const Eigen::Quaterniond change =
      written_body_from_camera.rotation().inverse() * body_from_camera.rotation();
  return 2.0 * std::atan2(change.vec().norm(), std::abs(change.w())) * 180.0 / std::numbers::pi;
}

double RayAngleRmsDeg(const geometry::PinholeRadTan& camera_a,
                      const geometry::Rigid3& body_from_camera_a,
                      const geometry::PinholeRadTan& camera_b,
                      const geometry::Rigid3& body_from_camera_b) {
  double sum = 0;
  int count = 0;
  for (int i = 0; i <= 8; ++i) {
    for (int j = 0; j <= 6; ++j) {
      const Eigen::Vector2d pixel((0.05 + 0.1125 * i) * camera_a.width,
                                  (0.05 + 0.15 * j) * camera_a.height);
      Eigen::Vector3d ray_a, ray_b;
      if (!camera_a.Unproject(pixel, &ray_a) || !camera_b.Unproject(pixel, &ray_b)) continue;
      const Eigen::Vector3d a = body_from_camera_a.rotation() * ray_a.normalized();
      const Eigen::Vector3d b = body_from_camera_b.rotation() * ray_b.normalized();
      const double angle = std::atan2(a.cross(b).norm(), a.dot(b));
      sum += angle * angle;
      ++count;
    }
  }
  return count > 0 ? std::sqrt(sum / count) * 180.0 / std::numbers::pi : 0.0;
}

namespace {

bool SameRigid(const geometry::Rigid3& a, const geometry::Rigid3& b) {
  return a.translation() == b.translation() && a.rotation().coeffs() == b.rotation().coeffs();
}

}  // namespace

void UseRefinedCalibrations(const std::vector<RefinedCalibration>& first,
                            std::vector<slam::RowOptimiser::Input>* passes,
                            std::deque<geometry::PinholeRadTan>* storage,
                            const std::vector<bool>& keep) {
  for (const RefinedCalibration& c : first) {
    if (!c.refined) continue;
    storage->push_back(c.camera);
    for (std::size_t p = 0; p < passes->size(); ++p) {
      slam::RowOptimiser::Input& pass = (*passes)[p];
      if (!keep.empty() && keep[p]) continue;
      if (pass.camera != nullptr && SameIntrinsics(*pass.camera, c.written_camera) &&
          SameRigid(pass.body_from_camera, c.written_body_from_camera)) {
        pass.camera = &storage->back();
        pass.body_from_camera = c.body_from_camera;
      }
    }
  }
}

void ReportRefinedCalibrations(const std::vector<RefinedCalibration>& first,
                               std::vector<RefinedCalibration>* second) {
  for (RefinedCalibration& held : *second) {
    for (const RefinedCalibration& c : first) {
      if (c.refined && SameIntrinsics(held.written_camera, c.camera) &&
          SameRigid(held.written_body_from_camera, c.body_from_camera)) {
        held.refined = true;
        held.written_camera = c.written_camera;
        held.written_body_from_camera = c.written_body_from_camera;
        held.num_cross_observations =
            std::max(held.num_cross_observations, c.num_cross_observations);
      }
    }
  }
}

}  // namespace crop4d::fusion
