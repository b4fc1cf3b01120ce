#include "crop4d/slam/reprojection_factor.h"

#include <Eigen/Geometry>
#include <limits>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {
namespace {
constexpr double kMinDepth = 1e-6;
}  // namespace

ReprojectionFactor::ReprojectionFactor(const geometry::PinholeRadTan& camera,
                                       const geometry::Rigid3& body_from_camera,
                                       const Eigen::Vector2d& pixel, double sigma_px)
    : camera_(camera), pixel_(pixel) {
  if (!camera.Check().empty() || !(sigma_px > 0.0)) {
    throw std::invalid_argument("ReprojectionFactor: invalid camera or sigma");
  }
  const geometry::Rigid3 camera_from_body = body_from_camera.Inverse();
  camera_from_body_rotation_ = camera_from_body.RotationMatrix();
  camera_from_body_translation_ = camera_from_body.translation();
  inv_sigma_ = 1.0 / sigma_px;
}

ceres::CostFunction* ReprojectionFactor::Create(const geometry::PinholeRadTan& camera,
                                                const geometry::Rigid3& body_from_camera,
                                                const Eigen::Vector2d& pixel, double sigma_px) {
  return new ReprojectionFactor(camera, body_from_camera, pixel, sigma_px);
}

bool ReprojectionFactor::Evaluate(double const* const* parameters, double* residuals,
                                  double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0]);
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0] + 3);
  const Eigen::Map<const Eigen::Vector3d> point_world(parameters[1]);
  const Eigen::Matrix3d Rt = q.normalized().toRotationMatrix().transpose();
  const Eigen::Vector3d point_body = Rt * (point_world - t);
  const Eigen::Vector3d point_camera =
      camera_from_body_rotation_ * point_body + camera_from_body_translation_;
  Eigen::Matrix<double, 2, 3> d_r_d_pc;
  if (!WhitenedReprojection(camera_, pixel_, inv_sigma_, point_camera, residuals,
                            jacobians != nullptr ? &d_r_d_pc : nullptr)) {
    return false;
  }
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    Eigen::Matrix<double, 3, 6> d_pc_d_pose;
    d_pc_d_pose.leftCols<3>() = -camera_from_body_rotation_ * Rt;
    d_pc_d_pose.rightCols<3>() = camera_from_body_rotation_ * geometry::Hat(point_body);
    const Eigen::Matrix<double, 2, 6> J = d_r_d_pc * d_pc_d_pose;
    WritePoseJacobian<2>(J, parameters[0], jacobians[0]);
  }
  if (jacobians[1] != nullptr) {
    (Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>>(jacobians[1])) =
        d_r_d_pc * camera_from_body_rotation_ * Rt;
  }
  return true;
}

bool WhitenedReprojection(const geometry::PinholeRadTan& camera, const Eigen::Vector2d& pixel,
                          double inv_sigma, const Eigen::Vector3d& point_camera, double* residuals,
                          Eigen::Matrix<double, 2, 3>* d_r_d_pc) {
  const double z = point_camera.z();
  if (!(z > kMinDepth)) return false;
  const Eigen::Vector2d xy(point_camera.x() / z, point_camera.y() / z);
  const Eigen::Vector2d xy_d = camera.Distort(xy);
  const Eigen::Vector2d uv(camera.fx * xy_d.x() + camera.cx, camera.fy * xy_d.y() + camera.cy);
  (Eigen::Map<Eigen::Vector2d>(residuals)) = inv_sigma * (uv - pixel);
  if (d_r_d_pc == nullptr) return true;
  Eigen::Matrix<double, 2, 3> d_xy_d_pc;
  d_xy_d_pc << 1.0 / z, 0.0, -xy.x() / z, 0.0, 1.0 / z, -xy.y() / z;
  *d_r_d_pc = inv_sigma * Eigen::Vector2d(camera.fx, camera.fy).asDiagonal() *
              camera.DistortJacobian(xy) * d_xy_d_pc;
  return true;
}

double ReprojectionError(const geometry::PinholeRadTan& camera,
                         const geometry::Rigid3& body_from_camera,
                         const geometry::Rigid3& world_from_body,
                         const Eigen::Vector3d& point_world, const Eigen::Vector2d& pixel) {
  const geometry::Rigid3 camera_from_world = (world_from_body * body_from_camera).Inverse();
  Eigen::Vector2d projected;
  if (!camera.Project(camera_from_world * point_world, &projected)) {
    return std::numeric_limits<double>::infinity();
  }
  return (projected - pixel).norm();
}

}  // namespace crop4d::slam
