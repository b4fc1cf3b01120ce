#include "crop4d/slam/pose_prior_factor.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

TEST(PoseManifold, PlusMinusAndJacobians) {
  const PoseManifold manifold;
  const Vector7d x = PoseToBlock(
      Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.3, -0.2, 2.0)), Eigen::Vector3d(1, 2, 3)));
  Vector6d delta;
  delta << 0.1, -0.2, 0.3, 0.05, 0.02, -0.04;
  Vector7d y;
  ASSERT_TRUE(manifold.Plus(x.data(), delta.data(), y.data()));
  // Right perturbation of the rotation, additive world translation.
  const Rigid3 expected(BlockToPose(x.data()).rotation() * geometry::ExpQuat(delta.tail<3>()),
                        x.head<3>() + delta.head<3>());
  EXPECT_LT((BlockToPose(y.data()).translation() - expected.translation()).norm(), 1e-12);
  EXPECT_LT(geometry::AngleBetween(BlockToPose(y.data()).rotation(), expected.rotation()), 1e-12);
  Vector6d back;
  ASSERT_TRUE(manifold.Minus(y.data(), x.data(), back.data()));
  EXPECT_LT((back - delta).norm(), 1e-12);
  // PlusJacobian against differences, and Lift · Plus = I.
  Eigen::Matrix<double, 7, 6, Eigen::RowMajor> P;
  manifold.PlusJacobian(x.data(), P.data());
  for (int k = 0; k < 6; ++k) {
    Vector6d d = Vector6d::Zero();
    Vector7d yp, ym;
    d(k) = 1e-6;
    manifold.Plus(x.data(), d.data(), yp.data());
    d(k) = -1e-6;
    manifold.Plus(x.data(), d.data(), ym.data());
    EXPECT_LT(((yp - ym) / 2e-6 - P.col(k)).norm(), 1e-8) << k;
  }
  Eigen::Matrix<double, 6, 7, Eigen::RowMajor> L;
  manifold.MinusJacobian(x.data(), L.data());
  EXPECT_LT((L * P - Matrix6d::Identity()).norm(), 1e-12);
}

TEST(PosePriorFactor, JacobiansAndSolveAlone) {
  const Rigid3 prior(geometry::ExpQuat(Eigen::Vector3d(0.1, 0.2, -1.0)), Eigen::Vector3d(1, 0, 2));
  Matrix6d covariance = Matrix6d::Identity() * 1e-2;
  covariance(0, 1) = covariance(1, 0) = 3e-3;
  covariance(3, 5) = covariance(5, 3) = -2e-3;
  const PosePriorFactor factor(prior, covariance);
  const PoseManifold manifold;
  const Vector7d pose = PoseToBlock(
      prior * Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.3, -0.4, 0.2)), Eigen::Vector3d(1, 1, 1)));
  EXPECT_LT(testing::CheckJacobians(factor, {Vec(pose)}, {&manifold}).max_relative_error, 1e-6);

  Vector7d estimate = pose;
  ceres::Problem problem;
  problem.AddParameterBlock(estimate.data(), 7, new PoseManifold);
  problem.AddResidualBlock(PosePriorFactor::Create(prior, covariance), nullptr, estimate.data());
  ceres::Solver::Options options;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Rigid3 solved = BlockToPose(estimate.data());
  EXPECT_LT((solved.translation() - prior.translation()).norm(), 1e-8);
  EXPECT_LT(geometry::AngleBetween(solved.rotation(), prior.rotation()), 1e-8);
}

}  // namespace
}  // namespace crop4d::slam
