#include "crop4d/slam/gps_factor.h"

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Geometry>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {
namespace {

Eigen::Vector3d SqrtInformation(const GpsMeasurement& m) {
  if (!(m.sigma_horizontal > 0.0 && m.sigma_vertical > 0.0)) {
    throw std::invalid_argument("GPS factor: sigmas must be positive");
  }
  return Eigen::Vector3d(1.0 / m.sigma_horizontal, 1.0 / m.sigma_horizontal,
                         1.0 / m.sigma_vertical);
}

}  // namespace

GpsFactor::GpsFactor(const GpsMeasurement& measurement, const Eigen::Vector3d& p_body_antenna)
    : position_world_(measurement.position_world),
      p_body_antenna_(p_body_antenna),
      sqrt_information_diagonal_(SqrtInformation(measurement)) {}

ceres::CostFunction* GpsFactor::Create(const GpsMeasurement& measurement,
                                       const Eigen::Vector3d& p_body_antenna) {
  return new GpsFactor(measurement, p_body_antenna);
}

bool GpsFactor::Evaluate(double const* const* parameters, double* residuals,
                         double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> t(parameters[0]);
  const Eigen::Map<const Eigen::Quaterniond> q(parameters[0] + 3);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  (Eigen::Map<Eigen::Vector3d>(residuals)) =
      sqrt_information_diagonal_.cwiseProduct(t + R * p_body_antenna_ - position_world_);
  if (jacobians != nullptr && jacobians[0] != nullptr) {
    Eigen::Matrix<double, 3, 6> J;
    J.leftCols<3>() = Eigen::Matrix3d::Identity();
    J.rightCols<3>() = -R * geometry::Hat(p_body_antenna_);
    const Eigen::Matrix<double, 3, 6> SJ = sqrt_information_diagonal_.asDiagonal() * J;
    WritePoseJacobian<3>(SJ, parameters[0], jacobians[0]);
  }
  return true;
}

GpsInterpolatedFactor::GpsInterpolatedFactor(const GpsMeasurement& measurement,
                                             const Eigen::Vector3d& p_body_antenna, double dt,
                                             double s)
    : position_world_(measurement.position_world),
      p_body_antenna_(p_body_antenna),
      sqrt_information_diagonal_(SqrtInformation(measurement)),
      weights_(ComputeGpInterpolationWeights(dt, s)) {}

ceres::CostFunction* GpsInterpolatedFactor::Create(const GpsMeasurement& measurement,
                                                   const Eigen::Vector3d& p_body_antenna, double dt,
                                                   double s) {
  return new ceres::AutoDiffCostFunction<GpsInterpolatedFactor, 3, 7, 3, 3, 7, 3, 3>(
      new GpsInterpolatedFactor(measurement, p_body_antenna, dt, s));
}

}  // namespace crop4d::slam
