#include "crop4d/slam/pose_prior_factor.h"

#include <Eigen/Cholesky>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {

PosePriorFactor::PosePriorFactor(const geometry::Rigid3& world_from_body_prior,
                                 const Matrix6d& covariance)
    : translation_prior_(world_from_body_prior.translation()),
      rotation_prior_(world_from_body_prior.rotation()) {
  const Eigen::LLT<Matrix6d> llt(covariance.inverse());
  if (llt.info() != Eigen::Success) {
    throw std::invalid_argument("PosePriorFactor: covariance is not positive definite");
  }
  sqrt_information_ = llt.matrixL().transpose();
}

ceres::CostFunction* PosePriorFactor::Create(const geometry::Rigid3& world_from_body_prior,
                                             const Matrix6d& covariance) {
  return new PosePriorFactor(world_from_body_prior, covariance);
}

ceres::CostFunction* PosePriorFactor::Create(const geometry::Rigid3& world_from_body_prior,
                                             double sigma_translation, double sigma_rotation) {
  Vector6d variances;
  variances << Eigen::Vector3d::Constant(sigma_translation * sigma_translation),
      Eigen::Vector3d::Constant(sigma_rotation * sigma_rotation);
  return new PosePriorFactor(world_from_body_prior, Matrix6d(variances.asDiagonal()));
}

bool PosePriorFactor::Evaluate(double const* const* parameters, double* residuals,
                               double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0]);
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0] + 3);
  Vector6d r;
  r.head<3>() = t - translation_prior_;
  r.tail<3>() = geometry::LogQuat(rotation_prior_.conjugate() * q.normalized());
  (Eigen::Map<Vector6d>(residuals)) = sqrt_information_ * r;
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Matrix6d J = Matrix6d::Zero();
    J.topLeftCorner<3, 3>().setIdentity();
    J.bottomRightCorner<3, 3>() = geometry::RightJacobianInverseSO3(r.tail<3>());
    const Matrix6d SJ = sqrt_information_ * J;
    WritePoseJacobian<6>(SJ, parameters[0], jacobians[0]);
  }
  return true;
}

}  // namespace crop4d::slam
