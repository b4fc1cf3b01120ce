#include "crop4d/slam/motion_constraint_factor.h"

#include <Eigen/Geometry>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

MotionConstraintFactor::MotionConstraintFactor(const Eigen::Vector3d& forward_axis_body,
                                               double sigma) {
  if (!(sigma > 0) || !(forward_axis_body.norm() > 0)) {
    throw std::invalid_argument("MotionConstraintFactor: sigma and the axis must be positive");
  }
  const Eigen::Vector3d f = forward_axis_body.normalized();
  const Eigen::Vector3d a1 = f.unitOrthogonal();
  const Eigen::Vector3d a2 = f.cross(a1);
  weighted_axes_.row(0) = a1.transpose() / sigma;
  weighted_axes_.row(1) = a2.transpose() / sigma;
}

ceres::CostFunction* MotionConstraintFactor::Create(const Eigen::Vector3d& forward_axis_body,
                                                    double sigma) {
  return new MotionConstraintFactor(forward_axis_body, sigma);
}

bool MotionConstraintFactor::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const double* pose = parameters[0];
  const Eigen::Map<const Eigen::Quaterniond> q(pose + 3);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Map<const Eigen::Vector3d> vel(parameters[1]);
  const Eigen::Vector3d vel_body = R.transpose() * vel;
  Eigen::Map<Eigen::Vector2d> r(residuals);
  r = weighted_axes_ * vel_body;
  if (jacobians == nullptr) return true;
  if (jacobians[0] != nullptr) {
    Eigen::Matrix<double, 2, 6> tangent = Eigen::Matrix<double, 2, 6>::Zero();
    tangent.rightCols<3>() = weighted_axes_ * geometry::Hat(vel_body);
    WritePoseJacobian<2>(tangent, pose, jacobians[0]);
  }
  if (jacobians[1] != nullptr) {
    Eigen::Map<Eigen::Matrix<double, 2, 3, Eigen::RowMajor>> j(jacobians[1]);
    j = weighted_axes_ * R.transpose();
  }
  return true;
}

}  // namespace crop4d::slam
