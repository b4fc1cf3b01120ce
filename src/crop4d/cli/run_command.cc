// crop4d run: the whole season in one command — validate, slam, associate, fuse, densify,
// analyze, eval (with ground truth), report — resumable and incremental
// (pipeline/season_run.h, docs/run.md).

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/pipeline/cluster_run.h"
#include "crop4d/pipeline/season_run.h"

namespace crop4d::cli {
namespace {

struct RunArgs {
  std::string field;
  std::string workspace;
  std::string config_file;
  std::optional<int> threads;
  std::string eval;
  bool no_densify = false;
  bool no_report = false;
  bool force = false;
  bool wait = false;
  bool print_config = false;
  std::string executor = "local";
  int jobs = 1;
  pipeline::SlurmOptions slurm;
};

// Submits the season to Slurm (pipeline/cluster_run.h) and says how to follow it.
int SubmitToSlurm(const RunArgs& args, const pipeline::RunOptions& options) {
  const pipeline::ClusterSubmission submission =
      pipeline::SubmitSeason(args.field, args.workspace, options, args.slurm);
  std::printf("submitted to Slurm: jobs %s (plan %s)\nfollow it with: crop4d status %s [--wait]\n",
              fmt::format("{}", fmt::join(submission.job_ids, ", ")).c_str(),
              submission.plan_path.c_str(), args.workspace.c_str());
  return 0;
}

int RunRun(const RunArgs& args) {
  pipeline::RunOptions options;
  if (!args.config_file.empty()) {
    options.config = pipeline::ReadRunConfig(args.config_file);
    options.config_source = args.config_file;
  }
  pipeline::RunConfig& c = options.config;
  // Command-line options override the file.
  if (args.threads) c.threads = *args.threads;
  if (!args.eval.empty()) c.eval = args.eval;
  if (args.no_densify) c.densify = false;
  if (args.no_report) c.report = false;
  if (args.print_config) {
    std::fputs(pipeline::FormatRunConfig(c).c_str(), stdout);
    return 0;
  }
  if (args.field.empty() || args.workspace.empty()) {
    throw InputError("crop4d run", 0, "FIELD and --workspace are required");
  }
  options.force = args.force;
  options.wait_for_workspace = args.wait;
  if (args.executor == "slurm") return SubmitToSlurm(args, options);
  const pipeline::RunResult result =
      args.jobs > 1 ? pipeline::RunSeasonInParallel(args.field, args.workspace, options, args.jobs)
                    : pipeline::RunSeason(args.field, args.workspace, options);
  std::fputs(("\n" + pipeline::FormatRunSummary(result)).c_str(), stdout);
  std::fflush(stdout);
  return result.any_stage_failed() || !result.complete() ? 1 : 0;
}

}  // namespace

RunFunction SetupRun(CLI::App& app) {
  auto args = std::make_shared<RunArgs>();
  app.description(
      "The whole season in one command (docs/run.md): validate → slam → associate → fuse → "
      "densify → analyze → eval (when FIELD/ground_truth/ exists) → report, into one workspace. "
      "Work whose inputs and options have not changed is skipped, so a run that was interrupted "
      "(even by kill -9) finishes where it stopped, and a session added to the field costs only "
      "its own passes, its association pairs and the stages that depend on every session. Bad "
      "data in one session is recorded (WS/run.json, the report) and the rest of the season is "
      "still processed. Writes WS/crop4d.yaml (the effective configuration), WS/run.json, "
      "WS/run_log.jsonl, WS/crop4d.log and WS/report.html. Exit code 0 when every stage ran, 1 "
      "when a stage failed, 2 for bad input.\n\nExamples:\n  crop4d run demo/field "
      "--workspace demo/workspace\n  crop4d run --print-config > season.yaml   # edit, then:\n"
      "  crop4d run field --workspace ws --config season.yaml --threads 2\n"
      "  crop4d run field --workspace /shared/ws --executor slurm --partition batch");
  app.add_option("field", args->field, "Field folder (docs/format.md)")
      ->check(CLI::ExistingDirectory);
  app.add_option("-w,--workspace", args->workspace, "Workspace folder (created if missing)");
  app.add_option("-c,--config", args->config_file,
                 "Configuration file (YAML, docs/run.md; default: every stage's defaults)")
      ->check(CLI::ExistingFile);
  app.add_option("--threads", args->threads, "Worker threads (0: all cores; overrides the file)")
      ->check(CLI::Range(0, pipeline::RunConfig::kMaxThreads));
  app.add_option("--eval", args->eval,
                 "Evaluation against ground truth: auto, always, never (overrides the file)")
      ->check(CLI::IsMember({"auto", "always", "never"}));
  app.add_flag("--no-densify", args->no_densify,
               "No dense clouds: the analysis uses the fused sparse clouds (faster, much less "
               "accurate canopy heights)");
  app.add_flag("--no-report", args->no_report, "Do not write WS/report.html");
  app.add_flag("--force", args->force, "Redo every stage even when its outputs are up to date");
  app.add_flag("--wait", args->wait,
               "When another crop4d process is writing into the workspace, wait until it ends "
               "(default: exit with code 2, naming it)");
  app.add_option("--executor", args->executor,
                 "Where the work runs: local (this process) or slurm (job arrays on a Slurm "
                 "cluster, the workspace on a shared file system; docs/cluster.md)")
      ->check(CLI::IsMember({"local", "slurm"}));
  app.add_option("--jobs", args->jobs,
                 "local: work units run side by side, as processes sharing the --threads "
                 "(passes, pass pairs, sessions; docs/run.md#parallelism-and-progress)")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  app.add_option("--partition", args->slurm.partition,
                 "slurm: the partition (default: the cluster's default)");
  app.add_option("--cpus-per-task", args->slurm.cpus_per_task,
                 "slurm: cores per task, its worker threads")
      ->check(CLI::PositiveNumber);
  app.add_option("--attempts", args->slurm.max_attempts,
                 "slurm: submissions of a work unit before it is reported as failed (1: no retry)")
      ->check(CLI::PositiveNumber);
  app.add_option("--sbatch-arg", args->slurm.sbatch_args,
                 "slurm: one more sbatch option for every job, e.g. --sbatch-arg=--time=02:00:00 "
                 "(repeatable)")
      ->allow_extra_args(false);
  app.add_option("--crop4d", args->slurm.crop4d,
                 "slurm: the crop4d binary the jobs run, on the shared file system (default: "
                 "this one)");
  app.add_flag("--print-config", args->print_config,
               "Print the effective configuration (defaults, the file, the options above) as "
               "YAML and exit");
  return [args] { return RunRun(*args); };
}

}  // namespace crop4d::cli
