#pragma once

// The terrain under the crop (DESIGN.md §2.6): a digital terrain model (DTM) on a regular grid
// of the field's ENU xy plane, from the ground points of registered clouds, and the paper's
// single ground plane per site, kept for comparison.
//
// Local surface model. Every grid node gets the value at the node of a quadratic surface
//   z(x, y) = c0 + c1 dx + c2 dy + c3 dx² + c4 dx dy + c5 dy²,   (dx, dy) = point − node,
// fitted to the ground points within `fit_radius_m` by iteratively reweighted least squares:
// a Gaussian weight in the distance to the node (σ = fit_radius_m / 2) times a robust weight in
// the residual. The robust weight is asymmetric, because what is not ground lies *above* it
// (leaves that the colour test missed, stems, plant shadows on leaves): a residual above
// +`outlier_sigmas`·σ gets weight 0, one below −`outlier_sigmas`·σ a Huber weight, where σ is the
// residuals' MAD scale (at least `noise_floor_m`). A quadratic over a few decimetres follows
// raised beds, furrows and tyre tracks (a bed of 6 cm over a 0.91 m row spacing has a curvature
// of 1.4 m⁻¹ at its crest, which one plane per site cannot follow: the paper's failure). A node
// is fitted only when its points surround it (every quadrant holds some), so the surface is
// interpolated, never extrapolated past the data.
//
// Sessions. The earliest session's ground points come first, when the plants are small and most
// of the soil is visible. Later sessions then add their ground points where the vegetation does
// not cover them: points that the colour test calls soil, that lie within
// `later_tolerance_m` of the first model, and that have no vegetation point of their own
// session within `vegetation_clearance_m`, each session's thinned to one per cell of
// `thin_cell_m` (its median, weighted by the points it stands for when the sessions are thinned
// together), so that a session can be added and its cloud freed (TerrainBuilder). The model is
// fitted again with all of them. Holes (nodes without enough surrounding points) are filled by
// harmonic interpolation from their neighbours up to `max_fill_distance_m` from a fitted node, and
// stay NaN beyond.
//
// Points are given as GroundCloud (one per session, time order), with a vegetation flag per
// point from analysis/vegetation.h.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/analysis/ground_filter.h"
#include "crop4d/core/option_check.h"

namespace crop4d::analysis {

// A regular grid of the ENU xy plane: node (i, j) at origin + (i, j) · cell_m, i = 0..width-1
// (east), j = 0..height-1 (north).
struct GridSpec {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  double cell_m = 0.05;
  int width = 0;
  int height = 0;

  OptionCheck Check() const;
  std::size_t size() const { return static_cast<std::size_t>(width) * height; }
  Eigen::Vector2d Node(int i, int j) const { return origin + cell_m * Eigen::Vector2d(i, j); }
  // The grid of `cell_m` nodes whose nodes cover `box` (edges snapped to multiples of cell_m).
  static GridSpec Covering(const Eigen::AlignedBox2d& box, double cell_m);
};

// One session's points for terrain modelling.
struct GroundCloud {
  const std::vector<Eigen::Vector3d>* points = nullptr;      // ENU, metres
  const std::vector<std::uint8_t>* is_vegetation = nullptr;  // one per point, or null: none
};

// A height field on a GridSpec: NaN where unknown.
class TerrainModel {
 public:
  TerrainModel() = default;
  TerrainModel(GridSpec grid, std::vector<float> heights);

  const GridSpec& grid() const { return grid_; }
  const std::vector<float>& heights() const { return heights_; }
  bool empty() const { return heights_.empty(); }

  // Bilinear interpolation between the four surrounding nodes; NaN outside the grid or when one
  // of them is unknown.
  double Height(double x, double y) const;
  // Node value (NaN if unknown).
  float At(int i, int j) const { return heights_[static_cast<std::size_t>(j) * grid_.width + i]; }
  // Fraction of nodes with a value.
  double Coverage() const;

 private:
  GridSpec grid_;
  std::vector<float> heights_;
};

struct TerrainOptions {
  // Spacing of the DTM nodes, metres.
  double cell_m = 0.05;
  // Radius of the neighbourhood of each node's quadratic fit, metres: a few decimetres follows
  // beds and furrows and still reaches past a young plant's canopy to the soil around it.
  double fit_radius_m = 0.2;
  // Fewest ground points in a node's neighbourhood for a fit (a quadratic has 6 coefficients).
  int min_points = 12;
  // Fewest points in each of the four quadrants around the node (no extrapolation).
  int min_points_per_quadrant = 2;
  // Residuals beyond this many robust sigmas: above the surface, rejected; below, Huber.
  double outlier_sigmas = 2.5;
  // Lower bound of the robust residual scale, metres (the clouds' own noise).
  double noise_floor_m = 0.003;
  // Reweighting iterations of each fit.
  int iterations = 5;
  // Soil-coloured points above the session's opened lowest surface are not ground.
  GroundFilterOptions ground_filter;
  // Use the ground points of later sessions where the vegetation does not cover them.
  bool use_later_sessions = true;
  // A later session's soil point joins the ground within this distance of the first model, m.
  double later_tolerance_m = 0.03;
  // ... and with no vegetation point of its own session closer than this (horizontally), m.
  double vegetation_clearance_m = 0.05;
  // Holes are filled up to this distance from fitted nodes, metres (NaN beyond).
  double max_fill_distance_m = 0.5;
  // Ground points are thinned to one per cell of this size (the cell's median height), metres;
  // 0 keeps them all. A dense cloud has tens of points per square decimetre: the fits need
  // far fewer, and the median of a cell is robust to its noise.
  double thin_cell_m = 0.02;

  OptionCheck Check() const;
};

struct TerrainSummary {
  std::size_t ground_points_first = 0;  // ground points of the earliest session, thinned
  std::size_t ground_points_later = 0;  // ground points added by later sessions, each thinned
  std::size_t nodes = 0;                // nodes of the grid
  std::size_t nodes_fitted = 0;         // nodes with a surface fit
  std::size_t nodes_filled = 0;         // nodes filled by interpolation
  double residual_scale_m = 0.0;        // median robust scale of the fits
  double seconds = 0.0;
};

// Points, each standing for `weights` points (the count of the cell it was thinned from).
struct WeightedPoints {
  std::vector<Eigen::Vector3d> points;
  std::vector<std::uint32_t> weights;  // one per point
};

// Builds the DTM over `bounds` one session at a time, so that no session's cloud needs to stay
// in memory after it was added: the earliest session with points fits the first model; each
// later session's ground points (soil, near the first model, clear of its own vegetation) are
// thinned to one per `thin_cell_m` cell of that session (the cell's median) and kept with the
// number of points it stands for; Finish thins the first session's and the later sessions' kept
// points together (the median weighted by those numbers: nearly the median of all their points)
// and fits again. What is kept grows with the sessions by at most one point per cell of soil per
// session (28 bytes per 2 × 2 cm).
class TerrainBuilder {
 public:
  TerrainBuilder(const Eigen::AlignedBox2d& bounds, const TerrainOptions& options);

  // Adds the next session (time order). A session without points is skipped; so is every
  // session after the first when options.use_later_sessions is false.
  void AddSession(const GroundCloud& session);

  // The same, the session given a tile at a time (the analysis reads a session in tiles, so that
  // its cloud is never held whole): BeginSession, AddTile for each tile, EndSession. A tile holds
  // the session's points within its extent along `axis` (0: x, 1: y) and within TileReach of it;
  // it adds the ground of the thinning cells whose lower edge along the axis lies in [lo, hi)
  // (of the points there when thin_cell_m is 0). Tiles that partition the axis add the ground
  // that AddSession adds from the whole session (the same points, up to their order).
  void BeginSession();
  void AddTile(const GroundCloud& tile, int axis, double lo, double hi);
  void EndSession();
  // How far around its extent a tile must hold the session's points, m: the ground filter's
  // reach, a thinning cell and the vegetation clearance.
  static double TileReach(const TerrainOptions& options);
  // The model of the sessions added. Call once.
  TerrainModel Finish(TerrainSummary* summary = nullptr);

 private:
  TerrainOptions options_;
  GridSpec grid_;
  Eigen::AlignedBox2d reach_;  // bounds + fit radius: the points any node's fit can use
  bool have_first_ = false;
  // Within BeginSession ... EndSession: whether it is the first session and has points.
  bool in_session_ = false, first_session_ = false, session_has_points_ = false;
  // The first session's thinned ground points, then the later ones'.
  WeightedPoints ground_;
  std::vector<float> first_heights_;  // the first model's nodes
  std::vector<float> first_scales_;
  TerrainModel first_model_;  // the first model, which later sessions' points must lie near
  TerrainSummary summary_;
  double seconds_ = 0.0;
};

// Fits the DTM over `bounds` from `sessions` (time order; the first is the earliest) with a
// TerrainBuilder. Sessions without points are skipped; with no ground points at all the model
// has no value anywhere.
TerrainModel BuildTerrain(const std::vector<GroundCloud>& sessions,
                          const Eigen::AlignedBox2d& bounds, const TerrainOptions& options,
                          TerrainSummary* summary = nullptr);

// ---- The paper's single plane per site (Dong et al. 2017, §V) ------------------------------

// A plane z = a + b x + c y in ENU.
struct GroundPlane {
  double a = 0.0, b = 0.0, c = 0.0;
  int inliers = 0;
  double Height(double x, double y) const { return a + b * x + c * y; }
};

struct PlaneOptions {
  // RANSAC inlier distance (vertical), metres.
  double inlier_threshold_m = 0.01;
  // RANSAC iterations.
  int iterations = 500;
  // Fewest ground points for a plane.
  int min_points = 10;
  // Seed of the sampler: the result is reproducible.
  std::uint64_t seed = 1;

  OptionCheck Check() const;
};

// The paper's ground: one plane by RANSAC through the earliest session's soil points (not
// vegetation) within `radius_m` of `center`, refined by least squares on its inliers. nullopt
// with fewer than `min_points` points.
std::optional<GroundPlane> FitSiteGroundPlane(const GroundCloud& earliest,
                                              const Eigen::Vector2d& center, double radius_m,
                                              const PlaneOptions& options);

}  // namespace crop4d::analysis
