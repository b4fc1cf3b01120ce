#include "crop4d/slam/pose_manifold.h"

#include <Eigen/Core>
#include <Eigen/Geometry>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

Vector7d PoseToBlock(const geometry::Rigid3& world_from_body) {
  Vector7d block;
  block.head<3>() = world_from_body.translation();
  block.tail<4>() = world_from_body.rotation().coeffs();
  return block;
}

geometry::Rigid3 BlockToPose(const double* pose) {
  return geometry::Rigid3(Eigen::Quaterniond(pose[6], pose[3], pose[4], pose[5]),
                          Eigen::Vector3d(pose[0], pose[1], pose[2]));
}

Eigen::Matrix<double, 4, 3> QuaternionPlusJacobian(const Eigen::Quaterniond& q) {
  // q ⊗ (δφ/2, 1) = (v + ½(w δφ + v × δφ), w − ½ vᵀδφ) to first order.
  Eigen::Matrix<double, 4, 3> P;
  P.topRows<3>() = 0.5 * (q.w() * Eigen::Matrix3d::Identity() + geometry::Hat(q.vec()));
  P.bottomRows<1>() = -0.5 * q.vec().transpose();
  return P;
}

Eigen::Matrix<double, 7, 6, Eigen::RowMajor> PosePlusJacobian(const double* pose) {
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> J =
      Eigen::Matrix<double, 7, 6, Eigen::RowMajor>::Zero();
  J.topLeftCorner<3, 3>().setIdentity();
  J.bottomRightCorner<4, 3>() =
      QuaternionPlusJacobian(Eigen::Map<const Eigen::Quaterniond>(pose + 3));
  return J;
}

Eigen::Matrix<double, 6, 7, Eigen::RowMajor> PoseLiftJacobian(const double* pose) {
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> L =
      Eigen::Matrix<double, 6, 7, Eigen::RowMajor>::Zero();
  L.topLeftCorner<3, 3>().setIdentity();
  L.bottomRightCorner<3, 4>() =
      4.0 * QuaternionPlusJacobian(Eigen::Map<const Eigen::Quaterniond>(pose + 3)).transpose();
  return L;
}

bool PoseManifold::Plus(const double* x, const double* delta, double* x_plus_delta) const {
  Eigen::Map<const Eigen::Vector3d> t(x);
  Eigen::Map<const Eigen::Quaterniond> q(x + 3);
  Eigen::Map<const Eigen::Vector3d> dt(delta);
  Eigen::Map<const Eigen::Vector3d> dphi(delta + 3);
  Eigen::Map<Eigen::Vector3d> t_out(x_plus_delta);
  Eigen::Map<Eigen::Quaterniond> q_out(x_plus_delta + 3);
  t_out = t + dt;
  q_out = (q * geometry::ExpQuat(dphi)).normalized();
  return true;
}

bool PoseManifold::PlusJacobian(const double* x, double* jacobian) const {
  (Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>>(jacobian)) = PosePlusJacobian(x);
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* y_minus_x) const {
  Eigen::Map<const Eigen::Quaterniond> qx(x + 3);
  Eigen::Map<const Eigen::Quaterniond> qy(y + 3);
  (Eigen::Map<Eigen::Vector3d>(y_minus_x)) =
      Eigen::Map<const Eigen::Vector3d>(y) - Eigen::Map<const Eigen::Vector3d>(x);
  (Eigen::Map<Eigen::Vector3d>(y_minus_x + 3)) = geometry::LogQuat(qx.conjugate() * qy);
  return true;
}

bool PoseManifold::MinusJacobian(const double* x, double* jacobian) const {
  (Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>>(jacobian)) = PoseLiftJacobian(x);
  return true;
}

}  // namespace crop4d::slam
