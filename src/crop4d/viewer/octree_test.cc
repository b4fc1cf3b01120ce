#include "crop4d/viewer/octree.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstring>
#include <random>
#include <set>

#include "crop4d/core/error.h"

namespace crop4d::viewer {
namespace {

// A field-like cloud: a 4 m × 20 m strip, soil with plants of up to 0.6 m.
std::vector<Eigen::Vector3d> FieldCloud(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-0.5, 3.5), y(0.0, 20.0), z(0.0, 0.6);
  std::vector<Eigen::Vector3d> points(n);
  for (auto& p : points) p = {x(rng), y(rng), z(rng) * z(rng)};
  return points;
}

OctreeOptions Small() {
  OctreeOptions o;
  o.max_points_per_node = 500;
  o.grid_cells = 16;
  return o;
}

TEST(OctreeTest, EveryPointLandsInExactlyOneNodeInsideItsCube) {
  const std::vector<Eigen::Vector3d> points = FieldCloud(50000, 3);
  const Octree tree = BuildOctree(points, Small());
  ASSERT_GT(tree.nodes.size(), 8u);
  std::vector<int> seen(points.size(), 0);
  for (const OctreeNode& node : tree.nodes) {
    for (std::uint32_t i : node.points) {
      ++seen[i];
      for (int k = 0; k < 3; ++k) {
        EXPECT_GE(points[i][k], node.min[k]) << node.name;
        EXPECT_LT(points[i][k], node.min[k] + node.side) << node.name;
      }
    }
  }
  for (std::size_t i = 0; i < points.size(); ++i) ASSERT_EQ(seen[i], 1) << i;
}

TEST(OctreeTest, InnerNodesKeepOnePointPerGridCellAndLeavesAreSmall) {
  const std::vector<Eigen::Vector3d> points = FieldCloud(50000, 4);
  const OctreeOptions options = Small();
  const Octree tree = BuildOctree(points, options);
  std::set<std::string> names;
  for (const OctreeNode& node : tree.nodes) {
    names.insert(node.name);
    if (node.name != "r")
      EXPECT_TRUE(names.count(node.name.substr(0, node.name.size() - 1)))
          << "parent after child: " << node.name;
    EXPECT_EQ(node.depth + 1, int(node.name.size()));
    if (node.child_mask == 0) {
      EXPECT_LE(node.points.size(), std::size_t(options.max_points_per_node)) << node.name;
      continue;
    }
    // An inner node: at most one point per cell of its grid.
    std::set<std::array<int, 3>> cells;
    for (std::uint32_t i : node.points) {
      std::array<int, 3> c;
      for (int k = 0; k < 3; ++k)
        c[k] = int((points[i][k] - node.min[k]) / node.side * options.grid_cells);
      EXPECT_TRUE(cells.insert(c).second) << node.name;
    }
    // Its children exist exactly where its mask says, with half its side.
    for (int c = 0; c < 8; ++c) {
      const auto child =
          std::find_if(tree.nodes.begin(), tree.nodes.end(),
                       [&](const OctreeNode& n) { return n.name == node.name + char('0' + c); });
      EXPECT_EQ(bool(node.child_mask & (1 << c)), child != tree.nodes.end()) << node.name << c;
      if (child != tree.nodes.end()) EXPECT_DOUBLE_EQ(child->side, node.side / 2);
    }
  }
}

TEST(OctreeTest, SmallCloudIsOneLeafAndEmptyCloudNoNode) {
  EXPECT_TRUE(BuildOctree({}, Small()).nodes.empty());
  const Octree tree = BuildOctree(FieldCloud(100, 5), Small());
  ASSERT_EQ(tree.nodes.size(), 1u);
  EXPECT_EQ(tree.nodes[0].points.size(), 100u);
  EXPECT_EQ(tree.nodes[0].child_mask, 0);
}

TEST(OctreeTest, DuplicatePointsStopAtTheDepthLimit) {
  std::vector<Eigen::Vector3d> points(3000, Eigen::Vector3d(1, 2, 3));
  points.push_back({4, 5, 6});
  OctreeOptions options = Small();
  options.max_depth = 5;
  const Octree tree = BuildOctree(points, options);
  std::size_t total = 0;
  for (const OctreeNode& node : tree.nodes) {
    EXPECT_LE(node.depth, 5);
    total += node.points.size();
  }
  EXPECT_EQ(total, points.size());
}

TEST(OctreeTest, TileRoundTripWithinTheQuantisationBound) {
  const std::vector<Eigen::Vector3d> points = FieldCloud(20000, 6);
  std::vector<std::array<std::uint8_t, 3>> colors(points.size());
  for (std::size_t i = 0; i < colors.size(); ++i)
    colors[i] = {std::uint8_t(i), std::uint8_t(i * 7), std::uint8_t(255 - i % 256)};
  const Octree tree = BuildOctree(points, Small());
  for (const OctreeNode& node : tree.nodes) {
    const std::string bytes = EncodeTile(node, points, colors);
    EXPECT_EQ(bytes.size(), 48 + 9 * node.points.size());
    const Tile tile = DecodeTile(bytes, node.name);
    ASSERT_EQ(tile.positions.size(), node.points.size());
    EXPECT_EQ(tile.min, node.min);
    EXPECT_EQ(tile.side, node.side);
    const double bound = node.side / 131070.0 + 1e-12;
    for (std::size_t k = 0; k < node.points.size(); ++k) {
      const Eigen::Vector3d error = tile.Position(k) - points[node.points[k]];
      EXPECT_LE(error.cwiseAbs().maxCoeff(), bound) << node.name << " " << k;
      EXPECT_EQ(tile.colors[k], colors[node.points[k]]);
    }
  }
}

TEST(OctreeTest, MalformedTilesAreRejected) {
  const std::vector<Eigen::Vector3d> points = FieldCloud(10, 7);
  const Octree tree = BuildOctree(points, Small());
  const std::string good = EncodeTile(tree.nodes[0], points, {});
  EXPECT_NO_THROW(DecodeTile(good));
  EXPECT_THROW(DecodeTile(good.substr(0, good.size() - 1)), InputError);  // truncated
  EXPECT_THROW(DecodeTile("C4DT"), InputError);                           // header cut
  std::string magic = good;
  magic[0] = 'X';
  EXPECT_THROW(DecodeTile(magic), InputError);
  std::string version = good;
  version[4] = 9;
  EXPECT_THROW(DecodeTile(version), InputError);
  std::string side = good;
  const double zero = 0.0;
  std::memcpy(side.data() + 40, &zero, 8);
  EXPECT_THROW(DecodeTile(side), InputError);
}

TEST(OctreeTest, OptionsAreChecked) {
  OctreeOptions o;
  EXPECT_EQ(o.Check(), "");
  o.grid_cells = 1;
  EXPECT_EQ(o.Check(), "grid_cells: must be in [2, 1024] (got 1)");
  o = OctreeOptions{};
  o.max_depth = 21;
  EXPECT_EQ(o.Check(), "max_depth: must be in [0, 20] (got 21)");
}

}  // namespace
}  // namespace crop4d::viewer
