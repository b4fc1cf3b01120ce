// crop4d fuse: the joint 4D optimisation of every row pass of every session with the cross
// matches of `crop4d associate` (DESIGN.md §2.4); outputs in WS/fused/ (pipeline/fuse_stage.h,
// docs/cli.md#fuse).

#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/pipeline/fuse_stage.h"

namespace crop4d::cli {
namespace {

struct FuseArgs {
  std::string linear_solver;
  std::string estimate_time_offset = "auto";
  std::string refine_calibration;
  std::string field;
  std::string workspace;
  int threads = 0;
  pipeline::FuseStageOptions options;
};

// auto (unset), true or false.
std::optional<bool> AutoBool(const char* option, const std::string& text) {
  if (text == "auto") return std::nullopt;
  if (text == "true" || text == "false") return text == "true";
  throw InputError(option, 0, "expected auto, true or false, got '" + text + "'");
}

int RunFuse(FuseArgs& args) {
  pipeline::FuseStageOptions& o = args.options;
  o.optimiser.row.num_threads = args.threads;
  if (args.linear_solver != "exact" && args.linear_solver != "iterative") {
    throw InputError("--linear-solver", 0,
                     "expected exact or iterative, got '" + args.linear_solver + "'");
  }
  o.optimiser.row.iterative_schur = args.linear_solver == "iterative";
  o.optimiser.estimate_time_offset = AutoBool("--estimate-time-offset", args.estimate_time_offset);
  o.optimiser.calibration.refine = AutoBool("--refine-calibration", args.refine_calibration);
  if (o.method != "robust" && o.method != "naive") {
    throw InputError("--method", 0, "expected robust or naive, got '" + o.method + "'");
  }
  if (const std::string why = o.Check(); !why.empty()) throw InputError("crop4d fuse", 0, why);
  // Ceres follows num_threads; the stage's parallel loops (triangulation, ties) follow this.
  std::optional<tbb::global_control> limit;
  if (args.threads > 0) limit.emplace(tbb::global_control::max_allowed_parallelism, args.threads);
  const auto lock = LockWorkspace(args.workspace, "crop4d fuse", /*create=*/false);
  const pipeline::FuseReport report = pipeline::RunFuseStage(args.field, args.workspace, o);
  if (!IsQuiet()) {
    std::fputs(pipeline::FormatFuseReport(report).c_str(), stdout);
    std::fflush(stdout);
  }
  return 0;
}

}  // namespace

RunFunction SetupFuse(CLI::App& app) {
  auto args = std::make_shared<FuseArgs>();
  pipeline::FuseStageOptions& o = args->options;
  app.description(
      "Joint 4D optimisation (docs/cli.md#fuse, docs/fusion.md): the season's row passes in "
      "Ceres problems — each pass's IMU, GP prior and GPS factors plus the cross matches of "
      "`crop4d associate` as shared landmarks — initialised from row SLAM, with robust losses "
      "and rejection of inconsistent matches; session by session in date order (a new "
      "session is solved with the one before it, the one before that held), re-optimised a "
      "window at a time with --full, or the whole season in one problem with --one-problem. Writes "
      "WS/fused/<session>/poses.tum "
      "and sparse.ply, WS/fused/landmarks.ply, a COLMAP text model in WS/fused/colmap/ and "
      "WS/fused/summary.json; skipped when its inputs have not changed.\n\nExample:\n  crop4d "
      "fuse demo/field --workspace demo/workspace");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace with row SLAM and associations")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_option("--method", o.method, "Associations to use: robust or naive")
      ->capture_default_str();
  app.add_flag("--full", o.full,
               "Re-optimise the whole season after the steps session by session: --full-sweeps "
               "rounds of a backward and a forward sweep over the windows, each with the "
               "sessions on both sides held (memory of a window, about 3x the time)");
  app.add_option("--full-sweeps", o.full_sweeps,
                 "Rounds of a backward and a forward sweep of --full")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_flag("--one-problem", o.one_problem,
               "One joint problem over every pass of every session (rebuilt whenever a session "
               "is added; its memory grows with the season)");
  app.add_option("--window-sessions", o.window_sessions,
                 "Sessions before the new one that each step of the incremental fuse optimises "
                 "again (the one before them is held)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--max-block-observations", o.blocks.max_observations,
                 "A joint problem whose free passes hold more observations is solved in blocks of "
                 "neighbouring passes of at most this many, so that memory stays bounded on wide "
                 "or long fields (0: always one problem; docs/fusion.md#blocks-of-passes)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--block-sweeps", o.blocks.sweeps,
                 "Sweeps over the blocks (the last holds the calibration the others refined)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--matches-per-image-pair", o.max_matches_per_image_pair,
                 "Cross matches of one image pair used at most (the best, spread over the image; "
                 "0: all)")
      ->capture_default_str();
  app.add_flag(
      "--no-ground-ties", [&o](std::int64_t) { o.ground_ties = false; },
      "No ground ties between the two dates of a row that association left without cross "
      "matches (docs/fusion.md#ground-ties)");
  app.add_option("--ground-tie-max-matches", o.ground_tie_max_matches,
                 "Pairs of passes of two sessions with fewer cross matches than this get ground "
                 "ties")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  app.add_option("--max-imu-gap", o.quality.max_imu_gap_s,
                 "A pass with no IMU sample for longer than this (s) degrades its session: it is "
                 "registered onto the trusted sessions without moving them (docs/fusion.md)")
      ->check(CLI::Range(0.001, 1e6))
      ->capture_default_str();
  app.add_option("--max-gps-rejected-share", o.quality.max_gps_rejected_share,
                 "A pass whose row SLAM rejected more than this share of its GPS fixes as "
                 "outliers degrades its session (docs/fusion.md)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  app.add_option("--max-reprojection-error", o.optimiser.row.max_reprojection_error_px,
                 "Observations above this error (px) are removed before the final solve")
      ->capture_default_str();
  args->linear_solver = o.optimiser.row.iterative_schur ? "iterative" : "exact";
  app.add_option("--linear-solver", args->linear_solver,
                 "exact: sparse Cholesky of the Schur complement; iterative: conjugate gradients "
                 "(faster on many passes)")
      ->capture_default_str();
  app.add_flag(
      "--no-image-weighting",
      [&o](std::int64_t) { o.optimiser.row.image_weighting.enabled = false; },
      "Every image's keypoints weigh the same (default: images less sharp than their "
      "neighbours, from blur or exposure, are down-weighted)");
  app.add_option("--max-iterations", o.optimiser.row.max_iterations,
                 "Levenberg–Marquardt iterations per solve")
      ->capture_default_str();
  app.add_option("--function-tolerance", o.optimiser.row.function_tolerance,
                 "A solve stops when an iteration lowers the cost by less than this fraction")
      ->check(CLI::Range(1e-12, 0.1))
      ->capture_default_str();
  app.add_option("--estimate-time-offset", args->estimate_time_offset,
                 "Refine each pass's camera-IMU time offset: auto (the passes whose row SLAM "
                 "estimated one), true (every pass) or false (row SLAM's held)")
      ->capture_default_str();
  app.add_option("--clock-line-sigma", o.optimiser.clock_line_sigma_s,
                 "The time offsets of a session's passes lie on one line over time (one camera "
                 "clock, a steady drift), each within this standard deviation, s (0: each pass's "
                 "offset on its own; docs/fusion.md#one-camera-clock-per-session)")
      ->check(CLI::Range(0.0, 1.0))
      ->capture_default_str();
  const std::optional<bool>& refine = o.optimiser.calibration.refine;
  args->refine_calibration = !refine ? "auto" : (*refine ? "true" : "false");
  app.add_option("--refine-calibration", args->refine_calibration,
                 "Refine each camera's intrinsics and T_BS rotation with the poses: "
                 "auto (a camera whose images hold enough observations of landmarks shared "
                 "between passes), true or false (as written; docs/fusion.md)")
      ->capture_default_str();
  app.add_flag(
      "--no-colmap", [&o](std::int64_t) { o.write_colmap = false; },
      "Do not write the COLMAP text model");
  app.add_option("--threads", args->threads, "Worker threads (0: all cores)")
      ->capture_default_str();
  app.add_flag("--force", o.force, "Fuse again even when the inputs have not changed");
  return [args] { return RunFuse(*args); };
}

}  // namespace crop4d::cli
