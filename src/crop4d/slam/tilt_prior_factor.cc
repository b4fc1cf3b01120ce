#include "crop4d/slam/tilt_prior_factor.h"

#include <Eigen/Geometry>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

TiltPriorFactor::TiltPriorFactor(const Eigen::Vector3d& up_body, double sigma_rad)
    : up_body_(up_body.normalized()), inverse_sigma_(1.0 / sigma_rad) {
  if (!(sigma_rad > 0) || !(up_body.norm() > 0)) {
    throw std::invalid_argument("TiltPriorFactor: needs an axis and a positive sigma");
  }
}

ceres::CostFunction* TiltPriorFactor::Create(const Eigen::Vector3d& up_body, double sigma_rad) {
  return new TiltPriorFactor(up_body, sigma_rad);
}

bool TiltPriorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Eigen::Matrix3d R =
      Eigen::Map<const Eigen::Quaterniond>(parameters[0] + 3).normalized().toRotationMatrix();
  const Eigen::Vector3d up_world = R * up_body_;
  residuals[0] = inverse_sigma_ * up_world.x();
  residuals[1] = inverse_sigma_ * up_world.y();
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Matrix<double, 2, 6> J = Eigen::Matrix<double, 2, 6>::Zero();
    J.rightCols<3>() = -inverse_sigma_ * (R * geometry::Hat(up_body_)).topRows<2>();
    WritePoseJacobian<2>(J, parameters[0], jacobians[0]);
  }
  return true;
}

}  // namespace crop4d::slam
