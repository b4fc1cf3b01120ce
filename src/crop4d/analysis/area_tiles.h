#pragma once

// The analysed area cut into tiles, so that a session's cloud is read and analysed a tile at a
// time and never held whole (the analysis of a field of the paper's size holds a hundred
// million points per session). The tiles are strips across the area's longer side, of equal
// length along it and the area's whole width across it. Each tile owns a part of the axis —
// the tiles' parts partition it, so each point belongs to one tile — and reads the points
// within a reach around that part as well, for the steps that look at a point's neighbours (lone
// points, the ground filter, the vegetation clearance: analyze's TileReach).

#include <Eigen/Geometry>
#include <vector>

namespace crop4d::analysis {

struct AreaTile {
  // The part of the axis the tile owns, [lo, hi): −∞ for the first tile's lo, +∞ for the last
  // tile's hi, so that no point is left out.
  double lo = 0.0, hi = 0.0;
  // The points it reads: [read_lo, read_hi] along the axis (lo − reach, hi + reach).
  double read_lo = 0.0, read_hi = 0.0;
  bool Owns(double v) const { return v >= lo && v < hi; }
};

struct AreaTiling {
  int axis = 0;  // 0: the tiles are strips of x (the area is longer along x), 1: of y
  std::vector<AreaTile> tiles;
};

// Tiles of at most `tile_m` along the longer side of `area`, each reading `reach_m` around the
// part it owns; one tile when tile_m <= 0 or the area is no longer than tile_m.
AreaTiling TileArea(const Eigen::AlignedBox2d& area, double tile_m, double reach_m);

}  // namespace crop4d::analysis
