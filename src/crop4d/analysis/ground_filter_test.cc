#include "crop4d/analysis/ground_filter.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "crop4d/analysis/analysis_test_util.h"

namespace crop4d::analysis {
namespace {

using testing_util::BedHeight;

// Ground of tilted raised beds, and soil-coloured clutter at canopy height along the crests,
// where the camera sees no soil.
struct Scene {
  std::vector<Eigen::Vector3d> points;
  std::vector<bool> is_ground;
};

Scene BedsUnderCanopies(std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.003);
  Scene s;
  for (int i = 0; i < 20000; ++i) {
    const double x = 3 * u(rng), y = 3 * u(rng);
    if (std::abs(std::remainder(x, 0.91)) < 0.15) continue;  // hidden by the canopy
    s.points.emplace_back(x, y, BedHeight(x, y) + noise(rng));
    s.is_ground.push_back(true);
  }
  // A 0.3 m wide canopy 12-25 cm up over the two inner crests. (At the edge of the data an
  // opening cannot tell an object from the ground: nothing lies beyond it.)
  for (int i = 0; i < 4000; ++i) {
    const double x = 0.91 * (1 + static_cast<int>(2 * u(rng))) + 0.3 * (u(rng) - 0.5);
    const double y = 3 * u(rng);
    s.points.emplace_back(x, y, BedHeight(x, y) + 0.12 + 0.13 * u(rng));
    s.is_ground.push_back(false);
  }
  return s;
}

TEST(GroundFilterTest, KeepsTiltedBedsAndRejectsWhatStandsOnThem) {
  const Scene s = BedsUnderCanopies(5);
  const std::vector<std::uint8_t> keep = GroundBelowOpening(s.points, GroundFilterOptions{});
  ASSERT_EQ(keep.size(), s.points.size());
  int ground_dropped = 0, clutter_kept = 0;
  for (std::size_t k = 0; k < keep.size(); ++k) {
    if (s.is_ground[k] && !keep[k]) ++ground_dropped;
    if (!s.is_ground[k] && keep[k]) ++clutter_kept;
  }
  EXPECT_EQ(ground_dropped, 0);
  EXPECT_EQ(clutter_kept, 0);
}

// What is wider than the window is ground to the filter: a flat 1 m wide platform 15 cm up,
// with no soil seen under it, is kept whole (and a canopy closed over a whole row spacing would
// be too: the terrain then comes from the sessions that saw the soil).
TEST(GroundFilterTest, WhatIsWiderThanTheWindowIsKept) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 60; ++i) {
    for (int j = 0; j < 60; ++j) {
      const double x = 0.05 * i, y = 0.05 * j;
      const bool platform = x > 1.0 && x < 2.0;
      points.emplace_back(x, y, platform ? 0.15 : 0.0);
    }
  }
  const std::vector<std::uint8_t> keep = GroundBelowOpening(points, GroundFilterOptions{});
  EXPECT_EQ(std::count(keep.begin(), keep.end(), 1), static_cast<long>(points.size()));
}

TEST(GroundFilterTest, NoWindowEmptyInputAndNonFinitePointsKeepEverything) {
  EXPECT_TRUE(GroundBelowOpening({}, GroundFilterOptions{}).empty());
  const Scene s = BedsUnderCanopies(7);
  GroundFilterOptions off;
  off.window_m = 0.0;
  const std::vector<std::uint8_t> keep = GroundBelowOpening(s.points, off);
  EXPECT_EQ(std::count(keep.begin(), keep.end(), 1), static_cast<long>(s.points.size()));
  const std::vector<Eigen::Vector3d> odd = {{0, 0, 0}, {NAN, 1, 1}, {0.1, 0.1, 5}};
  const std::vector<std::uint8_t> k2 = GroundBelowOpening(odd, GroundFilterOptions{});
  EXPECT_EQ(k2, (std::vector<std::uint8_t>{1, 1, 0}));
}

TEST(GroundFilterTest, CheckRejectsBadValues) {
  EXPECT_EQ(GroundFilterOptions{}.Check(), "");
  GroundFilterOptions o;
  o.cell_m = 0;
  EXPECT_NE(o.Check(), "");
  o = {};
  o.window_m = -1;
  EXPECT_NE(o.Check(), "");
  o = {};
  o.max_height_m = NAN;
  EXPECT_NE(o.Check(), "");
}

}  // namespace
}  // namespace crop4d::analysis
