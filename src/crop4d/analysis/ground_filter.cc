#include "crop4d/analysis/ground_filter.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>

namespace crop4d::analysis {
namespace {

constexpr float kInf = std::numeric_limits<float>::infinity();

// In place: every value becomes the extreme (min when `take_min`, else max) of the values within
// `half` cells of it along one line of `n` values `stride` apart. A monotonic deque makes it
// linear in n whatever the window.
void SlidingExtreme(float* line, int n, std::ptrdiff_t stride, int half, bool take_min,
                    std::vector<float>* scratch) {
  scratch->resize(static_cast<std::size_t>(n));
  for (int i = 0; i < n; ++i) (*scratch)[i] = line[i * stride];
  const auto better = [take_min](float a, float b) { return take_min ? a <= b : a >= b; };
  std::deque<int> window;  // indices, values monotonic from the extreme at the front
  int next = 0;
  for (int i = 0; i < n; ++i) {
    for (; next < n && next <= i + half; ++next) {
      while (!window.empty() && better((*scratch)[next], (*scratch)[window.back()])) {
        window.pop_back();
      }
      window.push_back(next);
    }
    while (window.front() < i - half) window.pop_front();
    line[i * stride] = (*scratch)[window.front()];
  }
}

// The extreme over a square of (2 half + 1)² cells, separably: along x, then along y.
void SquareExtreme(std::vector<float>* grid, int width, int height, int half, bool take_min) {
  std::vector<float> scratch;
  for (int j = 0; j < height; ++j) {
    SlidingExtreme(grid->data() + static_cast<std::ptrdiff_t>(j) * width, width, 1, half, take_min,
                   &scratch);
  }
  for (int i = 0; i < width; ++i) {
    SlidingExtreme(grid->data() + i, height, width, half, take_min, &scratch);
  }
}

}  // namespace

OptionCheck GroundFilterOptions::Check() const {
  OptionChecker c;
  c.AtLeast("window_m", window_m, 0.0)
      .Finite("window_m", window_m)
      .Greater("cell_m", cell_m, 0.0)
      .Finite("cell_m", cell_m)
      .Greater("max_height_m", max_height_m, 0.0)
      .Finite("max_height_m", max_height_m);
  return c.Result();
}

namespace {

int HalfWindowCells(const GroundFilterOptions& options) {
  return static_cast<int>(std::lround(0.5 * options.window_m / options.cell_m));
}

}  // namespace

double GroundFilterReach(const GroundFilterOptions& options) {
  return (2 * std::max(HalfWindowCells(options), 0) + 1) * options.cell_m;
}

std::vector<std::uint8_t> GroundBelowOpening(const std::vector<Eigen::Vector3d>& points,
                                             const GroundFilterOptions& options) {
  std::vector<std::uint8_t> keep(points.size(), 1);
  const int half = HalfWindowCells(options);
  if (half <= 0) return keep;
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const Eigen::Vector3d& p : points) {
    if (!p.allFinite()) continue;
    lo = lo.cwiseMin(p.head<2>());
    hi = hi.cwiseMax(p.head<2>());
  }
  if (!(lo.x() <= hi.x())) return keep;
  // The cells are those of one grid of the plane (cell k spans [k, k + 1) · cell_m), whatever
  // points are given: a part of a cloud (the analysis reads a session in tiles) gets the cells,
  // and so the opened surface, that the whole cloud gets there.
  const auto index = [&](double v) {
    return static_cast<std::int64_t>(std::floor(v / options.cell_m));
  };
  const std::int64_t i0 = index(lo.x()), j0 = index(lo.y());
  const int width = static_cast<int>(index(hi.x()) - i0) + 1;
  const int height = static_cast<int>(index(hi.y()) - j0) + 1;
  const auto cell_of = [&](const Eigen::Vector3d& p) {
    const auto i = static_cast<std::size_t>(index(p.x()) - i0);
    const auto j = static_cast<std::size_t>(index(p.y()) - j0);
    return j * static_cast<std::size_t>(width) + i;
  };
  // The median height per cell (+inf: empty), eroded: empty cells never win a minimum. The
  // median, not the lowest point: a dense cloud's soil has outliers below the ground, and the
  // erosion would carry one over the whole window.
  std::vector<std::pair<std::size_t, float>> cell_heights;
  cell_heights.reserve(points.size());
  for (const Eigen::Vector3d& p : points) {
    if (p.allFinite()) cell_heights.emplace_back(cell_of(p), static_cast<float>(p.z()));
  }
  std::sort(cell_heights.begin(), cell_heights.end());
  std::vector<float> surface(static_cast<std::size_t>(width) * height, kInf);
  for (std::size_t b = 0; b < cell_heights.size();) {
    std::size_t e = b;
    while (e < cell_heights.size() && cell_heights[e].first == cell_heights[b].first) ++e;
    surface[cell_heights[b].first] = cell_heights[b + (e - b) / 2].second;
    b = e;
  }
  SquareExtreme(&surface, width, height, half, /*take_min=*/true);
  // Dilated: a cell whose window held no point (+inf) must not win a maximum.
  for (float& z : surface) {
    if (z == kInf) z = -kInf;
  }
  SquareExtreme(&surface, width, height, half, /*take_min=*/false);
  for (std::size_t k = 0; k < points.size(); ++k) {
    const Eigen::Vector3d& p = points[k];
    if (!p.allFinite()) continue;
    const float opened = surface[cell_of(p)];
    if (opened != -kInf && p.z() - opened > options.max_height_m) keep[k] = 0;
  }
  return keep;
}

}  // namespace crop4d::analysis
