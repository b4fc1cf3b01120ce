#pragma once

// The factor of a ground tie (fusion/ground_ties.h): the same ground point, fixed in the body
// frames of a state of pass a (p_a) and of a state of pass b (p_b), must land at the same place
// across the row and vertically:
//   d = (t_b + R_b p_b) − (t_a + R_a p_a),   r = (aᵀ d / σ_across, d_z / σ_vertical),
// with a the horizontal unit vector across pass a's track. Along the row nothing is asked.
// Parameter blocks: pose_a[7], pose_b[7] (slam/state_layout.h); differentiated by ceres::Jet
// (tested against numerical differences on the pose manifold).

#include <ceres/autodiff_cost_function.h>

#include <Eigen/Core>

#include "crop4d/slam/se3_templated.h"

namespace crop4d::fusion {

class GroundTieFactor {
 public:
  GroundTieFactor(const Eigen::Vector3d& point_body_a, const Eigen::Vector3d& point_body_b,
                  const Eigen::Vector3d& across, double sigma_across, double sigma_vertical)
      : point_body_a_(point_body_a),
        point_body_b_(point_body_b),
        across_(across),
        weight_across_(1.0 / sigma_across),
        weight_vertical_(1.0 / sigma_vertical) {}

  static ceres::CostFunction* Create(const Eigen::Vector3d& point_body_a,
                                     const Eigen::Vector3d& point_body_b,
                                     const Eigen::Vector3d& across, double sigma_across,
                                     double sigma_vertical) {
    return new ceres::AutoDiffCostFunction<GroundTieFactor, 2, 7, 7>(
        new GroundTieFactor(point_body_a, point_body_b, across, sigma_across, sigma_vertical));
  }

  template <typename T>
  bool operator()(const T* pose_a, const T* pose_b, T* residuals) const {
    const auto world = [](const T* pose, const Eigen::Vector3d& p) {
      const Eigen::Matrix<T, 4, 1> q(pose[3], pose[4], pose[5], pose[6]);
      const Eigen::Matrix<T, 3, 1> t(pose[0], pose[1], pose[2]);
      return Eigen::Matrix<T, 3, 1>(t + slam::templated::QuatToMatrix(q) * p.cast<T>());
    };
    const Eigen::Matrix<T, 3, 1> d = world(pose_b, point_body_b_) - world(pose_a, point_body_a_);
    residuals[0] = T(weight_across_) * d.dot(across_.cast<T>());
    residuals[1] = T(weight_vertical_) * d.z();
    return true;
  }

 private:
  Eigen::Vector3d point_body_a_;
  Eigen::Vector3d point_body_b_;
  Eigen::Vector3d across_;
  double weight_across_;
  double weight_vertical_;
};

}  // namespace crop4d::fusion
