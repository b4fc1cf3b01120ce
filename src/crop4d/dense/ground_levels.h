#pragma once

// A coarse ground model for the height-field sweep: per square tile of the ENU xy plane, a
// robust ground level from a sparse cloud that holds mostly soil points (the fused SIFT cloud of
// `crop4d fuse`). The level of a tile is a low quantile of the z of its points, which ignores the
// few points on plants above and most false matches; tiles without points take the mean of
// their neighbours' levels (grown outwards until every tile has one).
//
//   GroundLevels ground(cloud.points, bounds, GroundLevels::Options{});
//   double z = ground.At(x, y);   // bilinear between tile centres

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::dense {

class GroundLevels {
 public:
  struct Options {
    // Side of a tile, m.
    double tile_m = 0.5;
    // The ground level of a tile is this quantile of its points' z.
    double quantile = 0.1;
    // Tiles with fewer points take their neighbours' level.
    int min_points = 5;

    OptionCheck Check() const;
  };

  GroundLevels() = default;
  // Levels on the tiles that cover `bounds` (xy, metres) from the points inside them. Without
  // any point in `bounds` the model is empty (valid() is false).
  GroundLevels(const std::vector<Eigen::Vector3d>& points, const Eigen::AlignedBox2d& bounds,
               const Options& options);

  bool valid() const { return !levels_.empty(); }
  // Ground height at (x, y): bilinear interpolation between tile centres, clamped at the border.
  double At(double x, double y) const;
  // Lowest and highest level of the tiles that the box touches (and their neighbours, which
  // the bilinear interpolation reaches).
  void Range(const Eigen::AlignedBox2d& box, double* lo, double* hi) const;

  int cols() const { return cols_; }
  int rows() const { return rows_; }
  // Tiles whose level came from their own points (not from neighbours).
  int num_measured_tiles() const { return num_measured_; }

 private:
  double Level(int col, int row) const;

  Options options_;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  int cols_ = 0, rows_ = 0;
  int num_measured_ = 0;
  std::vector<double> levels_;  // row-major, rows_ × cols_
};

// How high above the ground levels a session's sweep searches for plant tops, from the same
// sparse cloud: its points lie on the soil and on the leaves that SIFT tracked, so a high
// quantile of their heights above the ground levels is about the canopy's top (the dense
// matcher's search range from the sparse model, as COLMAP's PatchMatch bounds its depths by
// the sparse points' depth quantiles). The sweep's coarse levels are most of its cost, and a
// young crop is a few centimetres tall under a range set for the season's end.
//
//   ceiling = clamp(scale · quantile_height + margin, min_m, max_m)
struct CanopyCeilingOptions {
  // Quantile of the points' heights above the ground levels: high enough for the tallest
  // plants, below the few false matches far above.
  double quantile = 0.995;
  // The quantile's height is scaled by this and the margin added: tops that no SIFT point
  // reached stay inside the range (on the demo field the tallest plant of a session stood up
  // to 1.7 times the quantile's height).
  double scale = 2.0;
  double margin_m = 0.1;
  // The ceiling is at least this, m.
  double min_m = 0.25;
  // Dense points within this of the ceiling are counted (CanopyCeiling::dense_points_near):
  // plants that reach it, m.
  double near_band_m = 0.02;

  OptionCheck Check() const;
};

struct CanopyCeiling {
  double ceiling_m = 0;          // the search range's top above the ground levels, m
  double quantile_height_m = 0;  // the quantile of the points' heights, m
  int num_points = 0;            // points inside the box (0: the ceiling is max_m)
  // Dense points within near_band_m of the ceiling (set by the caller after the sweep): many of
  // them say that plants reach it and their tops may be cut.
  std::int64_t dense_points_near = 0;
};

// Dense points whose height above the ground levels lies within `band_m` of `ceiling_m`.
std::int64_t PointsNearCeiling(const std::vector<Eigen::Vector3d>& points,
                               const GroundLevels& ground, double ceiling_m, double band_m);

// The ceiling from the points inside `box`, at most `max_m` (the fixed range's top).
CanopyCeiling SparseCanopyCeiling(const std::vector<Eigen::Vector3d>& points,
                                  const GroundLevels& ground, const Eigen::AlignedBox2d& box,
                                  const CanopyCeilingOptions& options, double max_m);

}  // namespace crop4d::dense
