// crop4d task: one step of a cluster run (pipeline/cluster_run.h, docs/cluster.md), as the Slurm
// jobs that `crop4d run --executor slurm` submits run it. Not for everyday use: `crop4d run` and
// `crop4d status` are the commands a user types.

#include <cstdlib>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/pipeline/cluster_run.h"

namespace crop4d::cli {
namespace {

struct TaskArgs {
  std::string action;
  std::string workspace;
  std::string stage;
  int offset = 0;
  std::optional<int> index;
  int threads = 0;
};

// The unit a task runs: --index, else the offset plus the job array's task id.
int UnitIndex(const TaskArgs& args) {
  if (args.index) return *args.index;
  const char* id = std::getenv("SLURM_ARRAY_TASK_ID");
  if (id == nullptr) {
    throw InputError("crop4d task", 0,
                     "no --index and no SLURM_ARRAY_TASK_ID: which unit? (run inside a job "
                     "array, or give --index)");
  }
  return args.offset + std::atoi(id);
}

int RunTask(const TaskArgs& args) {
  if (args.action == "dispatch") {
    pipeline::DispatchStage(args.workspace, args.stage);
    return 0;
  }
  return pipeline::RunClusterTask(args.workspace, args.stage, UnitIndex(args), args.threads);
}

}  // namespace

RunFunction SetupTask(CLI::App& app) {
  auto args = std::make_shared<TaskArgs>();
  app.description(
      "One step of a cluster run (docs/cluster.md), as the jobs of `crop4d run --executor "
      "slurm` run it: `run` does one work unit of a stage with the local run's code (its state "
      "and record in WS/cluster/<stage>/), `dispatch` resubmits the units of the stage before "
      "that did not finish and submits the next stage's units. Idempotent: a unit whose outputs "
      "are up to date is skipped.\n\nExample:\n  crop4d task run --workspace ws --stage slam "
      "--index 3");
  app.add_option("action", args->action, "run or dispatch")
      ->required()
      ->check(CLI::IsMember({"run", "dispatch"}));
  app.add_option("-w,--workspace", args->workspace, "The workspace of the cluster run")
      ->required()
      ->check(CLI::ExistingDirectory);
  std::vector<std::string> stages(std::begin(pipeline::kUnitStages),
                                  std::end(pipeline::kUnitStages));
  stages.push_back("end");
  app.add_option("--stage", args->stage, "The stage (dispatch: the stage to submit next; end)")
      ->required()
      ->check(CLI::IsMember(stages));
  app.add_option("--offset", args->offset,
                 "run: added to SLURM_ARRAY_TASK_ID (stages of more units than an array holds)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--threads", args->threads, "run: worker threads (0: the plan's cores per task)")
      ->check(CLI::NonNegativeNumber);
  app.add_option("--index", args->index, "run: the unit's index (instead of the array task id)")
      ->check(CLI::NonNegativeNumber);
  return [args] { return RunTask(*args); };
}

}  // namespace crop4d::cli
