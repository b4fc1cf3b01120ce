#include "crop4d/analysis/area_tiles.h"

#include <gtest/gtest.h>

#include <cmath>

namespace crop4d::analysis {
namespace {

TEST(TileAreaTest, StripsAcrossTheLongerSideOwnEveryPointOnce) {
  const Eigen::AlignedBox2d area(Eigen::Vector2d(-1.0, 2.0), Eigen::Vector2d(3.0, 12.5));
  const AreaTiling tiling = TileArea(area, 4.0, 0.7);
  EXPECT_EQ(tiling.axis, 1);  // 10.5 m along y against 4 m along x
  ASSERT_EQ(tiling.tiles.size(), 3u);
  EXPECT_TRUE(std::isinf(tiling.tiles.front().lo));
  EXPECT_TRUE(std::isinf(tiling.tiles.back().hi));
  for (std::size_t k = 0; k + 1 < tiling.tiles.size(); ++k) {
    EXPECT_EQ(tiling.tiles[k].hi, tiling.tiles[k + 1].lo);
    EXPECT_NEAR(tiling.tiles[k].hi, 2.0 + 3.5 * (k + 1), 1e-12);
    EXPECT_NEAR(tiling.tiles[k].read_hi - tiling.tiles[k].hi, 0.7, 1e-12);
    EXPECT_NEAR(tiling.tiles[k + 1].lo - tiling.tiles[k + 1].read_lo, 0.7, 1e-12);
  }
  for (double v = -5.0; v < 20.0; v += 0.01) {
    int owners = 0;
    for (const AreaTile& t : tiling.tiles) {
      owners += t.Owns(v) ? 1 : 0;
      if (t.Owns(v)) {
        EXPECT_TRUE(v >= t.read_lo && v <= t.read_hi);
      }
    }
    EXPECT_EQ(owners, 1) << v;
  }
}

TEST(TileAreaTest, OneTileWhenTheAreaIsShortOrTilesAreOff) {
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(6.0, 2.0));
  EXPECT_EQ(TileArea(area, 0.0, 1.0).tiles.size(), 1u);
  EXPECT_EQ(TileArea(area, 6.0, 1.0).tiles.size(), 1u);
  const AreaTiling two = TileArea(area, 5.9, 1.0);
  EXPECT_EQ(two.axis, 0);
  EXPECT_EQ(two.tiles.size(), 2u);
  EXPECT_EQ(TileArea(Eigen::AlignedBox2d(), 2.0, 1.0).tiles.size(), 1u);
}

}  // namespace
}  // namespace crop4d::analysis
