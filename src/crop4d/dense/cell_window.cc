#include "crop4d/dense/cell_window.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <limits>
#include <utility>

#include "crop4d/core/error.h"

namespace crop4d::dense {
namespace {

// Island labels (CellWindow::label).
constexpr std::uint8_t kSearching = 1;
constexpr std::uint8_t kIsland = 2;
constexpr std::uint8_t kLarge = 3;

constexpr std::uint8_t kTooFewNeighbours = 1;
constexpr std::uint8_t kFalseIsland = 2;

// Drops the first `drop` entries and grows to `n`, new entries `fill`.
template <typename T>
void SlideVector(std::vector<T>* v, std::size_t drop, std::size_t n, const T& fill) {
  v->erase(v->begin(), v->begin() + static_cast<std::ptrdiff_t>(std::min(drop, v->size())));
  v->resize(n, fill);
}

// Calls f(i, j, g) for every held cell with along-coordinate in [a0, a1), g its index: in
// parallel over the cross-coordinate (oneTBB).
template <typename F>
void ParallelForCells(const CellWindow& w, int a0, int a1, const F& f) {
  tbb::parallel_for(tbb::blocked_range<int>(0, w.cross_size()), [&](const auto& range) {
    for (int c = range.begin(); c < range.end(); ++c) {
      for (int a = a0; a < a1; ++a) {
        const int i = w.I(a, c), j = w.J(a, c);
        f(i, j, w.At(i, j));
      }
    }
  });
}

// The same, one cell after the other in along-major order (the order of the cloud's points).
template <typename F>
void ForCellsInOrder(const CellWindow& w, int a0, int a1, const F& f) {
  for (int a = a0; a < a1; ++a) {
    for (int c = 0; c < w.cross_size(); ++c) {
      const int i = w.I(a, c), j = w.J(a, c);
      f(i, j, w.At(i, j));
    }
  }
}

}  // namespace

CellWindow CellWindow::ForRegion(double cell_m, const DenseRegion& region) {
  CellWindow w;
  const double s = cell_m;
  w.s = s;
  w.origin = Eigen::Vector2d(std::floor(region.bounds.min().x() / s) * s,
                             std::floor(region.bounds.min().y() / s) * s);
  w.gx = static_cast<int>(std::ceil((region.bounds.max().x() - w.origin.x()) / s));
  w.gy = static_cast<int>(std::ceil((region.bounds.max().y() - w.origin.y()) / s));
  w.along_y = w.gy >= w.gx;
  return w;
}

void CellWindow::Slide(int new_lo, int new_hi, const DenseRegion& region) {
  CROP4D_CHECK(new_lo >= lo && new_hi >= hi && new_lo <= new_hi);
  const int first_new = std::max(hi, new_lo);
  const std::size_t drop = static_cast<std::size_t>(std::min(new_lo, hi) - lo) * cross_size();
  lo = new_lo;
  hi = new_hi;
  const std::size_t n = size();
  SlideVector(&state, drop, n, std::uint8_t{kOutside});
  SlideVector(&height, drop, n, std::numeric_limits<float>::quiet_NaN());
  SlideVector(&score, drop, n, 0.0f);
  SlideVector(&unique, drop, n, 0.0f);
  SlideVector(&disagreement, drop, n, -1.0f);
  SlideVector(&num_views, drop, n, std::uint8_t{0});
  SlideVector(&rgb, drop, n, std::array<std::uint8_t, 3>{0, 0, 0});
  SlideVector(&reference_of, drop, n, -1);
  SlideVector(&on_top_surface, drop, n, std::uint8_t{0});
  SlideVector(&blocked, drop, n, 0);
  SlideVector(&isolated, drop, n, std::uint8_t{0});
  SlideVector(&label_at, drop, n, std::uint32_t{0});
  SlideVector(&label, drop, n, std::uint8_t{0});
  for (int a = first_new; a < hi; ++a) {
    for (int c = 0; c < cross_size(); ++c) {
      const int i = I(a, c), j = J(a, c);
      if (region.Contains(Centre(i, j))) state[At(i, j)] = kNoViews;
    }
  }
}

CellFilters::CellFilters(const HeightFieldStereo::Options& options, const DenseRegion& region,
                         CellWindow* window, std::vector<Eigen::Vector3d> centres,
                         double reference_reach_m, HeightFieldStereo::PointSink sink,
                         io::PlyPointCloud* cloud, HeightFieldStereo::Summary* summary)
    : o_(options),
      region_(region),
      w_(*window),
      centres_(std::move(centres)),
      sink_(std::move(sink)),
      cloud_(cloud),
      summary_(summary) {
  const double s = w_.s;
  band_cells_ = std::max(1, o_.tile_cells);
  num_bands_ = (w_.along_size() + band_cells_ - 1) / band_cells_;
  // A ray walks from its point towards the reference camera, no further than the camera's
  // horizontal distance (+ 2 cells for the rounding to cells).
  occlusion_reach_ =
      o_.max_blocked_rays > 0 ? static_cast<int>(std::ceil(reference_reach_m / s)) + 2 : 0;
  // An island has fewer than min_island_cells_ cells, so it spans fewer cells than that along;
  // the neighbourhood it is compared with adds island_radius_m, and telling whether a cell of
  // that neighbourhood is itself in an island looks one island extent further. A connected set
  // that reaches beyond is larger than an island.
  min_island_cells_ = static_cast<int>(std::ceil(o_.island_area_m2 / (s * s)));
  island_reach_ =
      o_.island_area_m2 > 0
          ? 2 * min_island_cells_ + static_cast<int>(std::ceil(o_.island_radius_m / s)) + 2
          : 0;
}

int CellFilters::Start(int band) const { return std::min(w_.along_size(), band * band_cells_); }
int CellFilters::End(int band) const { return Start(band + 1); }

int CellFilters::LowestNeeded() const {
  const int lowest = std::min({Start(next_walk_) - occlusion_reach_, Start(next_occluding_),
                               Start(next_isolated_) - 1, Start(next_emit_) - island_reach_});
  return std::clamp(lowest, w_.lo, w_.along_size());
}

void CellFilters::Hold(int along_end) {
  const int hi = std::clamp(along_end, w_.hi, w_.along_size());
  w_.Slide(LowestNeeded(), hi, region_);
  summary_->max_cells_held =
      std::max(summary_->max_cells_held, static_cast<std::int64_t>(w_.size()));
}

void CellFilters::Matched(int along_end) {
  matched_ = std::max(matched_, std::min(along_end, w_.along_size()));
  CROP4D_CHECK(matched_ <= w_.hi);
  Advance();
}

void CellFilters::Finish() {
  Hold(w_.along_size());
  Matched(w_.along_size());
  CROP4D_CHECK(next_emit_ == num_bands_);
}

// Each step of a band once the cells it reads are final: the rays of a band once every cell
// they can cross is matched; a band's visibility once every ray that can cross it is walked;
// its isolated points once its neighbours' visibility is; its islands and points once the
// isolated points within an island decision's reach are.
void CellFilters::Advance() {
  const int n = w_.along_size();
  while (next_walk_ < num_bands_ && std::min(n, End(next_walk_) + occlusion_reach_) <= matched_) {
    WalkRays(next_walk_++);
  }
  const int walked = Start(next_walk_);
  while (next_occluding_ < num_bands_ &&
         std::min(n, End(next_occluding_) + occlusion_reach_) <= walked) {
    MarkOccluding(next_occluding_++);
  }
  const int occluding_known = Start(next_occluding_);
  while (next_isolated_ < num_bands_ && std::min(n, End(next_isolated_) + 1) <= occluding_known) {
    MarkIsolated(next_isolated_++);
  }
  const int isolated_known = Start(next_isolated_);
  while (next_emit_ < num_bands_ &&
         std::min(n, End(next_emit_) + island_reach_) <= isolated_known) {
    Emit(next_emit_++);
  }
}

// Visibility: walk from every kept point towards its reference camera; a kept cell on the way
// that lies above the ray blocks it. A false match floating above the soil blocks the reference
// rays of many soil points behind it; a real leaf blocks none, since the points behind it were
// matched in a reference that sees them.
void CellFilters::WalkRays(int band) {
  if (!(o_.max_blocked_rays > 0)) return;
  const double s = w_.s;
  const double z_top_span = o_.max_canopy_height_m + o_.below_ground_m + 0.5;
  ParallelForCells(w_, Start(band), End(band), [&](int i, int j, std::size_t g) {
    if (w_.state[g] != kKept || w_.reference_of[g] < 0) return;
    const Eigen::Vector3d p(w_.origin.x() + (i + 0.5) * s, w_.origin.y() + (j + 0.5) * s,
                            w_.height[g]);
    const Eigen::Vector3d d = centres_[w_.reference_of[g]] - p;
    if (d.z() <= 0) return;
    // Up to where the ray is above anything that can have been matched.
    const double t_max = std::min(1.0, z_top_span / d.z());
    const double horizontal = d.head<2>().norm() * t_max;
    const int steps = static_cast<int>(horizontal / (0.5 * s));
    std::int64_t last = -1;
    for (int k = 3; k <= steps; ++k) {  // from 1.5 cells away (not the point's own patch)
      const double t = t_max * k / std::max(1, steps);
      const Eigen::Vector3d q = p + t * d;
      const int ci = static_cast<int>(std::floor((q.x() - w_.origin.x()) / s));
      const int cj = static_cast<int>(std::floor((q.y() - w_.origin.y()) / s));
      if (!w_.InGrid(ci, cj)) break;
      const std::int64_t key = static_cast<std::int64_t>(cj) * w_.gx + ci;
      if (key == last) continue;
      last = key;
      CROP4D_CHECK_MSG(w_.Holds(ci, cj), "a reference ray left the window of cells");
      const std::size_t b = w_.At(ci, cj);
      if (w_.state[b] == kKept && w_.height[b] > q.z() + o_.visibility_tolerance_m) {
        std::atomic_ref<int>(w_.blocked[b]).fetch_add(1, std::memory_order_relaxed);
      }
    }
  });
}

// Cells that block more than max_blocked_rays reference rays become kOccluding.
void CellFilters::MarkOccluding(int band) {
  if (!(o_.max_blocked_rays > 0)) return;
  ForCellsInOrder(w_, Start(band), End(band), [&](int, int, std::size_t g) {
    if (w_.blocked[g] > o_.max_blocked_rays) w_.state[g] = kOccluding;
  });
}

// Isolated points: kept cells with fewer than min_neighbours of the 8 neighbours within
// neighbour_tolerance_m.
void CellFilters::MarkIsolated(int band) {
  ParallelForCells(w_, Start(band), End(band), [&](int i, int j, std::size_t g) {
    if (w_.state[g] != kKept) return;
    int agree = 0;
    for (int dj = -1; dj <= 1; ++dj) {
      for (int di = -1; di <= 1; ++di) {
        const int ii = i + di, jj = j + dj;
        if ((di == 0 && dj == 0) || !w_.InGrid(ii, jj)) continue;
        const std::size_t n = w_.At(ii, jj);
        if (w_.state[n] == kKept &&
            std::abs(w_.height[n] - w_.height[g]) <= o_.neighbour_tolerance_m) {
          ++agree;
        }
      }
    }
    if (agree < o_.min_neighbours) w_.isolated[g] |= kTooFewNeighbours;
  });
}

// Islands are connected sets of kept, not isolated cells (8-neighbours within
// neighbour_tolerance_m) of fewer than min_island_cells_ cells. The search stops as soon as a
// set is known to be larger: it reached that many cells, a cell already found in a large set,
// or a cell whose isolation is not known yet (only sets larger than an island reach one from
// where islands are decided). The labels hold for one pass (one band's decisions).
std::uint8_t CellFilters::Label(int i, int j, std::vector<std::pair<int, int>>* members) {
  const std::size_t start = w_.At(i, j);
  if (w_.label_at[start] == pass_) return w_.label[start];
  const int isolated_known = Start(next_isolated_);
  std::vector<std::pair<int, int>> visited = {{i, j}}, stack = {{i, j}};
  w_.label_at[start] = pass_;
  w_.label[start] = kSearching;
  bool large = static_cast<int>(visited.size()) >= min_island_cells_;
  while (!stack.empty() && !large) {
    const auto [ci, cj] = stack.back();
    stack.pop_back();
    const float h = w_.height[w_.At(ci, cj)];
    for (int dj = -1; dj <= 1 && !large; ++dj) {
      for (int di = -1; di <= 1 && !large; ++di) {
        const int ii = ci + di, jj = cj + dj;
        if ((di == 0 && dj == 0) || !w_.InGrid(ii, jj)) continue;
        const int a = w_.Along(ii, jj);
        if (a < w_.lo || a >= isolated_known) {
          large = true;  // beyond what is known
          break;
        }
        const std::size_t n = w_.At(ii, jj);
        if (w_.state[n] != kKept || (w_.isolated[n] & kTooFewNeighbours) ||
            std::abs(w_.height[n] - h) > o_.neighbour_tolerance_m) {
          continue;
        }
        if (w_.label_at[n] == pass_) {
          large = large || w_.label[n] == kLarge;
          continue;
        }
        w_.label_at[n] = pass_;
        w_.label[n] = kSearching;
        visited.emplace_back(ii, jj);
        stack.emplace_back(ii, jj);
        large = static_cast<int>(visited.size()) >= min_island_cells_;
      }
    }
  }
  const std::uint8_t label = large ? kLarge : kIsland;
  for (const auto& [vi, vj] : visited) w_.label[w_.At(vi, vj)] = label;
  if (members != nullptr && !large) *members = std::move(visited);
  return label;
}

// The false islands float where the two references, each alone, disagree: an island's points
// whose references' heights differ by more than island_max_disagreement_m go; the whole island
// does when it rises more than island_max_rise_m above every other point within
// island_radius_m (a leaf does not float high above everything around it; its plant grows from
// below).
void CellFilters::IsolateIfFalse(const std::vector<std::pair<int, int>>& island) {
  const int reach = static_cast<int>(std::ceil(o_.island_radius_m / w_.s));
  float top = -INFINITY;
  int i0 = w_.gx, i1 = -1, j0 = w_.gy, j1 = -1;
  for (const auto& [i, j] : island) {
    top = std::max(top, w_.height[w_.At(i, j)]);
    i0 = std::min(i0, i);
    i1 = std::max(i1, i);
    j0 = std::min(j0, j);
    j1 = std::max(j1, j);
  }
  float around = -INFINITY;
  for (int j = std::max(0, j0 - reach); j <= std::min(w_.gy - 1, j1 + reach); ++j) {
    for (int i = std::max(0, i0 - reach); i <= std::min(w_.gx - 1, i1 + reach); ++i) {
      CROP4D_CHECK_MSG(w_.Holds(i, j), "an island's neighbourhood left the window of cells");
      const std::size_t g = w_.At(i, j);
      if (w_.state[g] == kKept && !(w_.isolated[g] & kTooFewNeighbours) &&
          Label(i, j, nullptr) != kIsland) {
        around = std::max(around, w_.height[g]);
      }
    }
  }
  const bool floating = top > around + o_.island_max_rise_m;
  for (const auto& [i, j] : island) {
    const std::size_t g = w_.At(i, j);
    if (floating || w_.disagreement[g] > o_.island_max_disagreement_m) {
      w_.isolated[g] |= kFalseIsland;
    }
  }
}

// A band's islands decided (an island that reaches into the next band is decided again there,
// the same way), then its points.
void CellFilters::Emit(int band) {
  if (o_.island_area_m2 > 0) {
    ++pass_;
    std::vector<std::vector<std::pair<int, int>>> islands;
    ForCellsInOrder(w_, Start(band), End(band), [&](int i, int j, std::size_t g) {
      if (w_.state[g] != kKept || (w_.isolated[g] & kTooFewNeighbours) || w_.label_at[g] == pass_) {
        return;
      }
      std::vector<std::pair<int, int>> members;
      if (Label(i, j, &members) == kIsland) islands.push_back(std::move(members));
    });
    for (const auto& island : islands) IsolateIfFalse(island);
  }
  Collect(band);
}

// The band's kept cells become points (with their colour, score, views and uniqueness), in
// along-major order; the others are counted in the summary by why they were not kept.
void CellFilters::Collect(int band) {
  HeightFieldStereo::Summary& summary = *summary_;
  // The fields of HeightFieldStereo::CloudLayout: score, num_views, uniqueness.
  io::PlyPointCloud part;
  for (const auto& [name, type] : HeightFieldStereo::CloudLayout().scalars) {
    part.scalars.push_back({name, type, {}});
  }
  std::vector<double>& score = part.scalars.at(0).values;
  std::vector<double>& views = part.scalars.at(1).values;
  std::vector<double>& uniqueness = part.scalars.at(2).values;
  ForCellsInOrder(w_, Start(band), End(band), [&](int i, int j, std::size_t g) {
    std::uint8_t& state = w_.state[g];
    if (state == kOutside) return;
    if (state != kNoViews) ++summary.num_cells_with_views;
    if (state == kKept && w_.isolated[g]) state = kIsolated;
    switch (state) {
      case kLowTexture:
        ++summary.num_low_texture;
        break;
      case kLowScore:
        ++summary.num_low_score;
        break;
      case kNotUnique:
        ++summary.num_not_unique;
        break;
      case kAtRangeEdge:
        ++summary.num_at_range_edge;
        break;
      case kIsolated:
        ++summary.num_isolated;
        break;
      case kOccluding:
        ++summary.num_occluding;
        break;
      default:
        break;
    }
    if (state != kKept) return;
    summary.num_top_surface += w_.on_top_surface[g];
    const Eigen::Vector2d xy = w_.Centre(i, j);
    part.points.emplace_back(xy.x(), xy.y(), w_.height[g]);
    part.colors.push_back(w_.rgb[g]);
    score.push_back(w_.score[g]);
    views.push_back(w_.num_views[g]);
    uniqueness.push_back(w_.unique[g]);
  });
  summary.num_points += static_cast<std::int64_t>(part.points.size());
  if (sink_) {
    sink_(part);
  } else {
    cloud_->Append(part);
  }
}

}  // namespace crop4d::dense
