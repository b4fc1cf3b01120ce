#pragma once

// The joint 4D problem (DESIGN.md §2.4): one Ceres problem over every row pass of every session.
// Each pass brings its own graph (slam/pass_graph.h: IMU, bias walk, angular rate, GP prior, GPS,
// non-holonomic constraint, priors), and the landmarks are shared: a landmark observed from
// several passes (merged through the cross matches of association) ties their poses together,
// so the sessions land in one frame. Reprojection factors have the Huber loss and landmarks are
// eliminated by the Schur complement, so the reduced system couples only the poses of passes
// that share landmarks: its cost grows with the number of associated pairs, not with the square
// of the number of passes.
//
// Ground ties (fusion/ground_ties.h) join pairs of passes that share no landmarks through the
// ground they both see: pose-to-pose factors across the row and vertically.
//
// Solving, initialised from row SLAM: (0) passes with an imprecise GPS aligned rigidly onto their
// neighbours through the shared landmarks and the ground ties (Options::align_passes), (1) every
// landmark triangulated from the row-SLAM poses (its worst views dropped while the reprojection
// bound fails), (2) Levenberg–Marquardt on the whole problem, (3) observations whose reprojection
// error exceeds the bound removed — a cross match that stays inconsistent with the rest goes
// here — the IMU re-preintegrated at the estimated biases and a final solve.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/fusion/camera_refinement.h"
#include "crop4d/fusion/clock_line.h"
#include "crop4d/fusion/ground_ties.h"
#include "crop4d/fusion/pass_alignment.h"
#include "crop4d/slam/row_optimiser.h"

namespace crop4d::fusion {

// One observation of a landmark: a pass, the state (image) in that pass, the distorted pixel.
struct JointObservation {
  int pass = -1;
  int state = -1;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// A ground tie (fusion/ground_ties.h) between two passes, in the world frame of their initial
// states.
struct JointGroundTie {
  int pass_a = -1;
  int pass_b = -1;
  GroundTie tie;
};

struct JointLandmark {
  std::vector<JointObservation> observations;
  std::array<std::uint8_t, 3> color{128, 128, 128};
};

// The median horizontal standard deviation of a pass's GPS fixes, m (infinity without GPS).
double MedianGpsSigma(const slam::RowOptimiser::Input& pass);

// A landmark triangulated from world_from_camera of every state of every pass (`cameras`), its
// worst views dropped while the reprojection bound fails (`kept`: which observations remain).
// Pixels of a pass whose camera differs from the landmark's first pass are mapped into that
// camera's pixels along the same ray, so one camera model triangulates them all.
slam::TriangulationResult TriangulateJointLandmark(
    const slam::RowOptimiser::Options& options,
    const std::vector<slam::RowOptimiser::Input>& passes,
    const std::vector<std::vector<geometry::Rigid3>>& cameras, const JointLandmark& landmark,
    std::vector<bool>* kept);

class JointOptimiser {
 public:
  struct Options {
    // Factor weights, losses, triangulation, rejection bound, iterations and threads, as in
    // row SLAM.
    slam::RowOptimiser::Options row;
    // Before triangulating, passes whose GPS is not precise are moved rigidly (yaw and
    // translation, pass_alignment.h) onto the passes they share landmarks with, so that a
    // metre-level GPS error does not make every shared landmark fail to triangulate. Passes
    // with a precise receiver (median horizontal sigma ≤ precise_gps_sigma_m) define the frame
    // and are not moved; without any, the first pass of each connected group does.
    bool align_passes = true;
    double precise_gps_sigma_m = 0.1;
    PassAlignmentOptions alignment;
    // Ground ties: standard deviation of one tie across the row (how closely the vehicle
    // follows the row from one date to the next) and vertically (a segment's median height
    // difference), m; Huber loss beyond this many standard deviations.
    double ground_tie_sigma_across_m = 0.05;
    double ground_tie_sigma_vertical_m = 0.01;
    double ground_tie_loss_scale = 3.0;
    // The camera–IMU time offset td of each pass (slam/time_offset_reprojection_factor.h: capture
    // instant = image stamp + td), one parameter per pass: the clock drifts, so the offset of a
    // session's passes differs by a few milliseconds. Unset: refined jointly for the passes
    // whose row SLAM estimated it (Pass::time_offset_s, the starting value), none for the
    // others. True: refined for every pass with a camera (from 0 where row SLAM gave none).
    // False: row SLAM's values held. `row.estimate_time_offset` is not used here; its prior
    // sigma and bounds are.
    std::optional<bool> estimate_time_offset;
    // The passes of one clock (Pass::clock: a session's) have their time offsets tied to one
    // line over time (clock_line.h), each by this standard deviation, s: what a quartz clock
    // strays from a steady drift between two passes of a session (a frequency that wanders by
    // 1 ppm strays 0.3 ms in ten minutes). Three passes of a clock at least, one of them with
    // its td refined; 0: no line. bench/RESULTS.md, "One camera clock per session".
    double clock_line_sigma_s = 0.0005;
    // The cameras' calibration (intrinsics and T_BS rotation) refined with the poses
    // (camera_refinement.h); by default where the passes' time offsets are in the problem and
    // enough cross observations see it. A camera with a fixed pass (Solve) is held.
    CalibrationRefinementOptions calibration;

    // Empty when the options are valid, otherwise the first invalid option and why, as
    // "name: must be ... (got x)" ("row.name: ..." for the row-SLAM options;
    // core/option_check.h).
    OptionCheck Check() const;
    std::string Error() const { return Check(); }
  };

  // One pass: its row-SLAM problem (initial_states from row SLAM; `tracks` is ignored, the
  // landmarks are given jointly; time_offset_s: row SLAM's estimated time offset, if any). A
  // pass without a camera takes part through its motion only.
  using Pass = slam::RowOptimiser::Input;

  struct Summary {
    int num_passes = 0;
    int num_states = 0;
    int num_landmarks_given = 0;
    // Passes moved by the alignment, and the largest move of a camera, m.
    int num_passes_aligned = 0;
    double max_alignment_shift_m = 0;
    // Landmarks triangulated and kept for the final solve; those seen from two or more passes.
    int num_landmarks = 0;
    int num_shared_landmarks = 0;
    std::int64_t num_observations = 0;
    // Observations of shared landmarks from a pass other than the landmark's first one (the
    // cross matches' contribution), kept in the final solve and rejected on the way.
    std::int64_t num_cross_observations = 0;
    std::int64_t num_rejected_observations = 0;
    std::int64_t num_rejected_cross_observations = 0;
    double initial_cost = 0;
    double final_cost = 0;
    int iterations = 0;
    double reprojection_rms_px = 0;
    double cross_reprojection_rms_px = 0;
    // Ground ties in the problem, and their RMS disagreement after the final solve across the
    // row and vertically, m.
    int num_ground_ties = 0;
    double ground_tie_rms_across_m = 0;
    double ground_tie_rms_vertical_m = 0;
    double triangulation_seconds = 0;
    double solve_seconds = 0;
    double final_solve_seconds = 0;
    bool converged = false;
    // Passes whose time offset the joint problem refined, and those whose given offset it held.
    int num_time_offsets_estimated = 0;
    int num_time_offsets_held = 0;
    // GPS fixes dropped by the outlier gate after the first solve (row.gps_gate_chi2; 0: off).
    int num_gps_rejected = 0;
    // Cameras whose calibration the joint problem refined (Options::calibration).
    int num_cameras_refined = 0;
    // Solved in blocks of passes (block_solve.h): the blocks and the sweeps over them; 1 and 1
    // for one problem.
    int num_blocks = 1;
    int num_sweeps = 1;
  };

  struct Result {
    // The states of every pass, in the order of the input.
    std::vector<std::vector<slam::RowState>> states;
    // Landmarks of the final solve: position, the index of the given landmark, and which of its
    // observations the final solve kept.
    std::vector<Eigen::Vector3d> landmarks_world;
    std::vector<int> landmark_ids;
    std::vector<std::vector<bool>> observations_kept;
    // world_from_camera of every state of every pass at its capture instant (with the pass's
    // time offset; world_from_body for a pass without camera).
    std::vector<std::vector<geometry::Rigid3>> cameras;
    // Each pass's camera–IMU time offset after the solve, s (refined or held; unset when the
    // reprojection factors of the pass did not use one).
    std::vector<std::optional<double>> time_offsets_s;
    // The camera clocks whose passes' offsets were tied to a line (Options::clock_line_sigma_s),
    // as solved.
    std::vector<ClockLine> clock_lines;
    // Every camera of the rig (camera_refinement.h: passes with identical intrinsics and T_BS
    // share one), its calibration as written and after the solve (the same when not refined).
    // `cameras` above are placed with the refined T_BS.
    std::vector<RefinedCalibration> calibrations;
    Summary summary;
  };

  explicit JointOptimiser(Options options);

  // Throws std::invalid_argument for inconsistent input (a pass with fewer than 2 states or
  // unsorted times, an observation of a pass without camera or out of range, a tie out of
  // range).
  // Passes with `fixed_passes[p]` (empty: none) keep their initial states: they are neither
  // aligned nor optimised, and the others are registered onto them (a degraded session onto the
  // trusted ones, pipeline/season_quality.h). A rig camera with a fixed pass is held, unless
  // the pass is also in `own_camera_passes` (empty: none): those passes get rig cameras of
  // their own (GroupPassesByCamera's `apart`), so that the camera of the free passes is still
  // refined while the fixed ones keep their calibration (an incremental fuse's held session).
  // Fixed passes with `camera_follows[p]` (empty: none) do not hold the camera they share: it is
  // refined with them, their poses held (a block's neighbours in block_solve.h, which are free
  // passes of the same problem).
  Result Solve(const std::vector<Pass>& passes, const std::vector<JointLandmark>& landmarks,
               const std::vector<JointGroundTie>& ground_ties = {},
               const std::vector<bool>& fixed_passes = {},
               const std::vector<bool>& own_camera_passes = {},
               const std::vector<bool>& camera_follows = {}) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace crop4d::fusion
