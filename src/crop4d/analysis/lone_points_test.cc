#include "crop4d/analysis/lone_points.h"

#include <gtest/gtest.h>

#include <random>

namespace crop4d::analysis {
namespace {

// A leaf sampled every 5 mm, and one false match 10 cm above it: only that one is lone.
TEST(LonePointsTest, APointFloatingAboveASurfaceIsLone) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 40; ++i) {
    for (int j = 0; j < 40; ++j) points.emplace_back(0.005 * i, 0.005 * j, 0.3 + 0.001 * i);
  }
  points.emplace_back(0.1, 0.1, 0.45);
  const std::vector<std::uint8_t> lone = FindLonePoints(points, 0.02);
  ASSERT_EQ(lone.size(), points.size());
  for (std::size_t i = 0; i + 1 < points.size(); ++i) EXPECT_EQ(lone[i], 0) << i;
  EXPECT_EQ(lone.back(), 1);
}

// Two points 1 cm apart have one neighbour each: not lone with the default count, lone when two
// are asked for. A point just beyond the radius is no neighbour; one at the radius is.
TEST(LonePointsTest, NeighbourCountAndRadius) {
  const std::vector<Eigen::Vector3d> pair = {{0, 0, 0}, {0, 0, 0.01}, {5, 5, 5}, {5, 5, 5.0201}};
  EXPECT_EQ(FindLonePoints(pair, 0.02), (std::vector<std::uint8_t>{0, 0, 1, 1}));
  EXPECT_EQ(FindLonePoints(pair, 0.02, 2), (std::vector<std::uint8_t>{1, 1, 1, 1}));
  EXPECT_EQ(FindLonePoints(pair, 0.0202), (std::vector<std::uint8_t>{0, 0, 0, 0}));
  // Far apart horizontally but within the radius in height does not make neighbours either.
  const std::vector<Eigen::Vector3d> column = {{0, 0, 0}, {0.03, 0, 0}};
  EXPECT_EQ(FindLonePoints(column, 0.02), (std::vector<std::uint8_t>{1, 1}));
  EXPECT_TRUE(FindLonePoints({}, 0.02).empty());
  EXPECT_EQ(FindLonePoints({{1, 2, 3}}, 0.02), (std::vector<std::uint8_t>{1}));
}

// Against brute force on a random cloud with clusters and scattered points.
TEST(LonePointsTest, AgreesWithBruteForce) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < 3000; ++i) points.emplace_back(u(rng), u(rng), 0.2 * u(rng));
  for (const int min_neighbors : {1, 3}) {
    const std::vector<std::uint8_t> lone = FindLonePoints(points, 0.03, min_neighbors);
    int num_lone = 0;
    for (std::size_t i = 0; i < points.size(); ++i) {
      int count = 0;
      for (std::size_t j = 0; j < points.size(); ++j) {
        count += j != i && (points[j] - points[i]).norm() <= 0.03;
      }
      ASSERT_EQ(lone[i], count < min_neighbors ? 1 : 0) << i;
      num_lone += lone[i];
    }
    EXPECT_GT(num_lone, 10);
    EXPECT_LT(num_lone, 2990);
  }
}

}  // namespace
}  // namespace crop4d::analysis
