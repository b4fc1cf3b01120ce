#pragma once

// A whole season in one call (`crop4d run`, docs/run.md): validate → slam → associate → fuse →
// densify → analyze → eval (when the field has ground truth) → report, into one workspace.
//
// Resumable and incremental: every stage records a fingerprint of what it consumed (content
// hashes of its input files and the options that matter to it) and skips the work whose inputs
// are unchanged — per pass (slam), per pass pair (associate), per session (densify), as a whole
// (fuse, analyze, eval). Every output is written atomically (io/atomic_file.h) and a stage's
// summary with its fingerprint last, so a run killed at any moment leaves either a finished
// item or none, and the next run finishes the rest with the same results as an uninterrupted
// run. A session added to the field costs its own passes, its association pairs, and the stages
// that depend on all sessions (fusion, the dense clouds of the sessions whose fused poses moved,
// the analysis, the evaluation).
//
// Bad input in one session (an unreadable image, a truncated IMU file, a session without GPS)
// is logged and recorded (WS/run.json "skipped", the report); the other sessions go on. Only a
// field that cannot be read at all, or a workspace that cannot be written, stops the run.
//
// Records: WS/crop4d.yaml (the effective configuration), WS/run.json, WS/run_log.jsonl and
// WS/crop4d.log (pipeline/run_log.h).

#include <string>

#include "crop4d/pipeline/run_config.h"
#include "crop4d/pipeline/run_log.h"

namespace crop4d::pipeline {

// The stages in run order (the names of WS/run.json and the run log).
inline constexpr const char* kRunStages[] = {"validate", "slam",    "associate", "fuse",
                                             "densify",  "analyze", "eval",      "report"};

// The stages as the Slurm executor runs them, as work units (pipeline/cluster_run.h): the slam
// stage in two steps, "passes" (a session cut into its passes, one unit per session) and "slam"
// (one unit per pass).
inline constexpr const char* kUnitStages[] = {"validate", "passes",  "slam", "associate", "fuse",
                                              "densify",  "analyze", "eval", "report"};

// One work unit of a stage: what one task of a cluster run does, with the local run's code.
struct WorkUnit {
  std::string stage;    // one of kUnitStages
  std::string session;  // passes, slam, densify: the session; empty for the others
  std::string item;     // slam: the pass id; associate: the pair (PassPairName); else empty
  // "stage", "stage session", "stage session/item" or "stage item": for logs and status.
  std::string Name() const;
};

struct RunOptions {
  RunConfig config;
  // Where the configuration came from, for the log ("defaults" or a file).
  std::string config_source = "defaults";
  // Redo every stage even when its outputs are up to date.
  bool force = false;
  bool show_progress = true;
  // When another crop4d process holds the workspace (io/workspace_lock.h): wait for it to end
  // instead of refusing to start.
  bool wait_for_workspace = false;
};

struct RunResult {
  RunRecord record;
  std::string record_path;  // WS/run.json
  // Every stage ran (some items may have been skipped: see record.skipped).
  bool complete() const { return record.complete; }
  // A stage failed as a whole.
  bool any_stage_failed() const;
};

// Runs the season. Holds the workspace's lock (io/workspace_lock.h) while it runs. Throws
// InputError when the field's field.yaml cannot be read, the workspace cannot be written or
// another process holds it (unless options.wait_for_workspace); everything else is recorded in
// the result.
RunResult RunSeason(const std::string& field_folder, const std::string& workspace,
                    const RunOptions& options);

// The work units of `stage` (one of kUnitStages) as the workspace stands: validate, fuse,
// analyze, eval and report are one unit; passes one per session of the field whose name the
// outputs can hold; slam one per pass that "passes" cut (WS/sessions/<id>/passes list); associate
// one per scheduled pair; densify one per session with fused poses; the stages the configuration
// turns off (densify, eval, report) and associate without a pair have none.
std::vector<WorkUnit> ListWorkUnits(const std::string& field_folder, const std::string& workspace,
                                    const RunConfig& config, const std::string& stage);

// Runs one work unit with the local run's code, restricted to the unit. It takes no lock (the
// caller holds the workspace's lock shared) and writes neither WS/run.json nor WS/crop4d.yaml:
// the record of its one stage goes to `record_path` (a run.json holding that stage alone) and
// its run-log events to `log_path`. Throws InputError for an unreadable field or an unknown
// stage; a unit that fails is recorded (status "failed" or "partial").
RunResult RunWorkUnit(const std::string& field_folder, const std::string& workspace,
                      const RunOptions& options, const WorkUnit& unit,
                      const std::string& record_path, const std::string& log_path);

// A short summary for the terminal: a line per stage (status, time, counts), what was skipped,
// the headline figures of WS/eval/metrics.json when present (trajectory error, cross-session
// misalignment, canopy-height RMSE), and where the report is.
std::string FormatRunSummary(const RunResult& result);

}  // namespace crop4d::pipeline
