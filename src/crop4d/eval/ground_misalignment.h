#pragma once

// Cross-session ground misalignment of per-session point clouds (DESIGN.md §2 step 4: the 4D
// model registers every session into one frame; where the ground has not changed, the clouds of
// two sessions should lie on one surface).
//
// 1. Ground points of a session (SelectGroundPoints): points horizontally farther than the
//    plant's true canopy radius + plant_margin_m from every plant of that session, and within
//    max_terrain_distance_m of the true terrain height there. They see bare soil, which does
//    not move between sessions (the canopy grows and the leaves move).
// 2. For every ground point p of session A and every other session B: the ground points of B
//    within radius_m of p horizontally (at least min_points of them) give a local plane (least
//    squares: centroid and the normal of least variance, pointing up); the misalignment of p is
//    its signed distance to that plane, positive when p lies above B's ground.
// 3. Per unordered pair {A, B} (A before B in the given order) both directions are pooled, the
//    signs oriented as "A above B": the median and 90th percentile of the absolute distances,
//    and the median of the signed ones (a vertical offset between the sessions). The same over
//    all pairs pooled.
// 4. The same for each session against itself (every point left out of its own plane): the
//    noise floor of the clouds (SelfMisalignment).
//
// It works on any set of per-session clouds in one world frame: the fused sparse clouds, the
// row-SLAM landmarks, dense clouds.

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::eval {

// A plant's footprint on one date (FIELD/ground_truth/<session>/plants.csv).
struct PlantFootprint {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // stem, ENU m
  double canopy_radius_m = 0.0;                  // 0 before emergence
  double height_m = 0.0;                         // above the terrain at the stem; 0 before
};

// Reads plants.csv (id,row,x,y,height_m,canopy_radius_m; a header line). Throws InputError with
// the file and line for anything malformed (a negative height or radius included).
std::vector<PlantFootprint> ReadPlantsCsv(const std::string& path);

// The terrain height on a regular grid, bilinear between the nodes
// (FIELD/ground_truth/terrain.csv: x,y,z rows of a full grid, x fastest).
class TerrainGrid {
 public:
  TerrainGrid() = default;
  // nx × ny nodes from (x0, y0) with spacing `step`; heights[iy * nx + ix].
  TerrainGrid(double x0, double y0, double step, int nx, int ny, std::vector<double> heights);
  // Samples `height(x, y)` on the grid of the box [x0, x1] × [y0, y1] (tests).
  static TerrainGrid FromFunction(double x0, double y0, double x1, double y1, double step,
                                  const std::function<double(double, double)>& height);
  // Reads terrain.csv. Throws InputError (file, line) when a line is malformed or the nodes do
  // not form a full regular grid.
  static TerrainGrid Read(const std::string& path);

  bool empty() const { return heights_.empty(); }
  // Bilinear height at (x, y); false outside the grid.
  bool Height(double x, double y, double* z) const;

 private:
  double x0_ = 0.0, y0_ = 0.0, step_ = 1.0;
  int nx_ = 0, ny_ = 0;
  std::vector<double> heights_;
};

struct GroundSelectionOptions {
  // Kept clear of each plant's canopy by this much beyond its true radius, m.
  double plant_margin_m = 0.05;
  // At most this far from the true terrain height (above or below), m, once the cloud's own
  // vertical offset from the terrain (the mode of the heights above it) is removed: generous
  // enough for a few centimetres of registration error, tight enough to drop weeds of the tree
  // line and outliers.
  double max_terrain_distance_m = 0.10;

  OptionCheck Check() const;
};

// The ground points of one session's cloud (step 1 above). Points outside the terrain grid are
// dropped.
std::vector<Eigen::Vector3d> SelectGroundPoints(const std::vector<Eigen::Vector3d>& points,
                                                const std::vector<PlantFootprint>& plants,
                                                const TerrainGrid& terrain,
                                                const GroundSelectionOptions& options = {});

struct GroundMisalignmentOptions {
  // Horizontal radius of the neighbourhood in the other session, m.
  double radius_m = 0.15;
  // Fewer neighbours than this: the point is skipped (no surface of the other session there).
  int min_points = 6;
  // A local plane steeper than this is not ground (collinear neighbours, e.g. points along one
  // furrow): skipped, degrees from horizontal.
  double max_slope_deg = 45.0;
  // Query points per session, evenly subsampled in cloud order beyond this (bounds the time on
  // dense clouds; every point still serves as a neighbour).
  int max_query_points = 20000;

  OptionCheck Check() const;
};

// One session's ground points.
struct SessionGround {
  std::string session;
  std::vector<Eigen::Vector3d> points;
};

struct MisalignmentStats {
  std::int64_t count = 0;        // distances
  std::int64_t skipped = 0;      // query points without enough neighbours or with a steep plane
  double median_m = 0.0;         // of |d|; NaN when count is 0
  double p90_m = 0.0;            // 90th percentile of |d|
  double signed_median_m = 0.0;  // of d, "A above B" positive
  double mean_abs_m = 0.0;       // mean of |d|
};

struct PairMisalignment {
  std::string a, b;  // a before b in the input order
  MisalignmentStats stats;
};

// A session's ground against itself: each point against the plane of its own neighbours (the
// point left out). The spread of one cloud's ground (landmark noise, rough soil): the floor
// below which the cross-session figures cannot go.
struct SelfMisalignment {
  std::string session;
  MisalignmentStats stats;
};

struct GroundMisalignment {
  std::vector<PairMisalignment> pairs;  // every unordered pair, (0,1), (0,2), ..., (1,2), ...
  MisalignmentStats pooled;             // every distance of every pair
  std::vector<SelfMisalignment> self;   // one per session, in the input order
  MisalignmentStats pooled_self;        // every distance of every session against itself
};

// Steps 2 and 3 above. Sessions with no point take part in no pair with a distance.
GroundMisalignment ComputeGroundMisalignment(const std::vector<SessionGround>& sessions,
                                             const GroundMisalignmentOptions& options = {});

}  // namespace crop4d::eval
