#pragma once

// Evaluation of the 4D fusion (DESIGN.md §2 step 4) and of the cross-session registration of
// per-session clouds, against a synthetic field's ground truth. Layout read:
//
//   WS/fused/<session>/poses.tum                  world_from_camera of every image (TUM)
//   WS/fused/<session>/sparse.ply                 the session's landmarks after fusion
//   WS/sessions/<session>/rows/<pass>/landmarks.ply   row-SLAM landmarks (before fusion)
//   FIELD/ground_truth/<session>/cam0_poses.tum   true world_from_camera at every image
//   FIELD/ground_truth/<session>/plants.csv       true plants of the session's date
//   FIELD/ground_truth/<session>/weeds.csv        its weeds, when the field has any
//   FIELD/ground_truth/terrain.csv                true terrain heights on a grid
//   WS/fused/<session>/camera.json, FIELD/ground_truth/calibration_truth.yaml
//                                                 the fused calibration and the rig's truth
//                                                 (calibration_eval.h), when the field has it
//
// Fused trajectories: the metrics of trajectory_metrics.h per session, pooled over sessions,
// plus one SE(3) alignment of all sessions together (the fused model is one frame: aligning each
// session on its own would hide a misregistration between them). Clouds: the ground
// misalignment of ground_misalignment.h between every two sessions.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/eval/calibration_eval.h"
#include "crop4d/eval/ground_misalignment.h"
#include "crop4d/eval/trajectory_metrics.h"

namespace crop4d::eval {

struct FusedSessionEval {
  std::string session;
  std::string poses_file;  // relative to the workspace
  std::string truth_file;  // relative to the field
  std::string error;       // non-empty: not evaluated
  int estimate_poses = 0;
  int exact = 0, interpolated = 0, dropped = 0;  // association by time (AssociateByTime)
  // The session's frame is set by convention (its row passes say origin_by_convention: no GPS):
  // its poses are first taken to the truth's frame by AlignYawTranslation, as for its passes.
  bool frame_by_convention = false;
  TrajectoryMetrics metrics;
  // The calibration the fused poses were placed with against the truth, when the field records
  // it (a simulated rig whose written calibration is off) and the session has camera.json.
  std::optional<CalibrationError> calibration;

  bool ok() const { return error.empty(); }
};

struct FusedEval {
  std::vector<FusedSessionEval> sessions;
  int num_evaluated = 0;
  int num_failed = 0;
  int num_poses = 0;
  // Pooled over the evaluated sessions' poses (ErrorStats::Pool); ate_aligned_m pools the
  // per-session aligned errors.
  ErrorStats ate_raw_m;
  ErrorStats ate_aligned_m;
  ErrorStats rotation_deg;
  // One SE(3) alignment (Umeyama) of every evaluated pose of every session at once.
  ErrorStats ate_aligned_joint_m;
  geometry::Rigid3 truth_from_estimate_joint;
};

// Evaluates WS/fused/<session>/poses.tum of every session folder under WS/fused (only those in
// `sessions` when not empty), each against FIELD/ground_truth/<session>/cam0_poses.tum.
// `max_dt` as for the row passes (WorkspaceEvalOptions::max_dt_s). A session without truth or
// with a malformed file is listed with its error.
FusedEval EvaluateFusedTrajectories(const std::string& workspace, const std::string& field,
                                    const std::vector<std::string>& session_order,
                                    const std::vector<std::string>& sessions, Timestamp max_dt,
                                    const TrajectoryMetricsOptions& options = {});

// The clouds of one kind ("fused", "row_slam"), one per session, and their misalignment.
struct CloudSetEval {
  std::string label;
  struct Session {
    std::string session;
    std::vector<std::string> files;  // relative to the workspace
    std::int64_t points = 0;         // in the files
    std::int64_t ground_points = 0;  // selected as ground
    std::string error;               // why the session takes no part (e.g. no plants.csv)
  };
  std::vector<Session> sessions;
  std::string error;  // why nothing was computed (e.g. no terrain.csv); then misalignment is empty
  GroundMisalignment misalignment;
};

struct CloudSetOptions {
  GroundSelectionOptions selection;
  GroundMisalignmentOptions misalignment;
};

// One session's cloud files for a cloud set.
struct SessionCloudFiles {
  std::string session;
  std::vector<std::string> files;  // relative to the workspace
};

// The cloud files of the workspace: "fused" = WS/fused/<s>/sparse.ply, "row_slam" = every
// WS/sessions/<s>/rows/*/landmarks.ply; sessions in `session_order` first (then by name),
// filtered by `sessions` when not empty; sessions without any file are left out.
std::vector<SessionCloudFiles> FindCloudFiles(const std::string& workspace,
                                              const std::string& label,
                                              const std::vector<std::string>& session_order,
                                              const std::vector<std::string>& sessions);

// Reads the clouds, selects their ground points with the truth of `field` and computes the
// misalignment between every two sessions (in the given order).
CloudSetEval EvaluateCloudSet(const std::string& workspace, const std::string& field,
                              const std::string& label,
                              const std::vector<SessionCloudFiles>& clouds,
                              const CloudSetOptions& options = {});

}  // namespace crop4d::eval
