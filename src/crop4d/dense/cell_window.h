#pragma once

// The cells of a height-field reconstruction (height_field_stereo.h), held a window at a time,
// and the filters that decide which matched cells become points: visibility (a point must not
// hide other points from the views they were matched in), isolated points and false islands.
//
// The region is cut into bands across its longer side (its "along" axis), one tile of cells
// deep. The tiles are matched band after band; each filter needs the cells within a known reach
// of a band (a point's reference ray, the 8 neighbours, an island and the neighbourhood it is
// compared with), so a band's points are final, and written, as soon as the cells within that
// reach are matched and filtered, and the cells no filter needs any more are dropped. Memory
// then holds a window of the region whose depth along it is set by those reaches (10.8–12.4 m
// on the simulated fields), not the region: the cells held do not grow with the row length
// (the same at 20 and 40 m rows; bench/RESULTS.md).
// The points are the same, to the bit and in the same order, as if the whole region were held:
// every filter sees the same cells (the reaches are bounds, taken from the data: see
// CellFilters), and the points are emitted in along-major order either way.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "crop4d/dense/height_field_stereo.h"

namespace crop4d::dense {

// Why a cell has no point (kept in a byte per cell).
enum CellState : std::uint8_t {
  kOutside = 0,
  kNoViews,
  kLowTexture,
  kLowScore,
  kNotUnique,
  kAtRangeEdge,
  kIsolated,
  kOccluding,
  kKept,
};

// The region's grid of cells (cell (i, j) has its centre at origin + (i + 0.5, j + 0.5) · s) and
// the cells of it that are held: along-coordinate in [lo, hi), every cross-coordinate. Per held
// cell: its state, what the sweeps found (set for kept cells), and the filters' working data.
struct CellWindow {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  double s = 0;  // cell size, m
  int gx = 0, gy = 0;
  bool along_y = true;  // the along axis: y when gy >= gx, else x
  int lo = 0, hi = 0;

  std::vector<std::uint8_t> state;
  std::vector<float> height, score, unique;
  // |height of reference 1 alone − height of reference 2 alone| (−1: one of them did not score).
  std::vector<float> disagreement;
  std::vector<std::uint8_t> num_views;
  std::vector<std::array<std::uint8_t, 3>> rgb;
  std::vector<int> reference_of;
  std::vector<std::uint8_t> on_top_surface;
  std::vector<int> blocked;             // reference rays this cell blocks (visibility)
  std::vector<std::uint8_t> isolated;   // bit 1: too few neighbours agree; bit 2: false island
  std::vector<std::uint32_t> label_at;  // island labels: valid when equal to the current pass
  std::vector<std::uint8_t> label;

  // The region's grid (nothing held yet).
  static CellWindow ForRegion(double cell_m, const DenseRegion& region);

  int along_size() const { return along_y ? gy : gx; }
  int cross_size() const { return along_y ? gx : gy; }
  int Along(int i, int j) const { return along_y ? j : i; }
  // Cell (i, j) from its along and cross coordinates.
  int I(int a, int c) const { return along_y ? c : a; }
  int J(int a, int c) const { return along_y ? a : c; }
  bool InGrid(int i, int j) const { return i >= 0 && j >= 0 && i < gx && j < gy; }
  bool Holds(int i, int j) const {
    const int a = Along(i, j);
    return InGrid(i, j) && a >= lo && a < hi;
  }
  // The index of held cell (i, j) in the per-cell vectors.
  std::size_t At(int i, int j) const {
    return static_cast<std::size_t>(Along(i, j) - lo) * cross_size() + (along_y ? i : j);
  }
  std::size_t size() const { return static_cast<std::size_t>(hi - lo) * cross_size(); }
  Eigen::Vector2d Centre(int i, int j) const {
    return origin + Eigen::Vector2d(i + 0.5, j + 0.5) * s;
  }

  // Holds along-coordinates [new_lo, new_hi) (new_lo >= lo, new_hi >= hi): the cells below new_lo
  // are dropped, those that come in start outside the region or with no views yet.
  void Slide(int new_lo, int new_hi, const DenseRegion& region);
};

// Runs the filters on the bands of a window as they are matched, and emits each band's points.
// Usage: Hold(a) before the tiles below along-coordinate a are matched into window(); Matched(a)
// once they are; Finish() after the last.
class CellFilters {
 public:
  // `centres`: the camera centre of every view; `reference_reach_m`: the farthest any cell lies,
  // horizontally, from a reference camera of its tile (the reach of its visibility ray). The
  // points go to `sink`, or are appended to `cloud` when it is empty.
  CellFilters(const HeightFieldStereo::Options& options, const DenseRegion& region,
              CellWindow* window, std::vector<Eigen::Vector3d> centres, double reference_reach_m,
              HeightFieldStereo::PointSink sink, io::PlyPointCloud* cloud,
              HeightFieldStereo::Summary* summary);

  // Makes the window hold every cell below `along_end` that is still needed (dropping the others).
  void Hold(int along_end);
  // Every cell below `along_end` is matched: filters and emits what is now final.
  void Matched(int along_end);
  // Every cell is matched: the rest is emitted.
  void Finish();

 private:
  int Start(int band) const;
  int End(int band) const;
  int LowestNeeded() const;
  void Advance();
  void WalkRays(int band);
  void MarkOccluding(int band);
  void MarkIsolated(int band);
  void Emit(int band);
  // The island label of the connected set of held cell (i, j) (kept, not isolated), found when
  // not yet: kIsland (fewer than min_cells) or kLarge. `members`: its cells when searched now.
  std::uint8_t Label(int i, int j, std::vector<std::pair<int, int>>* members);
  void IsolateIfFalse(const std::vector<std::pair<int, int>>& island);
  void Collect(int band);

  const HeightFieldStereo::Options& o_;
  const DenseRegion& region_;
  CellWindow& w_;
  std::vector<Eigen::Vector3d> centres_;
  HeightFieldStereo::PointSink sink_;
  io::PlyPointCloud* cloud_;
  HeightFieldStereo::Summary* summary_;
  int band_cells_;  // depth of a band along, cells
  int num_bands_;
  int occlusion_reach_;  // cells a reference ray may cross along
  int island_reach_;     // cells an island decision looks at along
  int min_island_cells_;
  int next_walk_ = 0, next_occluding_ = 0, next_isolated_ = 0, next_emit_ = 0;
  int matched_ = 0;
  std::uint32_t pass_ = 0;
};

}  // namespace crop4d::dense
