#include "crop4d/analysis/terrain.h"

#include <tbb/blocked_range.h>
#include <tbb/parallel_for.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <limits>
#include <random>

#include "crop4d/analysis/ground_filter.h"
#include "crop4d/analysis/point_buckets.h"
#include "crop4d/core/error.h"

namespace crop4d::analysis {
namespace {

constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

bool IsVegetation(const GroundCloud& cloud, std::size_t i) {
  return cloud.is_vegetation != nullptr && (*cloud.is_vegetation)[i] != 0;
}

// The points of `cloud` in `reach` that may be ground: not vegetation, and not above the
// session's opened lowest surface (ground_filter.h).
std::vector<Eigen::Vector3d> GroundCandidates(const GroundCloud& cloud,
                                              const Eigen::AlignedBox2d& reach,
                                              const TerrainOptions& options) {
  std::vector<Eigen::Vector3d> soil;
  for (std::size_t i = 0; i < cloud.points->size(); ++i) {
    const Eigen::Vector3d& p = (*cloud.points)[i];
    if (!IsVegetation(cloud, i) && p.allFinite() && reach.contains(p.head<2>())) soil.push_back(p);
  }
  const std::vector<std::uint8_t> keep = GroundBelowOpening(soil, options.ground_filter);
  std::vector<Eigen::Vector3d> out;
  for (std::size_t k = 0; k < soil.size(); ++k) {
    if (keep[k]) out.push_back(soil[k]);
  }
  return out;
}

double Median(std::vector<double>& v) {
  if (v.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2);
  std::nth_element(v.begin(), mid, v.end());
  return *mid;
}

struct NodeFit {
  float height = kNaN;
  float scale = kNaN;
};

// The robust quadratic fit of one node (see the header). `points` are the candidates.
NodeFit FitNode(const Eigen::Vector2d& node, const std::vector<Eigen::Vector3d>& ground,
                const PointBuckets& buckets, const TerrainOptions& o,
                std::vector<std::uint32_t>* scratch) {
  NodeFit fit;
  scratch->clear();
  buckets.Query(node, o.fit_radius_m, ground, scratch);
  const int n = static_cast<int>(scratch->size());
  if (n < o.min_points) return fit;
  std::array<int, 4> quadrant{0, 0, 0, 0};
  for (std::uint32_t k : *scratch) {
    const Eigen::Vector3d& p = ground[k];
    quadrant[(p.x() >= node.x() ? 1 : 0) + (p.y() >= node.y() ? 2 : 0)]++;
  }
  for (int q : quadrant) {
    if (q < o.min_points_per_quadrant) return fit;
  }
  const double sigma_d = 0.5 * o.fit_radius_m;
  Eigen::VectorXd spatial(n), dz(n), robust = Eigen::VectorXd::Ones(n);
  Eigen::Matrix<double, Eigen::Dynamic, 6> a(n, 6);
  for (int r = 0; r < n; ++r) {
    const Eigen::Vector3d& p = ground[(*scratch)[r]];
    const double dx = p.x() - node.x(), dy = p.y() - node.y();
    a.row(r) << 1.0, dx, dy, dx * dx, dx * dy, dy * dy;
    dz(r) = p.z();
    spatial(r) = std::exp(-0.5 * (dx * dx + dy * dy) / (sigma_d * sigma_d));
  }
  Eigen::Matrix<double, 6, 1> c = Eigen::Matrix<double, 6, 1>::Zero();
  std::vector<double> abs_res(n);
  double scale = o.noise_floor_m;
  for (int it = 0; it < o.iterations; ++it) {
    const Eigen::VectorXd w = spatial.cwiseProduct(robust);
    const Eigen::Matrix<double, 6, 6> ata = a.transpose() * w.asDiagonal() * a;
    const Eigen::Matrix<double, 6, 1> atb = a.transpose() * w.cwiseProduct(dz);
    Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(ata);
    if (ldlt.info() != Eigen::Success) return fit;
    c = ldlt.solve(atb);
    if (!c.allFinite()) return fit;
    const Eigen::VectorXd res = dz - a * c;
    for (int r = 0; r < n; ++r) abs_res[r] = std::abs(res(r));
    std::vector<double> tmp = abs_res;
    scale = std::max(o.noise_floor_m, 1.4826 * Median(tmp));
    const double limit = o.outlier_sigmas * scale;
    int kept = 0;
    for (int r = 0; r < n; ++r) {
      if (res(r) > limit) {
        robust(r) = 0.0;  // above the ground: not ground
      } else if (res(r) < -limit) {
        robust(r) = limit / -res(r);  // Huber below
        ++kept;
      } else {
        robust(r) = 1.0;
        ++kept;
      }
    }
    if (kept < o.min_points) return fit;
  }
  fit.height = static_cast<float>(c(0));
  fit.scale = static_cast<float>(scale);
  return fit;
}

void Append(const WeightedPoints& from, WeightedPoints* to) {
  to->points.insert(to->points.end(), from.points.begin(), from.points.end());
  to->weights.insert(to->weights.end(), from.weights.begin(), from.weights.end());
}

WeightedPoints Unweighted(std::vector<Eigen::Vector3d> points) {
  WeightedPoints out;
  out.weights.assign(points.size(), 1);
  out.points = std::move(points);
  return out;
}

// One point per `cell` × `cell` square: the weighted median by height (the lowest whose
// cumulative weight passes half the cell's; with unit weights the middle point, the upper of the
// two middle ones of an even count), standing for the cell's total weight. All when cell <= 0.
// Thinning each session's points and then their union with these weights gives nearly the median
// of all the sessions' points, without holding them.
WeightedPoints Thin(const WeightedPoints& in, double cell) {
  if (cell <= 0.0 || in.points.empty()) return in;
  struct Entry {
    std::int64_t key;
    double z;
    std::uint32_t index;
  };
  std::vector<Entry> entries;
  entries.reserve(in.points.size());
  for (std::uint32_t i = 0; i < in.points.size(); ++i) {
    const Eigen::Vector3d& p = in.points[i];
    const std::int64_t cx = static_cast<std::int64_t>(std::floor(p.x() / cell));
    const std::int64_t cy = static_cast<std::int64_t>(std::floor(p.y() / cell));
    entries.push_back({(cx << 32) ^ (cy & 0xffffffffLL), p.z(), i});
  }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) {
    return a.key != b.key ? a.key < b.key : (a.z != b.z ? a.z < b.z : a.index < b.index);
  });
  WeightedPoints out;
  for (std::size_t b = 0; b < entries.size();) {
    std::size_t e = b;
    std::uint64_t total = 0;
    for (; e < entries.size() && entries[e].key == entries[b].key; ++e) {
      total += in.weights[entries[e].index];
    }
    std::size_t m = b;
    for (std::uint64_t below = 0; m + 1 < e; ++m) {
      below += in.weights[entries[m].index];
      if (2 * below > total) break;
    }
    out.points.push_back(in.points[entries[m].index]);
    out.weights.push_back(static_cast<std::uint32_t>(std::min<std::uint64_t>(total, UINT32_MAX)));
    b = e;
  }
  return out;
}

// The points of the cells of `cell` whose lower edge along `axis` lies in [lo, hi) (tiles that
// partition the axis own each cell once: the cell's index is computed alike in every tile); of
// the points in [lo, hi) when cell <= 0.
WeightedPoints InTile(WeightedPoints in, int axis, double lo, double hi, double cell) {
  std::size_t kept = 0;
  for (std::size_t i = 0; i < in.points.size(); ++i) {
    const double v = in.points[i][axis];
    const double edge = cell > 0.0 ? std::floor(v / cell) * cell : v;
    if (!(edge >= lo && edge < hi)) continue;
    in.points[kept] = in.points[i];
    in.weights[kept] = in.weights[i];
    ++kept;
  }
  in.points.resize(kept);
  in.weights.resize(kept);
  return in;
}

// Fits every node; returns heights (NaN where no fit) and the scales of fitted nodes.
std::vector<float> FitAllNodes(const GridSpec& grid, const std::vector<Eigen::Vector3d>& ground,
                               const TerrainOptions& o, std::vector<float>* scales) {
  std::vector<float> heights(grid.size(), kNaN);
  scales->assign(grid.size(), kNaN);
  if (ground.empty()) return heights;
  const PointBuckets buckets(ground, 0.5 * o.fit_radius_m);
  tbb::parallel_for(tbb::blocked_range<int>(0, grid.height), [&](const tbb::blocked_range<int>& r) {
    std::vector<std::uint32_t> scratch;
    for (int j = r.begin(); j < r.end(); ++j) {
      for (int i = 0; i < grid.width; ++i) {
        const NodeFit fit = FitNode(grid.Node(i, j), ground, buckets, o, &scratch);
        const std::size_t k = static_cast<std::size_t>(j) * grid.width + i;
        heights[k] = fit.height;
        (*scales)[k] = fit.scale;
      }
    }
  });
  return heights;
}

// Harmonic fill of the unknown nodes within `max_distance` of known ones: Gauss–Seidel sweeps of
// the 4-neighbour average, starting from the nearest known value (breadth-first).
std::size_t FillHoles(const GridSpec& grid, double max_distance, std::vector<float>* heights) {
  const int w = grid.width, h = grid.height;
  const int max_steps = static_cast<int>(std::floor(max_distance / grid.cell_m));
  std::vector<int> steps(grid.size(), -1);
  std::deque<int> queue;
  for (int k = 0; k < static_cast<int>(grid.size()); ++k) {
    if (std::isfinite((*heights)[k])) {
      steps[k] = 0;
      queue.push_back(k);
    }
  }
  if (queue.empty() || max_steps <= 0) return 0;
  std::vector<int> filled;
  while (!queue.empty()) {
    const int k = queue.front();
    queue.pop_front();
    if (steps[k] >= max_steps) continue;
    const int i = k % w, j = k / w;
    const int nbr[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
    for (const auto& q : nbr) {
      if (q[0] < 0 || q[0] >= w || q[1] < 0 || q[1] >= h) continue;
      const int kk = q[1] * w + q[0];
      if (steps[kk] >= 0) continue;
      steps[kk] = steps[k] + 1;
      (*heights)[kk] = (*heights)[k];
      filled.push_back(kk);
      queue.push_back(kk);
    }
  }
  // Relax the filled nodes towards the harmonic interpolant of their known neighbours.
  for (int sweep = 0; sweep < 200; ++sweep) {
    double change = 0.0;
    for (int k : filled) {
      const int i = k % w, j = k / w;
      double sum = 0.0;
      int count = 0;
      const int nbr[4][2] = {{i - 1, j}, {i + 1, j}, {i, j - 1}, {i, j + 1}};
      for (const auto& q : nbr) {
        if (q[0] < 0 || q[0] >= w || q[1] < 0 || q[1] >= h) continue;
        const float v = (*heights)[q[1] * w + q[0]];
        if (std::isfinite(v)) {
          sum += v;
          ++count;
        }
      }
      if (count == 0) continue;
      const float next = static_cast<float>(sum / count);
      change = std::max(change, static_cast<double>(std::abs(next - (*heights)[k])));
      (*heights)[k] = next;
    }
    if (change < 1e-5) break;
  }
  return filled.size();
}

}  // namespace

OptionCheck GridSpec::Check() const {
  OptionChecker c;
  c.Require(origin.allFinite(), "origin", "must be finite")
      .Finite("cell_m", cell_m)
      .Greater("cell_m", cell_m, 0.0)
      .Greater("width", width, 0)
      .Greater("height", height, 0);
  return c.Result();
}

GridSpec GridSpec::Covering(const Eigen::AlignedBox2d& box, double cell_m) {
  CROP4D_CHECK(cell_m > 0.0 && !box.isEmpty());
  GridSpec g;
  g.cell_m = cell_m;
  const Eigen::Vector2d lo = (box.min() / cell_m).array().floor() * cell_m;
  const Eigen::Vector2d hi = (box.max() / cell_m).array().ceil() * cell_m;
  g.origin = lo;
  g.width = static_cast<int>(std::lround((hi.x() - lo.x()) / cell_m)) + 1;
  g.height = static_cast<int>(std::lround((hi.y() - lo.y()) / cell_m)) + 1;
  return g;
}

TerrainModel::TerrainModel(GridSpec grid, std::vector<float> heights)
    : grid_(grid), heights_(std::move(heights)) {
  CROP4D_CHECK_OPTIONS(grid_, "TerrainModel::TerrainModel");
  CROP4D_CHECK(heights_.size() == grid_.size());
}

double TerrainModel::Height(double x, double y) const {
  if (heights_.empty()) return std::numeric_limits<double>::quiet_NaN();
  const double u = (x - grid_.origin.x()) / grid_.cell_m;
  const double v = (y - grid_.origin.y()) / grid_.cell_m;
  if (!(u >= 0.0 && v >= 0.0 && u <= grid_.width - 1 && v <= grid_.height - 1)) {
    return std::numeric_limits<double>::quiet_NaN();
  }
  const int i = std::min(static_cast<int>(u), std::max(grid_.width - 2, 0));
  const int j = std::min(static_cast<int>(v), std::max(grid_.height - 2, 0));
  const double fu = u - i, fv = v - j;
  const int i1 = std::min(i + 1, grid_.width - 1), j1 = std::min(j + 1, grid_.height - 1);
  return (1 - fu) * (1 - fv) * At(i, j) + fu * (1 - fv) * At(i1, j) + (1 - fu) * fv * At(i, j1) +
         fu * fv * At(i1, j1);
}

double TerrainModel::Coverage() const {
  if (heights_.empty()) return 0.0;
  const auto known =
      std::count_if(heights_.begin(), heights_.end(), [](float v) { return std::isfinite(v); });
  return static_cast<double>(known) / heights_.size();
}

OptionCheck TerrainOptions::Check() const {
  OptionChecker c;
  c.Greater("cell_m", cell_m, 0.0)
      .Require(fit_radius_m > cell_m, "fit_radius_m", "must be > cell_m", fit_radius_m)
      .AtLeast("min_points", min_points, 6)
      .AtLeast("min_points_per_quadrant", min_points_per_quadrant, 0)
      .Greater("outlier_sigmas", outlier_sigmas, 0.0)
      .Greater("noise_floor_m", noise_floor_m, 0.0)
      .AtLeast("iterations", iterations, 1)
      .Greater("later_tolerance_m", later_tolerance_m, 0.0)
      .AtLeast("vegetation_clearance_m", vegetation_clearance_m, 0.0)
      .AtLeast("max_fill_distance_m", max_fill_distance_m, 0.0)
      .Nested("ground_filter", ground_filter.Check());
  return c.Result();
}

TerrainBuilder::TerrainBuilder(const Eigen::AlignedBox2d& bounds, const TerrainOptions& options)
    : options_(options) {
  CROP4D_CHECK_OPTIONS(options_, "TerrainBuilder");
  grid_ = GridSpec::Covering(bounds, options_.cell_m);
  summary_.nodes = grid_.size();
  reach_ = bounds;
  reach_.extend(bounds.min() - Eigen::Vector2d::Constant(options_.fit_radius_m));
  reach_.extend(bounds.max() + Eigen::Vector2d::Constant(options_.fit_radius_m));
}

void TerrainBuilder::AddSession(const GroundCloud& c) {
  BeginSession();
  const double inf = std::numeric_limits<double>::infinity();
  AddTile(c, 0, -inf, inf);
  EndSession();
}

double TerrainBuilder::TileReach(const TerrainOptions& options) {
  return GroundFilterReach(options.ground_filter) + std::max(options.thin_cell_m, 0.0) +
         std::max(options.vegetation_clearance_m, 0.0);
}

void TerrainBuilder::BeginSession() {
  CROP4D_CHECK(!in_session_);
  in_session_ = true;
  first_session_ = !have_first_;
  session_has_points_ = false;
}

void TerrainBuilder::AddTile(const GroundCloud& c, int axis, double lo, double hi) {
  CROP4D_CHECK(in_session_ && (axis == 0 || axis == 1));
  if (c.points == nullptr || c.points->empty()) return;
  session_has_points_ = true;
  if (!first_session_ && !options_.use_later_sessions) return;
  const auto t0 = std::chrono::steady_clock::now();
  std::vector<Eigen::Vector3d> ground = GroundCandidates(c, reach_, options_);
  if (!first_session_) {
    // Where the first model is unknown (the first session did not see the ground there), a
    // later soil point is taken on the clearance test alone.
    std::vector<Eigen::Vector3d> vegetation;
    for (std::size_t i = 0; i < c.points->size(); ++i) {
      if (IsVegetation(c, i)) vegetation.push_back((*c.points)[i]);
    }
    const double clearance = std::max(options_.vegetation_clearance_m, 1e-3);
    const PointBuckets veg_buckets(vegetation, clearance);
    std::vector<Eigen::Vector3d> accepted;
    for (const Eigen::Vector3d& p : ground) {
      const double z = first_model_.Height(p.x(), p.y());
      if (std::isfinite(z) && std::abs(p.z() - z) > options_.later_tolerance_m) continue;
      if (options_.vegetation_clearance_m > 0.0 &&
          veg_buckets.Any(p.head<2>(), options_.vegetation_clearance_m, vegetation)) {
        continue;
      }
      accepted.push_back(p);
    }
    ground = std::move(accepted);
  }
  const WeightedPoints thinned = InTile(Thin(Unweighted(std::move(ground)), options_.thin_cell_m),
                                        axis, lo, hi, options_.thin_cell_m);
  if (!first_session_) summary_.ground_points_later += thinned.points.size();
  Append(thinned, &ground_);
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

void TerrainBuilder::EndSession() {
  CROP4D_CHECK(in_session_);
  in_session_ = false;
  if (!first_session_ || !session_has_points_) return;
  // The earliest session with points gives the first ground; its tiles' cells, in the order
  // of the cells (as from the whole session: the fit does not depend on the tiling).
  const auto t0 = std::chrono::steady_clock::now();
  have_first_ = true;
  ground_ = Thin(ground_, options_.thin_cell_m);
  summary_.ground_points_first = ground_.points.size();
  first_heights_ = FitAllNodes(grid_, ground_.points, options_, &first_scales_);
  first_model_ = TerrainModel(grid_, first_heights_);
  seconds_ += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TerrainModel TerrainBuilder::Finish(TerrainSummary* summary) {
  const auto t0 = std::chrono::steady_clock::now();
  TerrainSummary s = summary_;
  std::vector<float> heights = std::move(first_heights_);
  std::vector<float> scales = std::move(first_scales_);
  if (!have_first_) {
    heights.assign(grid_.size(), kNaN);
    scales.assign(grid_.size(), kNaN);
  } else if (s.ground_points_later > 0) {
    heights = FitAllNodes(grid_, Thin(ground_, options_.thin_cell_m).points, options_, &scales);
  }
  ground_ = WeightedPoints();
  std::vector<double> fitted_scales;
  for (std::size_t k = 0; k < heights.size(); ++k) {
    if (std::isfinite(heights[k])) {
      ++s.nodes_fitted;
      fitted_scales.push_back(scales[k]);
    }
  }
  s.residual_scale_m = fitted_scales.empty() ? 0.0 : Median(fitted_scales);
  s.nodes_filled = FillHoles(grid_, options_.max_fill_distance_m, &heights);
  s.seconds =
      seconds_ + std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  if (summary) *summary = s;
  return TerrainModel(grid_, std::move(heights));
}

TerrainModel BuildTerrain(const std::vector<GroundCloud>& sessions,
                          const Eigen::AlignedBox2d& bounds, const TerrainOptions& options,
                          TerrainSummary* summary) {
  TerrainBuilder builder(bounds, options);
  for (const GroundCloud& c : sessions) builder.AddSession(c);
  return builder.Finish(summary);
}

OptionCheck PlaneOptions::Check() const {
  OptionChecker c;
  c.Greater("inlier_threshold_m", inlier_threshold_m, 0.0)
      .AtLeast("iterations", iterations, 1)
      .AtLeast("min_points", min_points, 3);
  return c.Result();
}

std::optional<GroundPlane> FitSiteGroundPlane(const GroundCloud& earliest,
                                              const Eigen::Vector2d& center, double radius_m,
                                              const PlaneOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "FitSiteGroundPlane");
  if (earliest.points == nullptr) return std::nullopt;
  std::vector<Eigen::Vector3d> pts;
  for (std::size_t i = 0; i < earliest.points->size(); ++i) {
    const Eigen::Vector3d& p = (*earliest.points)[i];
    if (!IsVegetation(earliest, i) && p.allFinite() &&
        (p.head<2>() - center).squaredNorm() <= radius_m * radius_m) {
      pts.push_back(p);
    }
  }
  const int n = static_cast<int>(pts.size());
  if (n < options.min_points) return std::nullopt;
  // Plane through points, least squares in centred coordinates (conditioning).
  auto fit = [&](const std::vector<int>& idx) -> std::optional<GroundPlane> {
    Eigen::MatrixXd a(idx.size(), 3);
    Eigen::VectorXd b(idx.size());
    for (std::size_t r = 0; r < idx.size(); ++r) {
      const Eigen::Vector3d& p = pts[idx[r]];
      a.row(r) << 1.0, p.x() - center.x(), p.y() - center.y();
      b(r) = p.z();
    }
    const Eigen::Vector3d c = a.colPivHouseholderQr().solve(b);
    if (!c.allFinite() || a.colPivHouseholderQr().rank() < 3) return std::nullopt;
    GroundPlane plane;
    plane.b = c(1);
    plane.c = c(2);
    plane.a = c(0) - c(1) * center.x() - c(2) * center.y();
    return plane;
  };
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best_inliers;
  for (int it = 0; it < options.iterations; ++it) {
    const int i = pick(rng), j = pick(rng), k = pick(rng);
    if (i == j || j == k || i == k) continue;
    const std::optional<GroundPlane> plane = fit({i, j, k});
    if (!plane) continue;
    std::vector<int> inliers;
    for (int q = 0; q < n; ++q) {
      if (std::abs(pts[q].z() - plane->Height(pts[q].x(), pts[q].y())) <
          options.inlier_threshold_m) {
        inliers.push_back(q);
      }
    }
    if (inliers.size() > best_inliers.size()) best_inliers = std::move(inliers);
  }
  if (static_cast<int>(best_inliers.size()) < 3) return std::nullopt;
  std::optional<GroundPlane> plane = fit(best_inliers);
  if (!plane) return std::nullopt;
  plane->inliers = static_cast<int>(best_inliers.size());
  return plane;
}

}  // namespace crop4d::analysis
