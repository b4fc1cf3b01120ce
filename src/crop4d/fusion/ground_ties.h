#pragma once

// Ground ties: the two passes of one row on two dates registered through the ground itself,
// where appearance gives no cross matches (after rain the soil texture is new and the plants
// have grown, so association finds nothing near the camera; bench/RESULTS.md, issue 5).
//
// What survives the rain is the shape of the ground and where the vehicle drives: a pass of a
// row follows that row, so the two passes' camera tracks lie over the same line across the
// row, and the soil under them is the same surface (beds, furrows, tyre tracks, relief). In
// the frame of pass a's track (s along it, l across it):
//   - across the row, pass b belongs where its track coincides with a's: the offset between
//     the two tracks at s;
//   - vertically, b's soil points belong on a's soil surface: per segment of the track, the
//     median of z_b − z_a over b's soil points, z_a the median height of a's soil points in
//     the cell at the same (s, l relative to the pass's own track);
//   - along the row the ground is nearly invariant, so nothing is measured: the GPS and the
//     passes' other ties decide it.
// Each segment with enough soil on both passes gives one tie: the same physical point as each
// pass places it (a point on a's track at the segment's ground height, and that point moved by
// the measured offset for b). GroundTieFactor (fusion/ground_tie_factor.h) then asks the two
// placements to agree across the row and vertically.
//
// Soil is told from plants by colour (core/color.h ExcessGreen), as the camera-height step
// does; points well below the cameras only.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::fusion {

struct GroundTieOptions {
  // Soil: excess green (2g − r − b)/(r + g + b) at most this.
  double max_excess_green = 0.05;
  // Soil points at most this far across the track from the pass's own track, m.
  double band_half_width_m = 1.2;
  // ... and at least this far below the cameras there, m (leaves out the tree line and
  // anything at camera height).
  double min_depth_below_camera_m = 0.5;
  // One tie per segment of this length along the track, m.
  double segment_m = 1.0;
  // Cells of pass a's soil surface, along and across the track, m.
  double cell_along_m = 0.10;
  double cell_across_m = 0.04;
  // A segment needs this many of b's soil points that fall on a cell of a's surface.
  int min_points = 30;
  // The two tracks must be parallel within this angle, degrees (the same row).
  double max_heading_difference_deg = 10.0;

  OptionCheck Check() const;
};

// One pass as the ties see it: its cameras (world_from_camera of every state, in state order)
// and its sparse points with their colours, in the same world frame.
struct GroundTiePass {
  std::vector<geometry::Rigid3> cameras;
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<std::uint8_t, 3>> colors;
};

// The same ground point as pass a and pass b place it, in the world frame of their inputs, and
// the states each is attached to (the camera nearest to it). `across` is the horizontal unit
// vector across pass a's track, to the left of its direction of travel.
struct GroundTie {
  int state_a = -1;
  int state_b = -1;
  Eigen::Vector3d point_a = Eigen::Vector3d::Zero();
  Eigen::Vector3d point_b = Eigen::Vector3d::Zero();
  Eigen::Vector3d across = Eigen::Vector3d::UnitX();
};

struct GroundTieSummary {
  int soil_points_a = 0;
  int soil_points_b = 0;
  int segments = 0;  // segments in the overlap of the two tracks
  int ties = 0;
  // Medians over the ties of b's offset from a (point_b − point_a) across the track (positive
  // to the left of pass a's travel) and vertically, m.
  double median_across_m = 0;
  double median_vertical_m = 0;
  // Median over the ties of the median absolute deviation of z_b − z_a in the segment, m.
  double median_spread_m = 0;
};

// The ties between two passes of the same row. Empty when the tracks are not parallel, do not
// overlap, or no segment holds enough soil. Throws std::invalid_argument for invalid options
// or points without a colour each.
std::vector<GroundTie> ComputeGroundTies(const GroundTiePass& a, const GroundTiePass& b,
                                         const GroundTieOptions& options,
                                         GroundTieSummary* summary = nullptr);

}  // namespace crop4d::fusion
