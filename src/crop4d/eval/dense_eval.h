#pragma once

// Accuracy of the dense clouds of `crop4d densify` (WS/dense/<session>.ply) against a synthetic
// field's ground truth, apart from the crop analysis that uses them. Canopy heights per site
// (canopy_eval.h) mix three error sources: the cloud, the stems the analysis finds and its
// terrain model. This section measures the cloud alone, at the true stems and on the true
// terrain:
//
//   plant tops  for every plant that has emerged (FIELD/ground_truth/<session>/plants.csv), the
//               highest point of the cloud within top_radius_m of its true stem, minus the true
//               terrain at the stem (FIELD/ground_truth/terrain.csv), minus its true height:
//               negative when the cloud misses the top leaves, positive for points floating
//               above the plant (or a taller neighbour's leaf within the radius). A plant
//               without any point within the radius is missing. The analysis's default
//               plant-top radius is the same 8 cm (docs/analysis.md §3);
//   soil        the points selected as ground as in the ground misalignment (clear of every
//               plant's canopy, near the true terrain: ground_misalignment.h), and their height
//               above the true terrain: the median (bias) and quantiles of its magnitude.
//
// Both include the registration error of the session (the dense cloud is in the fused frame).

#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/eval/ground_misalignment.h"

namespace crop4d::eval {

struct DenseEvalOptions {
  // A plant's top is the highest point within this horizontal distance of its true stem, m.
  double top_radius_m = 0.08;
  // A top within this of the truth is "within"; below -tolerance_m it is "low", above "high", m.
  double tolerance_m = 0.02;
  // The soil points.
  GroundSelectionOptions ground;

  OptionCheck Check() const;
};

// Error statistics of the plant tops (cloud top - true height), m; NaN without values.
struct PlantTopStats {
  int num_plants = 0;   // emerged plants (true height > 0) on the terrain grid
  int num_found = 0;    // with at least one point within top_radius_m
  int num_missing = 0;  // without
  double median_m = std::numeric_limits<double>::quiet_NaN();
  double p10_m = std::numeric_limits<double>::quiet_NaN();
  double p90_m = std::numeric_limits<double>::quiet_NaN();
  double rmse_m = std::numeric_limits<double>::quiet_NaN();
  // Shares of the found plants: |error| <= tolerance, error < -tolerance, error > +tolerance.
  double within_share = std::numeric_limits<double>::quiet_NaN();
  double low_share = std::numeric_limits<double>::quiet_NaN();
  double high_share = std::numeric_limits<double>::quiet_NaN();
};

struct SoilStats {
  std::int64_t num_points = 0;                                     // selected as soil
  double median_m = std::numeric_limits<double>::quiet_NaN();      // of z - terrain (signed)
  double abs_median_m = std::numeric_limits<double>::quiet_NaN();  // of |z - terrain|
  double abs_p90_m = std::numeric_limits<double>::quiet_NaN();
};

struct DenseSessionEval {
  std::string session;
  std::string file;         // relative to the workspace
  std::string error;        // why the session could not be evaluated; the rest is empty then
  std::int64_t points = 0;  // in the cloud
  PlantTopStats tops;
  SoilStats soil;
  // Per plant: error (m) of the found ones, in plants.csv order (for pooling).
  std::vector<double> top_errors_m;

  bool ok() const { return error.empty(); }
};

struct DenseEval {
  DenseEvalOptions options;
  std::string error;  // why nothing was evaluated (e.g. no terrain.csv)
  std::vector<DenseSessionEval> sessions;
  PlantTopStats tops;  // pooled over the evaluated sessions
};

// WS/dense/<session>.ply of every session (relative paths), sessions in `session_order` first
// (then by name), only those in `sessions` when it is not empty.
std::vector<std::string> FindDenseClouds(const std::string& workspace,
                                         const std::vector<std::string>& session_order,
                                         const std::vector<std::string>& sessions);

// The plant-top and soil statistics of one cloud (tests and EvaluateDenseClouds).
DenseSessionEval EvaluateDenseCloud(const std::vector<Eigen::Vector3d>& points,
                                    const std::vector<PlantFootprint>& plants,
                                    const TerrainGrid& terrain, const DenseEvalOptions& options);

// Reads each cloud of `files` (from FindDenseClouds) and its session's truth. A session whose
// cloud or plants.csv is missing or malformed is listed with its error; a missing or malformed
// terrain.csv is the section's error.
DenseEval EvaluateDenseClouds(const std::string& workspace, const std::string& field,
                              const std::vector<std::string>& files,
                              const DenseEvalOptions& options = {});

// A table for people: one line per session (points, plants found/missing, top error median,
// p10, p90, RMSE, shares within/low/high, soil points and height error), then all sessions.
std::string FormatDenseTable(const DenseEval& eval);

}  // namespace crop4d::eval
