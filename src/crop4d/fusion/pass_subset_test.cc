#include "crop4d/fusion/pass_subset.h"

#include <gtest/gtest.h>

namespace crop4d::fusion {
namespace {

TEST(PassSubsetTest, KeptPassesAreRenumberedWithTheirLandmarksAndTies) {
  std::vector<JointOptimiser::Pass> passes(3);
  for (int p = 0; p < 3; ++p) passes[p].anchor_state = 10 + p;  // tells the passes apart
  JointLandmark landmark;
  landmark.observations = {{1, 4, Eigen::Vector2d(1, 2)}, {2, 7, Eigen::Vector2d(3, 4)}};
  landmark.color = {1, 2, 3};
  std::vector<JointGroundTie> ties(2);
  ties[0].pass_a = 0;
  ties[0].pass_b = 1;
  ties[1].pass_a = 2;
  ties[1].pass_b = 1;
  const PassSubset subset = RestrictToPasses(passes, {landmark}, ties, {false, true, true});
  ASSERT_EQ(subset.passes.size(), 2u);
  EXPECT_EQ(subset.passes[0].anchor_state, 11);
  EXPECT_EQ(subset.passes[1].anchor_state, 12);
  EXPECT_EQ(subset.original_pass, (std::vector<int>{1, 2}));
  ASSERT_EQ(subset.landmarks.size(), 1u);
  EXPECT_EQ(subset.landmarks[0].observations[0].pass, 0);
  EXPECT_EQ(subset.landmarks[0].observations[0].state, 4);
  EXPECT_EQ(subset.landmarks[0].observations[1].pass, 1);
  EXPECT_EQ(subset.landmarks[0].color, landmark.color);
  ASSERT_EQ(subset.ties.size(), 1u);  // the tie with the left-out pass 0 is dropped
  EXPECT_EQ(subset.ties[0].pass_a, 1);
  EXPECT_EQ(subset.ties[0].pass_b, 0);
}

TEST(PassSubsetDeathTest, ALandmarkOfALeftOutPassIsAProgrammerError) {
  std::vector<JointOptimiser::Pass> passes(2);
  JointLandmark landmark;
  landmark.observations = {{0, 0, Eigen::Vector2d::Zero()}, {1, 0, Eigen::Vector2d::Zero()}};
  EXPECT_DEATH(RestrictToPasses(passes, {landmark}, {}, {false, true}), "left-out pass");
}

}  // namespace
}  // namespace crop4d::fusion
