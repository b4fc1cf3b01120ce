#pragma once

// Levels of detail for the 4D viewer (docs/viewer.md): an octree over a point cloud in which
// every point lands in exactly one node. A node keeps one point per cell of a coarse grid over its
// box (a spatially even subsample, Potree's scheme) and hands the others down to its eight
// children; a node with few points, or at the deepest level, keeps them all. Drawing a node
// together with its ancestors shows every point of its box at that node's density, so a viewer
// draws coarse nodes first and adds finer ones where they are large on the screen.
//
// Tiles: a node's points are written as one binary tile (EncodeTile), positions quantised to
// 16 bits per axis relative to the node's cube, colours as 8-bit RGB:
//
//   offset  size    field
//   0       4       magic "C4DT"
//   4       4       format version, uint32 (1)
//   8       4       point count n, uint32
//   12      4       reserved, 0
//   16      24      cube minimum corner x, y, z, float64 (field ENU metres)
//   40      8       cube side, float64 (metres)
//   48      6n      positions: n × (qx, qy, qz) uint16; p = min + q · side / 65535
//   48+6n   3n      colours: n × (r, g, b) uint8
//
// All little-endian. The quantisation error is at most side / 131070 per axis (0.17 mm for a
// 22 m field at the root, less in finer nodes).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::viewer {

struct OctreeOptions {
  // A node with at most this many points keeps them all (a leaf).
  int max_points_per_node = 20000;
  // Cells per side of the subsampling grid of an inner node: an inner node keeps at most
  // grid_cells³ points, one per occupied cell.
  int grid_cells = 64;
  // Nodes at this depth (root = 0) are leaves whatever their size.
  int max_depth = 16;

  // max_points_per_node ≥ 1, grid_cells in [2, 1024], max_depth in [0, 20]; `why` says what is
  // wrong.
  OptionCheck Check() const;
};

struct OctreeNode {
  // "r" for the root, then one digit 0..7 per level: the child index, bit 0 = +x half,
  // bit 1 = +y, bit 2 = +z.
  std::string name;
  int depth = 0;
  // The node's cube: minimum corner and side.
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  double side = 0.0;
  // Indices of the input points kept by this node, in input order.
  std::vector<std::uint32_t> points;
  // Bit i set when child i exists.
  std::uint8_t child_mask = 0;
};

struct Octree {
  // Parents before their children (breadth-first order); nodes[0] is the root. Empty for an empty
  // cloud.
  std::vector<OctreeNode> nodes;
};

// Builds the octree of `points` (finite; CHECKed) over their bounding cube (the smallest cube
// at the box's minimum corner that holds them, enlarged by a millimetre so no point sits on the
// far faces). Deterministic.
Octree BuildOctree(const std::vector<Eigen::Vector3d>& points, const OctreeOptions& options);

// A decoded tile.
struct Tile {
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  double side = 0.0;
  std::vector<std::array<std::uint16_t, 3>> positions;  // quantised, see the header comment
  std::vector<std::array<std::uint8_t, 3>> colors;

  Eigen::Vector3d Position(std::size_t i) const;
};

// The tile of `node`: the points it keeps, quantised in its cube, and their colours (`colors`
// empty: grey). CHECKs that every point lies in the cube.
std::string EncodeTile(const OctreeNode& node, const std::vector<Eigen::Vector3d>& points,
                       const std::vector<std::array<std::uint8_t, 3>>& colors);

// Decodes a tile. Throws InputError naming `name` for a wrong magic or version, a size that does
// not match the count, or a non-finite or non-positive cube.
Tile DecodeTile(const std::string& bytes, const std::string& name = "tile");

}  // namespace crop4d::viewer
