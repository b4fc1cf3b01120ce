// End-to-end tests of association and 4D fusion on a small simulated field (the tiny preset with
// three rows and two sessions without rain in between, so that every kind of pass pair exists):
// row SLAM → associate (robust and naive) → fuse → eval, with outcome bounds of the same kind as
// the demo targets, and the cam+imu+gps case in which association alone must register
// the sessions.

#include "crop4d/pipeline/fuse_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <nlohmann/json.hpp>

#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/colmap_text.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/sim/cached_field_test_util.h"
#include "crop4d/sim/sim_config.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

// The tiny preset with three rows and no rain between its two sessions, with the true depth map
// of every image (the evaluation of the associations reads them instead of rendering them).
const std::string& Field() {
  static const std::string path = [] {
    sim::SimConfig config = sim::PresetConfig("tiny");
    config.world.num_rows = 3;
    config.sessions.at(1).rain_before = false;
    config.ground_truth.depth = true;
    return sim::testing::CachedSimulatedField("tiny_three_rows", config);
  }();
  return path;
}

// Row SLAM (cam+imu+rtk) of Field(): a workspace made once per build of this test program
// (sim::testing::CachedTestFolder) and copied by the tests that start from it.
const std::string& RtkSlamOfField() {
  static const std::string path = [] {
    const std::string self = fs::read_symlink("/proc/self/exe").string();
    const std::string key = "test program " + sim::testing::BuiltFileStamp(self) + "\nfield " +
                            Field() + "\nsensors cam+imu+rtk\n";
    const std::string folder =
        sim::testing::CachedTestFolder("fusion_rtk_slam", key, [](const std::string& made) {
          SlamStageOptions o;
          o.show_progress = false;
          o.sensors = slam::ParseSensorSet("cam+imu+rtk");
          bool ok = true;
          for (const PassReport& r : RunSlamStage(Field(), made + "/ws", o)) {
            if (r.failed) ADD_FAILURE() << r.session << "/" << r.pass.id << ": " << r.message;
            ok = ok && !r.failed;
          }
          return ok;
        });
    return folder + "/ws";
  }();
  return path;
}

// The tiny preset as it is: two rows, rain between its two sessions (new soil texture).
const std::string& RainField() {
  static const std::string path =
      sim::testing::CachedSimulatedField("tiny_rain", sim::PresetConfig("tiny"));
  return path;
}

// The tiny preset with a third session and no rain (season_run_test.cc's field, shared through
// the cache).
const std::string& ThreeSessionField() {
  static const std::string path = [] {
    sim::SimConfig config = sim::PresetConfig("tiny");
    config.sessions = {{"2016-06-10", false}, {"2016-06-24", false}, {"2016-07-08", false}};
    return sim::testing::CachedSimulatedField("tiny_three_sessions", config);
  }();
  return path;
}

class FusionStagesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    workspace_ = (fs::path(::testing::TempDir()) /
                  ("crop4d_fusion_" + std::to_string(getpid()) + "_" +
                   ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                     .string();
    fs::remove_all(workspace_);
  }
  void TearDown() override { fs::remove_all(workspace_); }

  void Slam(const std::string& sensors, const std::string& field = Field(),
            const std::string& session = "") {
    SlamStageOptions o;
    o.show_progress = false;
    o.session = session;
    o.sensors = slam::ParseSensorSet(sensors);
    for (const PassReport& r : RunSlamStage(field, workspace_, o)) {
      ASSERT_FALSE(r.failed) << r.session << "/" << r.pass.id << ": " << r.message;
    }
  }

  // The workspace after Slam("cam+imu+rtk") on Field(), from RtkSlamOfField().
  void CopyRtkSlamOfField() { fs::copy(RtkSlamOfField(), workspace_, fs::copy_options::recursive); }

  static const eval::AssociationGroupEval* Group(const eval::WorkspaceEval& e, eval::PairType type,
                                                 const std::string& method) {
    for (const eval::AssociationGroupEval& g : e.association->eval.groups) {
      if (g.type == type && g.method == method) return &g;
    }
    return nullptr;
  }
  static const eval::CloudSetEval* Clouds(const eval::WorkspaceEval& e, const std::string& label) {
    for (const eval::CloudSetEval& c : e.clouds) {
      if (c.label == label) return &c;
    }
    return nullptr;
  }

  // Associates every other image (half the time, the same kind of result) with the robust method.
  std::vector<PassPairReport> Associate(const std::string& field) {
    AssociateStageOptions ao;
    ao.show_progress = false;
    ao.image_pairs.stride = 2;
    return RunAssociateStage(field, workspace_, ao);
  }

  // The median cross-session ground misalignment of a cloud set of the workspace (NaN, and a
  // failure, when it was not evaluated).
  double MedianMisalignment(const std::string& field, const std::string& label) {
    eval::WorkspaceEvalOptions eo;
    eo.associations = false;
    // The evaluation is kept alive while the pointer into it is read.
    const eval::WorkspaceEval e = eval::EvaluateWorkspace(workspace_, field, eo);
    const eval::CloudSetEval* clouds = Clouds(e, label);
    if (clouds == nullptr) {
      ADD_FAILURE() << "no " << label << " clouds evaluated";
      return std::numeric_limits<double>::quiet_NaN();
    }
    return clouds->misalignment.pooled.median_m;
  }

  std::string workspace_;
};

TEST_F(FusionStagesTest, RtkAssociationIsPreciseAndFusionKeepsTheAccuracy) {
  CopyRtkSlamOfField();
  AssociateStageOptions ao;
  ao.show_progress = false;
  ao.method = "both";
  ao.image_pairs.stride = 2;  // every other image: half the time, the same kind of result
  const std::vector<PassPair> schedule = ScheduleAssociations(Field(), workspace_, ao);
  // Per session: rows 0–2 are driven up, down, up: 0–2 same direction, 0–1 and 1–2 opposite;
  // across the two sessions: each row with itself.
  int same = 0, opposite = 0, sessions = 0;
  for (const PassPair& p : schedule) {
    same += p.type == PassPairType::kSameDirection;
    opposite += p.type == PassPairType::kOppositeDirection;
    sessions += p.type == PassPairType::kCrossSession;
  }
  EXPECT_EQ(same, 2);
  EXPECT_EQ(opposite, 4);
  EXPECT_EQ(sessions, 3);
  const std::vector<PassPairReport> reports = RunAssociateStage(Field(), workspace_, ao);
  ASSERT_EQ(reports.size(), 2 * schedule.size());
  FuseStageOptions fo;
  const FuseReport fused = RunFuseStage(Field(), workspace_, fo);
  EXPECT_GT(fused.joint.num_shared_landmarks, 100);

  // The demo's criterion is 2 cm at 640×480 and fx = 280; the tiny field's pixels (320×240,
  // fx = 140) cover twice the ground, so its counterpart is 4 cm.
  eval::WorkspaceEvalOptions eo;
  eo.association.max_distance_m = 0.04;
  eo.association.coarse_distance_m = 0.08;
  const eval::WorkspaceEval e = eval::EvaluateWorkspace(workspace_, Field(), eo);
  ASSERT_TRUE(e.association.has_value());
  ASSERT_TRUE(e.association->error.empty()) << e.association->error;
  const eval::AssociationGroupEval* robust_rows =
      Group(e, eval::PairType::kCrossRowSameDirection, "robust");
  const eval::AssociationGroupEval* naive_rows =
      Group(e, eval::PairType::kCrossRowSameDirection, "naive");
  const eval::AssociationGroupEval* robust_sessions =
      Group(e, eval::PairType::kCrossSession, "robust");
  ASSERT_NE(robust_rows, nullptr);
  ASSERT_NE(naive_rows, nullptr);
  ASSERT_NE(robust_sessions, nullptr);
  // The demo's bound is 95% (measured there: 96% across rows, 99% across sessions, see
  // bench/RESULTS.md). The tiny field's cross-row pairs see each other's ground only at grazing
  // angles through its coarser pixels (92% measured), so their bound here is 90%.
  EXPECT_GT(robust_rows->counts.correct, 200);
  EXPECT_GE(robust_rows->counts.Precision(), 0.90);
  EXPECT_GT(robust_sessions->counts.correct, 200);
  EXPECT_GE(robust_sessions->counts.Precision(), 0.95);
  EXPECT_GT(robust_rows->counts.correct, naive_rows->counts.correct);

  // Fusion keeps RTK-grade poses (no worse than row SLAM) and puts the sessions' ground on top of
  // each other.
  ASSERT_TRUE(e.fused.has_value());
  EXPECT_LT(e.fused->ate_raw_m.rmse, 0.02);
  EXPECT_LT(e.fused->ate_raw_m.rmse, e.overall.ate_raw_m.rmse * 1.15 + 0.002);
  const eval::CloudSetEval* clouds = Clouds(e, "fused");
  ASSERT_NE(clouds, nullptr);
  EXPECT_LT(clouds->misalignment.pooled.median_m, 0.015);

  // Outputs: a consistent COLMAP model of both sessions, and a rerun that does nothing.
  const io::ColmapModel model = io::ReadColmapText(workspace_ + "/fused/colmap");
  std::string why;
  EXPECT_TRUE(model.Check(&why)) << why;
  EXPECT_EQ(model.cameras.size(), 2u);
  EXPECT_GT(model.points.size(), 1000u);
  for (const PassPairReport& r : RunAssociateStage(Field(), workspace_, ao)) EXPECT_TRUE(r.skipped);
  EXPECT_TRUE(RunFuseStage(Field(), workspace_, fo).skipped);
}

TEST_F(FusionStagesTest, LowAccuracyGpsSessionsAreRegisteredByAssociation) {
  Slam("cam+imu+gps");
  const std::vector<PassPairReport> reports = Associate(Field());
  int prealigned = 0;
  for (const PassPairReport& r : reports) prealigned += r.prealigned ? 1 : 0;
  EXPECT_GE(prealigned, 3);  // at least the cross-session pairs
  FuseStageOptions fo;
  const FuseReport fused = RunFuseStage(Field(), workspace_, fo);
  EXPECT_GE(fused.joint.num_passes_aligned, 1);
  // Each session sits where its biased receiver put it; after fusion the ground of the two
  // sessions agrees to the 5 cm.
  EXPECT_GT(MedianMisalignment(Field(), "row_slam"), 0.1);
  EXPECT_LT(MedianMisalignment(Field(), "fused"), 0.05);
}

TEST_F(FusionStagesTest, AcrossRainGroundTiesRegisterTheSessionsWithoutMatches) {
  Slam("cam+imu+gps", RainField());
  Associate(RainField());
  FuseStageOptions fo;
  const FuseReport fused = RunFuseStage(RainField(), workspace_, fo);
  // After the rain nothing matches: each row's two dates are tied through the ground.
  ASSERT_EQ(fused.tie_pairs.size(), 2u);
  for (const FuseTiePairReport& t : fused.tie_pairs) {
    EXPECT_LT(t.cross_matches, fo.ground_tie_max_matches);
    EXPECT_GE(t.ties.ties, 5) << t.a << " ~ " << t.b;
  }
  EXPECT_EQ(fused.joint.num_ground_ties,
            fused.tie_pairs[0].ties.ties + fused.tie_pairs[1].ties.ties);
  EXPECT_LT(fused.joint.ground_tie_rms_vertical_m, 0.03);
  EXPECT_LT(MedianMisalignment(RainField(), "fused"), 0.05);
  // Without the ties the receivers' errors stay between the two dates.
  fo.ground_ties = false;
  fo.force = true;
  const FuseReport apart = RunFuseStage(RainField(), workspace_, fo);
  EXPECT_EQ(apart.joint.num_ground_ties, 0);
  EXPECT_GT(MedianMisalignment(RainField(), "fused"), 0.1);
}

// The incremental fuse (fuse_incremental.h): two sessions are fused in one step; when a third
// arrives only its step runs, the first session held; a damaged step file makes that step run
// again; the full fuse sweeps the season a window at a time; both are as accurate as one problem
// over the whole season.
TEST_F(FusionStagesTest, TheIncrementalFuseAddsASessionInOneStepAsWellAsOneProblem) {
  const std::string& field = ThreeSessionField();
  const std::vector<std::string> sessions = io::Field(field).session_ids();
  ASSERT_EQ(sessions.size(), 3u);
  Slam("cam+imu+rtk", field, sessions[0]);
  Slam("cam+imu+rtk", field, sessions[1]);
  Associate(field);
  FuseStageOptions fo;
  const FuseReport two = RunFuseStage(field, workspace_, fo);
  ASSERT_EQ(two.steps.size(), 1u);
  EXPECT_FALSE(two.steps[0].skipped);
  EXPECT_EQ(two.steps[0].optimised, (std::vector<std::string>{sessions[0], sessions[1]}));
  EXPECT_TRUE(two.steps[0].held.empty());

  Slam("cam+imu+rtk", field, sessions[2]);
  Associate(field);
  const FuseReport three = RunFuseStage(field, workspace_, fo);
  ASSERT_EQ(three.steps.size(), 2u);
  EXPECT_TRUE(three.steps[0].skipped);
  ASSERT_FALSE(three.steps[1].skipped);
  EXPECT_EQ(three.steps[1].optimised, (std::vector<std::string>{sessions[1], sessions[2]}));
  EXPECT_EQ(three.steps[1].held, (std::vector<std::string>{sessions[0]}));
  EXPECT_EQ(three.passes.size(), 6u);
  EXPECT_GT(three.joint.num_shared_landmarks, 100);
  EXPECT_TRUE(RunFuseStage(field, workspace_, fo).skipped);

  eval::WorkspaceEvalOptions eo;
  eo.associations = false;
  const eval::WorkspaceEval incremental = eval::EvaluateWorkspace(workspace_, field, eo);
  ASSERT_TRUE(incremental.fused.has_value());
  const eval::CloudSetEval* incremental_clouds = Clouds(incremental, "fused");
  ASSERT_NE(incremental_clouds, nullptr);
  const io::ColmapModel model = io::ReadColmapText(workspace_ + "/fused/colmap");
  std::string why;
  EXPECT_TRUE(model.Check(&why)) << why;
  EXPECT_EQ(model.cameras.size(), 3u);
  EXPECT_GT(model.points.size(), 1000u);

  // A damaged step: that step runs again (and the one after it, which starts from it).
  const fs::path step_landmarks =
      fs::path(workspace_) / "fused/steps" / sessions[1] / "landmarks.bin";
  ASSERT_TRUE(fs::exists(step_landmarks));
  std::ofstream(step_landmarks, std::ios::app) << "x";
  const FuseReport repaired = RunFuseStage(field, workspace_, fo);
  ASSERT_EQ(repaired.steps.size(), 2u);
  EXPECT_FALSE(repaired.steps[0].skipped);
  EXPECT_FALSE(repaired.steps[1].skipped);

  // The full fuse a window at a time: the steps that added the sessions are reused, and its
  // backward and forward sweeps each solve one window with the session beside it held.
  fo.full = true;
  const FuseReport swept = RunFuseStage(field, workspace_, fo);
  ASSERT_EQ(swept.steps.size(), 4u);
  EXPECT_TRUE(swept.steps[0].skipped);
  EXPECT_TRUE(swept.steps[1].skipped);
  ASSERT_FALSE(swept.steps[2].skipped);
  EXPECT_EQ(swept.steps[0].sweep, 0);
  EXPECT_EQ(swept.steps[2].name, "sweep1b-" + sessions[1]);
  EXPECT_EQ(swept.steps[2].sweep, 1);
  EXPECT_EQ(swept.steps[2].optimised, (std::vector<std::string>{sessions[0], sessions[1]}));
  EXPECT_EQ(swept.steps[2].held, (std::vector<std::string>{sessions[2]}));
  ASSERT_FALSE(swept.steps[3].skipped);
  EXPECT_EQ(swept.steps[3].optimised, (std::vector<std::string>{sessions[1], sessions[2]}));
  EXPECT_EQ(swept.steps[3].held, (std::vector<std::string>{sessions[0]}));
  // The season had settled in the steps that added its sessions: the sweeps move it little.
  EXPECT_LT(swept.steps[2].moved_m, 0.01);
  EXPECT_LT(swept.steps[3].moved_m, 0.01);
  EXPECT_EQ(swept.passes.size(), 6u);
  EXPECT_TRUE(RunFuseStage(field, workspace_, fo).skipped);
  const eval::WorkspaceEval sweeps = eval::EvaluateWorkspace(workspace_, field, eo);
  ASSERT_TRUE(sweeps.fused.has_value());
  const eval::CloudSetEval* sweeps_clouds = Clouds(sweeps, "fused");
  ASSERT_NE(sweeps_clouds, nullptr);
  const io::ColmapModel swept_model = io::ReadColmapText(workspace_ + "/fused/colmap");
  EXPECT_TRUE(swept_model.Check(&why)) << why;
  EXPECT_EQ(swept_model.cameras.size(), 3u);
  // Each landmark once: from the sweeps' steps, about as many as the steps session by session.
  EXPECT_GT(swept_model.points.size(), model.points.size() * 9 / 10);
  EXPECT_LT(swept_model.points.size(), model.points.size() * 11 / 10);

  // One problem over the whole season: the same accuracy, within a few millimetres.
  fo.full = false;
  fo.one_problem = true;
  const FuseReport full = RunFuseStage(field, workspace_, fo);
  EXPECT_TRUE(full.steps.empty());
  EXPECT_FALSE(fs::exists(fs::path(workspace_) / "fused/steps"));
  const eval::WorkspaceEval whole = eval::EvaluateWorkspace(workspace_, field, eo);
  ASSERT_TRUE(whole.fused.has_value());
  const eval::CloudSetEval* whole_clouds = Clouds(whole, "fused");
  ASSERT_NE(whole_clouds, nullptr);
  EXPECT_LT(incremental.fused->ate_raw_m.rmse, 0.02);
  EXPECT_LT(incremental.fused->ate_raw_m.rmse, whole.fused->ate_raw_m.rmse * 1.1 + 0.002);
  EXPECT_LT(incremental_clouds->misalignment.pooled.median_m,
            whole_clouds->misalignment.pooled.median_m * 1.1 + 0.002);
  EXPECT_LT(sweeps.fused->ate_raw_m.rmse, whole.fused->ate_raw_m.rmse * 1.1 + 0.002);
  EXPECT_LT(sweeps_clouds->misalignment.pooled.median_m,
            whole_clouds->misalignment.pooled.median_m * 1.1 + 0.002);
  std::printf(
      "fused ATE %.2f / %.2f / %.2f cm, misalignment %.2f / %.2f / %.2f cm (session by "
      "session / full, sweeps / one problem)\n",
      100 * incremental.fused->ate_raw_m.rmse, 100 * sweeps.fused->ate_raw_m.rmse,
      100 * whole.fused->ate_raw_m.rmse, 100 * incremental_clouds->misalignment.pooled.median_m,
      100 * sweeps_clouds->misalignment.pooled.median_m,
      100 * whole_clouds->misalignment.pooled.median_m);
}

// After row SLAM the workspace holds each pass's problem (priors in summary.json, measurements in
// measurements.bin): associate, fuse and densify run with every sensor file of the field gone
// (data.csv, sensor.yaml, session.yaml of every sensor); only field.yaml and the image files,
// whose pixels the workspace does not copy, stay.
TEST_F(FusionStagesTest, AssociateFuseAndDensifyReadOnlyTheWorkspace) {
  const fs::path field = fs::path(workspace_ + "_field");
  fs::remove_all(field);
  fs::copy(Field(), field, fs::copy_options::recursive);
  // Row SLAM of the field (that of its copy: the workspace does not depend on where the field
  // lies).
  CopyRtkSlamOfField();
  int removed = 0;
  for (const fs::directory_entry& e : fs::recursive_directory_iterator(field / "sessions")) {
    const std::string ext = e.path().extension().string();
    if (e.is_regular_file() && ext != ".png" && ext != ".jpg") {
      fs::remove(e.path());
      ++removed;
    }
  }
  EXPECT_GE(removed, 6);  // two sessions, each with at least a camera, an IMU and a receiver

  Associate(field.string());
  const FuseReport fused = RunFuseStage(field.string(), workspace_, FuseStageOptions{});
  EXPECT_GT(fused.joint.num_shared_landmarks, 100);
  const std::vector<io::StampedPose> poses =
      io::ReadTum(workspace_ + "/fused/" + fused.passes.front().session + "/poses.tum");
  ASSERT_FALSE(poses.empty());
  DensifyStageOptions dense;
  dense.show_progress = false;
  dense.sessions = {fused.passes.front().session};
  // A disc under the middle camera: enough views to match, seconds to densify.
  dense.centers = {poses[poses.size() / 2].pose.translation().head<2>()};
  dense.radius_m = 0.3;
  const std::vector<DensifySessionReport> clouds =
      RunDensifyStage(field.string(), workspace_, dense);
  ASSERT_EQ(clouds.size(), 1u);
  EXPECT_GT(clouds[0].stereo.num_points, 100);
  fs::remove_all(field);
}

}  // namespace
}  // namespace crop4d::pipeline
