#pragma once

// Evaluates the row-pass trajectories of a workspace against a synthetic field's ground truth
// and writes WS/eval/metrics.json (DESIGN.md §5, §8). Layout read:
//
//   WS/sessions/<session>/rows/<pass>/poses.tum     estimate (TUM), world_from_camera at the
//                                                   image timestamps, or world_from_body
//   WS/sessions/<session>/rows/<pass>/summary.json  {"session", "pass", "row", "direction",
//                                                    "sensors", "pose_frame": camera|body, ...}
//   FIELD/ground_truth/<session>/cam0_poses.tum     world_from_camera at every image timestamp
//   FIELD/ground_truth/<session>/body_poses.tum     world_from_body at the IMU timestamps
//
// The truth file is chosen by the pass's pose_frame. Metrics: trajectory_metrics.h.
//
// The later stages are evaluated when their outputs are there (each section is optional):
//
//   WS/associations/**/*.bin                        cross matches (association_file.h), e.g.
//                                                   robust/<name>.bin and naive/<name>.bin
//   WS/sessions/<session>/passes.csv                row and direction of each pass
//   FIELD/ground_truth/simulate.yaml                the simulation (true geometry, rain)
//       → association precision per pair type and method (association_eval.h)
//   WS/fused/<session>/poses.tum, sparse.ply        the 4D fusion's output
//   WS/sessions/<session>/rows/*/landmarks.ply      the row-SLAM clouds
//   FIELD/ground_truth/<session>/plants.csv, FIELD/ground_truth/terrain.csv
//       → fused trajectory accuracy and cross-session ground misalignment (fused_eval.h)
//   WS/analysis/site_heights.csv, site_heights_single_plane.csv   canopy heights (analyze)
//   FIELD/ground_truth/site_truth.csv
//       → canopy height errors per method and session (canopy_eval.h)
//   WS/dense/<session>.ply                          dense clouds (densify)
//   FIELD/ground_truth/<session>/plants.csv, FIELD/ground_truth/terrain.csv
//       → plant tops and soil of each cloud against the truth (dense_eval.h)

#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/eval/association_ceiling.h"
#include "crop4d/eval/association_eval.h"
#include "crop4d/eval/canopy_eval.h"
#include "crop4d/eval/dense_eval.h"
#include "crop4d/eval/fused_eval.h"
#include "crop4d/eval/trajectory_metrics.h"

namespace crop4d::eval {

struct WorkspaceEvalOptions {
  TrajectoryMetricsOptions metrics;
  // Association tolerance, s: an estimate pose without a truth pose at the same timestamp is
  // compared with the truth interpolated between its neighbours when both are within this.
  // The truth is at every image (camera) or IMU (body) timestamp, so 50 ms is generous.
  double max_dt_s = 0.05;
  // Evaluate only these sessions (empty: all). An association file is evaluated when both of
  // its sessions are selected.
  std::vector<std::string> sessions;

  // Association precision, when the workspace has association files.
  bool associations = true;
  AssociationEvalOptions association;
  // Where depth maps rendered for it are kept (<dir>/<session>/<t>.png); empty:
  // WS/eval/depth.
  std::string depth_cache_dir;
  // Render the true depth maps that are neither in the field (simulated with --depth) nor in
  // the cache; off: their matches count as unknown.
  bool render_depth = true;
  // Fused trajectories and the ground misalignment of the fused and row-SLAM clouds.
  bool fused = true;
  CloudSetOptions clouds;
  // Canopy heights per site and session, when the workspace has WS/analysis/site_heights.csv
  // and the field ground_truth/site_truth.csv (`sessions` above applies; the one here is
  // ignored).
  bool canopy = true;
  CanopyEvalOptions canopy_options;
  // Plant tops and soil of the dense clouds (WS/dense/<session>.ply), when there are any.
  bool dense = true;
  DenseEvalOptions dense_options;

  OptionCheck Check() const;
};

// One row pass.
struct PassEval {
  std::string session;
  std::string pass;  // the folder name under rows/ (= summary.json "pass")
  int row = -1;
  int direction = 0;
  std::string sensors;     // e.g. "cam+imu+rtk"
  std::string pose_frame;  // "camera" or "body"
  std::string poses_file;  // relative to the workspace
  std::string truth_file;  // relative to the field
  // Why the pass could not be evaluated (no truth, malformed file, no pose in the truth's
  // span); empty when `metrics` holds the result.
  std::string error;
  // The pass's frame is set by convention (no GPS: summary.json trust flag
  // origin_by_convention): its poses are first taken to the truth's frame by the rotation about
  // the vertical and the translation that fit them best (AlignYawTranslation), so "raw" ATE and
  // rotation measure what the pass estimated (tilt, shape, drift) rather than the convention.
  bool frame_by_convention = false;
  int estimate_poses = 0;                                                     // poses in poses.tum
  int exact = 0, interpolated = 0, dropped_out_of_span = 0, dropped_gap = 0;  // association
  TrajectoryMetrics metrics;
  // Row SLAM's camera–IMU time offset (summary.json back_end.time_offset_s: capture instant −
  // image stamp, s) when it was estimated, and the truth over the pass's images when the field
  // records the capture instants (ground_truth/<session>/cam0_exposure.csv).
  std::optional<double> time_offset_s, true_time_offset_s;
  // The offset the joint 4D problem used for the pass (WS/fused/summary.json passes[].
  // time_offset_s), when it used one.
  std::optional<double> fused_time_offset_s;

  bool ok() const { return error.empty(); }
};

// All evaluated passes' poses pooled (ErrorStats::Pool). ate_aligned_m pools the per-pass
// aligned errors (each pass aligned on its own).
struct OverallEval {
  int num_passes = 0;     // passes found
  int num_evaluated = 0;  // passes with metrics
  int num_failed = 0;     // passes with an error
  int num_poses = 0;
  ErrorStats ate_raw_m;
  ErrorStats ate_aligned_m;
  ErrorStats rotation_deg;
  ErrorStats rpe_translation_percent;
  ErrorStats rpe_rotation_deg_per_m;
  // The evaluated pass with the largest raw ATE RMSE; -1 when none was evaluated.
  int worst_pass = -1;
};

// The association section: present when the workspace has association files.
struct WorkspaceAssociationEval {
  // Why nothing could be evaluated (e.g. no simulate.yaml in the field); `eval` is then empty
  // except for the files found.
  std::string error;
  int num_files = 0;  // association files found (selected sessions)
  AssociationEval eval;
  // How many correct matches the matched image pairs hold at all (association_ceiling.h);
  // empty groups when `error` is set.
  AssociationCeiling ceiling;
};

struct WorkspaceEval {
  std::string workspace, field;
  WorkspaceEvalOptions options;
  std::vector<PassEval> passes;  // sorted by session, then pass (numbers numerically)
  OverallEval overall;
  std::optional<WorkspaceAssociationEval> association;
  std::optional<FusedEval> fused;  // when WS/fused/<session>/poses.tum exist
  // Ground misalignment per cloud set, "row_slam" then "fused", each when at least two
  // sessions have clouds of that kind.
  std::vector<CloudSetEval> clouds;
  // Canopy heights, when their files exist.
  std::optional<CanopyEval> canopy;
  // Why the canopy section was skipped (one line; empty when it was evaluated or disabled).
  std::string canopy_skipped;
  // The dense clouds, when the workspace has any.
  std::optional<DenseEval> dense;
};

// Reads every pass of `workspace` and evaluates it against `field`'s ground truth, then the
// association files, the fused trajectories, the clouds, the dense clouds and the canopy heights
// when they exist. A pass, a file or a session whose files are missing or malformed, or without
// truth, is listed with its error.
// Throws InputError when the workspace has nothing to evaluate (no sessions/*/rows/* folder, no
// association file, no fused session, no WS/analysis/site_heights.csv and no dense cloud) or
// the field has no ground_truth/ folder. When the true geometry is unavailable (no simulate.yaml,
// no EGL/OpenGL to render depth maps with) the association section holds the error and the other
// sections are still evaluated.
WorkspaceEval EvaluateWorkspace(const std::string& workspace, const std::string& field,
                                const WorkspaceEvalOptions& options = {});

// The metrics.json text (schema in docs/cli.md, `crop4d eval`). Distances in metres, angles in
// degrees.
std::string WorkspaceEvalJson(const WorkspaceEval& eval);

// Writes WorkspaceEvalJson atomically to `path` (default WS/eval/metrics.json when empty).
// Returns the path written.
std::string WriteWorkspaceEval(const WorkspaceEval& eval, const std::string& path = "");

// A table for people: one line per pass (session, pass, sensors, N, ATE raw cm, ATE aligned cm,
// RPE %, rotation deg), failed passes with their error, then the pooled line; then the tables
// of the sections that are present (FormatAssociationTable, FormatFusedTable,
// FormatCanopyTable; a skipped canopy section as one line).
std::string FormatWorkspaceEvalTable(const WorkspaceEval& eval);

// The row passes only (the first table of FormatWorkspaceEvalTable).
std::string FormatPassTable(const WorkspaceEval& eval);

// Association precision: one line per pair type and method (files, matches, correct, incorrect,
// unknown, precision %), a line per method over all types, and where the depth maps came from.
std::string FormatAssociationTable(const WorkspaceAssociationEval& association);

// Fused trajectories (one line per session and the pooled line, as for the passes) and the
// ground misalignment of each cloud set (pooled, and each pair of consecutive sessions: median,
// 90th percentile and signed median in cm, distances).
std::string FormatFusedTable(const WorkspaceEval& eval);

}  // namespace crop4d::eval
