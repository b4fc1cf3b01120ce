// crop4d eval --workspace WS --truth FIELD: compares a workspace with a synthetic field's ground
// truth — row-pass trajectories, cross matches, fused trajectories, cross-session ground
// misalignment, dense clouds, canopy heights — prints tables and writes WS/eval/metrics.json.

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/logging.h"
#include "crop4d/eval/workspace_eval.h"

namespace crop4d::cli {
namespace {

struct EvalArgs {
  std::string workspace;
  std::string truth;
  std::string output;
  bool strict = false;
  eval::WorkspaceEvalOptions options;
};

int RunEval(const EvalArgs& args) {
  const auto lock = LockWorkspace(args.workspace, "crop4d eval", /*create=*/false);
  const eval::WorkspaceEval result =
      eval::EvaluateWorkspace(args.workspace, args.truth, args.options);
  const std::string written = eval::WriteWorkspaceEval(result, args.output);
  for (const eval::PassEval& pass : result.passes) {
    if (!pass.ok())
      spdlog::warn("pass {}/{} not evaluated: {}", pass.session, pass.pass, pass.error);
  }
  if (!IsQuiet()) {
    std::fputs(eval::FormatWorkspaceEvalTable(result).c_str(), stdout);
    std::fflush(stdout);
  }
  int failed = result.overall.num_failed;
  if (result.association) {
    const eval::WorkspaceAssociationEval& a = *result.association;
    if (!a.error.empty()) {
      spdlog::warn("association files not evaluated: {}", a.error);
    } else {
      for (const eval::AssociationFileEval& f : a.eval.files) {
        if (!f.ok()) spdlog::warn("association file {} not evaluated: {}", f.file, f.error);
      }
    }
    failed += a.eval.num_failed;
  }
  if (result.fused) {
    for (const eval::FusedSessionEval& s : result.fused->sessions) {
      if (!s.ok()) spdlog::warn("fused session {} not evaluated: {}", s.session, s.error);
    }
    failed += result.fused->num_failed;
  }
  for (const eval::CloudSetEval& set : result.clouds) {
    if (!set.error.empty()) spdlog::warn("{} clouds not evaluated: {}", set.label, set.error);
    for (const eval::CloudSetEval::Session& s : set.sessions) {
      if (!s.error.empty())
        spdlog::warn("{} cloud of {} not used: {}", set.label, s.session, s.error);
    }
  }
  if (result.dense) {
    if (!result.dense->error.empty()) {
      spdlog::warn("dense clouds not evaluated: {}", result.dense->error);
      ++failed;
    }
    for (const eval::DenseSessionEval& s : result.dense->sessions) {
      if (!s.ok()) {
        spdlog::warn("dense cloud of {} not evaluated: {}", s.session, s.error);
        ++failed;
      }
    }
  }
  if (result.canopy) {
    for (const eval::CanopyMethodEval& m : result.canopy->methods) {
      if (!m.ok()) {
        spdlog::warn("canopy heights of {} not evaluated: {}", m.method, m.error);
        ++failed;
      }
    }
  }
  std::string also;
  if (result.association) {
    also += fmt::format(", {} association files", result.association->num_files);
  }
  if (result.fused) also += fmt::format(", {} fused sessions", result.fused->sessions.size());
  for (const eval::CloudSetEval& set : result.clouds) {
    also += fmt::format(", {} clouds of {} sessions", set.label, set.sessions.size());
  }
  if (result.dense) also += fmt::format(", {} dense clouds", result.dense->sessions.size());
  if (result.canopy) {
    also += fmt::format(", canopy heights of {} method{}", result.canopy->methods.size(),
                        result.canopy->methods.size() == 1 ? "" : "s");
  }
  std::fprintf(stderr, "eval: %d of %d passes evaluated%s, metrics in %s\n",
               result.overall.num_evaluated, result.overall.num_passes, also.c_str(),
               written.c_str());
  return args.strict && failed > 0 ? 2 : 0;
}

}  // namespace

RunFunction SetupEval(CLI::App& app) {
  auto args = std::make_shared<EvalArgs>();
  app.description(
      "Compare the trajectories of a workspace with the ground truth of a synthetic field "
      "(crop4d simulate) and write WS/eval/metrics.json.\n"
      "Reads WS/sessions/<session>/rows/<pass>/poses.tum and summary.json (written by crop4d "
      "slam) and FIELD/ground_truth/<session>/cam0_poses.tum (pose_frame \"camera\") or "
      "body_poses.tum (pose_frame \"body\"). Estimate poses are matched with the truth by "
      "timestamp (the truth is interpolated between neighbours within --max-dt).\n"
      "Per pass: ATE (position error RMSE/mean/max) raw, i.e. in the GPS world frame with no "
      "alignment, and after a per-pass SE(3) alignment (Umeyama); RPE, the error of relative "
      "poses --rpe-distance metres of true path apart, in % of the distance travelled and deg "
      "per metre; rotation error (angle of R_truth^T R_est, deg). Overall: the same pooled over "
      "all poses, and the worst pass (largest raw ATE).\n"
      "A pass without ground truth or with a malformed file is listed with its error.\n"
      "Later stages, each when its outputs exist:\n"
      "- associations (WS/associations/**/*.bin, e.g. robust/ and naive/): a cross match is "
      "correct when the true 3D points of its two keypoints lie within --match-distance; the "
      "true point of a keypoint is what its pixel sees at the true pose, from a depth map "
      "rendered from the World of FIELD/ground_truth/simulate.yaml (or the simulator's --depth "
      "maps; rendered maps are kept in --depth-cache). Keypoints on a depth edge, in the sky or "
      "without truth make the match unknown. Precision = correct / (correct + incorrect), per "
      "pair type (cross-row same/opposite direction from WS/sessions/<s>/passes.csv, "
      "cross-session, cross-session after rain) and method.\n"
      "- fusion (WS/fused/<session>/poses.tum): ATE raw and aligned per session and pooled, and "
      "with one alignment of all sessions.\n"
      "- clouds (WS/fused/<s>/sparse.ply, WS/sessions/<s>/rows/*/landmarks.ply): cross-session "
      "ground misalignment, the distance of each session's ground points to the local plane of "
      "another session's ground points (median, 90th percentile, signed median).\n"
      "- canopy heights (WS/analysis/site_heights.csv, written by crop4d analyze, and "
      "site_heights_single_plane.csv, the paper's single-plane method, when present) against "
      "FIELD/ground_truth/site_truth.csv, joined on (site_id, session): pairs, missing "
      "estimates, RMSE, bias (mean of estimate - truth), mean absolute error, the worst "
      "site/session, the failures (|error| > --canopy-max-error, or no estimate) and the same "
      "per session. Skipped with a note when either file is missing.\n"
      "- dense clouds (WS/dense/<session>.ply, written by crop4d densify): for every plant of "
      "FIELD/ground_truth/<session>/plants.csv, the highest point within --dense-top-radius of "
      "its true stem minus its true height above FIELD/ground_truth/terrain.csv (median, 10th "
      "and 90th percentiles, RMSE, shares within/below/above ±2 cm; plants without a point are "
      "missing), and the height of the soil points above the true terrain: the cloud's accuracy "
      "apart from the analysis's stems and terrain model.\n"
      "Example:\n"
      "  crop4d simulate --preset tiny --out field\n"
      "  crop4d slam field --workspace ws\n"
      "  crop4d eval --workspace ws --truth field\n"
      "Exit code: 0 when metrics.json is written (2 with --strict when a pass, an association "
      "file, a fused session, a dense cloud or a canopy-height file could not be evaluated); 2 "
      "for a missing workspace, nothing to evaluate, or a field without ground_truth/.");
  app.add_option("--workspace", args->workspace, "The workspace (holds sessions/)")
      ->required()
      ->type_name("WS");
  app.add_option("--truth", args->truth, "The synthetic field (holds ground_truth/)")
      ->required()
      ->type_name("FIELD");
  app.add_option("--output", args->output, "Write the metrics here instead of WS/eval/metrics.json")
      ->type_name("PATH");
  app.add_option("--session", args->options.sessions,
                 "Evaluate only this session (repeatable; default: every session)")
      ->type_name("ID");
  app.add_option("--rpe-distance", args->options.metrics.rpe_distance_m,
                 "RPE pose pairs are this many metres of true path apart; 0: one pair per pass, "
                 "first pose to last")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e6));
  app.add_option("--max-dt", args->options.max_dt_s,
                 "Interpolate the truth only between neighbours within this many seconds of an "
                 "estimate pose")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e3));
  app.add_flag("--strict", args->strict,
               "Exit with code 2 when a pass, an association file, a fused session, a dense "
               "cloud or a canopy-height file could not be evaluated");
  // Associations.
  app.add_flag("!--no-associations", args->options.associations,
               "Skip the association precision (WS/associations/)");
  app.add_option("--match-distance", args->options.association.max_distance_m,
                 "A cross match is correct when the true 3D points of its two keypoints are at "
                 "most this many metres apart")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1e3));
  app.add_option("--near-depth", args->options.association.near_depth_m,
                 "Also count the matches whose keypoint in the first image sees a point at most "
                 "this many metres deep: the ground and crop near the vehicle")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 1e3));
  app.add_option("--depth-edge", args->options.association.true_point.max_edge_m,
                 "A keypoint whose 3x3 pixels depart from one smooth surface by more than this "
                 "many metres sits on a depth edge: its true point is unknown")
      ->capture_default_str()
      ->check(CLI::Range(1e-6, 1e3));
  app.add_option("--depth-cache", args->options.depth_cache_dir,
                 "Keep the rendered true depth maps here (default WS/eval/depth)")
      ->type_name("DIR");
  app.add_flag("!--no-render", args->options.render_depth,
               "Do not render missing true depth maps (their matches count as unknown)");
  // Fusion and clouds.
  app.add_flag("!--no-fused", args->options.fused,
               "Skip the fused trajectories and the ground misalignment of the clouds");
  app.add_option("--ground-radius", args->options.clouds.misalignment.radius_m,
                 "Ground misalignment: horizontal radius of the local plane fitted to the other "
                 "session's ground points, m")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 1e3));
  app.add_option("--ground-min-points", args->options.clouds.misalignment.min_points,
                 "Ground misalignment: fewer of the other session's ground points within the "
                 "radius and the point is skipped")
      ->capture_default_str()
      ->check(CLI::Range(3, 1000000));
  // Canopy heights.
  app.add_flag("!--no-canopy", args->options.canopy,
               "Skip the canopy heights (WS/analysis/site_heights*.csv)");
  app.add_option("--canopy-max-error", args->options.canopy_options.max_error_m,
                 "Canopy heights: a site/session whose |estimate - truth| exceeds this many "
                 "metres is a failure (as is a missing estimate)")
      ->capture_default_str()
      ->check(CLI::Range(0.0, 1e3));
  // Dense clouds.
  app.add_flag("!--no-dense", args->options.dense,
               "Skip the plant tops and soil of the dense clouds (WS/dense/<session>.ply)");
  app.add_option("--dense-top-radius", args->options.dense_options.top_radius_m,
                 "Dense clouds: a plant's top is the highest point within this distance of its "
                 "true stem, m")
      ->capture_default_str()
      ->check(CLI::Range(1e-3, 10.0));
  return [args] { return RunEval(*args); };
}

}  // namespace crop4d::cli
