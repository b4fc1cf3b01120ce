#include "crop4d/pipeline/cluster_run.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spawn.h>
#include <spdlog/spdlog.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>
#include <thread>

#include "crop4d/core/error.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/workspace_lock.h"
#include "crop4d/workspace/layout.h"

extern char** environ;

namespace crop4d::pipeline {

namespace fs = std::filesystem;
using json = nlohmann::json;

namespace {

// A job array's task ids run below this bound (Slurm's default MaxArraySize is 1001): a stage of
// more units is submitted as several arrays, each with the offset of its first unit.
constexpr int kArrayChunk = 1000;

// The files of a cluster run (cluster_run.h).
struct ClusterFiles {
  explicit ClusterFiles(const std::string& workspace)
      : dir(workspace::Layout(workspace).ClusterDir()) {}
  fs::path Plan() const { return dir / "season.json"; }
  fs::path Script() const { return dir / "task.sh"; }
  fs::path Jobs() const { return dir / "jobs.jsonl"; }
  fs::path StageDir(const std::string& stage) const { return dir / stage; }
  fs::path Units(const std::string& stage) const { return StageDir(stage) / "units.json"; }
  fs::path Task(const std::string& stage, int i) const {
    return StageDir(stage) / fmt::format("task-{}.json", i);
  }
  fs::path TaskRecord(const std::string& stage, int i) const {
    return StageDir(stage) / fmt::format("task-{}.run.json", i);
  }
  fs::path TaskLog(const std::string& stage, int i) const {
    return StageDir(stage) / fmt::format("task-{}.jsonl", i);
  }
  fs::path dir;
};

// The plan of a cluster run (WS/cluster/season.json).
struct Plan {
  std::string field, workspace, config_source, submitted;
  bool force = false;
  bool finished = false;
  bool stopped = false;
  SlurmOptions slurm;
  // Run here instead of on Slurm (crop4d run --jobs): this many tasks at once, and the threads
  // of the machine they share (RunSeasonInParallel).
  int local_jobs = 0;
  int local_threads = 0;
};

json ToJson(const Plan& p) {
  return {{"field", p.field},
          {"workspace", p.workspace},
          {"config_source", p.config_source},
          {"submitted", p.submitted},
          {"force", p.force},
          {"finished", p.finished},
          {"stopped", p.stopped},
          {"partition", p.slurm.partition},
          {"sbatch_args", p.slurm.sbatch_args},
          {"cpus_per_task", p.slurm.cpus_per_task},
          {"max_attempts", p.slurm.max_attempts},
          {"crop4d", p.slurm.crop4d},
          {"sbatch", p.slurm.sbatch},
          {"local_jobs", p.local_jobs},
          {"local_threads", p.local_threads}};
}

json ReadJson(const fs::path& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path.string(), 0, "cannot read the file");
  try {
    return json::parse(in);
  } catch (const json::exception& e) {
    throw InputError(path.string(), 0, std::string("not JSON: ") + e.what());
  }
}

void WriteJson(const fs::path& path, const json& j) {
  io::WriteFileAtomic(path.string(), j.dump(2) + "\n");
}

Plan ReadPlan(const std::string& workspace) {
  const fs::path path = ClusterFiles(workspace).Plan();
  if (!fs::exists(path)) {
    throw InputError(workspace, 0,
                     "no cluster run in this workspace (crop4d run --executor slurm starts one)");
  }
  const json j = ReadJson(path);
  Plan p;
  try {
    p.field = j.at("field");
    p.workspace = j.at("workspace");
    p.config_source = j.at("config_source");
    p.submitted = j.at("submitted");
    p.force = j.at("force");
    p.finished = j.at("finished");
    p.stopped = j.at("stopped");
    p.slurm.partition = j.at("partition");
    p.slurm.sbatch_args = j.at("sbatch_args").get<std::vector<std::string>>();
    p.slurm.cpus_per_task = j.at("cpus_per_task");
    p.slurm.max_attempts = j.at("max_attempts");
    p.slurm.crop4d = j.at("crop4d");
    p.slurm.sbatch = j.at("sbatch");
    p.local_jobs = j.value("local_jobs", 0);
    p.local_threads = j.value("local_threads", 0);
  } catch (const json::exception& e) {
    throw InputError(path.string(), 0, std::string("malformed plan: ") + e.what());
  }
  return p;
}

json ToJson(const WorkUnit& u) {
  return {{"stage", u.stage}, {"session", u.session}, {"item", u.item}};
}

std::vector<WorkUnit> ReadUnits(const ClusterFiles& files, const std::string& stage) {
  const json file = ReadJson(files.Units(stage));
  std::vector<WorkUnit> units;
  for (const json& u : file.at("units")) {
    units.push_back({u.at("stage"), u.at("session"), u.at("item")});
  }
  return units;
}

json ToJson(const TaskState& t) {
  return {{"state", t.state},       {"submissions", t.submissions},
          {"attempts", t.attempts}, {"gave_up", t.gave_up},
          {"job", t.job},           {"host", t.host},
          {"started", t.started},   {"finished", t.finished},
          {"seconds", t.seconds},   {"status", t.status},
          {"message", t.message}};
}

// The state of unit i; "waiting" with no attempt when its task has not started.
TaskState ReadTask(const ClusterFiles& files, const std::string& stage, int i) {
  TaskState t;
  const fs::path path = files.Task(stage, i);
  if (!fs::exists(path)) return t;
  const json j = ReadJson(path);
  t.state = j.value("state", "waiting");
  t.submissions = j.value("submissions", 0);
  t.attempts = j.value("attempts", 0);
  t.gave_up = j.value("gave_up", false);
  t.job = j.value("job", "");
  t.host = j.value("host", "");
  t.started = j.value("started", "");
  t.finished = j.value("finished", "");
  t.seconds = j.value("seconds", 0.0);
  t.status = j.value("status", "");
  t.message = j.value("message", "");
  return t;
}

// What a process printed (stdout and stderr together) and how it ended.
struct ProcessOutput {
  int exit_code = -1;
  std::string output;
};

// Runs argv[0] (searched on PATH) with `argv`, this process's environment (so that the jobs
// inherit SLURM_CONF and the like), and collects its output. Throws InputError when it cannot
// be started.
ProcessOutput RunProcess(const std::vector<std::string>& argv) {
  int fds[2];
  if (::pipe2(fds, O_CLOEXEC) != 0) throw InputError(argv[0], 0, "cannot create a pipe");
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
  posix_spawn_file_actions_adddup2(&actions, fds[1], STDERR_FILENO);
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_t pid = 0;
  const int rc = ::posix_spawnp(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  ::close(fds[1]);
  if (rc != 0) {
    ::close(fds[0]);
    throw InputError(argv[0], 0, fmt::format("cannot run it: {}", std::strerror(rc)));
  }
  ProcessOutput out;
  std::array<char, 4096> buffer;
  ssize_t n = 0;
  while ((n = ::read(fds[0], buffer.data(), buffer.size())) != 0) {
    if (n < 0) {
      if (errno == EINTR) continue;
      break;
    }
    out.output.append(buffer.data(), static_cast<std::size_t>(n));
  }
  ::close(fds[0]);
  int status = 0;
  while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
  }
  out.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
  return out;
}

// Task ids as sbatch --array takes them: "0-9" for a range, "3,7,8" for a list.
std::string ArraySpec(const std::vector<int>& ids) {
  const bool range = ids.back() - ids.front() + 1 == static_cast<int>(ids.size());
  if (range) return fmt::format("{}-{}", ids.front(), ids.back());
  return fmt::format("{}", fmt::join(ids, ","));
}

// sbatch with the plan's options; returns the job id. `array` empty: a single job.
std::string Sbatch(const Plan& plan, const std::string& name, const std::string& array, int cpus,
                   const std::vector<std::string>& dependencies, const fs::path& output,
                   const std::vector<std::string>& command) {
  std::vector<std::string> argv = {plan.slurm.sbatch,
                                   "--parsable",
                                   "--job-name=" + name,
                                   fmt::format("--cpus-per-task={}", cpus),
                                   "--output=" + output.string(),
                                   "--chdir=" + plan.workspace};
  if (!array.empty()) argv.push_back("--array=" + array);
  if (!plan.slurm.partition.empty()) argv.push_back("--partition=" + plan.slurm.partition);
  if (!dependencies.empty()) {
    argv.push_back(fmt::format("--dependency=afterany:{}", fmt::join(dependencies, ":")));
  }
  for (const std::string& a : plan.slurm.sbatch_args) argv.push_back(a);
  argv.push_back(ClusterFiles(plan.workspace).Script().string());
  for (const std::string& a : command) argv.push_back(a);
  ProcessOutput out;
  try {
    out = RunProcess(argv);
  } catch (const InputError& e) {
    throw InputError(
        plan.slurm.sbatch, 0,
        std::string(e.what()) + " (is this a machine with the Slurm client? Debian: slurm-client)");
  }
  std::string id = out.output.substr(0, out.output.find_first_of(";\n"));
  const bool numeric = !id.empty() && std::all_of(id.begin(), id.end(), ::isdigit);
  if (out.exit_code != 0 || !numeric) {
    throw InputError(plan.slurm.sbatch, 0,
                     fmt::format("submitting {} failed (exit {}): {}", name, out.exit_code,
                                 out.output.empty() ? "no output" : out.output));
  }
  std::ofstream(ClusterFiles(plan.workspace).Jobs(), std::ios::app)
      << json{{"time", IsoTimeNow()},
              {"name", name},
              {"job", id},
              {"array", array},
              {"dependency", dependencies}}
             .dump()
      << "\n";
  spdlog::info("submitted {} as job {}{}", name, id, array.empty() ? "" : " array " + array);
  return id;
}

// Runs units `ids` of `stage` on this machine (a local plan), `crop4d task run` processes of the
// plan's binary, at most plan.local_jobs at once; returns when all have ended. The machine's
// threads are shared among the tasks that run together: a stage of fewer units than jobs gives
// each more (fuse, analyze: all of them).
void RunUnitsHere(const Plan& plan, const std::string& stage, const std::vector<int>& ids) {
  const ClusterFiles files(plan.workspace);
  const int together = std::min<int>(plan.local_jobs, static_cast<int>(ids.size()));
  const int threads = std::max(1, plan.local_threads / std::max(1, together));
  std::map<pid_t, int> running;  // child -> unit
  std::size_t next = 0;
  const auto start_next = [&] {
    const int i = ids[next++];
    const std::vector<std::string> argv = {plan.slurm.crop4d,
                                           "task",
                                           "run",
                                           "--workspace",
                                           plan.workspace,
                                           "--stage",
                                           stage,
                                           "--index",
                                           std::to_string(i),
                                           "--threads",
                                           std::to_string(threads)};
    const std::string log = (files.StageDir(stage) / fmt::format("local-{}.out", i)).string();
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, log.c_str(),
                                     O_WRONLY | O_CREAT | O_APPEND, 0644);
    posix_spawn_file_actions_adddup2(&actions, STDOUT_FILENO, STDERR_FILENO);
    std::vector<char*> args;
    for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    pid_t pid = 0;
    const int rc = ::posix_spawn(&pid, argv[0].c_str(), &actions, nullptr, args.data(), environ);
    posix_spawn_file_actions_destroy(&actions);
    if (rc != 0) {
      throw InputError(argv[0], 0, fmt::format("cannot run it: {}", std::strerror(rc)));
    }
    running[pid] = i;
  };
  spdlog::info("{}: {} unit(s), {} at once, {} thread(s) each", stage, ids.size(), together,
               threads);
  while (next < ids.size() || !running.empty()) {
    while (next < ids.size() && static_cast<int>(running.size()) < plan.local_jobs) start_next();
    int status = 0;
    const pid_t pid = ::waitpid(-1, &status, 0);
    if (pid < 0) {
      if (errno == EINTR) continue;
      throw InputError("crop4d run --jobs", 0,
                       fmt::format("waiting for the tasks: {}", std::strerror(errno)));
    }
    const auto it = running.find(pid);
    if (it == running.end()) continue;  // not one of the tasks
    // A task that threw says so in its state; one that was killed is concluded by the dispatch.
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
      spdlog::warn("{} unit {} ended with {}", stage, it->second,
                   WIFEXITED(status) ? fmt::format("exit code {}", WEXITSTATUS(status))
                                     : fmt::format("signal {}", WTERMSIG(status)));
    }
    running.erase(it);
  }
}

// Submits units `ids` of `stage` as arrays of at most kArrayChunk task ids; returns the jobs.
std::vector<std::string> SubmitUnits(const Plan& plan, const std::string& stage,
                                     const std::vector<int>& ids,
                                     const std::vector<std::string>& dependencies) {
  const ClusterFiles files(plan.workspace);
  std::map<int, std::vector<int>> chunks;  // offset -> task ids
  for (int i : ids) {
    chunks[i / kArrayChunk * kArrayChunk].push_back(i % kArrayChunk);
    // Counted before the job exists: once submitted, its task may write the file any moment.
    TaskState t = ReadTask(files, stage, i);
    ++t.submissions;
    WriteJson(files.Task(stage, i), ToJson(t));
  }
  if (plan.local_jobs > 0) {
    RunUnitsHere(plan, stage, ids);
    return {"local"};
  }
  std::vector<std::string> jobs;
  const fs::path out = files.StageDir(stage) / "slurm-%A_%a.out";
  for (const auto& [offset, task_ids] : chunks) {
    jobs.push_back(Sbatch(plan, "crop4d-" + stage, ArraySpec(task_ids), plan.slurm.cpus_per_task,
                          dependencies, out,
                          {plan.slurm.crop4d, "task", "run", "--workspace", plan.workspace,
                           "--stage", stage, "--offset", std::to_string(offset)}));
  }
  return jobs;
}

// Submits the dispatch of `stage` after `dependencies`.
std::string SubmitDispatch(const Plan& plan, const std::string& stage,
                           const std::vector<std::string>& dependencies) {
  return Sbatch(
      plan, "crop4d-dispatch-" + stage, "", 1, dependencies,
      ClusterFiles(plan.workspace).dir / ("dispatch-" + stage + "-%j.out"),
      {plan.slurm.crop4d, "task", "dispatch", "--workspace", plan.workspace, "--stage", stage});
}

// The dispatch of `stage` after `jobs`: submitted to Slurm, or for a local plan handed to the
// loop of RunSeasonInParallel through `local_next`.
std::string ChainDispatch(const Plan& plan, const std::string& stage,
                          const std::vector<std::string>& jobs, std::string* local_next) {
  if (plan.local_jobs > 0) {
    *local_next = stage;
    return "local";
  }
  return SubmitDispatch(plan, stage, jobs);
}

int StageIndex(const std::string& stage) {
  for (std::size_t i = 0; i < std::size(kUnitStages); ++i) {
    if (stage == kUnitStages[i]) return static_cast<int>(i);
  }
  if (stage == "end") return static_cast<int>(std::size(kUnitStages));
  throw InputError("crop4d task", 0, "no stage '" + stage + "'");
}

// After the unit's array has ended: a task still marked running was killed (failed); a unit
// not done whose submissions are used up is given up. Returns whether it should run again.
bool ConcludeAfterArray(TaskState& t, int max_attempts) {
  if (t.state == "running") {
    t.state = "failed";
    t.message = "killed while running (node failure, time limit, scancel)";
  }
  if (t.state == "done" || t.gave_up) return false;
  if (t.submissions < max_attempts) return true;
  t.gave_up = true;
  if (t.state == "waiting") {
    t.state = "failed";
    t.message = "never started (its job was cancelled or could not run)";
  }
  return false;
}

// The records of every unit merged into WS/run.json: per stage the sums of the units' counts,
// their messages and what they skipped, and the units that failed after their attempts.
void WriteMergedRecord(const Plan& plan) {
  const ClusterFiles files(plan.workspace);
  RunRecord record;
  record.crop4d_version = kVersion;
  record.field = plan.field;
  record.workspace = plan.workspace;
  record.started = plan.submitted;
  record.threads = plan.slurm.cpus_per_task;
  for (const char* stage : kUnitStages) {
    StageRecord merged;
    merged.name = stage;
    if (!fs::exists(files.Units(stage))) {
      record.stages.push_back(merged);  // "not run"
      continue;
    }
    const std::vector<WorkUnit> units = ReadUnits(files, stage);
    if (units.empty())
      merged.status = ReadJson(files.Units(stage)).value("status", "nothing to do");
    std::set<std::string> statuses;
    for (int i = 0; i < static_cast<int>(units.size()); ++i) {
      const TaskState t = ReadTask(files, stage, i);
      if (t.gave_up) {
        ++merged.failed;
        statuses.insert("failed");
        record.skipped.push_back(
            {stage, units[i].session, units[i].item,
             fmt::format("task failed after {} submission(s): {}", t.submissions, t.message)});
        continue;
      }
      if (t.state != "done" || !fs::exists(files.TaskRecord(stage, i))) {
        statuses.insert("not run");
        continue;
      }
      const RunRecord unit = ReadRunRecord(files.TaskRecord(stage, i).string());
      for (const StageRecord& s : unit.stages) {
        merged.seconds += s.seconds;
        merged.cpu_seconds += s.cpu_seconds;
        merged.peak_rss_mb = std::max(merged.peak_rss_mb, s.peak_rss_mb);
        merged.done += s.done;
        merged.skipped += s.skipped;
        merged.failed += s.failed;
        for (const std::string& m : s.messages) {
          if (merged.messages.size() < StageRecord::kMaxMessages) merged.messages.push_back(m);
        }
        statuses.insert(s.status);
      }
      record.skipped.insert(record.skipped.end(), unit.skipped.begin(), unit.skipped.end());
    }
    if (!units.empty()) {
      if (statuses.count("not run")) {
        merged.status = "not run";
      } else if (statuses.count("failed") || statuses.count("partial")) {
        merged.status = statuses.size() == 1 && statuses.count("failed") ? "failed" : "partial";
      } else if (statuses.count("done")) {
        merged.status = "done";
      } else if (statuses.size() == 1) {
        merged.status = *statuses.begin();  // up to date, disabled, nothing to do
      } else {
        merged.status = "up to date";
      }
    }
    record.stages.push_back(merged);
  }
  record.finished = plan.finished ? IsoTimeNow() : "";
  // As the local run records it: complete when every stage ran (the report reads this record
  // before its own stage has run, so the report's stage does not count).
  record.complete = !plan.stopped && !record.AnyStageFailed() &&
                    std::none_of(record.stages.begin(), record.stages.end() - 1,
                                 [](const StageRecord& s) { return s.status == "not run"; });
  WriteRunRecord(workspace::Layout(plan.workspace).RunRecord().string(), record);
}

// The status of a stage without units, as the local run records it.
std::string EmptyStageStatus(const std::string& stage, const RunConfig& config) {
  const bool disabled = (stage == "densify" && !config.densify) ||
                        (stage == "report" && !config.report) || stage == "eval";
  return disabled ? "disabled" : "nothing to do";
}

// Whether any pass of any session was solved (the local run stops after slam otherwise).
bool AnyPassSolved(const Plan& plan) {
  const workspace::Layout layout(plan.workspace);
  for (const WorkUnit& u : ListWorkUnits(plan.field, plan.workspace, {}, "slam")) {
    if (fs::exists(layout.PassSummary(u.session, u.item))) return true;
  }
  return false;
}

std::string ThisBinary() {
  std::error_code ec;
  const fs::path self = fs::read_symlink("/proc/self/exe", ec);
  if (ec) throw InputError("crop4d", 0, "cannot find this program's path: give --crop4d");
  return self.string();
}

// The job ids of this cluster run still known to Slurm's queue; unset when squeue is missing or
// fails.
std::optional<std::vector<std::string>> QueuedJobs(const std::string& workspace) {
  const fs::path jobs = ClusterFiles(workspace).Jobs();
  std::vector<std::string> ids;
  std::ifstream in(jobs);
  for (std::string line; std::getline(in, line);) {
    const json j = json::parse(line, nullptr, false);
    if (j.is_object() && j.contains("job")) ids.push_back(j["job"]);
  }
  if (ids.empty()) return std::vector<std::string>{};
  ProcessOutput out;
  try {
    out = RunProcess(
        {"squeue", "--noheader", "--format=%A", fmt::format("--jobs={}", fmt::join(ids, ","))});
  } catch (const InputError&) {
    return std::nullopt;
  }
  // squeue refuses a list whose jobs have all left the queue ("Invalid job id").
  if (out.exit_code != 0) {
    if (out.output.find("Invalid job id") != std::string::npos) return std::vector<std::string>{};
    return std::nullopt;
  }
  std::vector<std::string> queued;
  std::istringstream lines(out.output);
  for (std::string id; lines >> id;) queued.push_back(id);
  return queued;
}

// Writes a new plan into the workspace (the previous cluster run's task states go; its outputs
// stay), with the configuration the tasks read and their batch script. Holds the workspace's
// lock exclusively meanwhile; refuses while jobs of an unfinished earlier plan are queued.
void WritePlan(const Plan& plan, const RunConfig& config) {
  const workspace::Layout layout(plan.workspace);
  const ClusterFiles files(plan.workspace);
  const io::WorkspaceLock lock(
      layout.Lock(), plan.local_jobs > 0 ? "crop4d run --jobs" : "crop4d run --executor slurm");
  if (fs::exists(files.Plan())) {
    const Plan previous = ReadPlan(plan.workspace);
    // An unfinished local run has no queue: its processes ended with it.
    if (!previous.finished && previous.local_jobs == 0) {
      const std::optional<std::vector<std::string>> queued = QueuedJobs(plan.workspace);
      if (!queued) {
        throw InputError(plan.workspace, 0,
                         "an unfinished cluster run of this workspace exists and squeue cannot "
                         "say whether its jobs still run");
      }
      if (!queued->empty()) {
        throw InputError(plan.workspace, 0,
                         fmt::format("a cluster run of this workspace is still queued or running "
                                     "(jobs {}): crop4d status shows it; scancel its jobs to "
                                     "stop it",
                                     fmt::join(*queued, ", ")));
      }
    }
  }
  io::RemoveStaleTemporaryFiles(plan.workspace);
  fs::remove_all(files.dir);
  fs::create_directories(files.dir);
  io::WriteFileAtomic(layout.Config().string(), FormatRunConfig(config));
  io::WriteFileAtomic(files.Script().string(),
                      "#!/bin/sh\n# A crop4d cluster task: the command is the job's arguments.\n"
                      "exec \"$@\"\n");
  fs::permissions(files.Script(), fs::perms::owner_exec | fs::perms::group_exec,
                  fs::perm_options::add);
  WriteJson(files.Plan(), ToJson(plan));
}

// A new plan of the season: checks the configuration and the field (an unreadable one fails
// here, not in a task) and creates the workspace folder.
Plan NewPlan(const std::string& field_folder, const std::string& workspace,
             const RunOptions& options) {
  std::string message;
  if (!options.config.Check(&message)) throw InputError(options.config_source, 0, message);
  const io::Field field(field_folder);
  if (field.session_ids().empty()) throw InputError(field_folder, 0, "the field has no session");
  std::error_code ec;
  fs::create_directories(workspace, ec);
  if (ec || !fs::is_directory(workspace)) {
    throw InputError(workspace, 0, "cannot create the workspace folder: " + ec.message());
  }
  Plan plan;
  plan.field = fs::absolute(field_folder).lexically_normal().string();
  plan.workspace = fs::absolute(workspace).lexically_normal().string();
  plan.config_source = options.config_source;
  plan.submitted = IsoTimeNow();
  plan.force = options.force;
  return plan;
}

}  // namespace

std::string SlurmOptions::Check() const {
  if (cpus_per_task < 1) return "cpus_per_task: must be >= 1";
  if (max_attempts < 1) return "max_attempts: must be >= 1";
  if (sbatch.empty()) return "sbatch: must name the sbatch command";
  for (const std::string& a : sbatch_args) {
    if (a.rfind("--array", 0) == 0 || a.rfind("--dependency", 0) == 0 ||
        a.rfind("--output", 0) == 0) {
      return "sbatch_args: " + a + " is set by crop4d itself";
    }
  }
  return {};
}

bool ClusterStatus::Stalled() const { return !finished && in_queue && !*in_queue; }

bool ClusterStatus::Complete() const {
  if (!finished || stopped) return false;
  for (const ClusterStageStatus& s : stages) {
    for (const TaskState& t : s.tasks) {
      if (t.state != "done") return false;
    }
  }
  return true;
}

ClusterSubmission SubmitSeason(const std::string& field_folder, const std::string& workspace,
                               const RunOptions& options, const SlurmOptions& slurm) {
  if (const std::string why = slurm.Check(); !why.empty()) throw InputError("slurm." + why);
  Plan plan = NewPlan(field_folder, workspace, options);
  plan.slurm = slurm;
  if (plan.slurm.crop4d.empty()) plan.slurm.crop4d = ThisBinary();
  plan.slurm.crop4d = fs::absolute(plan.slurm.crop4d).string();

  WritePlan(plan, options.config);
  ClusterSubmission submission;
  submission.plan_path = ClusterFiles(plan.workspace).Plan().string();
  // The first dispatch, here: the validation's one unit needs nothing before it.
  submission.job_ids = DispatchStage(plan.workspace, kUnitStages[0]);
  return submission;
}

namespace {

// DispatchStage; for a local plan, the units run before it returns and the stage to dispatch
// next goes to `local_next` (empty: the run has ended).
std::vector<std::string> Dispatch(const std::string& workspace, const std::string& stage,
                                  std::string* local_next) {
  Plan plan = ReadPlan(workspace);
  const ClusterFiles files(plan.workspace);
  const io::WorkspaceLock lock(workspace::Layout(plan.workspace).Lock(), "crop4d task dispatch",
                               io::WorkspaceLock::IfBusy::kWait,
                               io::WorkspaceLock::Sharing::kShared);
  int index = StageIndex(stage);
  // The stage before: its units that did not finish run again while they have attempts left.
  if (index > 0) {
    const std::string previous = kUnitStages[index - 1];
    const std::vector<WorkUnit> units = ReadUnits(files, previous);
    std::vector<int> again;
    for (int i = 0; i < static_cast<int>(units.size()); ++i) {
      const TaskState before = ReadTask(files, previous, i);
      TaskState t = before;
      if (ConcludeAfterArray(t, plan.slurm.max_attempts)) again.push_back(i);
      if (ToJson(t) != ToJson(before)) WriteJson(files.Task(previous, i), ToJson(t));
    }
    if (!again.empty()) {
      spdlog::info("{}: {} unit(s) to run again", previous, again.size());
      std::vector<std::string> jobs = SubmitUnits(plan, previous, again, {});
      jobs.push_back(ChainDispatch(plan, stage, jobs, local_next));
      WriteMergedRecord(plan);
      return jobs;
    }
  }
  // The next stage with units: submitted, with the dispatch after it.
  RunConfig config = ReadRunConfig(workspace::Layout(plan.workspace).Config().string());
  for (; index < static_cast<int>(std::size(kUnitStages)); ++index) {
    const std::string name = kUnitStages[index];
    if (name == "associate" && !AnyPassSolved(plan)) {
      // As the local run: nothing downstream of row SLAM can run.
      spdlog::error("row SLAM gave no pass in any session: nothing to go on with");
      plan.finished = plan.stopped = true;
      WriteJson(files.Plan(), ToJson(plan));
      WriteMergedRecord(plan);
      return {};
    }
    const std::vector<WorkUnit> units = ListWorkUnits(plan.field, plan.workspace, config, name);
    fs::create_directories(files.StageDir(name));
    json list = json::array();
    for (const WorkUnit& u : units) list.push_back(ToJson(u));
    WriteJson(files.Units(name),
              {{"stage", name}, {"units", list}, {"status", EmptyStageStatus(name, config)}});
    if (units.empty()) {
      spdlog::info("{}: no unit", name);
      continue;
    }
    std::vector<int> ids(units.size());
    for (int i = 0; i < static_cast<int>(ids.size()); ++i) ids[i] = i;
    std::vector<std::string> jobs = SubmitUnits(plan, name, ids, {});
    const std::string next =
        index + 1 < static_cast<int>(std::size(kUnitStages)) ? kUnitStages[index + 1] : "end";
    jobs.push_back(ChainDispatch(plan, next, jobs, local_next));
    WriteMergedRecord(plan);
    return jobs;
  }
  plan.finished = true;
  WriteJson(files.Plan(), ToJson(plan));
  WriteMergedRecord(plan);
  spdlog::info("cluster run finished: {}", workspace::Layout(plan.workspace).RunRecord().string());
  return {};
}

}  // namespace

std::vector<std::string> DispatchStage(const std::string& workspace, const std::string& stage) {
  std::string local_next;
  return Dispatch(workspace, stage, &local_next);
}

RunResult RunSeasonInParallel(const std::string& field_folder, const std::string& workspace,
                              const RunOptions& options, int jobs) {
  if (jobs < 1) throw InputError("--jobs", 0, "must be >= 1");
  Plan plan = NewPlan(field_folder, workspace, options);
  plan.slurm.crop4d = ThisBinary();
  plan.local_jobs = jobs;
  plan.local_threads = options.config.threads > 0
                           ? options.config.threads
                           : std::max(1, static_cast<int>(std::thread::hardware_concurrency()));
  plan.slurm.cpus_per_task = std::max(1, plan.local_threads / jobs);
  WritePlan(plan, options.config);
  // Held shared for the whole run: another crop4d run waits or refuses, as with a local run.
  const io::WorkspaceLock lock(workspace::Layout(plan.workspace).Lock(), "crop4d run --jobs",
                               options.wait_for_workspace ? io::WorkspaceLock::IfBusy::kWait
                                                          : io::WorkspaceLock::IfBusy::kFail,
                               io::WorkspaceLock::Sharing::kShared);
  spdlog::info("crop4d {} run: field {}, workspace {}, {} units at once", kVersion, plan.field,
               plan.workspace, jobs);
  for (std::string stage = kUnitStages[0]; !stage.empty();) {
    std::string next;
    Dispatch(plan.workspace, stage, &next);
    stage = next;
  }
  const std::string record_path = workspace::Layout(plan.workspace).RunRecord().string();
  return {ReadRunRecord(record_path), record_path};
}

int RunClusterTask(const std::string& workspace, const std::string& stage, int index, int threads) {
  const Plan plan = ReadPlan(workspace);
  const ClusterFiles files(plan.workspace);
  const std::vector<WorkUnit> units = ReadUnits(files, stage);
  if (index < 0 || index >= static_cast<int>(units.size())) {
    throw InputError(files.Units(stage).string(), 0,
                     fmt::format("no unit {} ({} units)", index, units.size()));
  }
  TaskState t = ReadTask(files, stage, index);
  t.state = "running";
  ++t.attempts;
  const char* array_job = std::getenv("SLURM_ARRAY_JOB_ID");
  const char* array_task = std::getenv("SLURM_ARRAY_TASK_ID");
  const char* job = std::getenv("SLURM_JOB_ID");
  t.job = array_job && array_task ? fmt::format("{}_{}", array_job, array_task) : job ? job : "";
  char host[256] = "?";
  ::gethostname(host, sizeof(host) - 1);
  t.host = host;
  t.started = IsoTimeNow();
  t.finished.clear();
  t.message.clear();
  t.status.clear();
  WriteJson(files.Task(stage, index), ToJson(t));
  const auto start = std::chrono::steady_clock::now();
  try {
    const io::WorkspaceLock lock(workspace::Layout(plan.workspace).Lock(), "crop4d task",
                                 io::WorkspaceLock::IfBusy::kFail,
                                 io::WorkspaceLock::Sharing::kShared);
    RunOptions options;
    options.config = ReadRunConfig(workspace::Layout(plan.workspace).Config().string());
    options.config.threads = threads > 0 ? threads : plan.slurm.cpus_per_task;
    options.config_source = plan.config_source;
    options.force = plan.force;
    options.show_progress = false;
    const RunResult result =
        RunWorkUnit(plan.field, plan.workspace, options, units[index],
                    files.TaskRecord(stage, index).string(), files.TaskLog(stage, index).string());
    t.state = "done";
    t.status = result.record.stages.front().status;
  } catch (const std::exception& e) {
    t.state = "failed";
    t.message = e.what();
    spdlog::error("{}: {}", units[index].Name(), e.what());
  }
  t.finished = IsoTimeNow();
  t.seconds = SecondsSince(start);
  WriteJson(files.Task(stage, index), ToJson(t));
  return t.state == "done" ? 0 : 1;
}

ClusterStatus ReadClusterStatus(const std::string& workspace) {
  const Plan plan = ReadPlan(workspace);
  const ClusterFiles files(plan.workspace);
  ClusterStatus status;
  status.field = plan.field;
  status.submitted = plan.submitted;
  status.finished = plan.finished;
  status.stopped = plan.stopped;
  status.max_attempts = plan.slurm.max_attempts;
  // A local run (crop4d run --jobs) has no queue to ask.
  if (!plan.finished && plan.local_jobs == 0) {
    if (const auto queued = QueuedJobs(plan.workspace)) status.in_queue = !queued->empty();
  }
  for (const char* stage : kUnitStages) {
    ClusterStageStatus s;
    s.stage = stage;
    s.listed = fs::exists(files.Units(stage));
    if (s.listed) {
      s.units = ReadUnits(files, stage);
      for (int i = 0; i < static_cast<int>(s.units.size()); ++i) {
        s.tasks.push_back(ReadTask(files, stage, i));
      }
    }
    status.stages.push_back(std::move(s));
  }
  return status;
}

std::string FormatClusterStatus(const ClusterStatus& status) {
  std::string out =
      fmt::format("cluster run of {}, submitted {}: {}\n", status.field, status.submitted,
                  status.Stalled()    ? "stalled"
                  : !status.finished  ? "in progress"
                  : status.stopped    ? "stopped (no pass solved)"
                  : status.Complete() ? "finished"
                                      : "finished with failed units");
  out += fmt::format("{:<10} {:>6} {:>8} {:>8} {:>6} {:>7}\n", "stage", "units", "waiting",
                     "running", "done", "failed");
  std::vector<std::string> failures;
  for (const ClusterStageStatus& s : status.stages) {
    if (!s.listed) {
      out += fmt::format("{:<10} {:>6}\n", s.stage, "-");
      continue;
    }
    int waiting = 0, running = 0, done = 0, failed = 0;
    for (std::size_t i = 0; i < s.tasks.size(); ++i) {
      const TaskState& t = s.tasks[i];
      if (t.state == "done") {
        ++done;
      } else if (t.state == "running") {
        ++running;
      } else if (t.gave_up) {
        ++failed;
        failures.push_back(fmt::format("  {}: {} submission(s), {} run(s), last job {}: {}",
                                       s.units[i].Name(), t.submissions, t.attempts,
                                       t.job.empty() ? "-" : t.job, t.message));
      } else {
        ++waiting;  // not started, or failed with attempts left
      }
    }
    out += fmt::format("{:<10} {:>6} {:>8} {:>8} {:>6} {:>7}\n", s.stage, s.units.size(), waiting,
                       running, done, failed);
  }
  if (!failures.empty()) out += "failed units:\n" + fmt::format("{}\n", fmt::join(failures, "\n"));
  if (status.Stalled()) {
    out +=
        "no job of this run is left in Slurm's queue: a dispatch failed or was cancelled (its "
        "output: WS/cluster/dispatch-*.out); `crop4d run --executor slurm` again resumes, "
        "skipping the work that is done\n";
  }
  return out;
}

}  // namespace crop4d::pipeline
