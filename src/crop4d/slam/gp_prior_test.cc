#include "crop4d/slam/gp_prior.h"

#include <ceres/cost_function.h>
#include <gtest/gtest.h>

#include <memory>
#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

// Motion with constant body velocity: T(t) = T0 Exp(t ϖ).
GpState ConstantVelocityState(const Rigid3& world_from_body_0, const Vector6d& varpi, double t) {
  GpState s;
  s.world_from_body = world_from_body_0 * geometry::ExpSE3(t * varpi);
  SetBodyVelocity(varpi, &s);
  return s;
}

std::vector<std::vector<double>> Blocks(const GpState& a, const GpState& b) {
  return {Vec(PoseToBlock(a.world_from_body)), Vec(a.vel_world), Vec(a.rate_body),
          Vec(PoseToBlock(b.world_from_body)), Vec(b.vel_world), Vec(b.rate_body)};
}

const Rigid3 kStart(geometry::ExpQuat(Eigen::Vector3d(0.1, -0.2, 0.7)),
                    Eigen::Vector3d(3.0, -1.0, 0.5));

Vector6d TestVelocity() {
  Vector6d varpi;
  varpi << 1.5, 0.1, -0.05, 0.05, -0.1, 0.4;
  return varpi;
}

TEST(GpPrior, ResidualIsZeroForConstantBodyVelocity) {
  const double dt = 0.4;
  const GpState a = ConstantVelocityState(kStart, TestVelocity(), 1.0);
  const GpState b = ConstantVelocityState(kStart, TestVelocity(), 1.0 + dt);
  std::unique_ptr<ceres::CostFunction> cost(GpPriorFactor::Create(GpPriorFactor::Options{}, dt));
  const auto blocks = Blocks(a, b);
  const double* params[6] = {blocks[0].data(), blocks[1].data(), blocks[2].data(),
                             blocks[3].data(), blocks[4].data(), blocks[5].data()};
  Eigen::Matrix<double, 12, 1> r;
  ASSERT_TRUE(cost->Evaluate(params, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-9);

  // An acceleration makes it non-zero.
  GpState c = b;
  c.vel_world += Eigen::Vector3d(0.2, 0.0, 0.0);
  const auto blocks_c = Blocks(a, c);
  const double* params_c[6] = {blocks_c[0].data(), blocks_c[1].data(), blocks_c[2].data(),
                               blocks_c[3].data(), blocks_c[4].data(), blocks_c[5].data()};
  ASSERT_TRUE(cost->Evaluate(params_c, r.data(), nullptr));
  EXPECT_GT(r.norm(), 0.1);
}

TEST(GpPrior, CovarianceIsWhiteNoiseOnAcceleration) {
  GpPriorFactor::Options options;
  options.qc_translation = 2.0;
  const GpPriorFactor factor(options, 0.5);
  EXPECT_NEAR(factor.covariance()(0, 0), 0.125 / 3.0 * 2.0, 1e-15);
  EXPECT_NEAR(factor.covariance()(0, 6), 0.125 * 2.0, 1e-15);
  EXPECT_NEAR(factor.covariance()(6, 6), 0.5 * 2.0, 1e-15);
  const Eigen::Matrix<double, 12, 12> S = factor.sqrt_information();
  EXPECT_LT(
      (S.transpose() * S * factor.covariance() - Eigen::Matrix<double, 12, 12>::Identity()).norm(),
      1e-9);
}

TEST(GpPrior, JacobiansMatchNumerical) {
  const PoseManifold pose_manifold;
  std::unique_ptr<ceres::CostFunction> cost(GpPriorFactor::Create(GpPriorFactor::Options{}, 0.3));
  GpState a = ConstantVelocityState(kStart, TestVelocity(), 0.0);
  GpState b = ConstantVelocityState(kStart, TestVelocity(), 0.3);
  // Perturb away from the prior's mean (non-zero residual) and test a near-identity ξ_ij too.
  b.world_from_body = b.world_from_body *
                      geometry::ExpSE3((Vector6d() << 0.05, -0.1, 0.02, 0.1, 0.2, -0.3).finished());
  b.vel_world += Eigen::Vector3d(0.3, -0.2, 0.1);
  b.rate_body += Eigen::Vector3d(-0.1, 0.2, 0.05);
  const std::vector<const ceres::Manifold*> manifolds = {&pose_manifold, nullptr, nullptr,
                                                         &pose_manifold, nullptr, nullptr};
  EXPECT_LT(testing::CheckJacobians(*cost, Blocks(a, b), manifolds).max_relative_error, 1e-6);
  GpState c = a;
  c.world_from_body = a.world_from_body * geometry::ExpSE3(Vector6d::Constant(1e-4));
  EXPECT_LT(testing::CheckJacobians(*cost, Blocks(a, c), manifolds).max_relative_error, 1e-6);
}

TEST(GpInterpolation, ExactForConstantBodyVelocity) {
  const double dt = 0.5;
  const GpState a = ConstantVelocityState(kStart, TestVelocity(), 2.0);
  const GpState b = ConstantVelocityState(kStart, TestVelocity(), 2.0 + dt);
  for (double s : {0.0, 0.1, 0.25, 0.4, 0.5}) {
    const GpState truth = ConstantVelocityState(kStart, TestVelocity(), 2.0 + s);
    const GpState interpolated = GpInterpolate(a, b, dt, s);
    EXPECT_LT(
        (interpolated.world_from_body.translation() - truth.world_from_body.translation()).norm(),
        1e-10)
        << s;
    EXPECT_LT(geometry::AngleBetween(interpolated.world_from_body.rotation(),
                                     truth.world_from_body.rotation()),
              1e-10)
        << s;
    EXPECT_LT((interpolated.vel_world - truth.vel_world).norm(), 1e-9) << s;
    EXPECT_LT((interpolated.rate_body - truth.rate_body).norm(), 1e-9) << s;
  }
}

TEST(GpInterpolation, WeightsReproduceEndpoints) {
  const GpInterpolationWeights w0 = ComputeGpInterpolationWeights(0.2, 0.0);
  const GpInterpolationWeights w1 = ComputeGpInterpolationWeights(0.2, 0.2);
  EXPECT_LT((w0.lambda - Eigen::Matrix2d::Identity()).norm(), 1e-12);
  EXPECT_LT(w0.psi.norm(), 1e-12);
  EXPECT_LT(w1.lambda.norm(), 1e-12);
  EXPECT_LT((w1.psi - Eigen::Matrix2d::Identity()).norm(), 1e-12);
}

TEST(GpInterpolation, JacobiansMatchNumerical) {
  const double dt = 0.4, s = 0.13;
  GpState a = ConstantVelocityState(kStart, TestVelocity(), 0.0);
  GpState b = ConstantVelocityState(kStart, TestVelocity(), dt);
  b.world_from_body = b.world_from_body *
                      geometry::ExpSE3((Vector6d() << 0.1, 0.05, -0.1, -0.1, 0.05, 0.2).finished());
  b.vel_world += Eigen::Vector3d(0.2, 0.1, -0.3);
  a.rate_body += Eigen::Vector3d(0.1, -0.1, 0.05);
  GpInterpolationJacobians J;
  const GpState nominal = GpInterpolate(a, b, dt, s, &J);
  const PoseManifold manifold;
  const Vector7d nominal_block = PoseToBlock(nominal.world_from_body);
  // d(T(τ) ⊟ T̄(τ))/d(input tangent), by central differences.
  auto output_delta = [&](const GpState& ai, const GpState& bj) {
    const Vector7d out = PoseToBlock(GpInterpolate(ai, bj, dt, s).world_from_body);
    Vector6d d;
    manifold.Minus(out.data(), nominal_block.data(), d.data());
    return d;
  };
  const double h = 1e-6;
  auto check_pose = [&](bool first, const Matrix6d& analytic) {
    Matrix6d numerical;
    for (int k = 0; k < 6; ++k) {
      Vector6d delta = Vector6d::Zero();
      GpState ap = a, am = a, bp = b, bm = b;
      GpState& plus = first ? ap : bp;
      GpState& minus = first ? am : bm;
      Vector7d block = PoseToBlock(plus.world_from_body), out;
      delta(k) = h;
      manifold.Plus(block.data(), delta.data(), out.data());
      plus.world_from_body = BlockToPose(out.data());
      delta(k) = -h;
      manifold.Plus(block.data(), delta.data(), out.data());
      minus.world_from_body = BlockToPose(out.data());
      numerical.col(k) = (output_delta(ap, bp) - output_delta(am, bm)) / (2 * h);
    }
    EXPECT_LT((numerical - analytic).cwiseAbs().maxCoeff(), 1e-6 * numerical.cwiseAbs().maxCoeff());
  };
  check_pose(true, J.pose_i);
  check_pose(false, J.pose_j);
  auto check_vector = [&](int which, const Eigen::Matrix<double, 6, 3>& analytic) {
    Eigen::Matrix<double, 6, 3> numerical;
    for (int k = 0; k < 3; ++k) {
      GpState ap = a, am = a, bp = b, bm = b;
      Eigen::Vector3d* plus[4] = {&ap.vel_world, &ap.rate_body, &bp.vel_world, &bp.rate_body};
      Eigen::Vector3d* minus[4] = {&am.vel_world, &am.rate_body, &bm.vel_world, &bm.rate_body};
      (*plus[which])(k) += h;
      (*minus[which])(k) -= h;
      numerical.col(k) = (output_delta(ap, bp) - output_delta(am, bm)) / (2 * h);
    }
    EXPECT_LT((numerical - analytic).cwiseAbs().maxCoeff(),
              1e-6 * std::max(1e-3, numerical.cwiseAbs().maxCoeff()))
        << which;
  };
  check_vector(0, J.vel_i);
  check_vector(1, J.rate_i);
  check_vector(2, J.vel_j);
  check_vector(3, J.rate_j);
}

}  // namespace
}  // namespace crop4d::slam
