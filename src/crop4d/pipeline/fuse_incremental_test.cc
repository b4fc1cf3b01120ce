// The plan of the incremental fuse (fuse_incremental.h): which sessions each step optimises and
// holds, and which sessions each step makes final.

#include "crop4d/pipeline/fuse_incremental.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>

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

// The full fuse a window at a time: the steps that add the sessions, then a backward and a
// forward sweep per round, each window with the sessions on both sides held.
TEST(FuseStepsTest, TheFullFuseSweepsBackAndForthWithBothSidesHeld) {
  for (const int window : {1, 2}) {
    for (const int rounds : {1, 2}) {
      const int n = 7;
      const std::vector<FuseStep> steps = PlanFullFuseSteps(n, window, rounds);
      const std::vector<FuseStep> adding = PlanFuseSteps(n, window);
      const std::size_t sweep_steps = 2 * (n - 1 - window);
      ASSERT_EQ(steps.size(), adding.size() + rounds * sweep_steps);
      std::vector<int> final_count(n, 0), landmark_owners(n, 0);
      std::vector<std::string> names;
      for (std::size_t s = 0; s < steps.size(); ++s) {
        const FuseStep& step = steps[s];
        SCOPED_TRACE("window " + std::to_string(window) + ", rounds " + std::to_string(rounds) +
                     ", step " + std::to_string(s));
        if (s < adding.size()) {
          EXPECT_EQ(step.sweep, 0);
          EXPECT_EQ(step.first, adding[s].first);
          EXPECT_EQ(step.last, adding[s].last);
          EXPECT_EQ(step.held, adding[s].held);
          EXPECT_EQ(step.held_after, -1);
        } else {
          const int r = 1 + static_cast<int>((s - adding.size()) / sweep_steps);
          EXPECT_EQ(step.sweep, r);
          EXPECT_EQ(step.backward, (s - adding.size()) % sweep_steps < sweep_steps / 2);
          // The window and the sessions either side of it, held where they exist.
          EXPECT_EQ(step.first, std::max(0, step.last - window));
          EXPECT_EQ(step.held, step.first - 1);
          EXPECT_EQ(step.held_after, step.last + 1 < n ? step.last + 1 : -1);
          // A step holds at most the window and its two neighbours, whatever the season.
          EXPECT_LE(step.last - step.first + 1 + (step.held >= 0) + (step.held_after >= 0),
                    window + 3);
          // A held session, and every session of the window, has been solved before.
          for (int k = step.first; k <= step.last; ++k) EXPECT_GE(SourceStep(steps, s, k), 0);
          if (step.held_after >= 0) EXPECT_GE(SourceStep(steps, s, step.held_after), 0);
          // No window is solved twice in a row.
          EXPECT_FALSE(steps[s - 1].first == step.first && steps[s - 1].last == step.last);
        }
        for (const int k : FinalSessions(steps, s)) ++final_count[k];
        if (step.assembled) {
          // A step's landmarks are those whose latest session lies in this range.
          for (int k = step.first == 0 ? 0 : step.last; k <= step.last; ++k) ++landmark_owners[k];
        }
        names.push_back(StepFolderName(step, {"a", "b", "c", "d", "e", "f", "g"}));
      }
      for (int k = 0; k < n; ++k) {
        EXPECT_EQ(final_count[k], 1) << "session " << k;
        EXPECT_EQ(landmark_owners[k], 1) << "session " << k;
      }
      // Every session is final in the last round's forward sweep or the backward step before it.
      EXPECT_EQ(steps.back().last, n - 1);
      EXPECT_EQ(steps.back().sweep, rounds);
      std::sort(names.begin(), names.end());
      EXPECT_EQ(std::unique(names.begin(), names.end()), names.end());
    }
  }
  EXPECT_EQ(StepFolderName(PlanFullFuseSteps(4, 1, 1)[3], {"a", "b", "c", "d"}), "sweep1b-c");
  // A season of one window is one problem already: nothing to sweep.
  EXPECT_EQ(PlanFullFuseSteps(2, 1, 3).size(), 1u);
  EXPECT_EQ(PlanFullFuseSteps(3, 2, 1).size(), 1u);
  EXPECT_TRUE(PlanFullFuseSteps(3, 2, 1)[0].assembled);
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
