// crop4d status: where a workspace's run stands — the stages of the last run (WS/run.json) and,
// for a cluster run, its units queued, running, done and failed (pipeline/cluster_run.h).

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/pipeline/cluster_run.h"
#include "crop4d/pipeline/run_log.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::cli {
namespace {

struct StatusArgs {
  std::string workspace;
  bool wait = false;
  double poll_s = 5.0;
};

std::string FormatLocalRecord(const pipeline::RunRecord& record) {
  std::string out = "run of " + record.field + ", started " + record.started + ": " +
                    (record.finished.empty() ? "running or interrupted"
                     : record.complete       ? "complete"
                                             : "finished with failures") +
                    "\n";
  for (const pipeline::StageRecord& s : record.stages) {
    out += "  " + s.name + ": " + s.status + "\n";
  }
  return out;
}

// "slam: 3 of 6 units done, 1 running": the first stage whose units are not all done.
std::string ProgressLine(const pipeline::ClusterStatus& status) {
  for (const pipeline::ClusterStageStatus& s : status.stages) {
    if (!s.listed) return s.stage + ": waiting for the stage before";
    int done = 0, running = 0;
    for (const pipeline::TaskState& t : s.tasks) {
      done += t.state == "done" || t.gave_up;
      running += t.state == "running";
    }
    if (done < static_cast<int>(s.tasks.size())) {
      return s.stage + ": " + std::to_string(done) + " of " + std::to_string(s.tasks.size()) +
             " units over, " + std::to_string(running) + " running";
    }
  }
  return "finishing";
}

int RunStatus(const StatusArgs& args) {
  namespace fs = std::filesystem;
  const workspace::Layout layout(args.workspace);
  if (!fs::exists(layout.ClusterDir() / "season.json")) {
    if (!fs::exists(layout.RunRecord())) {
      throw InputError(args.workspace, 0, "no run in this workspace (no run.json)");
    }
    const pipeline::RunRecord record = pipeline::ReadRunRecord(layout.RunRecord().string());
    std::fputs(FormatLocalRecord(record).c_str(), stdout);
    return record.complete ? 0 : 1;
  }
  pipeline::ClusterStatus status = pipeline::ReadClusterStatus(args.workspace);
  std::string last;
  while (args.wait && !status.finished && !status.Stalled()) {
    // Progress while waiting: a line on stderr whenever it changes.
    if (const std::string line = ProgressLine(status); line != last) {
      std::fprintf(stderr, "%s\n", line.c_str());
      last = line;
    }
    std::this_thread::sleep_for(std::chrono::duration<double>(args.poll_s));
    status = pipeline::ReadClusterStatus(args.workspace);
  }
  std::fputs(pipeline::FormatClusterStatus(status).c_str(), stdout);
  if (status.Stalled()) return 1;
  if (!status.finished) return 0;
  return status.Complete() ? 0 : 1;
}

}  // namespace

RunFunction SetupStatus(CLI::App& app) {
  auto args = std::make_shared<StatusArgs>();
  app.description(
      "Where a workspace's run stands. For a cluster run (crop4d run --executor slurm, "
      "docs/cluster.md): per stage the units waiting (queued, or failed with attempts left), "
      "running, done and failed, and why each failed unit failed. For a local run: the stages "
      "of WS/run.json. Exit code 0 while a run is in progress or when it completed, 1 when it "
      "finished with failures or stalled (no job of it left in the queue), 2 for a workspace "
      "without a run.\n\nExamples:\n  crop4d status "
      "ws\n  crop4d status ws --wait   # until the cluster run has finished");
  app.add_option("workspace", args->workspace, "Workspace folder")
      ->required()
      ->check(CLI::ExistingDirectory);
  app.add_flag("--wait", args->wait, "Wait until the cluster run has finished, then print");
  app.add_option("--poll", args->poll_s, "Seconds between two looks while waiting")
      ->check(CLI::PositiveNumber);
  return [args] { return RunStatus(*args); };
}

}  // namespace crop4d::cli
