// crop4d eval --workspace WS --truth FIELD: compares the row-pass trajectories of a workspace
// with a synthetic field's ground truth, prints a table and writes WS/eval/metrics.json.

#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <string>

#include "crop4d/cli/command.h"
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
  const eval::WorkspaceEval result =
      eval::EvaluateWorkspace(args.workspace, args.truth, args.options);
  const std::string written = eval::WriteWorkspaceEval(result, args.output);
  for (const eval::PassEval& pass : result.passes) {
    if (!pass.ok())
      spdlog::warn("pass {}/{} not evaluated: {}", pass.session, pass.pass, pass.error);
  }
  if (spdlog::get_level() <= spdlog::level::info) {
    std::fputs(eval::FormatWorkspaceEvalTable(result).c_str(), stdout);
    std::fflush(stdout);
  }
  std::fprintf(stderr, "eval: %d of %d passes evaluated, metrics in %s\n",
               result.overall.num_evaluated, result.overall.num_passes, written.c_str());
  return args.strict && result.overall.num_failed > 0 ? 2 : 0;
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
      "Example:\n"
      "  crop4d simulate --preset tiny --out field\n"
      "  crop4d slam field --workspace ws\n"
      "  crop4d eval --workspace ws --truth field\n"
      "Exit code: 0 when metrics.json is written (2 with --strict when a pass could not be "
      "evaluated); 2 for a missing workspace, no pass, or a field without ground_truth/.");
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
  app.add_flag("--strict", args->strict, "Exit with code 2 when a pass could not be evaluated");
  return [args] { return RunEval(*args); };
}

}  // namespace crop4d::cli
