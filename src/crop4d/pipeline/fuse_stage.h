#pragma once

// The 4D fusion stage (`crop4d fuse`, DESIGN.md §2.4): the row passes of every session in joint
// problems (fusion/joint_optimiser.h), with the cross matches of `crop4d associate` as shared
// landmarks — session by session in date order by default (fuse_incremental.h), with refinement
// sweeps over the whole season (FuseStageOptions::full), or every pass of the season in one
// problem (FuseStageOptions::one_problem).
//
// Landmarks: the observations (pass, image, feature) of each pass's optimised landmarks
// (tracks.bin) are joined with the cross matches — each match joins the landmark (cloud track)
// of pass a it came from with the feature of pass b and that feature's own track — by
// union-find, replayed best first (smallest descriptor distance): a match that would put two
// features of one image into a landmark is refused (counted as inconsistent).
//
// Outputs in WS/fused/:
//   <session>/poses.tum   world_from_camera of every image of the session (all passes), TUM;
//   <session>/sparse.ply  the session's cloud: every track of its passes' row-SLAM clouds
//                         re-triangulated from the fused poses (colour, track length, error);
//   landmarks.ply         the joint problem's landmarks, with the number of passes and
//                         sessions that see each;
//   quality.json          the grade of every session (season_quality.h): a degraded session
//                         is registered onto the trusted ones, held fixed after a first solve
//                         of the trusted passes alone, so that it cannot move them;
//   colmap/               the whole 4D reconstruction as a COLMAP text model (one camera per
//                         session, images named <session>/<pass>/<image file>, the joint
//                         landmarks as 3D points);
//   steps/<name>/         the steps of the fuse session by session and of its sweeps
//                         (fuse_incremental.h);
//   summary.json          counts, costs, times, per-pass corrections, the ground ties per pair
//                         of passes, the steps, and a fingerprint of the
//                         inputs: an unchanged workspace is not fused again (unless `force`).

#include <string>
#include <vector>

#include "crop4d/fusion/block_solve.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::pipeline {

struct FuseStageOptions {
  // The associations to use: WS/associations/<method>/ ("robust" or "naive").
  std::string method = "robust";
  // By default the sessions are fused one by one in date order (pipeline/fuse_incremental.h):
  // adding a session solves its passes with those of the `window_sessions` sessions before it,
  // the session before those held, so that its cost and memory do not grow with the season.
  // `full` (`crop4d fuse --full`) re-optimises the whole season after those steps, a window at a
  // time: `full_sweeps` rounds of a backward and a forward sweep over the windows, each with the
  // sessions on both sides held (fuse_incremental.h, PlanFullFuseSteps); its memory is that of a
  // window. `one_problem` (`--one-problem`) solves every pass of the season in one joint problem
  // instead, rebuilt whenever a session is added: its loading and landmark graph grow with the
  // season (for small seasons and comparisons).
  bool full = false;
  int full_sweeps = 1;
  bool one_problem = false;
  int window_sessions = 1;
  // At most this many cross matches of one image pair join the problem (0: all): the best by
  // descriptor distance, spread over a 4×4 grid of image a. A few dozen per image pair register
  // the passes as well as hundreds, and keep the joint problem small.
  int max_matches_per_image_pair = 30;
  fusion::JointOptimiser::Options optimiser = [] {
    fusion::JointOptimiser::Options o;
    o.row.max_iterations = 30;  // started at row SLAM's solution: few iterations needed
    // The exact Schur complement (sparse Cholesky on OpenBLAS): with each camera's intrinsics,
    // T_BS and every pass's time offset in the problem, conjugate gradients with the
    // Schur-Jacobi preconditioner need 50 iterations per step and 30 steps without converging;
    // the exact solver converges in about 10 steps, 2.6x faster on the imperfect demo and 1.7x
    // on the ideal one, at the same figures (bench/RESULTS.md "Fuse: the exact solver").
    o.row.iterative_schur = false;
    // The iterations after the cost stops falling by 1e-4 per iteration lower the fused ATE RMSE
    // by at most 0.24 mm on the demo field (bench/RESULTS.md).
    o.row.function_tolerance = 1e-4;
    o.row.gps_gate_chi2 = 21.1;  // as row SLAM's (slam_stage.h)
    return o;
  }();
  // A joint problem (a step, or the season with `full`) whose free passes hold more
  // observations than blocks.max_observations is solved in blocks of neighbouring passes
  // (fusion/block_solve.h), so that its memory stays bounded on wide or long fields.
  fusion::BlockSolveOptions blocks;
  // Ground ties (fusion/ground_ties.h) between the two passes of a row on two dates whose
  // association kept fewer than `ground_tie_max_matches` cross matches (after rain, appearance
  // matches nothing near the camera), unless both have a precise GPS: their soil surfaces
  // register them across the row and vertically. Off with `ground_ties = false`.
  bool ground_ties = true;
  int ground_tie_max_matches = 50;
  fusion::GroundTieOptions ground_tie;
  // Re-triangulation of the per-session clouds from the fused poses (and of the row-SLAM
  // clouds the ground ties are measured on).
  slam::TriangulationOptions cloud;
  bool write_colmap = true;
  // The grades of the sessions (season_quality.h).
  QualityOptions quality;
  bool force = false;

  // Empty when the options are valid, else the option that is wrong and why ("state_rate_hz:
  // must be > 0"; the names of the configuration file's section, docs/run.md).
  std::string Check() const;
};

struct FusePassReport {
  std::string session;
  std::string pass;
  int images = 0;
  // Camera positions after fusion minus row SLAM's: mean (m, east/north/up) and RMS of the
  // change in rotation (degrees).
  Eigen::Vector3d mean_shift = Eigen::Vector3d::Zero();
  double rotation_change_deg = 0;
};

// The ground ties of one pair of passes.
struct FuseTiePairReport {
  std::string a, b;  // session/pass
  std::int64_t cross_matches = 0;
  fusion::GroundTieSummary ties;
};

// One step of the incremental fuse: the session it added, the sessions it optimised and held.
struct FuseStepReport {
  std::string session;
  // The step's folder in WS/fused/steps/ (the session it adds, or its sweep and last session).
  std::string name;
  // 0: the step adds a session; r >= 1: a step of the r-th round of sweeps of `full`.
  int sweep = 0;
  std::vector<std::string> optimised;
  std::vector<std::string> held;
  bool skipped = false;  // up to date
  int passes = 0;
  int landmarks = 0;
  std::int64_t observations = 0;
  // How far the step moved its free passes from where it started them: the largest RMS change of
  // a pass's body positions (m). Over a sweep of the full fuse it shows how far the season was
  // from settled.
  double moved_m = 0;
  double seconds = 0;
};

struct FuseReport {
  bool skipped = false;  // up to date
  // The steps of the fuse session by session and of its sweeps (none with one_problem).
  std::vector<FuseStepReport> steps;
  int num_sessions = 0;
  int num_passes = 0;
  int num_association_files = 0;
  std::int64_t num_cross_matches = 0;
  // Cross matches left out by FuseStageOptions::max_matches_per_image_pair.
  std::int64_t num_thinned_matches = 0;
  // Cross matches dropped because they made a landmark inconsistent, or referred to images or
  // features that do not exist (a stale association file).
  std::int64_t num_conflicting_matches = 0;
  std::int64_t num_invalid_matches = 0;
  fusion::JointOptimiser::Summary joint;
  std::vector<FuseTiePairReport> tie_pairs;
  std::vector<FusePassReport> passes;
  // The rig's cameras: their calibration as written and after the joint solve (refined with
  // fuse.refine_calibration).
  std::vector<fusion::RefinedCalibration> calibrations;
  // The sessions' grades (written to quality.json; read back when the stage is up to date).
  SeasonQuality quality;
  double seconds = 0;
};

// Runs the stage on the passes of WS/sessions that have a camera. Throws InputError for a field or
// workspace that cannot be read (no row SLAM results, damaged files).
FuseReport RunFuseStage(const std::string& field_folder, const std::string& workspace,
                        const FuseStageOptions& options);

// A table of the report for the terminal.
std::string FormatFuseReport(const FuseReport& report);

}  // namespace crop4d::pipeline
