#include "crop4d/dense/ground_levels.h"

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"

namespace crop4d::dense {

OptionCheck GroundLevels::Options::Check() const {
  OptionChecker c;
  c.Greater("tile_m", tile_m, 0.0)
      .InRange("quantile", quantile, 0.0, 1.0)
      .AtLeast("min_points", min_points, 1);
  return c.Result();
}

GroundLevels::GroundLevels(const std::vector<Eigen::Vector3d>& points,
                           const Eigen::AlignedBox2d& bounds, const Options& options)
    : options_(options) {
  CROP4D_CHECK_OPTIONS(options, "GroundLevels");
  if (bounds.isEmpty()) return;
  origin_ = bounds.min();
  cols_ = std::max(1, static_cast<int>(std::ceil(bounds.sizes().x() / options.tile_m)));
  rows_ = std::max(1, static_cast<int>(std::ceil(bounds.sizes().y() / options.tile_m)));
  std::vector<std::vector<double>> z(static_cast<std::size_t>(cols_) * rows_);
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) continue;
    const int c = static_cast<int>(std::floor((p.x() - origin_.x()) / options.tile_m));
    const int r = static_cast<int>(std::floor((p.y() - origin_.y()) / options.tile_m));
    if (c < 0 || r < 0 || c >= cols_ || r >= rows_) continue;
    z[static_cast<std::size_t>(r) * cols_ + c].push_back(p.z());
  }
  std::vector<double> level(z.size(), 0.0);
  std::vector<char> known(z.size(), 0);
  for (std::size_t i = 0; i < z.size(); ++i) {
    if (static_cast<int>(z[i].size()) < options.min_points) continue;
    const std::size_t k =
        std::min(z[i].size() - 1,
                 static_cast<std::size_t>(std::floor(options.quantile * (z[i].size() - 1))));
    std::nth_element(z[i].begin(), z[i].begin() + static_cast<std::ptrdiff_t>(k), z[i].end());
    level[i] = z[i][k];
    known[i] = 1;
    ++num_measured_;
  }
  if (num_measured_ == 0) {
    cols_ = rows_ = 0;
    return;
  }
  // Grow the measured levels outwards: each pass gives every unknown tile with a known
  // 8-neighbour the mean of those neighbours.
  for (bool changed = true; changed;) {
    changed = false;
    std::vector<double> next = level;
    std::vector<char> next_known = known;
    for (int r = 0; r < rows_; ++r) {
      for (int c = 0; c < cols_; ++c) {
        const std::size_t i = static_cast<std::size_t>(r) * cols_ + c;
        if (known[i]) continue;
        double sum = 0;
        int n = 0;
        for (int dr = -1; dr <= 1; ++dr) {
          for (int dc = -1; dc <= 1; ++dc) {
            const int rr = r + dr, cc = c + dc;
            if (rr < 0 || cc < 0 || rr >= rows_ || cc >= cols_) continue;
            const std::size_t j = static_cast<std::size_t>(rr) * cols_ + cc;
            if (!known[j]) continue;
            sum += level[j];
            ++n;
          }
        }
        if (n == 0) continue;
        next[i] = sum / n;
        next_known[i] = 1;
        changed = true;
      }
    }
    level.swap(next);
    known.swap(next_known);
  }
  levels_ = std::move(level);
}

double GroundLevels::Level(int col, int row) const {
  col = std::clamp(col, 0, cols_ - 1);
  row = std::clamp(row, 0, rows_ - 1);
  return levels_[static_cast<std::size_t>(row) * cols_ + col];
}

double GroundLevels::At(double x, double y) const {
  CROP4D_CHECK(valid());
  // Tile centres at origin + (i + 0.5) tile.
  const double u = (x - origin_.x()) / options_.tile_m - 0.5;
  const double v = (y - origin_.y()) / options_.tile_m - 0.5;
  const double uc = std::clamp(u, 0.0, static_cast<double>(cols_ - 1));
  const double vc = std::clamp(v, 0.0, static_cast<double>(rows_ - 1));
  const int c0 = std::min(static_cast<int>(std::floor(uc)), std::max(0, cols_ - 2));
  const int r0 = std::min(static_cast<int>(std::floor(vc)), std::max(0, rows_ - 2));
  const double a = cols_ > 1 ? uc - c0 : 0.0, b = rows_ > 1 ? vc - r0 : 0.0;
  return (1 - b) * ((1 - a) * Level(c0, r0) + a * Level(c0 + 1, r0)) +
         b * ((1 - a) * Level(c0, r0 + 1) + a * Level(c0 + 1, r0 + 1));
}

void GroundLevels::Range(const Eigen::AlignedBox2d& box, double* lo, double* hi) const {
  CROP4D_CHECK(valid());
  const int c0 = static_cast<int>(std::floor((box.min().x() - origin_.x()) / options_.tile_m)) - 1;
  const int c1 = static_cast<int>(std::floor((box.max().x() - origin_.x()) / options_.tile_m)) + 1;
  const int r0 = static_cast<int>(std::floor((box.min().y() - origin_.y()) / options_.tile_m)) - 1;
  const int r1 = static_cast<int>(std::floor((box.max().y() - origin_.y()) / options_.tile_m)) + 1;
  *lo = INFINITY;
  *hi = -INFINITY;
  for (int r = std::max(0, r0); r <= std::min(rows_ - 1, r1); ++r) {
    for (int c = std::max(0, c0); c <= std::min(cols_ - 1, c1); ++c) {
      *lo = std::min(*lo, Level(c, r));
      *hi = std::max(*hi, Level(c, r));
    }
  }
  if (!std::isfinite(*lo)) *lo = *hi = At(box.center().x(), box.center().y());
}

OptionCheck CanopyCeilingOptions::Check() const {
  OptionChecker c;
  c.InRange("quantile", quantile, 0.0, 1.0)
      .AtLeast("scale", scale, 1.0)
      .AtLeast("margin_m", margin_m, 0.0)
      .Greater("min_m", min_m, 0.0)
      .Greater("near_band_m", near_band_m, 0.0);
  return c.Result();
}

CanopyCeiling SparseCanopyCeiling(const std::vector<Eigen::Vector3d>& points,
                                  const GroundLevels& ground, const Eigen::AlignedBox2d& box,
                                  const CanopyCeilingOptions& options, double max_m) {
  CROP4D_CHECK_OPTIONS(options, "SparseCanopyCeiling");
  CROP4D_CHECK(ground.valid());
  std::vector<double> heights;
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite() || !box.contains(p.head<2>())) continue;
    heights.push_back(p.z() - ground.At(p.x(), p.y()));
  }
  CanopyCeiling c;
  c.num_points = static_cast<int>(heights.size());
  c.ceiling_m = max_m;
  if (heights.empty()) return c;
  const std::size_t k = std::min(
      heights.size() - 1,
      static_cast<std::size_t>(std::floor(options.quantile * static_cast<double>(heights.size()))));
  std::nth_element(heights.begin(), heights.begin() + static_cast<std::ptrdiff_t>(k),
                   heights.end());
  c.quantile_height_m = heights[k];
  c.ceiling_m = std::clamp(options.scale * std::max(c.quantile_height_m, 0.0) + options.margin_m,
                           std::min(options.min_m, max_m), max_m);
  return c;
}

std::int64_t PointsNearCeiling(const std::vector<Eigen::Vector3d>& points,
                               const GroundLevels& ground, double ceiling_m, double band_m) {
  CROP4D_CHECK(ground.valid());
  std::int64_t n = 0;
  for (const Eigen::Vector3d& p : points) {
    if (p.allFinite() && p.z() - ground.At(p.x(), p.y()) >= ceiling_m - band_m) ++n;
  }
  return n;
}

}  // namespace crop4d::dense
