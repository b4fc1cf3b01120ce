#include "crop4d/sim/trajectory.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/sim/sim_config.h"

namespace crop4d::sim {
namespace {

WorldOptions TinyWorld() { return PresetConfig("tiny").MakeWorldOptions(); }

TEST(UniformBSplineTest, ReproducesStraightLinesAndDifferentiates) {
  // Control points of x(t) = 2 + 3 t at the Greville abscissae give exactly that line.
  constexpr int kDegree = 5;
  const double dt = 0.2;
  std::vector<Eigen::VectorXd> points;
  for (int i = 0; i < 20; ++i) {
    points.push_back(
        Eigen::VectorXd::Constant(1, 2.0 + 3.0 * UniformBSpline::GrevilleTime(kDegree, dt, i)));
  }
  const UniformBSpline line(kDegree, dt, points);
  EXPECT_NEAR(line.EndTime(), 15 * dt, 1e-12);
  for (double t = 0.0; t <= line.EndTime(); t += 0.0371) {
    EXPECT_NEAR(line.Evaluate(t)[0], 2.0 + 3.0 * t, 1e-12);
    EXPECT_NEAR(line.Evaluate(t, 1)[0], 3.0, 1e-11);
    EXPECT_NEAR(line.Evaluate(t, 2)[0], 0.0, 1e-9);
  }

  // Derivatives of a curvy spline against central differences.
  std::vector<Eigen::VectorXd> wiggly;
  for (int i = 0; i < 20; ++i) wiggly.push_back(Eigen::VectorXd::Constant(1, std::sin(i * 1.3)));
  const UniformBSpline curve(kDegree, dt, wiggly);
  const double h = 1e-5;
  for (double t = 0.1; t < curve.EndTime() - 0.1; t += 0.0917) {
    const double d1 = (curve.Evaluate(t + h)[0] - curve.Evaluate(t - h)[0]) / (2 * h);
    const double d2 = (curve.Evaluate(t + h, 1)[0] - curve.Evaluate(t - h, 1)[0]) / (2 * h);
    EXPECT_NEAR(curve.Evaluate(t, 1)[0], d1, 1e-6);
    EXPECT_NEAR(curve.Evaluate(t, 2)[0], d2, 1e-5);
  }
}

TEST(TrajectoryTest, DrivesEveryRowBoustrophedonBetweenTheRows) {
  WorldOptions options = TinyWorld();
  options.num_rows = 4;
  const World world(options);
  const Trajectory traj(world, TrajectoryOptions(), 3);
  ASSERT_EQ(traj.passes().size(), 4u);
  EXPECT_GT(traj.Duration(), 4 * options.row_length_m / 1.5);
  for (const Pass& pass : traj.passes()) {
    EXPECT_EQ(pass.lane, pass.index);
    EXPECT_NEAR(pass.lane_x, pass.lane * options.row_spacing_m, 1e-12);  // straddling row r
    EXPECT_EQ(pass.northward, pass.index % 2 == 0);
    EXPECT_LT(pass.t_begin, pass.t_end);
    // Inside the rows: a few cm from the lane centre, heading along the row, cruise speed.
    int samples = 0;
    for (double t = pass.t_begin; t <= pass.t_end; t += 0.05) {
      const BodyState s = traj.StateAt(t);
      const Eigen::Vector3d p = s.world_from_body.translation();
      if (p.y() < 0.0 || p.y() > options.row_length_m) continue;
      ++samples;
      EXPECT_LT(std::abs(p.x() - pass.lane_x), 0.15) << "t " << t;
      // The pass index is recoverable from the position alone.
      EXPECT_EQ(std::lround(p.x() / options.row_spacing_m), pass.lane);
      EXPECT_NEAR(std::sin(s.yaw), pass.northward ? 1.0 : -1.0, 0.01);
      EXPECT_GT(s.velocity_world.head<2>().norm(), 0.95);
      EXPECT_LT(s.velocity_world.head<2>().norm(), 1.55);
      // Body above the ground, small roll and pitch from the terrain.
      EXPECT_NEAR(p.z() - world.TerrainHeight(p.x(), p.y()), 0.8, 0.1);
      EXPECT_LT(std::abs(s.roll), 0.1);
      EXPECT_LT(std::abs(s.pitch), 0.1);
    }
    EXPECT_GT(samples, 50);
  }
  // Between the passes the vehicle turns in the headland, within the world's bounds.
  for (double t = 0.0; t < traj.Duration(); t += 0.1) {
    const Eigen::Vector3d p = traj.WorldFromBody(t).translation();
    EXPECT_TRUE(world.Bounds().contains(p.head<2>())) << p.transpose();
  }
}

TEST(TrajectoryTest, FurrowLanesLieBetweenRows) {
  WorldOptions options = TinyWorld();
  options.num_rows = 3;
  const World world(options);
  TrajectoryOptions drive;
  drive.lane = "furrow";
  const Trajectory traj(world, drive, 3);
  ASSERT_EQ(traj.passes().size(), 2u);
  EXPECT_NEAR(traj.passes()[0].lane_x, 0.5 * options.row_spacing_m, 1e-12);
  EXPECT_NEAR(traj.passes()[1].lane_x, 1.5 * options.row_spacing_m, 1e-12);
}

TEST(TrajectoryTest, DerivativesMatchThePoses) {
  const World world(TinyWorld());
  const Trajectory traj(world, TrajectoryOptions(), 5);
  const double h = 1e-4;
  for (double t = 0.5; t < traj.Duration() - 0.5; t += 0.37) {
    const BodyState s = traj.StateAt(t);
    const BodyState a = traj.StateAt(t - h), b = traj.StateAt(t + h);
    const Eigen::Vector3d v_num =
        (b.world_from_body.translation() - a.world_from_body.translation()) / (2 * h);
    EXPECT_LT((v_num - s.velocity_world).norm(), 1e-6) << "t " << t;
    const Eigen::Vector3d acc_num = (b.velocity_world - a.velocity_world) / (2 * h);
    EXPECT_LT((acc_num - s.acceleration_world).norm(), 1e-5) << "t " << t;
    // ω_B from R(t)ᵀ R(t + h) = Exp(ω h).
    const Eigen::Matrix3d relative =
        a.world_from_body.RotationMatrix().transpose() * b.world_from_body.RotationMatrix();
    const Eigen::Vector3d omega_num = geometry::LogSO3(relative) / (2 * h);
    EXPECT_LT((omega_num - s.angular_velocity_body).norm(), 1e-6) << "t " << t;
  }
}

TEST(TrajectoryTest, MaxDurationCutsTheSession) {
  const World world(TinyWorld());
  TrajectoryOptions drive;
  drive.max_duration_s = 4.0;
  const Trajectory traj(world, drive, 5);
  EXPECT_DOUBLE_EQ(traj.Duration(), 4.0);
  ASSERT_EQ(traj.passes().size(), 1u);
  EXPECT_DOUBLE_EQ(traj.passes()[0].t_end, 4.0);
}

TEST(TrajectoryTest, RejectsTurnsThatLeaveTheHeadland) {
  WorldOptions options = TinyWorld();
  options.headland_m = 3.0;
  const World world(options);
  try {
    Trajectory traj(world, TrajectoryOptions(), 1);
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("drive.turn_radius_m"), std::string::npos) << e.what();
  }
  TrajectoryOptions bad;
  bad.speed_mps = -1.0;
  EXPECT_THROW(bad.Check(), InputError);
}

}  // namespace
}  // namespace crop4d::sim
