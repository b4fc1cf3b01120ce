#pragma once

// The densify stage (`crop4d densify`, DESIGN.md §2.5): a dense point cloud per session from the
// fused cameras, by height-field multi-view stereo (dense/height_field_stereo.h) — the surface
// seen from above: soil and the tops of the plants, one point per grid cell (default 1 cm).
//
// Inputs: the images row SLAM used (the camera's calibration and image list from the session's
// passes' measurements.bin in the workspace, the pixels from the field folder),
// WS/fused/<session>/poses.tum (world_from_camera per image timestamp, from `crop4d fuse`) and
// WS/fused/<session>/sparse.ply (its sparse cloud, mostly soil: it bounds the heights swept,
// dense/ground_levels.h). Of the field it reads field.yaml (rows, sites) and the image files.
//
// Region: the crop rows of field.yaml widened by `margin_m` (without rows: the sparse cloud's xy
// extent), optionally restricted to boxes and/or discs around points (e.g. the field's sites).
//
// Outputs in WS/dense/:
//   <session>.ply   x y z (double, ENU metres), red green blue (from the reference view), and
//                   the scalars score (aggregated ZNCC), num_views, uniqueness;
//   <session>.json  counts, times, options, region, and a fingerprint of the inputs (poses.tum,
//                   sparse.ply, the passes' measurements.bin, field.yaml, options): a session
//                   whose inputs are unchanged is skipped (unless `force`).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "crop4d/dense/ground_levels.h"
#include "crop4d/dense/height_field_stereo.h"

namespace crop4d::pipeline {

struct DensifyStageOptions {
  // Sessions to densify (empty: every session of the field that has fused poses).
  std::vector<std::string> sessions;
  // The camera whose images are matched: the one row SLAM used (checked).
  std::string camera = "cam0";
  // The crop rows of field.yaml are widened by this much on every side, m.
  double margin_m = 0.6;
  // Restrict the region to these boxes (ENU xy) and/or to discs of `radius_m` around `centers`
  // (none: the whole region). `around_sites` adds the field's sites to the centers.
  std::vector<Eigen::AlignedBox2d> boxes;
  std::vector<Eigen::Vector2d> centers;
  bool around_sites = false;
  double radius_m = 0.6;
  dense::HeightFieldStereo::Options stereo;
  dense::GroundLevels::Options ground;
  // Sweep each session only up to the canopy that its sparse cloud shows (dense::
  // SparseCanopyCeiling), at most stereo.max_canopy_height_m; false: always up to it.
  bool adaptive_ceiling = true;
  dense::CanopyCeilingOptions ceiling;
  // Worker threads (0: all cores).
  int num_threads = 0;
  bool force = false;
  bool show_progress = true;

  // Empty when the options are valid, else the option that is wrong and why ("state_rate_hz:
  // must be > 0"; the names of the configuration file's section, docs/run.md).
  std::string Check() const;
};

struct DensifySessionReport {
  std::string session;
  bool skipped = false;  // up to date
  int num_poses = 0;
  int num_views = 0;           // poses with an image in the session
  Eigen::AlignedBox2d region;  // the grid's bounds
  dense::HeightFieldStereo::Summary stereo;
  dense::CanopyCeiling ceiling;  // the plant tops' search range (ceiling_m: the one swept)
  std::string ply_path;
  double seconds = 0;
};

// Runs the stage. Throws InputError for a field or workspace that cannot be read, and for a
// session without fused poses or sparse cloud ("run `crop4d fuse` first").
std::vector<DensifySessionReport> RunDensifyStage(const std::string& field_folder,
                                                  const std::string& workspace,
                                                  const DensifyStageOptions& options);

// A table of the reports for the terminal.
std::string FormatDensifyReport(const std::vector<DensifySessionReport>& reports);

}  // namespace crop4d::pipeline
