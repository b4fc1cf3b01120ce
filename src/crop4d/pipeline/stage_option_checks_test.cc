// The checks of the stages' nested options: an invalid option of a module's struct is reported
// with the path of its key in the stage's section ("optimiser.max_iterations: ..."), both by the
// stage options' Check() and by the InputError the stage raises before it reads anything.

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/pipeline/analyze_stage.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/pipeline/slam_stage.h"

namespace crop4d::pipeline {
namespace {

std::string InputErrorOf(const std::function<void()>& run) {
  try {
    run();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

constexpr const char* kNoField = "/nonexistent/crop4d_field";
constexpr const char* kNoWorkspace = "/nonexistent/crop4d_workspace";

TEST(StageOptionChecksTest, SlamPassesANestedReasonUpWithItsKey) {
  SlamStageOptions o;
  o.optimiser.max_iterations = 0;
  EXPECT_EQ(o.Check(), "optimiser.max_iterations: must be > 0 (got 0)");
  EXPECT_EQ(InputErrorOf([&] { RunSlamStage(kNoField, kNoWorkspace, o); }),
            "slam.optimiser.max_iterations: must be > 0 (got 0)");
  o = SlamStageOptions();
  o.cloud.max_reprojection_error_px = -1;
  ASSERT_FALSE(o.cloud.Check().empty());
  EXPECT_EQ(o.Check(), "cloud." + o.cloud.Check());
}

TEST(StageOptionChecksTest, AssociatePassesANestedReasonUpWithItsKey) {
  AssociateStageOptions o;
  o.naive.descriptors.max_ratio = 2;
  ASSERT_FALSE(o.naive.Check().empty());
  EXPECT_EQ(o.Check(), "naive." + o.naive.Check());
  EXPECT_EQ(InputErrorOf([&] { RunAssociateStage(kNoField, kNoWorkspace, o); }),
            "associate.naive." + o.naive.Check());
  o = AssociateStageOptions();
  o.alignment.min_inliers = 1;
  ASSERT_FALSE(o.alignment.Check().empty());
  EXPECT_EQ(o.Check(), "alignment." + o.alignment.Check());
  o = AssociateStageOptions();
  o.robust.search_sigmas = -1;
  ASSERT_FALSE(o.robust.Check().empty());
  EXPECT_EQ(o.Check(), "robust." + o.robust.Check());
}

TEST(StageOptionChecksTest, FusePassesANestedReasonUpWithItsKey) {
  FuseStageOptions o;
  o.optimiser.row.max_iterations = 0;
  EXPECT_EQ(o.Check(), "optimiser.row.max_iterations: must be > 0 (got 0)");
  EXPECT_EQ(InputErrorOf([&] { RunFuseStage(kNoField, kNoWorkspace, o); }),
            "fuse.optimiser.row.max_iterations: must be > 0 (got 0)");
  o = FuseStageOptions();
  o.ground_tie.min_points = -1;
  ASSERT_FALSE(o.ground_tie.Check().empty());
  EXPECT_EQ(o.Check(), "ground_tie." + o.ground_tie.Check());
}

TEST(StageOptionChecksTest, DensifyPassesANestedReasonUpWithItsKey) {
  DensifyStageOptions o;
  o.stereo.cell_m = 0;
  ASSERT_FALSE(o.stereo.Check().empty());
  EXPECT_EQ(o.Check(), "stereo." + o.stereo.Check());
  EXPECT_EQ(InputErrorOf([&] { RunDensifyStage(kNoField, kNoWorkspace, o); }),
            "densify.stereo." + o.stereo.Check());
}

TEST(StageOptionChecksTest, AnalyzeNamesTheOptionAndWhy) {
  EXPECT_EQ(AnalyzeStageOptions().Check(), "");
  AnalyzeStageOptions o;
  o.cloud = "mesh";
  EXPECT_EQ(o.Check(), "cloud: must be auto, dense or sparse (got 'mesh')");
  EXPECT_EQ(InputErrorOf([&] { RunAnalyzeStage(kNoField, kNoWorkspace, o); }),
            "analyze.cloud: must be auto, dense or sparse (got 'mesh')");
  o = AnalyzeStageOptions();
  o.raster_cell_m = 0;
  EXPECT_EQ(o.Check(), "raster_cell_m: must be > 0 (got 0)");
  o = AnalyzeStageOptions();
  o.growth.robust_loss_m = -1;
  ASSERT_FALSE(o.growth.Check().empty());
  EXPECT_EQ(o.Check(), "growth." + o.growth.Check());
}

}  // namespace
}  // namespace crop4d::pipeline
