#include "crop4d/io/ply_strips.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

// Points along a 10 m strip of y, coloured by their index.
PlyPointCloud Strip(std::size_t n, bool ordered, std::uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> x(0.0, 2.0), y(0.0, 10.0);
  PlyPointCloud cloud;
  for (std::size_t i = 0; i < n; ++i) cloud.points.emplace_back(x(rng), y(rng), 0.01 * i);
  if (ordered) {
    std::sort(cloud.points.begin(), cloud.points.end(),
              [](const Eigen::Vector3d& a, const Eigen::Vector3d& b) { return a.y() < b.y(); });
  }
  for (std::size_t i = 0; i < n; ++i) {
    cloud.colors.push_back({static_cast<std::uint8_t>(i), static_cast<std::uint8_t>(i >> 8), 7});
  }
  return cloud;
}

// Every strip gives the kept points within it, in file order, with their indices; strips that
// partition the axis give each kept point once. An ordered cloud is read about once in all.
TEST(PlyStripReaderTest, StripsGiveTheKeptPointsWithinThemInFileOrder) {
  testing::TempDir dir;
  const auto keep = [](const Eigen::Vector3d& p) { return p.x() < 1.5; };
  for (const bool ordered : {true, false}) {
    SCOPED_TRACE(ordered ? "ordered along y" : "in no order");
    const PlyPointCloud cloud = Strip(5000, ordered, 3);
    WritePly(dir / "c.ply", cloud);
    PlyStripReader reader(dir / "c.ply", 1, keep, 256);
    ASSERT_EQ(reader.size(), cloud.size());
    std::size_t expected_kept = 0;
    for (const Eigen::Vector3d& p : cloud.points) expected_kept += keep(p) ? 1 : 0;
    EXPECT_EQ(reader.kept(), expected_kept);

    std::vector<std::uint64_t> seen;
    for (int t = 0; t < 10; ++t) {
      const double lo = t, hi = std::nextafter(t + 1.0, 0.0);  // [t, t + 1)
      std::vector<std::uint64_t> indices;
      const PlyPointCloud part = reader.Read(lo, hi, &indices);
      ASSERT_EQ(indices.size(), part.size());
      std::vector<std::uint64_t> expected;
      for (std::size_t i = 0; i < cloud.size(); ++i) {
        const Eigen::Vector3d& p = cloud.points[i];
        if (keep(p) && p.y() >= lo && p.y() <= hi) expected.push_back(i);
      }
      ASSERT_EQ(indices, expected);
      for (std::size_t k = 0; k < part.size(); ++k) {
        EXPECT_EQ(part.points[k], cloud.points[indices[k]]);
        EXPECT_EQ(part.colors[k], cloud.colors[indices[k]]);
      }
      seen.insert(seen.end(), indices.begin(), indices.end());
    }
    std::sort(seen.begin(), seen.end());
    EXPECT_EQ(seen.size(), expected_kept);
    EXPECT_TRUE(std::adjacent_find(seen.begin(), seen.end()) == seen.end());
    if (ordered) {
      // 20 slices, each read once, plus those that straddle a strip's end.
      EXPECT_LE(reader.read_fraction(), 1.5);
    } else {
      EXPECT_NEAR(reader.read_fraction(), 10.0, 1e-9);
    }
  }
}

// A reader opened with an earlier reader's index gives the same strips, reading only them.
TEST(PlyStripReaderTest, AnIndexFromAnEarlierReaderGivesTheSameStrips) {
  testing::TempDir dir;
  WritePly(dir / "c.ply", Strip(3000, true, 5));
  const auto keep = [](const Eigen::Vector3d& p) { return p.x() < 1.0; };
  PlyStripReader first(dir / "c.ply", 1, keep, 128);
  const PlyStripIndex index = first.index();
  PlyStripReader again(dir / "c.ply", 1, keep, 128, &index);
  EXPECT_EQ(again.kept(), first.kept());
  std::vector<std::uint64_t> a, b;
  const PlyPointCloud from_first = first.Read(2.0, 3.5, &a);
  const PlyPointCloud from_again = again.Read(2.0, 3.5, &b);
  EXPECT_EQ(a, b);
  EXPECT_EQ(from_first.points, from_again.points);
  EXPECT_GT(a.size(), 0u);
  EXPECT_EQ(again.read_fraction(), first.read_fraction());
  EXPECT_LT(again.read_fraction(), 0.3);
  // An index of another slice size is not used: the file is indexed again.
  PlyStripReader other(dir / "c.ply", 1, keep, 256, &index);
  EXPECT_EQ(other.index().slice, 256u);
  EXPECT_EQ(other.index().ranges.size(), (3000u + 255u) / 256u);
}

TEST(PlyStripReaderTest, AnEmptyStripAndAMissingFile) {
  testing::TempDir dir;
  WritePly(dir / "c.ply", Strip(100, true, 1));
  PlyStripReader reader(dir / "c.ply", 0, [](const Eigen::Vector3d&) { return true; });
  EXPECT_EQ(reader.Read(5.0, 6.0).size(), 0u);
  EXPECT_EQ(reader.Read(-1.0, 3.0).size(), 100u);
  EXPECT_THROW(PlyStripReader(dir / "missing.ply", 0, [](const Eigen::Vector3d&) { return true; }),
               InputError);
}

}  // namespace
}  // namespace crop4d::io
