// Trajectory metrics on synthetic trajectories with known errors, and association by time.

#include "crop4d/eval/trajectory_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/eval/eval_test_util.h"

namespace crop4d::eval {
namespace {

using geometry::Rigid3;
using testing::CurvedRowPose;

constexpr double kDeg = M_PI / 180.0;

// Poses every 0.1 m (1 m/s at 10 Hz) along the curved row, 20 m.
std::vector<Rigid3> CurvedTruth(int n = 201) {
  std::vector<Rigid3> poses;
  for (int k = 0; k < n; ++k) poses.push_back(CurvedRowPose(0.1 * k));
  return poses;
}

// Poses every 0.125 m (exact in binary) along a straight line (x axis), heading east; 20 m.
std::vector<Rigid3> StraightTruth(int n = 161) {
  std::vector<Rigid3> poses;
  for (int k = 0; k < n; ++k)
    poses.emplace_back(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.125 * k, 2.0, 0.3));
  return poses;
}

std::vector<Rigid3> Translated(const std::vector<Rigid3>& poses, const Eigen::Vector3d& offset) {
  std::vector<Rigid3> out;
  for (const Rigid3& p : poses) out.emplace_back(p.rotation(), p.translation() + offset);
  return out;
}

TEST(TrajectoryMetricsTest, ConstantOffsetIsRawAteAndAlignsAway) {
  const Eigen::Vector3d offset(0.018, -0.024, 0.0);  // 3 cm
  for (const auto& truth : {CurvedTruth(), StraightTruth()}) {
    const TrajectoryMetrics m = ComputeTrajectoryMetrics(Translated(truth, offset), truth);
    EXPECT_EQ(m.num_poses, static_cast<int>(truth.size()));
    EXPECT_NEAR(m.ate_raw_m.rmse, 0.03, 1e-12);
    EXPECT_NEAR(m.ate_raw_m.mean, 0.03, 1e-12);
    EXPECT_NEAR(m.ate_raw_m.max, 0.03, 1e-12);
    EXPECT_EQ(m.ate_aligned_m.count, m.num_poses);
    EXPECT_LT(m.ate_aligned_m.max, 1e-9);
    EXPECT_NEAR(m.rotation_deg.max, 0.0, 1e-6);
    // A world offset leaves the relative poses unchanged.
    EXPECT_GT(m.rpe_translation_percent.count, 140);
    EXPECT_LT(m.rpe_translation_percent.max, 1e-8);
    EXPECT_LT(m.rpe_rotation_deg_per_m.max, 1e-6);
  }
  // The alignment of the curved case is the inverse offset.
  const TrajectoryMetrics m =
      ComputeTrajectoryMetrics(Translated(CurvedTruth(), offset), CurvedTruth());
  EXPECT_LT((m.truth_from_estimate.translation() + offset).norm(), 1e-9);
  EXPECT_LT(RotationAngleDeg(m.truth_from_estimate.rotation()), 1e-7);
}

TEST(TrajectoryMetricsTest, KnownRotationErrorIsTheRotationRmse) {
  const std::vector<Rigid3> truth = CurvedTruth();
  const Rigid3 body_error(Eigen::Quaterniond(Eigen::AngleAxisd(
                              2.0 * kDeg, Eigen::Vector3d(1.0, 2.0, 0.5).normalized())),
                          Eigen::Vector3d::Zero());
  std::vector<Rigid3> estimate;
  for (const Rigid3& p : truth) estimate.push_back(p * body_error);
  const TrajectoryMetrics m = ComputeTrajectoryMetrics(estimate, truth);
  EXPECT_NEAR(m.rotation_deg.rmse, 2.0, 1e-9);
  EXPECT_NEAR(m.rotation_deg.mean, 2.0, 1e-9);
  EXPECT_NEAR(m.rotation_deg.max, 2.0, 1e-9);
  EXPECT_LT(m.ate_raw_m.max, 1e-12);
}

TEST(TrajectoryMetricsTest, ScaleDriftOfOnePercentIsOnePercentRpe) {
  // Positions stretched by 1 % about the first pose: the estimate has travelled 1 % too far.
  const std::vector<Rigid3> truth = StraightTruth();
  std::vector<Rigid3> estimate;
  for (const Rigid3& p : truth) {
    estimate.emplace_back(
        p.rotation(), truth[0].translation() + 1.01 * (p.translation() - truth[0].translation()));
  }
  const TrajectoryMetrics m = ComputeTrajectoryMetrics(estimate, truth);
  EXPECT_NEAR(m.path_length_m, 20.0, 1e-9);
  EXPECT_EQ(m.rpe_distance_m, 1.0);
  // Pairs i → i+8 (1 m) for i = 0..152.
  EXPECT_EQ(m.rpe_translation_percent.count, 153);
  EXPECT_NEAR(m.rpe_translation_percent.mean, 1.0, 1e-6);
  EXPECT_NEAR(m.rpe_translation_percent.rmse, 1.0, 1e-6);
  EXPECT_NEAR(m.rpe_rotation_deg_per_m.max, 0.0, 1e-9);
  // Raw ATE grows to 20 cm at the end; ATE is what drift costs in absolute terms.
  EXPECT_NEAR(m.ate_raw_m.max, 0.2, 1e-9);

  // The whole pass: one pair, first → last.
  TrajectoryMetricsOptions whole;
  whole.rpe_distance_m = 0.0;
  const TrajectoryMetrics w = ComputeTrajectoryMetrics(estimate, truth, whole);
  EXPECT_EQ(w.rpe_translation_percent.count, 1);
  EXPECT_NEAR(w.rpe_translation_percent.rmse, 1.0, 1e-9);

  // On the curved row, 1 % scale is ≈ 1 % of the distance travelled (chord ≤ arc).
  const std::vector<Rigid3> curved = CurvedTruth();
  std::vector<Rigid3> curved_estimate;
  for (const Rigid3& p : curved) curved_estimate.emplace_back(p.rotation(), 1.01 * p.translation());
  const TrajectoryMetrics c = ComputeTrajectoryMetrics(curved_estimate, curved);
  EXPECT_NEAR(c.rpe_translation_percent.mean, 1.0, 0.01);
  EXPECT_LE(c.rpe_translation_percent.max, 1.0 + 1e-9);
}

TEST(TrajectoryMetricsTest, RpeDistanceLongerThanThePathGivesNoPair) {
  TrajectoryMetricsOptions options;
  options.rpe_distance_m = 50.0;
  const TrajectoryMetrics m = ComputeTrajectoryMetrics(CurvedTruth(), CurvedTruth(), options);
  EXPECT_EQ(m.rpe_translation_percent.count, 0);
  EXPECT_EQ(m.rpe_rotation_deg_per_m.count, 0);
  EXPECT_EQ(m.ate_raw_m.count, 201);
  options.rpe_distance_m = -1.0;
  EXPECT_NE(options.Check(), "");
}

TEST(TrajectoryMetricsTest, UmeyamaRecoversAKnownSE3) {
  const Rigid3 known(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.3, 1.0).normalized())),
      Eigen::Vector3d(12.0, -3.5, 0.8));
  const std::vector<Rigid3> truth = CurvedTruth();
  std::vector<Eigen::Vector3d> src, dst;
  for (const Rigid3& p : truth) {
    src.push_back(p.translation());
    dst.push_back(known * p.translation());
  }
  const Rigid3 found = AlignSE3(src, dst);
  EXPECT_LT((found.translation() - known.translation()).norm(), 1e-9);
  EXPECT_LT(RotationAngleDeg(found.rotation().conjugate() * known.rotation()), 1e-7);

  // An estimate in a world frame moved by `known`⁻¹: the metrics align it back.
  std::vector<Rigid3> estimate;
  for (const Rigid3& p : truth) estimate.push_back(known.Inverse() * p);
  const TrajectoryMetrics m = ComputeTrajectoryMetrics(estimate, truth);
  EXPECT_LT((m.truth_from_estimate.translation() - known.translation()).norm(), 1e-9);
  EXPECT_LT(RotationAngleDeg(m.truth_from_estimate.rotation().conjugate() * known.rotation()),
            1e-7);
  EXPECT_GT(m.ate_raw_m.rmse, 1.0);
  EXPECT_LT(m.ate_aligned_m.max, 1e-9);
  // The rotation error is not aligned: every pose is off by the angle of `known`.
  EXPECT_NEAR(m.rotation_deg.rmse, 0.7 / kDeg, 1e-7);
  // Relative poses do not depend on the world frame.
  EXPECT_LT(m.rpe_translation_percent.max, 1e-8);
}

TEST(TrajectoryMetricsTest, YawTranslationAlignmentRecoversAHeadingAndAShift) {
  const Rigid3 known(Eigen::Quaterniond(Eigen::AngleAxisd(-2.1, Eigen::Vector3d::UnitZ())),
                     Eigen::Vector3d(-4.0, 7.5, 1.2));
  const std::vector<Rigid3> truth = CurvedTruth();
  std::vector<Rigid3> estimate;
  for (const Rigid3& p : truth) estimate.push_back(known.Inverse() * p);
  const Rigid3 found = AlignYawTranslation(estimate, truth);
  EXPECT_LT((found.translation() - known.translation()).norm(), 1e-9);
  EXPECT_LT(RotationAngleDeg(found.rotation().conjugate() * known.rotation()), 1e-7);
  // A rig standing still: one position, the heading from the orientation alone.
  const std::vector<Rigid3> still(5, truth[3]);
  std::vector<Rigid3> still_estimate(5, known.Inverse() * truth[3]);
  const Rigid3 from_rotation = AlignYawTranslation(still_estimate, still);
  EXPECT_LT(RotationAngleDeg(from_rotation.rotation().conjugate() * known.rotation()), 1e-7);
  // A tilt is not aligned away: only the heading and the shift are free.
  const Rigid3 tilt(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitX())),
                    Eigen::Vector3d::Zero());
  for (Rigid3& p : estimate) p = tilt * p;
  EXPECT_LT(std::abs(AlignYawTranslation(estimate, truth).RotationMatrix()(2, 2) - 1.0), 1e-12);
}

TEST(TrajectoryMetricsTest, GaussianNoiseGivesItsRmse) {
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.02);
  const std::vector<Rigid3> truth = CurvedTruth(2001);
  std::vector<Rigid3> estimate;
  for (const Rigid3& p : truth) {
    estimate.emplace_back(p.rotation(),
                          p.translation() + Eigen::Vector3d(noise(rng), noise(rng), noise(rng)));
  }
  const TrajectoryMetrics m = ComputeTrajectoryMetrics(estimate, truth);
  // E|e|² = 3σ² → RMSE = √3 σ.
  EXPECT_NEAR(m.ate_raw_m.rmse, std::sqrt(3.0) * 0.02, 0.002);
  EXPECT_LE(m.ate_aligned_m.rmse, m.ate_raw_m.rmse);
  EXPECT_NEAR(m.ate_aligned_m.rmse, m.ate_raw_m.rmse, 0.002);
}

TEST(TrajectoryMetricsTest, FewPosesHaveNoAlignment) {
  const std::vector<Rigid3> truth = CurvedTruth(2);
  const TrajectoryMetrics m =
      ComputeTrajectoryMetrics(Translated(truth, Eigen::Vector3d(0, 0, 0.05)), truth);
  EXPECT_EQ(m.num_poses, 2);
  EXPECT_NEAR(m.ate_raw_m.rmse, 0.05, 1e-12);
  EXPECT_EQ(m.ate_aligned_m.count, 0);
  const TrajectoryMetrics empty = ComputeTrajectoryMetrics({}, {});
  EXPECT_EQ(empty.num_poses, 0);
  EXPECT_EQ(empty.ate_raw_m.count, 0);
}

TEST(ErrorStatsTest, OfAndPool) {
  const ErrorStats a = ErrorStats::Of({1.0, 2.0, 2.0});
  EXPECT_EQ(a.count, 3);
  EXPECT_NEAR(a.mean, 5.0 / 3.0, 1e-12);
  EXPECT_NEAR(a.rmse, 3.0 / std::sqrt(3.0), 1e-12);
  EXPECT_EQ(a.max, 2.0);
  const ErrorStats b = ErrorStats::Of({4.0});
  const ErrorStats pooled = ErrorStats::Pool({a, ErrorStats(), b});
  const ErrorStats all = ErrorStats::Of({1.0, 2.0, 2.0, 4.0});
  EXPECT_EQ(pooled.count, 4);
  EXPECT_NEAR(pooled.rmse, all.rmse, 1e-12);
  EXPECT_NEAR(pooled.mean, all.mean, 1e-12);
  EXPECT_EQ(pooled.max, 4.0);
  EXPECT_EQ(ErrorStats::Pool({}).count, 0);
}

TEST(RotationAngleTest, Degrees) {
  EXPECT_NEAR(
      RotationAngleDeg(Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()))),
      0.3 / kDeg, 1e-10);
  // q and −q are the same rotation.
  const Eigen::Quaterniond q(Eigen::AngleAxisd(3.0, Eigen::Vector3d::UnitX()));
  EXPECT_NEAR(RotationAngleDeg(Eigen::Quaterniond(-q.coeffs())), 3.0 / kDeg, 1e-9);
  EXPECT_NEAR(RotationAngleDeg(Eigen::Quaterniond::Identity()), 0.0, 1e-12);
}

// ---------------------------------------------------------------------------------------------
// Association.

std::vector<io::StampedPose> Stamped(const std::vector<Timestamp>& times) {
  std::vector<io::StampedPose> poses;
  for (Timestamp t : times) {
    const double s = 1e-9 * static_cast<double>(t);
    poses.push_back({t, CurvedRowPose(s)});
  }
  return poses;
}

constexpr Timestamp kMs = kNanosPerMillisecond;

TEST(AssociateByTimeTest, ExactMatches) {
  const auto truth = Stamped({0, 100 * kMs, 200 * kMs, 300 * kMs});
  auto estimate = Stamped({100 * kMs, 300 * kMs, 0});  // any order
  for (auto& p : estimate) p.pose = Rigid3(p.pose.rotation(), p.pose.translation() * 2.0);
  const AssociatedPoses a = AssociateByTime(estimate, truth, 10 * kMs);
  ASSERT_EQ(a.size(), 3);
  EXPECT_EQ(a.exact, 3);
  EXPECT_EQ(a.interpolated, 0);
  EXPECT_EQ(a.dropped(), 0);
  EXPECT_EQ(a.t[0], 100 * kMs);
  EXPECT_EQ(a.t[2], 0);
  EXPECT_EQ(a.truth[0].translation(), truth[1].pose.translation());
  EXPECT_EQ(a.estimate[0].translation(), estimate[0].pose.translation());
  EXPECT_EQ(a.truth[1].translation(), truth[3].pose.translation());
}

TEST(AssociateByTimeTest, InterpolatesBetweenNeighboursWithinMaxDt) {
  const auto truth = Stamped({0, 100 * kMs, 200 * kMs});
  const auto estimate = Stamped({25 * kMs, 150 * kMs});
  const AssociatedPoses a = AssociateByTime(estimate, truth, 100 * kMs);
  ASSERT_EQ(a.size(), 2);
  EXPECT_EQ(a.interpolated, 2);
  EXPECT_EQ(a.exact, 0);
  const Rigid3 expected0 = geometry::InterpolateSeparately(truth[0].pose, truth[1].pose, 0.25);
  EXPECT_LT((a.truth[0].translation() - expected0.translation()).norm(), 1e-12);
  EXPECT_LT(a.truth[0].rotation().angularDistance(expected0.rotation()), 1e-12);
  const Eigen::Vector3d mid = 0.5 * (truth[1].pose.translation() + truth[2].pose.translation());
  EXPECT_LT((a.truth[1].translation() - mid).norm(), 1e-12);
  // The interpolated truth is close to the true pose (the trajectory is smooth).
  EXPECT_LT((a.truth[1].translation() - CurvedRowPose(0.15).translation()).norm(), 1e-3);
  EXPECT_LT(a.truth[1].rotation().angularDistance(CurvedRowPose(0.15).rotation()), 1e-3);

  // A neighbour further than max_dt: dropped as in a gap.
  const AssociatedPoses tight = AssociateByTime(estimate, truth, 60 * kMs);
  EXPECT_EQ(tight.size(), 1);  // 150 ms: both neighbours 50 ms away; 25 ms: 75 ms to 100 ms
  EXPECT_EQ(tight.dropped_gap, 1);
  EXPECT_EQ(tight.t[0], 150 * kMs);
}

TEST(AssociateByTimeTest, OutOfSpanAndGapsAreDroppedAndCounted) {
  const auto truth = Stamped({1000 * kMs, 1010 * kMs, 1020 * kMs, 2000 * kMs, 2010 * kMs});
  const auto estimate =
      Stamped({900 * kMs, 999 * kMs, 1005 * kMs, 1500 * kMs, 2010 * kMs, 2011 * kMs, 3000 * kMs});
  const AssociatedPoses a = AssociateByTime(estimate, truth, 20 * kMs);
  EXPECT_EQ(a.dropped_out_of_span, 4);  // 900, 999, 2011, 3000
  EXPECT_EQ(a.dropped_gap, 1);          // 1500: in the truth's 980 ms gap
  EXPECT_EQ(a.exact, 1);                // 2010
  EXPECT_EQ(a.interpolated, 1);         // 1005
  EXPECT_EQ(a.size(), 2);
  EXPECT_EQ(AssociateByTime(estimate, {}, 20 * kMs).dropped_out_of_span, 7);
}

TEST(TrajectoryWanderTest, HeadingChangeAndDisplacementFromTheFirstPose) {
  // A camera looking north-east and down; later poses turn by 2° about the vertical and move.
  const Eigen::Quaterniond look(Eigen::AngleAxisd(M_PI / 4, Eigen::Vector3d::UnitZ()) *
                                Eigen::AngleAxisd(-2.0, Eigen::Vector3d::UnitX()));
  std::vector<Rigid3> poses;
  for (int k = 0; k < 5; ++k) {
    const Eigen::Quaterniond turn(
        Eigen::AngleAxisd(k * 0.5 * M_PI / 180, Eigen::Vector3d::UnitZ()));
    poses.emplace_back(turn * look, Eigen::Vector3d(k * 0.001, 0, -k * 0.002));
  }
  const Wander w = TrajectoryWander(poses);
  EXPECT_NEAR(w.max_heading_change_deg, 2.0, 1e-9);
  EXPECT_NEAR(w.max_displacement_m, std::sqrt(0.004 * 0.004 + 0.008 * 0.008), 1e-12);
  // A turn about the vertical and a shift leave the tilt unchanged; a roll of 1° does not.
  std::vector<Rigid3> other;
  const Eigen::Quaterniond yaw(Eigen::AngleAxisd(1.0, Eigen::Vector3d::UnitZ()));
  for (const Rigid3& p : poses)
    other.emplace_back(yaw * p.rotation(), p.translation() + Eigen::Vector3d(5, 6, 7));
  EXPECT_LT(MaxTiltErrorDeg(poses, other), 1e-6);
  other[2] = Rigid3(Eigen::AngleAxisd(M_PI / 180, Eigen::Vector3d::UnitX()) * poses[2].rotation(),
                    poses[2].translation());
  EXPECT_NEAR(MaxTiltErrorDeg(poses, other), 1.0, 1e-6);
}

}  // namespace
}  // namespace crop4d::eval
