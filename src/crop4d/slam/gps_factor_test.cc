#include "crop4d/slam/gps_factor.h"

#include <ceres/ceres.h>
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/pose_prior_factor.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

const Eigen::Vector3d kAntenna(0.3, -0.1, 1.2);

GpState ConstantVelocityState(const Rigid3& start, const Vector6d& varpi, double t) {
  GpState s;
  s.world_from_body = start * geometry::ExpSE3(t * varpi);
  SetBodyVelocity(varpi, &s);
  return s;
}

TEST(GpsFactor, ResidualAndJacobians) {
  const Rigid3 pose(geometry::ExpQuat(Eigen::Vector3d(0.2, -0.1, 1.0)), Eigen::Vector3d(1, 2, 3));
  GpsMeasurement z;
  z.position_world = pose * kAntenna + Eigen::Vector3d(0.02, -0.04, 0.08);
  z.sigma_horizontal = 0.02;
  z.sigma_vertical = 0.04;
  const GpsFactor factor(z, kAntenna);
  const Vector7d block = PoseToBlock(pose);
  const double* params[1] = {block.data()};
  Eigen::Vector3d r;
  ASSERT_TRUE(factor.Evaluate(params, r.data(), nullptr));
  EXPECT_LT((r - Eigen::Vector3d(-1.0, 2.0, -2.0)).norm(), 1e-9);
  const PoseManifold manifold;
  EXPECT_LT(testing::CheckJacobians(factor, {Vec(block)}, {&manifold}).max_relative_error, 1e-6);
}

TEST(GpsInterpolatedFactor, ZeroAtTrueInterpolatedPositionAndJacobians) {
  Vector6d varpi;
  varpi << 1.2, 0.05, 0.0, 0.02, -0.03, 0.3;
  const Rigid3 start(geometry::ExpQuat(Eigen::Vector3d(0.05, 0.02, 0.4)), Eigen::Vector3d(5, 1, 0));
  const double dt = 1.0 / 7.5, s = 0.071;
  const GpState a = ConstantVelocityState(start, varpi, 0.0);
  const GpState b = ConstantVelocityState(start, varpi, dt);
  const GpState at_tau = ConstantVelocityState(start, varpi, s);
  GpsMeasurement z;
  z.position_world = at_tau.world_from_body * kAntenna;
  std::unique_ptr<ceres::CostFunction> cost(GpsInterpolatedFactor::Create(z, kAntenna, dt, s));
  std::vector<std::vector<double>> blocks = {
      Vec(PoseToBlock(a.world_from_body)), Vec(a.vel_world), Vec(a.rate_body),
      Vec(PoseToBlock(b.world_from_body)), Vec(b.vel_world), Vec(b.rate_body)};
  const double* params[6];
  for (int k = 0; k < 6; ++k) params[k] = blocks[k].data();
  Eigen::Vector3d r;
  ASSERT_TRUE(cost->Evaluate(params, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-8);

  // Jacobians away from the truth.
  blocks[1][0] += 0.3;
  blocks[5][2] -= 0.2;
  blocks[3][0] += 0.1;
  const PoseManifold manifold;
  EXPECT_LT(testing::CheckJacobians(*cost, blocks,
                                    {&manifold, nullptr, nullptr, &manifold, nullptr, nullptr})
                .max_relative_error,
            1e-6);
}

// A vehicle weaving along a row: p(t) = (1.5t, 0.5 sin 0.5t, 0), heading along the velocity.
GpState WeavingState(double t) {
  const Eigen::Vector3d p(1.5 * t, 0.5 * std::sin(0.5 * t), 0.0);
  const Eigen::Vector3d v(1.5, 0.25 * std::cos(0.5 * t), 0.0);
  const Eigen::Vector3d a(0.0, -0.125 * std::sin(0.5 * t), 0.0);
  const double yaw = std::atan2(v.y(), v.x());
  const double yaw_rate = (v.x() * a.y() - v.y() * a.x()) / v.squaredNorm();
  GpState s;
  s.world_from_body = Rigid3(geometry::ExpQuat(Eigen::Vector3d(0, 0, yaw)), p);
  s.vel_world = v;
  s.rate_body = Eigen::Vector3d(0, 0, yaw_rate);
  return s;
}

// GP prior + interpolated GPS alone: from noisy 5 Hz fixes the smoothed trajectory at the
// 7.5 Hz states is more accurate than the raw fixes.
TEST(GpsInterpolatedFactor, GpAndGpsSmoothTrajectoryBetterThanRawGps) {
  const double camera_dt = 1.0 / 7.5;
  const int num_states = 31;  // 4 s
  std::mt19937 rng(3);
  std::normal_distribution<double> normal(0.0, 1.0);
  const double sigma = 0.05;

  std::vector<Vector7d> poses(num_states);
  std::vector<Eigen::Vector3d> vels(num_states), rates(num_states);
  for (int k = 0; k < num_states; ++k) {
    const GpState s = WeavingState(k * camera_dt);
    // Initial guess: 20 cm, 0.05 rad off.
    const Eigen::Vector3d dp(normal(rng), normal(rng), normal(rng));
    const Eigen::Vector3d dr(normal(rng), normal(rng), normal(rng));
    poses[k] = PoseToBlock(Rigid3(s.world_from_body.rotation() * geometry::ExpQuat(0.05 * dr),
                                  s.world_from_body.translation() + 0.2 * dp));
    vels[k] = s.vel_world + Eigen::Vector3d(0.2 * normal(rng), 0.2 * normal(rng), 0.0);
    rates[k] = Eigen::Vector3d::Zero();
  }

  ceres::Problem problem;
  for (auto& pose : poses) problem.AddParameterBlock(pose.data(), 7, new PoseManifold);
  // Gauge: the GP prior and GPS leave the heading only weakly observable (through the lever
  // arm), so the first pose gets a loose prior.
  problem.AddResidualBlock(PosePriorFactor::Create(WeavingState(0.0).world_from_body, 1.0, 0.01),
                           nullptr, poses[0].data());
  GpPriorFactor::Options gp_options;
  gp_options.qc_translation = 0.05;
  gp_options.qc_rotation = 0.01;
  for (int k = 0; k + 1 < num_states; ++k) {
    problem.AddResidualBlock(GpPriorFactor::Create(gp_options, camera_dt), nullptr, poses[k].data(),
                             vels[k].data(), rates[k].data(), poses[k + 1].data(),
                             vels[k + 1].data(), rates[k + 1].data());
  }
  double raw_squared_error = 0.0;
  int num_fixes = 0;
  for (double t = 0.037; t < (num_states - 1) * camera_dt; t += 0.2) {
    const int k = static_cast<int>(std::floor(t / camera_dt));
    const Eigen::Vector3d truth = WeavingState(t).world_from_body * kAntenna;
    GpsMeasurement z;
    z.sigma_horizontal = z.sigma_vertical = sigma;
    z.position_world = truth + sigma * Eigen::Vector3d(normal(rng), normal(rng), normal(rng));
    raw_squared_error += (z.position_world - truth).squaredNorm();
    ++num_fixes;
    problem.AddResidualBlock(
        GpsInterpolatedFactor::Create(z, kAntenna, camera_dt, t - k * camera_dt), nullptr,
        poses[k].data(), vels[k].data(), rates[k].data(), poses[k + 1].data(), vels[k + 1].data(),
        rates[k + 1].data());
  }
  ceres::Solver::Options options;
  options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  options.max_num_iterations = 100;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  ASSERT_TRUE(summary.IsSolutionUsable()) << summary.BriefReport();

  double squared_error = 0.0;
  for (int k = 0; k < num_states; ++k) {
    const Eigen::Vector3d truth = WeavingState(k * camera_dt).world_from_body * kAntenna;
    squared_error += (BlockToPose(poses[k].data()) * kAntenna - truth).squaredNorm();
  }
  const double raw_rms = std::sqrt(raw_squared_error / num_fixes);
  const double rms = std::sqrt(squared_error / num_states);
  EXPECT_LT(rms, 0.7 * raw_rms) << "raw " << raw_rms << " smoothed " << rms;
}

}  // namespace
}  // namespace crop4d::slam
