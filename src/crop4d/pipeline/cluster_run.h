#pragma once

// A season on a Slurm cluster (`crop4d run --executor slurm`, docs/cluster.md): the season's
// work units (season_run.h kUnitStages, ListWorkUnits) as Slurm job arrays, one array per stage,
// each task `crop4d task run` — the local run's code on one unit (RunWorkUnit) — in a workspace
// on a file system every node sees.
//
// The number of units of a stage is known only when the stage before it has run (a session's
// passes once it is cut, the pairs once the passes are solved), so the stages are chained by
// small dispatch jobs (`crop4d task dispatch`): each runs after the array before it has ended
// (--dependency=afterany), resubmits the units of that array that did not finish (a task that
// threw, was killed or never started) while they have attempts left, then lists the units of
// the next stage, submits them as an array and submits the next dispatch after it. The first
// dispatch runs inside `crop4d run --executor slurm`, which returns once it has submitted.
//
// Every task holds the workspace's lock shared (io/workspace_lock.h: a local run or a stage
// command on the same workspace waits for the tasks, and they for it), writes its outputs
// atomically like the local run, and skips work that is up to date: a task killed mid-way is
// simply run again.
//
// Files (owned by this module), in WS/cluster/:
//   season.json               the plan: field, options, when submitted, finished or not;
//   task.sh                   the batch script every job runs ("exec" of its arguments);
//   <stage>/units.json        the stage's units, in index order;
//   <stage>/task-<i>.json     unit i's state: waiting, running, done or failed, attempts, job;
//   <stage>/task-<i>.run.json the record of unit i's stage (run_log.h RunRecord);
//   <stage>/task-<i>.jsonl    unit i's run-log events;
//   <stage>/slurm-<job>_<task>.out  what Slurm captured of a task's output;
//   jobs.jsonl                every submission (stage, job id, array, dependency).
// WS/run.json is the records of every unit merged (rewritten by each dispatch), WS/crop4d.yaml
// the configuration the tasks read.

#include <optional>
#include <string>
#include <vector>

#include "crop4d/pipeline/season_run.h"

namespace crop4d::pipeline {

struct SlurmOptions {
  // sbatch --partition (empty: the cluster's default partition).
  std::string partition;
  // More sbatch options for every job, as given ("--account=crops", "--time=02:00:00").
  std::vector<std::string> sbatch_args;
  // Cores per task (sbatch --cpus-per-task); a task's worker threads.
  int cpus_per_task = 2;
  // Submissions of a unit before it is reported as failed (1: no retry).
  int max_attempts = 3;
  // The crop4d binary the jobs run, on the shared file system (empty: this process's binary).
  std::string crop4d;
  // The sbatch command (a name on PATH or a path).
  std::string sbatch = "sbatch";

  // Empty when valid, else the option that is wrong and why.
  std::string Check() const;
};

// What SubmitSeason did.
struct ClusterSubmission {
  std::string plan_path;             // WS/cluster/season.json
  std::vector<std::string> job_ids;  // the jobs it submitted (the first array, a dispatch)
};

// Plans the season in WS/cluster/ (a previous cluster run's task states are discarded; its
// outputs stay and are skipped where up to date), writes WS/crop4d.yaml and submits the first
// stage and the dispatch after it. Takes the workspace's lock exclusively for that time.
// Throws InputError for bad options, an unreadable field, a workspace in use, a cluster run of
// the workspace still in the queue, or an sbatch that fails (with its message).
ClusterSubmission SubmitSeason(const std::string& field_folder, const std::string& workspace,
                               const RunOptions& options, const SlurmOptions& slurm);

// `crop4d task dispatch`: the step before `stage` (one of kUnitStages, or "end": after the last
// stage) as described above. Returns the ids of the jobs it submitted (none at the end).
std::vector<std::string> DispatchStage(const std::string& workspace, const std::string& stage);

// `crop4d task run`: unit `index` of `stage`, with `threads` worker threads (0: the plan's
// cpus_per_task). Returns the process exit code: 0 when the unit ran (its items may have failed:
// its record says so), 1 when it threw (its state says why).
int RunClusterTask(const std::string& workspace, const std::string& stage, int index,
                   int threads = 0);

// `crop4d run --jobs N`: the season's work units on this machine, the cluster executor's plan,
// tasks, retries and records without Slurm — each stage's units run as `crop4d task run`
// processes, at most `jobs` at once, sharing the machine's threads (options.config.threads, 0:
// every core): passes, pass pairs and sessions side by side; the next stage's units are listed
// when a stage has ended. Holds the workspace's lock shared while it runs (another run waits or
// refuses, as with the local executor). Returns the merged record (WS/run.json). Throws
// InputError as SubmitSeason does.
RunResult RunSeasonInParallel(const std::string& field_folder, const std::string& workspace,
                              const RunOptions& options, int jobs);

// A unit's state as its task file records it.
struct TaskState {
  // waiting (submitted, not started), running, done (it ran to its end: its record says how
  // its items went), failed (it threw, or was killed while running).
  std::string state = "waiting";
  // Submissions of the unit, and the runs that started.
  int submissions = 0;
  int attempts = 0;
  // Set by the dispatch after the unit's last submission ended without its being done: the
  // unit is reported as failed and the season goes on without it.
  bool gave_up = false;
  std::string job;  // the Slurm job of the last attempt ("123_4")
  std::string host;
  std::string started, finished;  // ISO 8601, UTC
  double seconds = 0.0;
  std::string status;   // the unit's stage status when done (StageRecord::status)
  std::string message;  // why it failed
};

// What `crop4d status` shows of a cluster run.
struct ClusterStageStatus {
  std::string stage;
  bool listed = false;  // the stage's units are known (its dispatch has run)
  std::vector<WorkUnit> units;
  std::vector<TaskState> tasks;  // per unit
};
struct ClusterStatus {
  std::string field, submitted;
  bool finished = false;  // the last dispatch has run
  bool stopped = false;   // a dispatch ended the run early (no pass solved)
  int max_attempts = 0;
  // Whether Slurm's queue still holds a job of this run (squeue); unset when squeue cannot be
  // asked. Not finished and no job left: the run stalled (a dispatch that failed or was
  // cancelled); `crop4d run --executor slurm` again resumes it.
  std::optional<bool> in_queue;
  std::vector<ClusterStageStatus> stages;
  // Finished, and every unit done.
  bool Complete() const;
  // Not finished, and Slurm's queue holds none of its jobs.
  bool Stalled() const;
};

// Reads WS/cluster/; throws InputError when the workspace has no cluster run.
ClusterStatus ReadClusterStatus(const std::string& workspace);
// A table per stage (units waiting, running, done, failed) and the failed units with why.
std::string FormatClusterStatus(const ClusterStatus& status);

}  // namespace crop4d::pipeline
