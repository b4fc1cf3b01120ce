#include "crop4d/association/match_thinning.h"

#include <gtest/gtest.h>

#include <set>

namespace crop4d::association {
namespace {

CrossMatch Match(int image_a, int image_b, float xa, float ya, float distance) {
  CrossMatch m;
  m.image_a = image_a;
  m.image_b = image_b;
  m.xa = xa;
  m.ya = ya;
  m.distance = distance;
  return m;
}

TEST(MatchThinningTest, ZeroKeepsEverythingAndSmallPairsAreKeptWhole) {
  const std::vector<CrossMatch> all{Match(1, 2, 10, 10, 5), Match(0, 0, 20, 20, 1),
                                    Match(1, 2, 30, 30, 2)};
  EXPECT_EQ(ThinCrossMatches(all, 640, 480, 0).size(), 3u);
  const std::vector<CrossMatch> kept = ThinCrossMatches(all, 640, 480, 2);
  ASSERT_EQ(kept.size(), 3u);
  // Image pairs in order; a pair's matches in their given order.
  EXPECT_EQ(kept[0].image_a, 0);
  EXPECT_EQ(kept[1].distance, 5);
  EXPECT_EQ(kept[2].distance, 2);
}

TEST(MatchThinningTest, BestOfEachCellFirstSoTheMatchesSpreadOverImageA) {
  std::vector<CrossMatch> all;
  // 20 excellent matches bunched in the top-left cell, one mediocre match in each other cell.
  for (int k = 0; k < 20; ++k) all.push_back(Match(0, 0, 10 + k, 10, 1.0f + 0.01f * k));
  for (int cy = 0; cy < kThinningGridCells; ++cy) {
    for (int cx = 0; cx < kThinningGridCells; ++cx) {
      if (cx == 0 && cy == 0) continue;
      all.push_back(Match(0, 0, 160 * cx + 80, 120 * cy + 60, 50.0f));
    }
  }
  const std::vector<CrossMatch> kept = ThinCrossMatches(all, 640, 480, 16);
  ASSERT_EQ(kept.size(), 16u);
  std::set<std::pair<int, int>> cells;
  for (const CrossMatch& m : kept) cells.insert({int(m.xa) / 160, int(m.ya) / 120});
  EXPECT_EQ(cells.size(), 16u);                  // one per cell
  EXPECT_FLOAT_EQ(kept.front().distance, 1.0f);  // the best of the crowded cell
  // Once every cell gave one, the crowded cell's next best follow.
  const std::vector<CrossMatch> more = ThinCrossMatches(all, 640, 480, 18);
  ASSERT_EQ(more.size(), 18u);
  EXPECT_FLOAT_EQ(more[16].distance, 1.01f);
  EXPECT_FLOAT_EQ(more[17].distance, 1.02f);
}

}  // namespace
}  // namespace crop4d::association
