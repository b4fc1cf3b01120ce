// The option checks of the slam, associate, fuse and densify stages: an invalid option is an
// InputError that names the option (with its configuration section) and why, raised before the
// stage reads anything.

#include <gtest/gtest.h>

#include <functional>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/pipeline/densify_stage.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/pipeline/run_config.h"
#include "crop4d/pipeline/slam_stage.h"

namespace crop4d::pipeline {
namespace {

// The message of the InputError `run` throws ("" when it throws none).
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

TEST(StageOptionsTest, DefaultsAreValid) {
  EXPECT_EQ(SlamStageOptions().Check(), "");
  EXPECT_EQ(AssociateStageOptions().Check(), "");
  EXPECT_EQ(FuseStageOptions().Check(), "");
  EXPECT_EQ(DensifyStageOptions().Check(), "");
}

TEST(StageOptionsTest, SlamNamesTheOptionAndWhy) {
  SlamStageOptions o;
  o.state_rate_hz = 0;
  EXPECT_EQ(o.Check(), "state_rate_hz: must be > 0");
  EXPECT_EQ(InputErrorOf([&] { RunSlamStage(kNoField, kNoWorkspace, o); }),
            "slam.state_rate_hz: must be > 0");
  o = SlamStageOptions();
  o.max_window_s = o.window_overlap_s;
  EXPECT_EQ(o.Check(), "max_window_s: must be > window_overlap_s");
  o = SlamStageOptions();
  o.gps_outages.push_back({10.0, -1.0});
  EXPECT_EQ(o.Check(), "gps_outages: a duration must be > 0");
  o = SlamStageOptions();
  o.optimiser.max_iterations = 0;
  EXPECT_EQ(o.Check(), "optimiser: invalid row optimiser options");
}

TEST(StageOptionsTest, AssociateNamesTheOptionAndWhy) {
  AssociateStageOptions o;
  o.prealign = "sometimes";
  EXPECT_EQ(o.Check(), "prealign: must be auto, always or never (got 'sometimes')");
  EXPECT_EQ(InputErrorOf([&] { RunAssociateStage(kNoField, kNoWorkspace, o); }),
            "associate.prealign: must be auto, always or never (got 'sometimes')");
  o = AssociateStageOptions();
  o.min_track_length = 1;
  EXPECT_EQ(o.Check(), "min_track_length: must be >= 2");
}

TEST(StageOptionsTest, FuseNamesTheOptionAndWhy) {
  FuseStageOptions o;
  o.max_matches_per_image_pair = -1;
  EXPECT_EQ(o.Check(), "max_matches_per_image_pair: must be >= 0 (0: all)");
  EXPECT_EQ(InputErrorOf([&] { RunFuseStage(kNoField, kNoWorkspace, o); }),
            "fuse.max_matches_per_image_pair: must be >= 0 (0: all)");
}

TEST(StageOptionsTest, DensifyNamesTheOptionAndWhy) {
  DensifyStageOptions o;
  o.radius_m = 0;
  EXPECT_EQ(o.Check(), "radius_m: must be > 0");
  EXPECT_EQ(InputErrorOf([&] { RunDensifyStage(kNoField, kNoWorkspace, o); }),
            "densify.radius_m: must be > 0");
}

TEST(StageOptionsTest, RunConfigNamesTheSectionAndOption) {
  RunConfig config;
  config.fuse.ground_tie_max_matches = -2;
  std::string message;
  EXPECT_FALSE(config.Check(&message));
  EXPECT_EQ(message, "fuse.ground_tie_max_matches: must be >= 0");
}

}  // namespace
}  // namespace crop4d::pipeline
