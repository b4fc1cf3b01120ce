#include "crop4d/pipeline/season_run.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <optional>
#include <set>

#include "crop4d/core/allocator.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/resource_usage.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/validator.h"
#include "crop4d/io/workspace_lock.h"
#include "crop4d/pipeline/season_run_eval.h"
#include "crop4d/report/html_report.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {

namespace fs = std::filesystem;

bool RunResult::any_stage_failed() const { return record.AnyStageFailed(); }

namespace {

// WS/crop4d.log on the default logger for the lifetime of the object.
class ScopedLogFile {
 public:
  explicit ScopedLogFile(const std::string& path) : sink_(AddLogFile(path)) {}
  ~ScopedLogFile() { RemoveLogSink(sink_); }

 private:
  spdlog::sink_ptr sink_;
};

// The state of one run: the record, the log and the stage being run.
class SeasonRun {
 public:
  // The whole season, recorded in WS/run.json and WS/run_log.jsonl.
  SeasonRun(std::string field, std::string workspace, const RunOptions& options)
      : SeasonRun(std::move(field), std::move(workspace), options,
                  workspace::Layout(workspace).RunRecord().string(),
                  workspace::Layout(workspace).RunLog().string(),
                  {std::begin(kRunStages), std::end(kRunStages)}) {}
  // One work unit, recorded in its own files.
  SeasonRun(std::string field, std::string workspace, const RunOptions& options,
            const WorkUnit& unit, const std::string& record_path, const std::string& log_path)
      : SeasonRun(std::move(field), std::move(workspace), options, record_path, log_path,
                  {unit.stage}) {
    unit_ = unit;
  }
  ~SeasonRun() {
    collector_->Remove();
    Progress::SetGlobalPrefix("");
  }

  RunResult Run();
  RunResult RunUnit();

 private:
  SeasonRun(std::string field, std::string workspace, const RunOptions& options,
            std::string record_path, const std::string& log_path,
            const std::vector<std::string>& stages)
      : field_(std::move(field)),
        ws_(std::move(workspace)),
        layout_(ws_),
        options_(options),
        config_(options.config),
        log_(log_path),
        record_path_(std::move(record_path)) {
    record_.crop4d_version = kVersion;
    record_.field = field_;
    record_.workspace = ws_;
    record_.started = IsoTimeNow();
    record_.threads = config_.threads;
    for (const std::string& name : stages) {
      record_.stages.emplace_back();
      record_.stages.back().name = name;
    }
    collector_ = MessageCollector::Install();
  }
  // The thread limit of the configuration (held until this object ends), and the stages'
  // thread counts from it.
  void ApplyThreads();
  // Runs one stage: times it, catches what it throws (the stage fails, the run goes on),
  // collects the messages logged meanwhile, and writes WS/run.json.
  void Stage(const std::string& name, const std::function<void(StageRecord&)>& body);
  void Item(StageRecord& stage, const std::string& session, const std::string& item,
            const char* action, double seconds, const std::string& reason = "");
  void Skip(const std::string& stage, const std::string& session, const std::string& item,
            const std::string& reason);

  void Validate(StageRecord& stage);
  void Passes(StageRecord& stage);
  void Slam(StageRecord& stage);
  void Associate(StageRecord& stage);
  void Fuse(StageRecord& stage);
  void Densify(StageRecord& stage);
  void Analyze(StageRecord& stage);
  void Eval(StageRecord& stage);
  void Report(StageRecord& stage);

  // Sessions with at least one row pass in the workspace.
  std::vector<std::string> SessionsWithPasses() const;

  std::string field_, ws_;
  workspace::Layout layout_;  // the paths of ws_
  RunOptions options_;
  RunConfig config_;
  std::vector<std::string> sessions_;
  RunLog log_;
  std::string record_path_;
  RunRecord record_;
  std::shared_ptr<MessageCollector> collector_;
  int stage_index_ = 0;
  // Set when this object runs one work unit (RunWorkUnit) rather than the season.
  std::optional<WorkUnit> unit_;
  std::optional<tbb::global_control> threads_;
};

void SeasonRun::Item(StageRecord& stage, const std::string& session, const std::string& item,
                     const char* action, double seconds, const std::string& reason) {
  const std::string name = session.empty() ? item : item.empty() ? session : session + "/" + item;
  log_.Add(stage.name, name, action, seconds, reason);
  if (std::string(action) == kActionDone) {
    ++stage.done;
  } else if (std::string(action) == kActionUpToDate) {
    ++stage.skipped;
  } else {
    ++stage.failed;
    Skip(stage.name, session, item, reason);
  }
}

void SeasonRun::Skip(const std::string& stage, const std::string& session, const std::string& item,
                     const std::string& reason) {
  record_.skipped.push_back({stage, session, item, reason});
  spdlog::warn("{}: {}{} skipped: {}", stage, session, item.empty() ? "" : "/" + item, reason);
}

void SeasonRun::Stage(const std::string& name, const std::function<void(StageRecord&)>& body) {
  ++stage_index_;
  StageRecord& stage = *record_.Stage(name);
  if (unit_) {
    Progress::SetGlobalPrefix(fmt::format("[{}] ", unit_->Name()));
    spdlog::info("== {}", unit_->Name());
  } else {
    Progress::SetGlobalPrefix(
        fmt::format("[{}/{} {}] ", stage_index_, std::size(kRunStages), name));
    spdlog::info("== {} ({}/{})", name, stage_index_, std::size(kRunStages));
  }
  log_.Add(name, "", "start");
  collector_->Take(0);  // messages of earlier stages are theirs
  const auto start = std::chrono::steady_clock::now();
  const double cpu_start = ProcessCpuSeconds();
  // What the stages before freed goes back to the kernel: the stage's peak is then its own (and
  // what is still live), and its memory is not crowded by an earlier stage's.
  ReturnFreedMemory();
  const bool peak_restarted = ResetPeakResidentMemory();
  try {
    body(stage);
    if (stage.status == "not run") {
      stage.status = stage.failed > 0 ? "partial" : stage.done > 0 ? "done" : "up to date";
    }
  } catch (const std::exception& e) {
    stage.status = "failed";
    Skip(name, "", "", e.what());
  }
  stage.seconds = SecondsSince(start);
  stage.cpu_seconds = ProcessCpuSeconds() - cpu_start;
  stage.peak_rss_mb = peak_restarted ? PeakResidentMemoryMb() : std::nan("");
  stage.messages = collector_->Take(StageRecord::kMaxMessages);
  log_.Add(name, "", "end", stage.seconds, stage.status);
  WriteRunRecord(record_path_, record_);
}

void SeasonRun::Validate(StageRecord& stage) {
  io::ValidateOptions o;
  o.progress = options_.show_progress;
  const io::ValidationReport report = io::ValidateField(field_, o);
  // Problems per session; the run goes on (a stage that cannot use a session says so).
  std::map<std::string, std::pair<int, std::string>> per_session;
  for (const io::Diagnostic& d : report.diagnostics) {
    if (d.severity != io::Severity::kError) continue;
    std::string session;
    if (d.file.rfind("sessions/", 0) == 0) {
      session = d.file.substr(9, d.file.find('/', 9) - 9);
    }
    auto& [count, first] = per_session[session];
    if (count++ == 0) first = d.ToString();
  }
  // A session whose name the outputs cannot hold is not processed at all (io::NameProblem).
  std::set<std::string> unnamable;
  for (const io::SessionReport& session : report.sessions) {
    if (session.name_problem.empty()) continue;
    unnamable.insert(session.id);
    Item(stage, session.id, "", kActionSkipped, 0,
         session.name_problem + ": not processed (rename the folder and its line in field.yaml)");
  }
  for (const std::string& id : sessions_) {
    auto it = per_session.find(id);
    if (unnamable.count(id)) continue;
    if (it == per_session.end()) {
      Item(stage, id, "", kActionDone, 0);
    } else {
      // Recorded, not skipped: the session is still processed (with warnings) by the stages.
      log_.Add("validate", id, "warning", 0,
               fmt::format("{} error(s), first: {}", it->second.first, it->second.second));
      record_.skipped.push_back({"validate", id, "",
                                 fmt::format("{} problem(s) in the data, first: {} (the session "
                                             "is processed without the bad samples)",
                                             it->second.first, it->second.second)});
      ++stage.failed;
    }
  }
  if (per_session.count("")) {
    spdlog::warn("validate: {}", per_session[""].second);
  }
  sessions_.erase(std::remove_if(sessions_.begin(), sessions_.end(),
                                 [&](const std::string& id) { return unnamable.count(id) > 0; }),
                  sessions_.end());
  // A session below what its data promise (a receiver without a fix, a sensor the others have)
  // is listed as degraded with the reason: the stages still use what it has.
  for (const io::SessionReport& session : report.sessions) {
    for (const std::string& reason : session.degradations) {
      log_.Add("validate", session.id, "degraded", 0, reason);
      record_.skipped.push_back({"validate", session.id, "", "degraded: " + reason});
    }
  }
}

void SeasonRun::Slam(StageRecord& stage) {
  for (const std::string& id : sessions_) {
    SlamStageOptions o = config_.slam;
    o.session = id;
    if (unit_) o.pass = unit_->item;
    o.force = options_.force;
    o.show_progress = options_.show_progress;
    std::vector<PassReport> reports;
    try {
      reports = RunSlamStage(field_, ws_, o);
    } catch (const std::exception& e) {
      Item(stage, id, "", kActionFailed, 0, e.what());
      continue;
    }
    if (reports.empty()) Item(stage, id, "", kActionFailed, 0, "no row pass found");
    for (const PassReport& r : reports) {
      Item(stage, id, r.pass.id,
           r.failed    ? kActionFailed
           : r.skipped ? kActionUpToDate
                       : kActionDone,
           r.seconds, r.message);
    }
  }
  if (SessionsWithPasses().empty()) {
    throw InputError(ws_, 0, "row SLAM gave no pass in any session: nothing to go on with");
  }
}

void SeasonRun::Passes(StageRecord& stage) {
  for (const std::string& id : sessions_) {
    SlamStageOptions o = config_.slam;
    o.session = id;
    o.passes_only = true;
    o.show_progress = options_.show_progress;
    const auto start = std::chrono::steady_clock::now();
    try {
      RunSlamStage(field_, ws_, o);
    } catch (const std::exception& e) {
      Item(stage, id, "", kActionFailed, SecondsSince(start), e.what());
      continue;
    }
    const std::size_t n = workspace::ReadPassList(ws_, id).size();
    if (n == 0) {
      Item(stage, id, "", kActionFailed, SecondsSince(start), "no row pass found");
    } else {
      Item(stage, id, "", kActionDone, SecondsSince(start));
    }
  }
}

std::vector<std::string> SeasonRun::SessionsWithPasses() const {
  std::vector<std::string> out;
  for (const std::string& id : sessions_) {
    bool any = false;
    for (const std::string& pass : layout_.PassFolders(id)) {
      if (fs::exists(layout_.PassSummary(id, pass))) any = true;
    }
    if (any) out.push_back(id);
  }
  return out;
}

void SeasonRun::Associate(StageRecord& stage) {
  AssociateStageOptions o = config_.associate;
  if (unit_) o.pair = unit_->item;
  o.force = options_.force;
  o.show_progress = options_.show_progress;
  o.num_threads = config_.threads;
  if (ScheduleAssociations(field_, ws_, o).empty()) {
    // One camera pass per session and a single session (an EuRoC sequence, a drive processed as
    // one trajectory), or no camera: fuse registers the passes without cross-pass matches.
    stage.status = "nothing to do";
    spdlog::info("associate: no pair of row passes with a camera: nothing to associate");
    return;
  }
  for (const PassPairReport& r : RunAssociateStage(field_, ws_, o)) {
    Item(stage, "",
         fmt::format("{}/{}__{}/{} ({})", r.pair.a.session, r.pair.a.pass, r.pair.b.session,
                     r.pair.b.pass, r.method),
         r.skipped ? kActionUpToDate : kActionDone, r.seconds);
  }
}

void SeasonRun::Fuse(StageRecord& stage) {
  FuseStageOptions o = config_.fuse;
  o.force = options_.force;
  o.optimiser.row.num_threads = config_.threads;
  const FuseReport report = RunFuseStage(field_, ws_, o);
  std::string what = fmt::format("{} sessions, {} passes", report.num_sessions, report.num_passes);
  if (!report.steps.empty()) {
    const auto solved = std::count_if(report.steps.begin(), report.steps.end(),
                                      [](const FuseStepReport& s) { return !s.skipped; });
    what += fmt::format(", {} of {} steps solved", solved, report.steps.size());
  }
  Item(stage, "", what, report.skipped ? kActionUpToDate : kActionDone, report.seconds);
  // The grades of the sessions (season_quality.h): a degraded one is listed with its reasons
  // and what was done about it.
  for (const SessionGrade* g : report.quality.Degraded()) {
    for (const std::string& reason : g->reasons) {
      const std::string text =
          reason + (report.quality.any_trusted
                        ? " (registered onto the trusted sessions without moving them; not used "
                          "for their terrain, stems or growth)"
                        : " (no session is trusted: used like the others)");
      log_.Add("fuse", g->session, "degraded", 0, text);
      record_.skipped.push_back({"fuse", g->session, "", "degraded: " + text});
    }
  }
}

void SeasonRun::Densify(StageRecord& stage) {
  for (const std::string& id : sessions_) {
    if (!fs::exists(layout_.FusedPoses(id))) {
      if (fs::exists(layout_.SessionDir(id))) {
        Item(stage, id, "", kActionSkipped, 0, "no fused poses (the session has no usable pass)");
      }
      continue;
    }
    DensifyStageOptions o = config_.densify_options;
    o.sessions = {id};
    o.force = options_.force;
    o.show_progress = options_.show_progress;
    o.num_threads = config_.threads;
    try {
      for (const DensifySessionReport& r : RunDensifyStage(field_, ws_, o)) {
        Item(stage, r.session, "", r.skipped ? kActionUpToDate : kActionDone, r.seconds);
      }
    } catch (const std::exception& e) {
      Item(stage, id, "", kActionFailed, 0, e.what());
    }
  }
}

void SeasonRun::Analyze(StageRecord& stage) {
  AnalyzeStageOptions o = config_.analyze;
  o.force = options_.force;
  if (!config_.densify) o.cloud = "sparse";
  if (o.sites_file.empty() && io::Field(field_).info().sites.empty()) {
    // A recording that is not a crop trial (a walk, an EuRoC sequence, a survey) has no sites:
    // nothing to measure, and the rest of the run stands.
    stage.status = "nothing to do";
    spdlog::info(
        "analyze: the field declares no measurement sites (field.yaml `sites`, or "
        "analyze.sites_file): no crop analysis");
    return;
  }
  const AnalyzeReport report = RunAnalyzeStage(field_, ws_, o);
  Item(stage, "",
       fmt::format("{} sessions, {} site estimates", report.sessions.size(), report.sites.size()),
       report.skipped ? kActionUpToDate : kActionDone, report.seconds);
  if (!report.skipped && !IsQuiet()) {
    spdlog::info("\n{}", FormatAnalyzeReport(report));
  }
}

void SeasonRun::Eval(StageRecord& stage) {
  const bool has_truth = fs::is_directory(fs::path(field_) / "ground_truth");
  if (config_.eval == "never" || (config_.eval == "auto" && !has_truth)) {
    stage.status = "disabled";
    if (config_.eval == "auto") spdlog::info("eval: the field has no ground_truth/");
    return;
  }
  const fs::path stamp_path = layout_.EvalInputsFingerprint();
  const fs::path metrics = layout_.EvalMetrics();
  const std::string stamp = EvalInputsFingerprint(field_, layout_, config_);
  // inputs.fingerprint: the inputs' fingerprint, then the hash of the metrics.json it gave.
  std::string previous, metrics_hash;
  if (std::ifstream in(stamp_path); in) {
    std::getline(in, previous);
    std::getline(in, metrics_hash);
  }
  if (!options_.force && previous == stamp && !metrics_hash.empty() &&
      workspace::FileHash(metrics) == metrics_hash) {
    Item(stage, "", metrics.filename().string(), kActionUpToDate, 0);
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  // The metrics of older inputs go first: if the evaluation fails, the report shows none
  // rather than stale ones.
  fs::remove(stamp_path);
  fs::remove(metrics);
  eval::WorkspaceEvalOptions o = config_.eval_options;
  const eval::WorkspaceEval result = eval::EvaluateWorkspace(ws_, field_, o);
  eval::WriteWorkspaceEval(result);
  io::WriteFileAtomic(stamp_path.string(), stamp + "\n" + workspace::FileHash(metrics) + "\n");
  Item(stage, "", metrics.filename().string(), kActionDone, SecondsSince(start));
  if (!IsQuiet()) {
    spdlog::info("\n{}", eval::FormatWorkspaceEvalTable(result));
  }
}

void SeasonRun::Report(StageRecord& stage) {
  if (!config_.report) {
    stage.status = "disabled";
    return;
  }
  const auto start = std::chrono::steady_clock::now();
  report::HtmlReportOptions o;
  const report::HtmlReportResult result = report::WriteHtmlReport(ws_, field_, "", o);
  for (const std::string& line : result.skipped) spdlog::warn("report: {}", line);
  Item(stage, "", fs::path(result.path).filename().string(), kActionDone, SecondsSince(start));
}

void SeasonRun::ApplyThreads() {
  if (config_.threads > 0) {
    threads_.emplace(tbb::global_control::max_allowed_parallelism, config_.threads);
  }
  config_.slam.front_end.num_threads = config_.threads;
  config_.slam.optimiser.num_threads = config_.threads;
}

RunResult SeasonRun::RunUnit() {
  const io::Field field(field_);  // throws InputError for an unreadable field.yaml
  sessions_ = field.session_ids();
  if (!unit_->session.empty()) {
    if (std::find(sessions_.begin(), sessions_.end(), unit_->session) == sessions_.end()) {
      throw InputError(field_, 0, "no session '" + unit_->session + "' in this field");
    }
    sessions_ = {unit_->session};
  }
  ApplyThreads();
  const std::map<std::string, std::function<void(StageRecord&)>> bodies = {
      {"validate", [this](StageRecord& s) { Validate(s); }},
      {"passes", [this](StageRecord& s) { Passes(s); }},
      {"slam", [this](StageRecord& s) { Slam(s); }},
      {"associate", [this](StageRecord& s) { Associate(s); }},
      {"fuse", [this](StageRecord& s) { Fuse(s); }},
      {"densify", [this](StageRecord& s) { Densify(s); }},
      {"analyze", [this](StageRecord& s) { Analyze(s); }},
      {"eval", [this](StageRecord& s) { Eval(s); }},
      {"report", [this](StageRecord& s) { Report(s); }},
  };
  const auto body = bodies.find(unit_->stage);
  if (body == bodies.end()) throw InputError("work unit", 0, "no stage '" + unit_->stage + "'");
  Stage(unit_->stage, body->second);
  record_.complete = !record_.AnyStageFailed();
  record_.finished = IsoTimeNow();
  WriteRunRecord(record_path_, record_);
  return {record_, record_path_};
}

RunResult SeasonRun::Run() {
  const io::Field field(field_);  // throws InputError for an unreadable field.yaml
  sessions_ = field.session_ids();
  if (sessions_.empty()) throw InputError(field_, 0, "the field has no session");
  // This run holds the workspace's lock: what a killed run was writing is garbage.
  if (const int n = io::RemoveStaleTemporaryFiles(ws_); n > 0) {
    spdlog::info("removed {} temporary file(s) left by an interrupted run", n);
  }
  io::WriteFileAtomic(layout_.Config().string(), FormatRunConfig(config_));
  spdlog::info("crop4d {} run: field {} ({} sessions), workspace {}, configuration {}", kVersion,
               field_, sessions_.size(), ws_, options_.config_source);
  WriteRunRecord(record_path_, record_);

  ApplyThreads();

  Stage("validate", [this](StageRecord& s) { Validate(s); });
  Stage("slam", [this](StageRecord& s) { Slam(s); });
  if (record_.Stage("slam")->status == "failed") {
    // Nothing downstream can run; the record says why.
    record_.finished = IsoTimeNow();
    WriteRunRecord(record_path_, record_);
    return {record_, record_path_};
  }
  Stage("associate", [this](StageRecord& s) { Associate(s); });
  Stage("fuse", [this](StageRecord& s) { Fuse(s); });
  Stage("densify", [this](StageRecord& s) {
    if (config_.densify) {
      Densify(s);
    } else {
      s.status = "disabled";
    }
  });
  Stage("analyze", [this](StageRecord& s) { Analyze(s); });
  Stage("eval", [this](StageRecord& s) { Eval(s); });
  // The report shows the record: complete (every stage ran to its end) before it is drawn.
  record_.complete = !record_.AnyStageFailed();
  record_.finished = IsoTimeNow();
  WriteRunRecord(record_path_, record_);
  Stage("report", [this](StageRecord& s) { Report(s); });
  record_.complete = !record_.AnyStageFailed();
  record_.finished = IsoTimeNow();
  WriteRunRecord(record_path_, record_);
  return {record_, record_path_};
}

}  // namespace

std::string WorkUnit::Name() const {
  std::string name = stage;
  if (!session.empty()) name += " " + session + (item.empty() ? "" : "/" + item);
  if (session.empty() && !item.empty()) name += " " + item;
  return name;
}

std::vector<WorkUnit> ListWorkUnits(const std::string& field_folder, const std::string& workspace,
                                    const RunConfig& config, const std::string& stage) {
  const io::Field field(field_folder);
  const workspace::Layout layout(workspace);
  std::vector<WorkUnit> units;
  if (stage == "passes") {
    for (const std::string& id : field.session_ids()) {
      if (io::NameProblem(id).empty()) units.push_back({stage, id, ""});
    }
  } else if (stage == "slam") {
    for (const std::string& id : field.session_ids()) {
      if (!fs::exists(layout.PassList(id))) continue;
      for (const slam::RowPass& pass : workspace::ReadPassList(workspace, id)) {
        units.push_back({stage, id, pass.id});
      }
    }
  } else if (stage == "associate") {
    for (const PassPair& pair : ScheduleAssociations(field_folder, workspace, config.associate)) {
      units.push_back({stage, "", PassPairName(pair)});
    }
  } else if (stage == "densify") {
    if (!config.densify) return {};
    for (const std::string& id : field.session_ids()) {
      if (fs::exists(layout.FusedPoses(id))) units.push_back({stage, id, ""});
    }
  } else if (stage == "report") {
    if (config.report) units.push_back({stage, "", ""});
  } else if (stage == "eval") {
    const bool has_truth = fs::is_directory(fs::path(field_folder) / "ground_truth");
    if (config.eval == "always" || (config.eval == "auto" && has_truth)) {
      units.push_back({stage, "", ""});
    }
  } else if (stage == "validate" || stage == "fuse" || stage == "analyze") {
    units.push_back({stage, "", ""});
  } else {
    throw InputError("work unit", 0, "no stage '" + stage + "'");
  }
  return units;
}

RunResult RunWorkUnit(const std::string& field_folder, const std::string& workspace,
                      const RunOptions& options, const WorkUnit& unit,
                      const std::string& record_path, const std::string& log_path) {
  std::string message;
  if (!options.config.Check(&message)) throw InputError(options.config_source, 0, message);
  SeasonRun run(field_folder, workspace, options, unit, record_path, log_path);
  return run.RunUnit();
}

RunResult RunSeason(const std::string& field_folder, const std::string& workspace,
                    const RunOptions& options) {
  std::string message;
  if (!options.config.Check(&message)) throw InputError(options.config_source, 0, message);
  std::error_code ec;
  fs::create_directories(workspace, ec);
  if (ec || !fs::is_directory(workspace)) {
    throw InputError(workspace, 0, "cannot create the workspace folder: " + ec.message());
  }
  // Before anything is written: a second run must not touch the first one's files.
  const io::WorkspaceLock lock(workspace::Layout(workspace).Lock(), "crop4d run",
                               options.wait_for_workspace ? io::WorkspaceLock::IfBusy::kWait
                                                          : io::WorkspaceLock::IfBusy::kFail);
  ScopedLogFile log_file(workspace::Layout(workspace).Log().string());
  SeasonRun run(field_folder, workspace, options);
  return run.Run();
}

}  // namespace crop4d::pipeline
