// The densify stage on a small rendered field with the simulator's true poses standing in for
// `crop4d fuse`'s: outputs and their accuracy, skipping when up to date, --force, a changed input,
// and the error for a workspace that has not been fused.

#include "crop4d/pipeline/densify_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <stdexcept>

#include "crop4d/core/error.h"
#include "crop4d/dense/dense_test_util.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/image_sequence.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/simulator.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_measurements.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

class DensifyStageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ =
        (fs::path(::testing::TempDir()) / ("crop4d_densify_" + std::to_string(getpid()))).string();
    fs::remove_all(root_);
    field_ = root_ + "/field";
    workspace_ = root_ + "/ws";
    fs::create_directories(workspace_);
  }
  void TearDown() override { fs::remove_all(root_); }

  // Renders the views of a small box on row 0 with the tiny preset's 320×240 camera and writes
  // the field and the "fused" workspace. False when there is no headless OpenGL.
  bool MakeField() {
    simulator_ = std::make_unique<sim::Simulator>(
        dense::testing::StripConfig({"2016-06-20"}, 3, /*small_camera=*/true));
    sim::RenderOptions ro;
    ro.camera = simulator_->config().camera.Intrinsics();
    std::unique_ptr<sim::Renderer> renderer;
    try {
      renderer = std::make_unique<sim::Renderer>(simulator_->world(), ro);
    } catch (const std::runtime_error&) {
      return false;
    }
    const dense::testing::RenderedSession rs =
        dense::testing::RenderAround(*simulator_, renderer.get(), 0, box_.center(), 4.0);
    session_ = rs.id;
    Eigen::AlignedBox2d wide = box_;
    wide.min() -= Eigen::Vector2d::Constant(1.5);
    wide.max() += Eigen::Vector2d::Constant(1.5);
    dense::testing::WriteFieldAndWorkspace(*simulator_, rs, wide, field_, workspace_);
    WriteRowSlamRecord();
    return true;
  }

  // What row SLAM records of the session for densify: one pass over the whole session with its
  // measurements (the camera and the image list of the field); and what fuse records of its
  // camera (camera.json: the calibration as written).
  void WriteRowSlamRecord() const {
    const io::ImageSequence images(io::Field(field_).OpenSession(session_), "cam0");
    std::vector<Timestamp> times;
    for (std::size_t i = 0; i < images.size(); ++i) times.push_back(images.time(i));
    slam::RowPass pass;
    pass.id = "whole";
    pass.row = -1;
    pass.t_begin = times.front();
    pass.t_end = times.back();
    const workspace::Layout layout(workspace_);
    fs::create_directories(layout.PassDir(session_, pass.id));
    workspace::WritePassList(layout.PassList(session_).string(), {pass});
    const slam::CameraStream camera{images.camera(), images.entries()};
    workspace::WritePassMeasurements(
        layout.PassMeasurements(session_, pass.id).string(),
        workspace::SelectPassMeasurements(&camera, nullptr, nullptr, times, times.front(),
                                          times.back(),
                                          fs::path(images.folder()).lexically_relative(field_)));
    workspace::WriteFusedCamera(layout.FusedCamera(session_).string(),
                                {images.camera().camera, images.camera().body_from_sensor});
  }

  // The tallest plant of the box on the strip's date, m above the ground.
  double TallestPlant() const {
    const sim::World& world = simulator_->world();
    const Timestamp date = simulator_->config().SessionDates()[0];
    double tallest = 0;
    for (const sim::Plant& plant : world.plants()) {
      if (box_.contains(plant.xy)) tallest = std::max(tallest, world.StateAt(plant, date).height_m);
    }
    return tallest;
  }

  DensifyStageOptions Options() const {
    DensifyStageOptions o;
    o.show_progress = false;
    o.boxes = {box_};
    o.stereo.cell_m = 0.015;  // the 320×240 camera's pixels cover twice the demo camera's ground
    // The strip is still (no wind): views of any time, the most informative there. The choice
    // of views near in time is checked once below (and in dense/height_field_stereo_test.cc).
    o.stereo.near_time_s = 0;
    return o;
  }

  std::string root_, field_, workspace_, session_;
  std::unique_ptr<sim::Simulator> simulator_;
  const Eigen::AlignedBox2d box_{Eigen::Vector2d(-0.3, 3.7), Eigen::Vector2d(0.5, 4.3)};
};

TEST_F(DensifyStageTest, WritesAnAccurateCloudAndSkipsWhenUpToDate) {
  if (!MakeField()) GTEST_SKIP() << "no headless OpenGL";
  const std::vector<DensifySessionReport> first = RunDensifyStage(field_, workspace_, Options());
  ASSERT_EQ(first.size(), 1u);
  EXPECT_FALSE(first[0].skipped);
  EXPECT_EQ(first[0].session, session_);
  EXPECT_GT(first[0].num_views, 20);
  const std::string ply = workspace_ + "/dense/" + session_ + ".ply";
  const std::string summary = workspace_ + "/dense/" + session_ + ".json";
  ASSERT_TRUE(fs::exists(ply));
  ASSERT_TRUE(fs::exists(summary));

  // The cloud: points inside the box, coloured, with the scalars; the soil on the terrain.
  const io::PlyPointCloud cloud = io::ReadPly(ply);
  EXPECT_EQ(static_cast<std::int64_t>(cloud.size()), first[0].stereo.num_points);
  EXPECT_GT(cloud.size(), 0.5 * first[0].stereo.num_cells);
  ASSERT_EQ(cloud.colors.size(), cloud.size());
  ASSERT_NE(cloud.FindScalar("score"), nullptr);
  ASSERT_NE(cloud.FindScalar("num_views"), nullptr);
  const sim::World& world = simulator_->world();
  const Timestamp date = simulator_->config().SessionDates()[0];
  std::vector<double> soil;
  for (const Eigen::Vector3d& p : cloud.points) {
    EXPECT_TRUE(box_.contains(p.head<2>()));
    bool near_plant = false;
    for (const sim::Plant& plant : world.plants()) {
      const sim::PlantState s = world.StateAt(plant, date);
      near_plant |= s.emerged && (p.head<2>() - plant.xy).norm() < s.canopy_radius_m + 0.05;
    }
    if (!near_plant) soil.push_back(std::abs(p.z() - world.TerrainHeight(p.x(), p.y())));
  }
  ASSERT_GT(soil.size(), 1000u);
  std::nth_element(soil.begin(), soil.begin() + soil.size() / 2, soil.end());
  // 320×240 pixels cover 2 cm of ground at 2.5 m: the soil is still within a few millimetres.
  EXPECT_LT(soil[soil.size() / 2], 0.005);
  {
    std::ifstream in(summary);
    const nlohmann::json j = nlohmann::json::parse(in);
    EXPECT_FALSE(j.value("fingerprint", "").empty());
    EXPECT_EQ(j.value("points", std::int64_t{0}), first[0].stereo.num_points);
    EXPECT_DOUBLE_EQ(j["canopy_ceiling"].value("m", 0.0), first[0].ceiling.ceiling_m);
  }
  // This sparse cloud holds soil alone: the plant tops are searched up to the least ceiling
  // (0.25 m), the strip's tallest plant (0.246 m) reaches the 2 cm below it, and the dense
  // points there are counted (the stage warns). DensifyStageTest.
  // SearchCeilingAboveThePlantsOfTheSparseCloud has plants in its sparse cloud.
  EXPECT_GT(first[0].ceiling.num_points, 0);
  EXPECT_DOUBLE_EQ(first[0].ceiling.ceiling_m, dense::CanopyCeilingOptions{}.min_m);
  EXPECT_GT(TallestPlant(), first[0].ceiling.ceiling_m - 0.02);
  EXPECT_GT(first[0].ceiling.dense_points_near, 0);

  // Unchanged: skipped; --force: densified again.
  const std::vector<DensifySessionReport> second = RunDensifyStage(field_, workspace_, Options());
  ASSERT_EQ(second.size(), 1u);
  EXPECT_TRUE(second[0].skipped);
  EXPECT_EQ(second[0].stereo.num_points, first[0].stereo.num_points);
  DensifyStageOptions force = Options();
  force.force = true;
  EXPECT_FALSE(RunDensifyStage(field_, workspace_, force)[0].skipped);

  // New fused poses (here: the same poses, one dropped) or other options: densified again.
  const std::string poses_path = workspace_ + "/fused/" + session_ + "/poses.tum";
  std::vector<io::StampedPose> poses = io::ReadTum(poses_path);
  poses.pop_back();
  io::WriteTum(poses_path, poses);
  EXPECT_FALSE(RunDensifyStage(field_, workspace_, Options())[0].skipped);
  EXPECT_TRUE(RunDensifyStage(field_, workspace_, Options())[0].skipped);
  // The images' capture times reach the matcher: with the default views near in time, tiles
  // with plants change their views, and the summary counts them.
  DensifyStageOptions near = Options();
  near.stereo.near_time_s = dense::HeightFieldStereo::Options{}.near_time_s;
  const DensifySessionReport with_time = RunDensifyStage(field_, workspace_, near)[0];
  EXPECT_FALSE(with_time.skipped);
  EXPECT_GT(with_time.stereo.num_tiles_near_in_time, 0);
  {
    std::ifstream in(summary);
    EXPECT_EQ(nlohmann::json::parse(in).value("tiles_near_in_time", -1),
              with_time.stereo.num_tiles_near_in_time);
  }
  DensifyStageOptions other = Options();
  other.stereo.min_score = 0.6;
  EXPECT_FALSE(RunDensifyStage(field_, workspace_, other)[0].skipped);

  // The intrinsics come from fuse's camera.json: another calibration is densified again, one of
  // another image size is refused naming the file.
  const std::string camera_path = workspace::Layout(workspace_).FusedCamera(session_).string();
  workspace::FusedCamera camera = workspace::ReadFusedCamera(camera_path);
  camera.intrinsics.cx += 0.5;
  camera.refined = true;
  workspace::WriteFusedCamera(camera_path, camera);
  EXPECT_FALSE(RunDensifyStage(field_, workspace_, other)[0].skipped);
  camera.intrinsics.width *= 2;
  workspace::WriteFusedCamera(camera_path, camera);
  try {
    RunDensifyStage(field_, workspace_, other);
    ADD_FAILURE() << "no InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("camera.json"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("crop4d fuse"), std::string::npos) << e.what();
  }
}

TEST_F(DensifyStageTest, SearchCeilingAboveThePlantsOfTheSparseCloud) {
  if (!MakeField()) GTEST_SKIP() << "no headless OpenGL";
  // A sparse cloud like the fused SIFT cloud: soil, and points on the leaves of every plant
  // at 30-70 % of its height (SIFT rarely tracks the top leaf).
  const sim::World& world = simulator_->world();
  const Timestamp date = simulator_->config().SessionDates()[0];
  io::PlyPointCloud sparse;
  sparse.points = dense::testing::SoilCloud(world, box_);
  for (const sim::Plant& plant : world.plants()) {
    const sim::PlantState state = world.StateAt(plant, date);
    if (!state.emerged) continue;
    const double ground = world.TerrainHeight(plant.xy.x(), plant.xy.y());
    for (int k = 0; k < 5; ++k) {
      const double angle = 1.3 * k;
      const Eigen::Vector2d xy = plant.xy + 0.5 * state.canopy_radius_m *
                                                Eigen::Vector2d(std::cos(angle), std::sin(angle));
      sparse.points.emplace_back(xy.x(), xy.y(), ground + (0.3 + 0.1 * k) * state.height_m);
    }
  }
  io::WritePly(workspace::Layout(workspace_).FusedSparse(session_).string(), sparse);
  const DensifySessionReport adaptive = RunDensifyStage(field_, workspace_, Options())[0];
  EXPECT_GT(adaptive.ceiling.ceiling_m, TallestPlant() + 0.05);
  EXPECT_LT(adaptive.ceiling.ceiling_m, Options().stereo.max_canopy_height_m);
  EXPECT_EQ(adaptive.ceiling.dense_points_near, 0);
  // --fixed-ceiling: the whole range, and another fingerprint.
  DensifyStageOptions fixed = Options();
  fixed.adaptive_ceiling = false;
  const DensifySessionReport whole = RunDensifyStage(field_, workspace_, fixed)[0];
  EXPECT_FALSE(whole.skipped);
  EXPECT_DOUBLE_EQ(whole.ceiling.ceiling_m, fixed.stereo.max_canopy_height_m);
}

TEST_F(DensifyStageTest, MissingFusedOutputSaysToRunFuse) {
  // A field with a session but no images (nothing is rendered: the error comes first).
  simulator_ = std::make_unique<sim::Simulator>(
      dense::testing::StripConfig({"2016-06-20"}, 3, /*small_camera=*/true));
  dense::testing::RenderedSession rs;
  rs.id = session_ = "2016-06-20";
  rs.camera = simulator_->config().camera.Intrinsics();
  dense::testing::WriteFieldAndWorkspace(*simulator_, rs, box_, field_, workspace_);
  fs::remove(workspace_ + "/fused/" + session_ + "/poses.tum");
  try {
    RunDensifyStage(field_, workspace_, Options());
    FAIL() << "expected InputError";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crop4d fuse"), std::string::npos) << e.what();
  }
  DensifyStageOptions named = Options();
  named.sessions = {session_};
  EXPECT_THROW(RunDensifyStage(field_, workspace_, named), InputError);
  named.sessions = {"1999-01-01"};
  EXPECT_THROW(RunDensifyStage(field_, workspace_, named), InputError);
}

}  // namespace
}  // namespace crop4d::pipeline
