#include "crop4d/slam/imu_preintegration.h"

#include <ceres/ceres.h>
#include <ceres/normal_prior.h>
#include <gtest/gtest.h>

#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/gps_factor.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/pose_prior_factor.h"
#include "crop4d/slam/synthetic_trajectory_test_util.h"

namespace crop4d::slam {
namespace {

using geometry::ExpSO3;
using geometry::LogSO3;
using testing::SinusoidalImu;
using testing::SinusoidalState;
using testing::TrueState;

std::vector<double> PoseVector(const Eigen::Matrix3d& R, const Eigen::Vector3d& p) {
  const Vector7d block = PoseToBlock(geometry::Rigid3(R, p));
  return std::vector<double>(block.data(), block.data() + 7);
}

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

// Deltas between two states of the true trajectory (Forster §VI-A solved for the deltas).
struct TrueDeltas {
  Eigen::Matrix3d R;
  Eigen::Vector3d v, p;
};
TrueDeltas TrueDeltasBetween(double t_i, double t_j) {
  const TrueState a = SinusoidalState(t_i);
  const TrueState b = SinusoidalState(t_j);
  const Eigen::Vector3d g(0, 0, -testing::kGravity);
  const double T = t_j - t_i;
  TrueDeltas d;
  d.R = a.rotation.transpose() * b.rotation;
  d.v = a.rotation.transpose() * (b.velocity - a.velocity - g * T);
  d.p = a.rotation.transpose() * (b.position - a.position - a.velocity * T - 0.5 * g * T * T);
  return d;
}

// Worst of the rotation (rad), velocity (m/s) and position (m) errors of the preintegration
// over [t_i, t_j] against the truth.
Eigen::Vector3d PreintegrationErrors(double rate_hz, Timestamp t_i, Timestamp t_j) {
  const std::vector<ImuSample> samples = SinusoidalImu(rate_hz, 4.0);
  ImuPreintegration pre(ImuPreintegration::Options{}, Vector6d::Zero());
  pre.Integrate(samples, t_i, t_j);
  const TrueDeltas truth = TrueDeltasBetween(TimestampToSeconds(t_i), TimestampToSeconds(t_j));
  return Eigen::Vector3d(LogSO3(truth.R.transpose() * pre.delta_rotation()).norm(),
                         (pre.delta_velocity() - truth.v).norm(),
                         (pre.delta_position() - truth.p).norm());
}

TEST(ImuPreintegration, MatchesTrueTrajectoryAndConvergesWithRate) {
  // Image times that fall between IMU samples (partial first and last intervals).
  const Timestamp t_i = SecondsToTimestamp(1.0031);
  const Timestamp t_j = SecondsToTimestamp(1.5367);
  const Eigen::Vector3d err_167 = PreintegrationErrors(167.0, t_i, t_j);
  const Eigen::Vector3d err_1000 = PreintegrationErrors(1000.0, t_i, t_j);
  EXPECT_LT(err_167(0), 2e-5);
  EXPECT_LT(err_167(1), 2e-4);
  EXPECT_LT(err_167(2), 5e-5);
  for (int k = 0; k < 3; ++k) EXPECT_LT(err_1000(k), 0.2 * err_167(k)) << k;

  // The IMU factor's residual with the true states is ≈ 0.
  ImuPreintegration pre(ImuPreintegration::Options{}, Vector6d::Zero());
  pre.Integrate(SinusoidalImu(167.0, 4.0), t_i, t_j);
  EXPECT_NEAR(pre.delta_time(), DurationSeconds(t_i, t_j), 1e-12);
  const ImuFactor factor(pre);
  const TrueState a = SinusoidalState(TimestampToSeconds(t_i));
  const TrueState b = SinusoidalState(TimestampToSeconds(t_j));
  const std::vector<double> pose_i = PoseVector(a.rotation, a.position);
  const std::vector<double> pose_j = PoseVector(b.rotation, b.position);
  const Vector6d bias = Vector6d::Zero();
  const Vector9d r = factor.UnweightedResidual(pose_i.data(), a.velocity.data(), bias.data(),
                                               pose_j.data(), b.velocity.data());
  EXPECT_LT(r.head<3>().norm(), 2e-5);
  EXPECT_LT(r.segment<3>(3).norm(), 2e-4);
  EXPECT_LT(r.tail<3>().norm(), 5e-5);
}

TEST(ImuPreintegration, PredictReproducesStateJ) {
  const Timestamp t_i = SecondsToTimestamp(0.5);
  const Timestamp t_j = SecondsToTimestamp(0.9);
  ImuPreintegration pre(ImuPreintegration::Options{}, Vector6d::Zero());
  pre.Integrate(SinusoidalImu(167.0, 2.0), t_i, t_j);
  const TrueState a = SinusoidalState(0.5);
  const TrueState b = SinusoidalState(0.9);
  NavState state_i;
  state_i.world_from_body_rotation = Eigen::Quaterniond(a.rotation);
  state_i.position_world = a.position;
  state_i.vel_world = a.velocity;
  const NavState state_j = pre.Predict(state_i, Vector6d::Zero());
  EXPECT_LT((state_j.position_world - b.position).norm(), 5e-5);
  EXPECT_LT((state_j.vel_world - b.velocity).norm(), 2e-4);
  EXPECT_LT(
      geometry::AngleBetween(state_j.world_from_body_rotation, Eigen::Quaterniond(b.rotation)),
      2e-5);
}

TEST(ImuPreintegration, ConsecutiveIntervalsCompose) {
  const std::vector<ImuSample> samples = SinusoidalImu(167.0, 2.0);
  const Timestamp t0 = SecondsToTimestamp(0.2011);
  // A sample time: then the breakpoints of the whole interval and of the two parts coincide.
  const Timestamp t1 = samples[76].timestamp;
  const Timestamp t2 = SecondsToTimestamp(0.7013);
  ImuPreintegration whole(ImuPreintegration::Options{}, Vector6d::Zero());
  whole.Integrate(samples, t0, t2);
  ImuPreintegration parts(ImuPreintegration::Options{}, Vector6d::Zero());
  parts.Integrate(samples, t0, t1);
  parts.Integrate(samples, t1, t2);
  EXPECT_LT((whole.delta_position() - parts.delta_position()).norm(), 1e-12);
  EXPECT_LT((whole.delta_velocity() - parts.delta_velocity()).norm(), 1e-12);
  EXPECT_LT((whole.covariance() - parts.covariance()).norm(), 1e-12 * whole.covariance().norm());
  EXPECT_LT((whole.bias_jacobian() - parts.bias_jacobian()).norm(), 1e-12);
}

TEST(ImuPreintegration, BiasCorrectionMatchesReintegration) {
  const std::vector<ImuSample> samples = SinusoidalImu(167.0, 2.0);
  const Timestamp t_i = SecondsToTimestamp(0.3);
  const Timestamp t_j = SecondsToTimestamp(0.8);
  Vector6d bias0;
  bias0 << 0.01, -0.02, 0.005, 0.1, -0.05, 0.08;
  Vector6d db;
  db << 2e-3, -1e-3, 3e-3, 2e-2, 3e-2, -1e-2;
  ImuPreintegration pre(ImuPreintegration::Options{}, bias0);
  pre.Integrate(samples, t_i, t_j);
  ImuPreintegration re(ImuPreintegration::Options{}, bias0 + db);
  re.Integrate(samples, t_i, t_j);

  const Vector6d bias1 = bias0 + db;
  const double change_R = LogSO3(pre.delta_rotation().transpose() * re.delta_rotation()).norm();
  const double error_R =
      LogSO3(pre.CorrectedDeltaRotation(bias1).transpose() * re.delta_rotation()).norm();
  const double change_v = (re.delta_velocity() - pre.delta_velocity()).norm();
  const double error_v = (re.delta_velocity() - pre.CorrectedDeltaVelocity(bias1)).norm();
  const double change_p = (re.delta_position() - pre.delta_position()).norm();
  const double error_p = (re.delta_position() - pre.CorrectedDeltaPosition(bias1)).norm();
  // First order: the error of the update is second order in δb, far below the change itself.
  EXPECT_LT(error_R, 1e-3 * change_R);
  EXPECT_LT(error_v, 1e-2 * change_v);
  EXPECT_LT(error_p, 1e-2 * change_p);
}

TEST(ImuPreintegration, CovarianceMatchesMonteCarlo) {
  ImuPreintegration::Options options;
  options.gyro_noise_density = 2e-3;
  options.accel_noise_density = 2e-2;
  const double rate_hz = 167.0;
  const std::vector<ImuSample> clean = SinusoidalImu(rate_hz, 1.2);
  const Timestamp t_i = SecondsToTimestamp(0.2031);
  const Timestamp t_j = SecondsToTimestamp(0.7013);
  ImuPreintegration reference(options, Vector6d::Zero());
  reference.Integrate(clean, t_i, t_j);

  const double sigma_g = options.gyro_noise_density * std::sqrt(rate_hz);
  const double sigma_a = options.accel_noise_density * std::sqrt(rate_hz);
  std::mt19937 rng(42);
  std::normal_distribution<double> normal(0.0, 1.0);
  const int runs = 2000;
  Matrix9d sample_covariance = Matrix9d::Zero();
  for (int run = 0; run < runs; ++run) {
    std::vector<ImuSample> noisy = clean;
    for (ImuSample& s : noisy) {
      for (int k = 0; k < 3; ++k) {
        s.gyro_body(k) += sigma_g * normal(rng);
        s.accel_body(k) += sigma_a * normal(rng);
      }
    }
    ImuPreintegration pre(options, Vector6d::Zero());
    pre.Integrate(noisy, t_i, t_j);
    Vector9d e;
    e << LogSO3(reference.delta_rotation().transpose() * pre.delta_rotation()),
        pre.delta_velocity() - reference.delta_velocity(),
        pre.delta_position() - reference.delta_position();
    sample_covariance += e * e.transpose() / runs;
  }
  for (int k = 0; k < 9; ++k) {
    const double predicted = reference.covariance()(k, k);
    EXPECT_NEAR(sample_covariance(k, k) / predicted, 1.0, 0.15) << "diagonal " << k;
  }
}

TEST(ImuFactor, JacobiansMatchNumerical) {
  const std::vector<ImuSample> samples = SinusoidalImu(167.0, 2.0);
  Vector6d bias0;
  bias0 << 0.01, -0.02, 0.005, 0.1, -0.05, 0.08;
  ImuPreintegration::Options options;
  options.gyro_noise_density = 1e-2;
  options.accel_noise_density = 1e-1;
  ImuPreintegration pre(options, bias0);
  pre.Integrate(samples, SecondsToTimestamp(0.4), SecondsToTimestamp(0.8));
  const ImuFactor factor(pre);
  const PoseManifold pose_manifold;
  const TrueState a = SinusoidalState(0.4);
  const TrueState b = SinusoidalState(0.8);
  // Away from the truth so that every residual and Jacobian term is non-trivial.
  Vector6d bias_i = bias0;
  bias_i << 0.013, -0.018, 0.007, 0.12, -0.04, 0.07;
  const std::vector<std::vector<double>> parameters = {
      PoseVector(a.rotation * ExpSO3(Eigen::Vector3d(0.05, -0.03, 0.02)),
                 a.position + Eigen::Vector3d(0.1, -0.2, 0.05)),
      Vec(a.velocity + Eigen::Vector3d(0.1, 0.2, -0.1)), Vec(bias_i),
      PoseVector(b.rotation * ExpSO3(Eigen::Vector3d(-0.02, 0.04, 0.03)),
                 b.position + Eigen::Vector3d(-0.1, 0.1, 0.2)),
      Vec(b.velocity + Eigen::Vector3d(-0.2, 0.1, 0.05))};
  const testing::JacobianCheckResult check = testing::CheckJacobians(
      factor, parameters, {&pose_manifold, nullptr, nullptr, &pose_manifold, nullptr});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

TEST(BiasRandomWalkFactor, ResidualAndJacobians) {
  const BiasRandomWalkFactor factor(1e-3, 1e-2, 0.25);
  Vector6d b_i, b_j;
  b_i << 0.01, 0.02, 0.03, 0.1, 0.2, 0.3;
  b_j = b_i + Vector6d::Constant(1e-3);
  const double* parameters[2] = {b_i.data(), b_j.data()};
  Vector6d r;
  factor.Evaluate(parameters, r.data(), nullptr);
  EXPECT_NEAR(r(0), 1e-3 / (1e-3 * 0.5), 1e-9);
  EXPECT_NEAR(r(3), 1e-3 / (1e-2 * 0.5), 1e-9);
  const testing::JacobianCheckResult check =
      testing::CheckJacobians(factor, {Vec(b_i), Vec(b_j)}, {nullptr, nullptr});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

// A chain of states at the camera rate over 2 s with IMU and bias random-walk factors, solved
// from perturbed initial values. With `gps`, every state gets a GpsFactor (the imu+rtk case) and
// the first state no pose/velocity prior; otherwise the first state is fixed by priors.
struct ChainErrors {
  double max_position = 0.0;
  double max_rotation = 0.0;
  bool usable = false;
};

ChainErrors SolveImuChain(bool gps) {
  const double camera_hz = 7.5;
  const int num_states = 16;
  const double t_start = 0.5133;
  const std::vector<ImuSample> samples = SinusoidalImu(167.0, 3.0);
  const Eigen::Vector3d p_body_antenna(0.2, 0.0, 1.0);
  ImuPreintegration::Options options;

  std::vector<Timestamp> times;
  for (int k = 0; k < num_states; ++k) times.push_back(SecondsToTimestamp(t_start + k / camera_hz));
  std::vector<Vector7d> poses(num_states);
  std::vector<Eigen::Vector3d> velocities(num_states);
  std::vector<Vector6d> biases(num_states, Vector6d::Zero());
  std::mt19937 rng(7);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto noise3 = [&](double sigma) -> Eigen::Vector3d {
    return Eigen::Vector3d(normal(rng), normal(rng), normal(rng)) * sigma;
  };
  for (int k = 0; k < num_states; ++k) {
    const TrueState s = SinusoidalState(TimestampToSeconds(times[k]));
    if (k == 0 && !gps) {
      poses[k] = PoseToBlock(s.Pose());
      velocities[k] = s.velocity;
    } else {
      poses[k] = PoseToBlock(
          geometry::Rigid3(s.rotation * ExpSO3(noise3(0.05)), s.position + noise3(0.3)));
      velocities[k] = s.velocity + noise3(0.2);
      biases[k].head<3>() = noise3(1e-3);
      biases[k].tail<3>() = noise3(1e-2);
    }
  }

  ceres::Problem problem;
  for (int k = 0; k < num_states; ++k) {
    problem.AddParameterBlock(poses[k].data(), 7, new PoseManifold);
  }
  const TrueState s0 = SinusoidalState(TimestampToSeconds(times[0]));
  if (gps) {
    for (int k = 0; k < num_states; ++k) {
      const TrueState s = SinusoidalState(TimestampToSeconds(times[k]));
      GpsMeasurement z;
      z.position_world = s.Pose() * p_body_antenna;
      z.sigma_horizontal = 0.02;
      z.sigma_vertical = 0.04;
      problem.AddResidualBlock(GpsFactor::Create(z, p_body_antenna), nullptr, poses[k].data());
    }
  } else {
    problem.AddResidualBlock(PosePriorFactor::Create(s0.Pose(), 1e-4, 1e-4), nullptr,
                             poses[0].data());
    problem.AddResidualBlock(new ceres::NormalPrior(Eigen::Matrix3d::Identity() * 1e4, s0.velocity),
                             nullptr, velocities[0].data());
  }
  problem.AddResidualBlock(new ceres::NormalPrior(Matrix6d::Identity() * 1e4, Vector6d::Zero()),
                           nullptr, biases[0].data());
  for (int k = 0; k + 1 < num_states; ++k) {
    ImuPreintegration pre(options, biases[k]);
    pre.Integrate(samples, times[k], times[k + 1]);
    problem.AddResidualBlock(ImuFactor::Create(pre), nullptr, poses[k].data(), velocities[k].data(),
                             biases[k].data(), poses[k + 1].data(), velocities[k + 1].data());
    problem.AddResidualBlock(
        BiasRandomWalkFactor::Create(options.gyro_random_walk, options.accel_random_walk,
                                     DurationSeconds(times[k], times[k + 1])),
        nullptr, biases[k].data(), biases[k + 1].data());
  }
  ceres::Solver::Options solver_options;
  solver_options.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver_options.max_num_iterations = 50;
  ceres::Solver::Summary summary;
  ceres::Solve(solver_options, &problem, &summary);

  ChainErrors errors;
  errors.usable = summary.IsSolutionUsable();
  for (int k = 0; k < num_states; ++k) {
    const TrueState s = SinusoidalState(TimestampToSeconds(times[k]));
    const geometry::Rigid3 pose = BlockToPose(poses[k].data());
    errors.max_position = std::max(errors.max_position, (pose.translation() - s.position).norm());
    errors.max_rotation =
        std::max(errors.max_rotation,
                 geometry::AngleBetween(pose.rotation(), Eigen::Quaterniond(s.rotation)));
  }
  return errors;
}

TEST(ImuFactor, ImuOnlyChainRecoversTrajectory) {
  const ChainErrors errors = SolveImuChain(/*gps=*/false);
  ASSERT_TRUE(errors.usable);
  EXPECT_LT(errors.max_position, 0.01);
  EXPECT_LT(errors.max_rotation, 1e-3);
}

TEST(ImuFactor, ImuAndRtkChainRecoversTrajectoryWithoutPosePrior) {
  const ChainErrors errors = SolveImuChain(/*gps=*/true);
  ASSERT_TRUE(errors.usable);
  EXPECT_LT(errors.max_position, 0.01);
  EXPECT_LT(errors.max_rotation, 1e-3);
}

TEST(AngularRateFactor, ResidualAndJacobians) {
  const std::vector<ImuSample> samples = SinusoidalImu(167.0, 1.0);
  const Timestamp t = SecondsToTimestamp(0.4321);
  const ImuSample sample = InterpolateImu(samples, t);
  const TrueState s = SinusoidalState(0.4321);
  // Linear interpolation of a smooth signal: error O(Δt²).
  EXPECT_LT((sample.gyro_body - s.rate_body).norm(), 1e-5);
  const AngularRateFactor factor(sample.gyro_body, 0.01);
  Vector6d bias = Vector6d::Zero();
  const double* params[2] = {s.rate_body.data(), bias.data()};
  Eigen::Vector3d r;
  ASSERT_TRUE(factor.Evaluate(params, r.data(), nullptr));
  EXPECT_LT(r.norm(), 1e-3);
  bias << 0.01, -0.02, 0.03, 0.1, 0.1, 0.1;
  EXPECT_LT(testing::CheckJacobians(factor, {Vec(s.rate_body), Vec(bias)}, {nullptr, nullptr})
                .max_relative_error,
            1e-6);
}

}  // namespace
}  // namespace crop4d::slam
