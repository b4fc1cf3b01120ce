#pragma once

// What `crop4d run` records about itself in the workspace:
//   WS/run_log.jsonl  one JSON object per line, appended as the run goes: every item a stage
//                     did, found up to date, skipped or failed ({"run", "time", "stage", "item",
//                     "action", "seconds", "message"}). It survives any interruption (a line cut
//                     off by `kill -9` is ignored when read) and accumulates over runs, so it
//                     says which work each run redid.
//   WS/run.json       the last run: per stage its status, time, counts and the warnings and
//                     errors logged during it; what was skipped and why; whether the run
//                     completed. Rewritten atomically after every stage (an interrupted run
//                     leaves "complete": false). The report (WS/report.html) shows it.
//   WS/crop4d.log     the text log of every run (core/logging.h AddLogFile).

#include <spdlog/sinks/base_sink.h>
#include <spdlog/spdlog.h>

#include <memory>
#include <mutex>
#include <string>
#include <vector>

namespace crop4d::pipeline {

// Item actions in the run log.
inline constexpr const char* kActionDone = "done";
inline constexpr const char* kActionUpToDate = "up to date";
inline constexpr const char* kActionFailed = "failed";
inline constexpr const char* kActionSkipped = "skipped";

struct StageRecord {
  std::string name;
  // "done" (work was done), "up to date" (nothing to redo), "partial" (some items failed or
  // were skipped), "failed" (the stage could not run), "not run" (an earlier stage stopped the
  // run, or the run was interrupted before it), "disabled" (by the configuration), "nothing to
  // do" (its inputs hold no work: associate without a pair of row passes, analyze on a field
  // without measurement sites).
  std::string status = "not run";
  double seconds = 0.0;
  // CPU seconds (user + system, every thread) and the peak resident memory, MB, of the process
  // during the stage (core/resource_usage.h; NaN where unknown). A cluster run's merged record
  // gives the sum of its units' CPU and the largest unit's peak.
  double cpu_seconds = 0.0;
  double peak_rss_mb = 0.0;
  int done = 0;
  int skipped = 0;  // up to date
  int failed = 0;
  // Warnings and errors logged during the stage (at most kMaxMessages, then a count).
  std::vector<std::string> messages;
  static constexpr std::size_t kMaxMessages = 50;
};

// Something the run left out, and why (a session whose data could not be read, a pass that
// failed, a stage that could not run).
struct SkippedItem {
  std::string stage;
  std::string session;
  std::string item;
  std::string reason;
};

struct RunRecord {
  std::string crop4d_version;
  std::string field;
  std::string workspace;
  std::string started;   // ISO 8601, UTC
  std::string finished;  // "" while running or when interrupted
  bool complete = false;
  int threads = 0;
  std::vector<StageRecord> stages;
  std::vector<SkippedItem> skipped;

  StageRecord* Stage(const std::string& name);
  // A stage failed as a whole (status "failed"): then the run is not complete.
  bool AnyStageFailed() const;
};

// WS/run.json: written atomically; read back (InputError for a malformed file).
void WriteRunRecord(const std::string& path, const RunRecord& record);
RunRecord ReadRunRecord(const std::string& path);

struct RunEvent {
  std::string run;  // the run's id (start time and process id)
  std::string time;
  std::string stage;
  std::string item;
  std::string action;
  double seconds = 0.0;
  std::string message;
};

// Appends events to WS/run_log.jsonl, one line each, flushed at once.
class RunLog {
 public:
  // Throws InputError when the file cannot be opened for appending.
  explicit RunLog(const std::string& path);
  ~RunLog();
  RunLog(const RunLog&) = delete;
  RunLog& operator=(const RunLog&) = delete;

  void Add(const std::string& stage, const std::string& item, const std::string& action,
           double seconds = 0.0, const std::string& message = "");
  const std::string& run_id() const { return run_id_; }

 private:
  std::mutex mutex_;
  std::FILE* file_ = nullptr;
  std::string run_id_;
};

// Every event of a run log; a line that is not a complete JSON object (the last line of a
// killed run) is ignored. A missing file gives no events.
std::vector<RunEvent> ReadRunLog(const std::string& path);

// The current UTC time, ISO 8601 with seconds ("2026-11-22T12:00:00Z").
std::string IsoTimeNow();

// Collects the warnings and errors logged through spdlog while installed on the default
// logger (Install / Remove), for StageRecord::messages.
class MessageCollector : public spdlog::sinks::base_sink<std::mutex> {
 public:
  // Adds this collector to the default logger's sinks; Remove() takes it out again.
  static std::shared_ptr<MessageCollector> Install();
  void Remove();
  // The messages collected since the last call, and how many more were dropped beyond `limit`.
  std::vector<std::string> Take(std::size_t limit);

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override;
  void flush_() override {}

 private:
  std::vector<std::string> messages_;
};

}  // namespace crop4d::pipeline
