// The plan of the incremental fuse (fuse_incremental.h): which sessions each step optimises and
// holds, and which sessions each step makes final.

#include "crop4d/pipeline/fuse_incremental.h"

#include <gtest/gtest.h>

#include "crop4d/pipeline/fuse_outputs.h"

namespace crop4d::pipeline::fuse {
namespace {

TEST(FuseStepsTest, TheFirstStepFusesTheWindowThenEachStepAddsOneSessionAndHoldsOne) {
  const std::vector<FuseStep> steps = PlanFuseSteps(5, 1);
  ASSERT_EQ(steps.size(), 4u);
  EXPECT_EQ(steps[0].first, 0);
  EXPECT_EQ(steps[0].last, 1);
  EXPECT_EQ(steps[0].held, -1);
  for (std::size_t s = 1; s < steps.size(); ++s) {
    EXPECT_EQ(steps[s].last, static_cast<int>(s) + 1);
    EXPECT_EQ(steps[s].first, steps[s].last - 1);
    EXPECT_EQ(steps[s].held, steps[s].last - 2);
  }
  // Every session is final in exactly one step, and held only once it is final.
  std::vector<int> final_count(5, 0);
  for (std::size_t s = 0; s < steps.size(); ++s) {
    for (const int k : FinalSessions(steps, s)) ++final_count[k];
    if (steps[s].held >= 0) {
      bool final_before = false;
      for (std::size_t t = 0; t < s; ++t) {
        for (const int k : FinalSessions(steps, t)) final_before |= k == steps[s].held;
      }
      EXPECT_TRUE(final_before) << "step " << s;
    }
  }
  for (int k = 0; k < 5; ++k) EXPECT_EQ(final_count[k], 1) << "session " << k;
  EXPECT_EQ(FinalSessions(steps, 3), (std::vector<int>{3, 4}));
}

TEST(FuseStepsTest, AWideWindowOrAShortSeasonIsOneStep) {
  const std::vector<FuseStep> one = PlanFuseSteps(3, 5);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_EQ(one[0].first, 0);
  EXPECT_EQ(one[0].last, 2);
  EXPECT_EQ(FinalSessions(one, 0), (std::vector<int>{0, 1, 2}));
  const std::vector<FuseStep> wide = PlanFuseSteps(6, 2);
  ASSERT_EQ(wide.size(), 4u);
  EXPECT_EQ(wide[1].first, 1);
  EXPECT_EQ(wide[1].held, 0);
  EXPECT_EQ(wide[3].first, 3);
  EXPECT_EQ(wide[3].held, 2);
  EXPECT_TRUE(PlanFuseSteps(0, 1).empty());
  EXPECT_EQ(PlanFuseSteps(1, 1).size(), 1u);
}

// A step's joint summary read back from its step.json, and the season's sum of the steps: the
// blocks and sweeps of a step solved in blocks (fusion/block_solve.h) are the most of any step.
TEST(FuseStepsTest, TheSeasonSummaryKeepsTheBlocksOfItsLargestStep) {
  fusion::JointOptimiser::Summary one, blocked;
  one.num_observations = 100;
  blocked.num_observations = 300;
  blocked.num_blocks = 3;
  blocked.num_sweeps = 2;
  const fusion::JointOptimiser::Summary read = JointSummaryFromJson(JointSummaryJson(blocked));
  EXPECT_EQ(read.num_blocks, 3);
  EXPECT_EQ(read.num_sweeps, 2);
  nlohmann::json older = JointSummaryJson(one);
  older.erase("blocks");
  older.erase("sweeps");
  EXPECT_EQ(JointSummaryFromJson(older).num_blocks, 1);
  fusion::JointOptimiser::Summary total;
  total.num_passes = 0;
  for (const fusion::JointOptimiser::Summary& step : {one, read, one})
    AddJointSummary(step, &total);
  EXPECT_EQ(total.num_blocks, 3);
  EXPECT_EQ(total.num_sweeps, 2);
  EXPECT_EQ(total.num_observations, 500);
}

}  // namespace
}  // namespace crop4d::pipeline::fuse
