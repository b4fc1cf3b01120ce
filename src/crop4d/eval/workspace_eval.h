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

#include <string>
#include <vector>

#include "crop4d/eval/trajectory_metrics.h"

namespace crop4d::eval {

struct WorkspaceEvalOptions {
  TrajectoryMetricsOptions metrics;
  // Association tolerance, s: an estimate pose without a truth pose at the same timestamp is
  // compared with the truth interpolated between its neighbours when both are within this.
  // The truth is at every image (camera) or IMU (body) timestamp, so 50 ms is generous.
  double max_dt_s = 0.05;
  // Evaluate only these sessions (empty: all).
  std::vector<std::string> sessions;

  bool Check() const;
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
  int estimate_poses = 0;                                                     // poses in poses.tum
  int exact = 0, interpolated = 0, dropped_out_of_span = 0, dropped_gap = 0;  // association
  TrajectoryMetrics metrics;

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

struct WorkspaceEval {
  std::string workspace, field;
  WorkspaceEvalOptions options;
  std::vector<PassEval> passes;  // sorted by session, then pass (numbers numerically)
  OverallEval overall;
};

// Reads every pass of `workspace` and evaluates it against `field`'s ground truth. A pass whose
// files are missing or malformed, or without truth, is listed with its error. Throws InputError
// when the workspace has no sessions/*/rows/* folder or the field has no ground_truth/ folder.
WorkspaceEval EvaluateWorkspace(const std::string& workspace, const std::string& field,
                                const WorkspaceEvalOptions& options = {});

// The metrics.json text (schema in docs/cli.md, `crop4d eval`). Distances in metres, angles in
// degrees.
std::string WorkspaceEvalJson(const WorkspaceEval& eval);

// Writes WorkspaceEvalJson atomically to `path` (default WS/eval/metrics.json when empty).
// Returns the path written.
std::string WriteWorkspaceEval(const WorkspaceEval& eval, const std::string& path = "");

// A table for people: one line per pass (session, pass, sensors, N, ATE raw cm, ATE aligned cm,
// RPE %, rotation deg), failed passes with their error, then the pooled line.
std::string FormatWorkspaceEvalTable(const WorkspaceEval& eval);

}  // namespace crop4d::eval
