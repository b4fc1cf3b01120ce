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

}  // namespace crop4d::dense
