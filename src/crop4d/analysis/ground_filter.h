#pragma once

// Ground candidates that stand above the ground: soil-coloured points at the height of the
// canopy (shaded leaves, stems, leaf edges whose colour the dense stereo blended with the soil
// behind them). Under a grown canopy they outnumber the soil the camera sees there, and a local
// surface fit through them bends up into the canopy.
//
// The test is a morphological opening of the candidates' median height per cell (erosion then
// dilation with a square window of `window_m`, as in the progressive morphological filter of Zhang
// et al. 2003, IEEE TGRS 41(4), with one window): an object narrower than the window disappears
// from the opened surface, a plane is kept exactly, and a convex bed crest is lowered by its
// curvature over half the window (a 6 cm bed over a 0.91 m row spacing: about 4 cm at 0.5 m).
// A candidate more than `max_height_m` above the opened surface of its cell is not ground.
// The window must be wider than the canopy of a row and narrower than the soil between rows
// is long, so that it reaches the soil on both sides of the plants.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::analysis {

struct GroundFilterOptions {
  // Side of the square window of the opening, m (0: no filter).
  double window_m = 0.5;
  // Cell of the median-height grid, m.
  double cell_m = 0.05;
  // Candidates higher than this above the opened surface are rejected, m.
  double max_height_m = 0.06;

  OptionCheck Check() const;
};

// How far (horizontally) the points that decide a point's test can lie from it, m: the opened
// surface of a cell depends on the medians of the cells within twice the window's half width.
// A part of a cloud holding every point within this reach of a point tests that point as the
// whole cloud does (the cells are one grid of the plane).
double GroundFilterReach(const GroundFilterOptions& options);

// 1 for the points of `points` that pass the test, 0 for those above the opened surface.
std::vector<std::uint8_t> GroundBelowOpening(const std::vector<Eigen::Vector3d>& points,
                                             const GroundFilterOptions& options);

}  // namespace crop4d::analysis
