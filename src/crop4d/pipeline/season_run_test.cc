// End-to-end tests of `crop4d run` (pipeline/season_run.h) on a simulated tiny field with three
// sessions: runs killed at random moments finish with the outputs of an uninterrupted run; a
// session added to the field redoes only its own work and what depends on every session; bad
// data in one session leaves the rest of the season processed and says what was skipped.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "crop4d/io/test_helpers.h"
#include "crop4d/pipeline/cluster_run.h"
#include "crop4d/pipeline/run_log.h"
#include "crop4d/pipeline/serial_reference_test_util.h"
#include "crop4d/sim/cached_field_test_util.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/workspace/fused_camera.h"

extern char** environ;

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using io::testing::Crop4dBinary;
using json = nlohmann::json;
using testing::kTestConfig;
using testing::MakeFieldView;
using testing::MakeFieldViewOf;
using testing::RunToEnd;
using testing::SerialReference;
using testing::Slurp;
using testing::Start;
using testing::TheSerialReference;
using testing::ThreeSessionField;

// In a field view, the folder of sensor `sensor` of session `id` becomes a folder of its own
// (its files linked but `data.csv`, copied) and is returned: its data.csv can be changed
// without touching the shared field.
fs::path OwnSensorData(const fs::path& view, const std::string& id, const std::string& sensor) {
  const fs::path session = view / "sessions" / id;
  if (fs::is_symlink(session)) {
    const fs::path target = fs::read_symlink(session);
    fs::remove(session);
    fs::create_directory(session);
    for (const auto& e : fs::directory_iterator(target)) {
      fs::create_symlink(e.path(), session / e.path().filename());
    }
  }
  const fs::path folder = session / sensor;
  if (fs::is_symlink(folder)) {
    const fs::path target = fs::read_symlink(folder);
    fs::remove(folder);
    fs::create_directory(folder);
    for (const auto& e : fs::directory_iterator(target)) {
      if (e.path().filename() == "data.csv") {
        fs::copy_file(e.path(), folder / "data.csv");
      } else {
        fs::create_symlink(e.path(), folder / e.path().filename());
      }
    }
  }
  return folder;
}

// Rewrites the data lines of a sensor CSV: `edit` returns false to drop a line.
void EditCsv(const fs::path& csv, const std::function<bool(std::string&)>& edit) {
  std::istringstream in(Slurp(csv));
  std::ostringstream out;
  std::string line;
  while (std::getline(in, line)) {
    if (!line.empty() && line[0] != '#' && !edit(line)) continue;
    out << line << "\n";
  }
  std::ofstream(csv, std::ios::trunc) << out.str();
}

// Every GPS fix of the receiver without a fix (fix column 0).
void RemoveFixes(const fs::path& view, const std::string& id, const std::string& receiver) {
  EditCsv(OwnSensorData(view, id, receiver) / "data.csv", [](std::string& line) {
    line = line.substr(0, line.rfind(',')) + ",0";
    return true;
  });
}

// Runs and kills the process with SIGKILL after `seconds` (if still running). Returns true when
// it was killed, false when it had finished before.
bool RunAndKill(const std::vector<std::string>& args, const fs::path& log, double seconds) {
  const pid_t pid = Start(args, log);
  if (pid < 0) return false;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(seconds);
  int status = 0;
  while (std::chrono::steady_clock::now() < deadline) {
    if (waitpid(pid, &status, WNOHANG) == pid) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  kill(pid, SIGKILL);
  waitpid(pid, &status, 0);
  return true;
}

// The products of a workspace: every file but the records that hold times (summaries, logs,
// run record, report), relative path → bytes.
std::map<std::string, std::string> Products(const fs::path& ws) {
  std::map<std::string, std::string> out;
  for (const auto& entry : fs::recursive_directory_iterator(ws)) {
    if (!entry.is_regular_file()) continue;
    const std::string name = entry.path().filename().string();
    const std::string ext = entry.path().extension().string();
    if (ext == ".json" || ext == ".jsonl" || ext == ".log" || name == "report.html") continue;
    out[fs::relative(entry.path(), ws).string()] = Slurp(entry.path());
  }
  return out;
}

// The coarser dense clouds of these tests (keeps them quick; the stages are the same).
// The same files (no stray temporary file, nothing missing) with the same bytes.
void ExpectSameProducts(const std::map<std::string, std::string>& expected,
                        const std::map<std::string, std::string>& actual) {
  std::set<std::string> names_expected, names_actual;
  for (const auto& [name, bytes] : expected) names_expected.insert(name);
  for (const auto& [name, bytes] : actual) names_actual.insert(name);
  EXPECT_EQ(names_actual, names_expected);
  for (const auto& [name, bytes] : expected) {
    auto it = actual.find(name);
    if (it != actual.end() && it->second != bytes) {
      ADD_FAILURE() << name << " differs from the uninterrupted run";
    }
  }
}

// Cuts `path` to `fraction` of its size.
void Truncate(const fs::path& path, double fraction) {
  ASSERT_TRUE(fs::exists(path)) << path;
  fs::resize_file(path, static_cast<std::uintmax_t>(fs::file_size(path) * fraction));
}

// Camera positions of a TUM file, by the time's text.
std::map<std::string, Eigen::Vector3d> TumPositions(const fs::path& path) {
  std::map<std::string, Eigen::Vector3d> out;
  std::istringstream in(Slurp(path));
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    std::string t;
    Eigen::Vector3d p;
    fields >> t >> p.x() >> p.y() >> p.z();
    out[t] = p;
  }
  return out;
}

// Heights of a site_heights.csv or site_truth.csv: "site session" → height, m (NaN: none).
std::map<std::string, double> SiteHeights(const fs::path& csv) {
  std::map<std::string, double> out;
  std::istringstream in(Slurp(csv));
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    std::vector<std::string> f;
    std::istringstream fields(line);
    for (std::string v; std::getline(fields, v, ',');) f.push_back(v);
    if (f.size() < 4) continue;
    out[f[0] + " " + f[1]] = f[3].empty() ? std::nan("") : std::stod(f[3]);
  }
  return out;
}

// Whether run.json lists `session` at `stage` with a reason that contains `text`.
bool Listed(const RunRecord& record, const std::string& stage, const std::string& session,
            const std::string& text) {
  for (const SkippedItem& s : record.skipped) {
    if (s.stage == stage && s.session == session && s.reason.find(text) != std::string::npos) {
      return true;
    }
  }
  return false;
}

class SeasonRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(Crop4dBinary())) << Crop4dBinary();
    dir_ = fs::path(::testing::TempDir()) /
           ("crop4d_run_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    ThreeSessionField();
    std::ofstream(dir_ / "config.yaml") << kTestConfig;
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  std::vector<std::string> RunArgs(const fs::path& field, const fs::path& ws,
                                   std::vector<std::string> extra = {}) const {
    std::vector<std::string> args = {"run",       field.string(), "--workspace",
                                     ws.string(), "--config",     (dir_ / "config.yaml").string(),
                                     "-q"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }

  fs::path dir_;
};

TEST_F(SeasonRunTest, RunsKilledAtRandomMomentsFinishWithTheOutputsOfAnUninterruptedRun) {
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 2);
  // One thread: Ceres sums in a fixed order, so results are reproducible to the last bit (with
  // more threads they agree to rounding, run to run, interrupted or not).
  const std::vector<std::string> extra = {"--threads", "1", "--eval", "never"};
  const SerialReference& reference = TheSerialReference();
  // The time of an uninterrupted run, from its stages' times in run.json.
  double full_s = 0;
  for (const auto& stage : ReadRunRecord((reference.ws / "run.json").string()).stages) {
    full_s += stage.seconds;
  }
  ASSERT_GT(full_s, 1.0);

  // Kill moments drawn at random (seeded: the test is repeatable), each 5–20 % of an
  // uninterrupted run after the start of its attempt: each resumed run gets further, since the
  // work already done is kept, and the four kills fall in different stages of the season while
  // work is still left for the last one.
  std::mt19937 rng(20261122);
  std::uniform_real_distribution<double> moment(0.05 * full_s, 0.2 * full_s);
  const fs::path ws = dir_ / "resumed";
  int kills = 0;
  for (int attempt = 0; attempt < 4; ++attempt) {
    if (RunAndKill(RunArgs(field, ws, extra), dir_ / "resumed.log", moment(rng))) ++kills;
  }
  EXPECT_GE(kills, 3) << "the runs finished before they could be killed";
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, extra), dir_ / "resumed.log"), 0)
      << Slurp(dir_ / "resumed.log");

  const auto expected = Products(reference.ws);
  ExpectSameProducts(expected, Products(ws));
  EXPECT_GT(expected.size(), 50u);  // passes, associations, fusion, dense, analysis
  EXPECT_TRUE(expected.count("analysis/site_heights.csv"));
  EXPECT_TRUE(expected.count("dense/2016-06-24.ply"));

  // The last run completed and says so.
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_TRUE(record.complete);
  EXPECT_TRUE(record.skipped.empty());
}

// Which items of `stage` the run `run_id` did (action "done").
std::set<std::string> DoneItems(const std::vector<RunEvent>& events, const std::string& run_id,
                                const std::string& stage) {
  std::set<std::string> items;
  for (const RunEvent& e : events) {
    if (e.run == run_id && e.stage == stage && e.action == kActionDone) items.insert(e.item);
  }
  return items;
}

TEST_F(SeasonRunTest, AddedSessionRedoesOnlyItsOwnWorkAndWhatDependsOnAllSessions) {
  const fs::path field = dir_ / "field";
  const fs::path ws = dir_ / "ws";
  MakeFieldView(field, 2);
  // The first run: the serial reference's, on the same two sessions (the workspace does not
  // depend on where the field lies).
  fs::copy(TheSerialReference().ws, ws, fs::copy_options::recursive);
  const std::vector<std::string> serial = {"--threads", "1", "--eval", "never"};
  // Nothing changed: nothing is redone.
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, serial), dir_ / "run2.log"), 0) << Slurp(dir_ / "run2.log");
  // The third session arrives (and the evaluation is asked for).
  fs::remove(field / "field.yaml");
  MakeFieldView(field, 3);
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, {"--threads", "1"}), dir_ / "run3.log"), 0)
      << Slurp(dir_ / "run3.log");

  const std::vector<RunEvent> events = ReadRunLog((ws / "run_log.jsonl").string());
  std::vector<std::string> runs;
  for (const RunEvent& e : events) {
    if (runs.empty() || runs.back() != e.run) runs.push_back(e.run);
  }
  ASSERT_EQ(runs.size(), 3u);

  // Run 2: up to date everywhere (the report is always drawn again).
  for (const char* stage : {"slam", "associate", "fuse", "densify", "analyze"}) {
    EXPECT_TRUE(DoneItems(events, runs[1], stage).empty()) << stage;
  }
  // Run 3: the new session's passes only.
  const std::set<std::string> slam = DoneItems(events, runs[2], "slam");
  EXPECT_EQ(slam, (std::set<std::string>{"2016-07-08/row00", "2016-07-08/row01"}));
  // Association pairs: only those with a pass of the new session (its rows with each other,
  // and with the same rows of the session before).
  const std::set<std::string> pairs = DoneItems(events, runs[2], "associate");
  EXPECT_FALSE(pairs.empty());
  for (const std::string& pair : pairs) {
    EXPECT_NE(pair.find("2016-07-08"), std::string::npos) << pair;
  }
  std::set<std::string> pairs_first_run = DoneItems(events, runs[0], "associate");
  for (const std::string& pair : pairs) EXPECT_EQ(pairs_first_run.count(pair), 0u) << pair;
  // Everything that depends on all sessions.
  EXPECT_EQ(DoneItems(events, runs[2], "fuse").size(), 1u);
  EXPECT_EQ(DoneItems(events, runs[2], "analyze").size(), 1u);
  EXPECT_EQ(DoneItems(events, runs[2], "eval").size(), 1u);
  EXPECT_TRUE(DoneItems(events, runs[2], "densify").count("2016-07-08"));

  // The results cover the three sessions.
  const std::string heights = Slurp(ws / "analysis" / "site_heights.csv");
  EXPECT_NE(heights.find("2016-07-08"), std::string::npos);
  const json metrics = json::parse(Slurp(ws / "eval" / "metrics.json"));
  EXPECT_EQ(metrics["fused"]["overall"]["num_evaluated"].get<int>(), 3);
  EXPECT_LT(metrics["fused"]["overall"]["ate_raw_m"]["rmse"].get<double>(), 0.05);
}

TEST_F(SeasonRunTest, BadDataInSessionsIsReportedAndTheRestOfTheSeasonIsProcessed) {
  // A copy of the field with: an image of a row pass overwritten with garbage (session 1), the
  // IMU file cut in the middle of a line (session 2), no GPS fix at all (session 3).
  const fs::path field = dir_ / "field";
  fs::copy(ThreeSessionField(), field, fs::copy_options::recursive);
  const fs::path s1 = field / "sessions" / "2016-06-10";
  std::vector<fs::path> images;
  for (const auto& e : fs::directory_iterator(s1 / "cam0" / "data")) images.push_back(e.path());
  std::sort(images.begin(), images.end());
  ASSERT_GT(images.size(), 100u);
  std::ofstream(images[images.size() / 4], std::ios::trunc) << "not an image";
  const fs::path imu = field / "sessions" / "2016-06-24" / "imu0" / "data.csv";
  fs::resize_file(imu, fs::file_size(imu) / 2 + 7);
  for (const char* gps : {"gps0", "gps1"}) {
    EditCsv(field / "sessions" / "2016-07-08" / gps / "data.csv", [](std::string& line) {
      line = line.substr(0, line.rfind(',')) + ",0";
      return true;
    });
  }

  const fs::path ws = dir_ / "ws";
  const int code = RunToEnd(RunArgs(field, ws, {"--eval", "never"}), dir_ / "run.log");
  EXPECT_EQ(code, 0) << Slurp(dir_ / "run.log");
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_TRUE(record.complete);
  std::set<std::string> sessions_named;
  for (const SkippedItem& s : record.skipped) sessions_named.insert(s.session);
  // Each damaged session is named, with a reason.
  for (const char* id : {"2016-06-10", "2016-06-24", "2016-07-08"}) {
    EXPECT_TRUE(sessions_named.count(id)) << id << " not in run.json's skipped list";
  }
  for (const SkippedItem& s : record.skipped) EXPECT_FALSE(s.reason.empty());
  // The readable sessions went all the way through.
  const std::string heights = Slurp(ws / "analysis" / "site_heights.csv");
  EXPECT_NE(heights.find("2016-06-10"), std::string::npos);
  EXPECT_TRUE(fs::exists(ws / "dense" / "2016-06-10.ply"));
  // The report says what was skipped: the session without GPS, with the reason.
  const std::string report = Slurp(ws / "report.html");
  EXPECT_NE(report.find("2016-07-08"), std::string::npos);
  EXPECT_NE(report.find("this session has none"), std::string::npos);
  // The terminal summary names what was skipped.
  EXPECT_NE(Slurp(dir_ / "run.log").find("skipped or degraded"), std::string::npos);
}

TEST_F(SeasonRunTest, ASecondRunOnTheSameWorkspaceRefusesOrWaitsForTheFirst) {
  const fs::path ws = dir_ / "ws";
  // The first two sessions: long enough a run to start the others while it holds the lock.
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 2);
  const std::vector<std::string> quick = {"--no-densify", "--eval", "never", "--no-report"};
  const pid_t first = Start(RunArgs(field, ws, quick), dir_ / "first.log");
  ASSERT_GT(first, 0);
  // The first run holds the lock once its line is in the lock file.
  const std::string holder = "crop4d run, pid " + std::to_string(first) + " ";
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (Slurp(ws / ".crop4d.lock").find(holder) == std::string::npos) {
    ASSERT_LT(std::chrono::steady_clock::now(), deadline) << "the first run never took the lock";
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  // A second run refuses at once (exit 2), naming the first.
  EXPECT_EQ(RunToEnd(RunArgs(field, ws, quick), dir_ / "second.log"), 2);
  EXPECT_NE(Slurp(dir_ / "second.log").find("in use by " + holder), std::string::npos)
      << Slurp(dir_ / "second.log");
  // A third, with --wait, starts once the first has ended and finds its work done.
  std::vector<std::string> waiting = quick;
  waiting.push_back("--wait");
  const pid_t third = Start(RunArgs(field, ws, waiting), dir_ / "third.log");
  ASSERT_GT(third, 0);
  std::this_thread::sleep_for(std::chrono::seconds(2));
  int status = 0;
  const bool first_outlived_the_wait = waitpid(first, &status, WNOHANG) == 0;
  if (first_outlived_the_wait) waitpid(first, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0) << Slurp(dir_ / "first.log");
  int third_status = 0;
  waitpid(third, &third_status, 0);
  EXPECT_TRUE(WIFEXITED(third_status) && WEXITSTATUS(third_status) == 0)
      << Slurp(dir_ / "third.log");
  if (first_outlived_the_wait) {
    EXPECT_NE(Slurp(dir_ / "third.log").find("waiting until it ends"), std::string::npos)
        << Slurp(dir_ / "third.log");
  }
  // The third run redid nothing, and the log has only whole lines of the two runs that ran.
  const std::vector<RunEvent> entries = ReadRunLog((ws / "run_log.jsonl").string());
  int done_after_third_start = 0, starts = 0;
  for (const RunEvent& e : entries) {
    if (e.action == "start" && e.stage == "validate") ++starts;
    if (starts == 2 && e.action == kActionDone && e.stage != "validate") ++done_after_third_start;
  }
  EXPECT_EQ(starts, 2);
  EXPECT_EQ(done_after_third_start, 0);
}

TEST_F(SeasonRunTest, AStageThatFailsAsAWholeLeavesTheRunIncomplete) {
  // A season processed up to the analysis (the serial reference's workspace), whose
  // WS/analysis is now a file, not a folder: the analysis cannot write anything and fails.
  const SerialReference& reference = TheSerialReference();
  const fs::path ws = dir_ / "ws";
  fs::copy(reference.ws, ws, fs::copy_options::recursive);
  fs::remove_all(ws / "analysis");
  std::ofstream(ws / "analysis") << "in the way\n";
  const int code =
      RunToEnd(RunArgs(reference.field, ws, {"--threads", "1", "--eval", "never", "--no-report"}),
               dir_ / "run.log");
  EXPECT_EQ(code, 1) << Slurp(dir_ / "run.log");
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_FALSE(record.complete);
  EXPECT_FALSE(record.finished.empty());
  RunRecord copy = record;
  ASSERT_NE(copy.Stage("analyze"), nullptr);
  EXPECT_EQ(copy.Stage("analyze")->status, "failed");
  EXPECT_EQ(copy.Stage("fuse")->status, "up to date");
  EXPECT_EQ(copy.Stage("densify")->status, "up to date");
  EXPECT_NE(Slurp(dir_ / "run.log").find("incomplete"), std::string::npos);
}

TEST_F(SeasonRunTest, TruncatedOutputsAreRedoneAndGiveTheResultsOfAnUninterruptedRun) {
  // On the reference's field view, whose workspace a copy of the reference is.
  const SerialReference& serial = TheSerialReference();
  const fs::path field = serial.field;
  const std::vector<std::string> extra = {"--threads", "1", "--eval", "never"};
  const fs::path reference = serial.ws;
  const fs::path ws = dir_ / "ws";
  fs::copy(reference, ws, fs::copy_options::recursive);
  // Cut short: a row pass's poses, a session's fused poses, another session's dense cloud.
  fs::path row_poses;
  for (const auto& e : fs::directory_iterator(ws / "sessions" / "2016-06-10" / "rows")) {
    if (fs::exists(e.path() / "poses.tum") && (row_poses.empty() || e.path() < row_poses)) {
      row_poses = e.path();
    }
  }
  ASSERT_FALSE(row_poses.empty());
  Truncate(row_poses / "poses.tum", 0.8);
  Truncate(ws / "fused" / "2016-06-10" / "poses.tum", 0.8);
  Truncate(ws / "dense" / "2016-06-24.ply", 0.5);

  ASSERT_EQ(RunToEnd(RunArgs(field, ws, extra), dir_ / "rerun.log"), 0)
      << Slurp(dir_ / "rerun.log");
  ExpectSameProducts(Products(reference), Products(ws));
  // Only the damaged units were redone.
  const std::vector<RunEvent> events = ReadRunLog((ws / "run_log.jsonl").string());
  const std::string last_run = events.back().run;
  EXPECT_EQ(DoneItems(events, last_run, "slam"),
            std::set<std::string>{"2016-06-10/" + row_poses.filename().string()});
  EXPECT_EQ(DoneItems(events, last_run, "fuse").size(), 1u);
  EXPECT_EQ(DoneItems(events, last_run, "densify"), std::set<std::string>{"2016-06-24"});
}

// Case 1: a session whose RTK receiver has no fix is processed with its metre-level one. It is
// listed as degraded and registered onto the healthy session without moving it, so the healthy
// session's poses, camera and canopy heights are those of a run without it: here the run in
// which it has no fix at all and is skipped. Case 2: that run takes its terrain from the later
// session, whose heights must be no more biased against the truth than with the earliest one
// (a canopy-top terrain made them 10-12 cm too low).
TEST_F(SeasonRunTest, ADegradedSessionCannotMoveAHealthyOneNorSetItsTerrain) {
  const std::vector<std::string> extra = {"--threads", "1", "--eval", "never", "--no-report"};
  const std::string early = "2016-06-10", late = "2016-06-24";
  const fs::path spoiled = dir_ / "spoiled", alone = dir_ / "alone";
  MakeFieldViewOf(spoiled, {early, late});
  RemoveFixes(spoiled, early, "gps0");
  MakeFieldViewOf(alone, {early, late});
  RemoveFixes(alone, early, "gps0");
  RemoveFixes(alone, early, "gps1");
  for (const fs::path& field : {spoiled, alone}) {
    const std::string name = field.filename().string();
    ASSERT_EQ(RunToEnd(RunArgs(field, dir_ / ("ws_" + name), extra), dir_ / (name + ".log")), 0)
        << Slurp(dir_ / (name + ".log"));
  }
  const RunRecord record = ReadRunRecord((dir_ / "ws_spoiled" / "run.json").string());
  EXPECT_TRUE(record.complete);
  EXPECT_TRUE(Listed(record, "validate", early, "gps0 has no fix"));
  EXPECT_TRUE(Listed(record, "fuse", early, "degraded: positioned with a metre-level GPS"))
      << Slurp(dir_ / "spoiled.log");
  EXPECT_NE(Slurp(dir_ / "ws_spoiled" / "fused" / "quality.json").find("\"trusted\": false"),
            std::string::npos);
  const RunRecord skipped = ReadRunRecord((dir_ / "ws_alone" / "run.json").string());
  EXPECT_TRUE(Listed(skipped, "slam", early, "")) << Slurp(dir_ / "alone.log");
  EXPECT_FALSE(fs::exists(dir_ / "ws_alone" / "fused" / early));

  const auto with = TumPositions(dir_ / "ws_spoiled" / "fused" / late / "poses.tum");
  const auto without = TumPositions(dir_ / "ws_alone" / "fused" / late / "poses.tum");
  ASSERT_GT(without.size(), 50u);
  ASSERT_EQ(with.size(), without.size());
  double worst = 0;
  for (const auto& [t, p] : without) {
    ASSERT_TRUE(with.count(t)) << t;
    worst = std::max(worst, (with.at(t) - p).norm());
  }
  EXPECT_LT(worst, 0.002);
  // The camera: refined from the trusted session alone in both runs (the degraded one then
  // holds it), so the same but for the slightly different landmarks of the two solves.
  const workspace::FusedCamera camera_with =
      workspace::ReadFusedCamera((dir_ / "ws_spoiled" / "fused" / late / "camera.json").string());
  const workspace::FusedCamera camera_without =
      workspace::ReadFusedCamera((dir_ / "ws_alone" / "fused" / late / "camera.json").string());
  EXPECT_EQ(camera_with.refined, camera_without.refined);
  EXPECT_NEAR(camera_with.intrinsics.fx, camera_without.intrinsics.fx, 0.01);
  EXPECT_NEAR(camera_with.intrinsics.cx, camera_without.intrinsics.cx, 0.01);
  EXPECT_NEAR(camera_with.intrinsics.cy, camera_without.intrinsics.cy, 0.01);
  EXPECT_NEAR(camera_with.rotation_change_deg, camera_without.rotation_change_deg, 0.01);
  const auto heights_with = SiteHeights(dir_ / "ws_spoiled" / "analysis" / "site_heights.csv");
  const auto heights_without = SiteHeights(dir_ / "ws_alone" / "analysis" / "site_heights.csv");
  int compared = 0;
  for (const auto& [key, h] : heights_without) {
    if (key.find(late) == std::string::npos) continue;
    ASSERT_TRUE(heights_with.count(key)) << key;
    // 1 cm: the dense clouds of this test's coarse 1.5 cm cells moved a site's height by up to
    // 6.2 mm for cameras 0.001 px apart (measured, with the poses 3 µm apart).
    EXPECT_NEAR(heights_with.at(key), h, 0.01) << key;
    ++compared;
  }
  EXPECT_EQ(compared, 4);

  const auto truth = SiteHeights(ThreeSessionField() / "ground_truth" / "site_truth.csv");
  const auto bias = [&](const fs::path& ws) {
    double sum = 0;
    int n = 0;
    for (const auto& [key, h] : SiteHeights(ws / "analysis" / "site_heights.csv")) {
      if (key.find(late) == std::string::npos || !std::isfinite(h)) continue;
      sum += h - truth.at(key);
      ++n;
    }
    EXPECT_EQ(n, 4) << ws;
    return sum / std::max(n, 1);
  };
  // With both sessions healthy: the serial run of the same two sessions.
  const double bias_full = bias(TheSerialReference().ws), bias_alone = bias(dir_ / "ws_alone");
  EXPECT_LE(std::abs(bias_alone), std::abs(bias_full) + 0.02)
      << "bias " << bias_alone << " m alone, " << bias_full << " m with the earliest session";
}

// A session without its RTK receiver's folder, and a pass with a 5 s IMU gap: each session is
// listed as degraded with its reason, the pass named.
TEST_F(SeasonRunTest, SessionsAreGradedByWhatTheirPassesHad) {
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 3);
  OwnSensorData(field, "2016-06-24", "gps0");
  fs::remove_all(field / "sessions" / "2016-06-24" / "gps0");
  // 5 s without IMU samples inside the second pass of 2016-07-08 (its passes are 6-7 s long).
  const fs::path imu = OwnSensorData(field, "2016-07-08", "imu0") / "data.csv";
  std::vector<long long> times;
  EditCsv(imu, [&](std::string& line) {
    times.push_back(std::stoll(line.substr(0, line.find(','))));
    return true;
  });
  ASSERT_GT(times.size(), 1000u);
  const std::string ws_probe = (dir_ / "probe").string();
  // The pass times come from a quick row SLAM of that session alone.
  ASSERT_EQ(
      RunToEnd({"slam", field.string(), "--workspace", ws_probe, "--session", "2016-07-08", "-q"},
               dir_ / "probe.log"),
      0)
      << Slurp(dir_ / "probe.log");
  const json pass = json::parse(
      Slurp(fs::path(ws_probe) / "sessions" / "2016-07-08" / "rows" / "row01" / "summary.json"));
  const long long begin = pass.at("t_begin_ns").get<long long>() + 1'000'000'000LL;
  const long long end = begin + 5'000'000'000LL;
  ASSERT_LT(end, pass.at("t_end_ns").get<long long>());
  EditCsv(imu, [&](std::string& line) {
    const long long t = std::stoll(line.substr(0, line.find(',')));
    return t < begin || t > end;
  });

  const fs::path ws = dir_ / "ws";
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, {"--no-densify", "--eval", "never", "--no-report"}),
                     dir_ / "run.log"),
            0)
      << Slurp(dir_ / "run.log");
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_TRUE(record.complete);
  EXPECT_TRUE(Listed(record, "fuse", "2016-06-24", "degraded: positioned with a metre-level GPS"))
      << Slurp(dir_ / "run.log");
  EXPECT_TRUE(Listed(record, "fuse", "2016-07-08", "degraded: pass row01: no IMU sample for 5.0 s"))
      << Slurp(dir_ / "run.log");
  EXPECT_FALSE(Listed(record, "fuse", "2016-06-10", "degraded"));
  EXPECT_NE(Slurp(dir_ / "run.log")
                .find("2016-07-08/row01: 1 gap(s) without IMU samples longer than 0.5 s inside the "
                      "pass, the longest 5.0 s"),
            std::string::npos);
}

// A session folder named with a space and an accent goes through every stage, the evaluation
// against its truth and the report included (the COLMAP export maps the space).
TEST_F(SeasonRunTest, ASessionNamedWithASpaceRunsThroughEveryStage) {
  const std::string id = "2016-06-10 fr\xc3\xbch";
  const fs::path field = dir_ / "field";
  fs::create_directories(field / "sessions");
  fs::create_directories(field / "ground_truth");
  std::string yaml = Slurp(ThreeSessionField() / "field.yaml");
  for (const std::string other : {"2016-06-24", "2016-07-08"}) {
    const std::string line = "  - \"" + other + "\"\n";
    yaml.erase(yaml.find(line), line.size());
  }
  yaml.replace(yaml.find("\"2016-06-10\""), 12, "\"" + id + "\"");
  std::ofstream(field / "field.yaml") << yaml;
  fs::create_directory_symlink(fs::absolute(ThreeSessionField() / "sessions" / "2016-06-10"),
                               field / "sessions" / id);
  for (const auto& e : fs::directory_iterator(ThreeSessionField() / "ground_truth")) {
    const std::string name = e.path().filename().string();
    if (name == "2016-06-24" || name == "2016-07-08") continue;
    fs::create_symlink(fs::absolute(e.path()),
                       field / "ground_truth" / (name == "2016-06-10" ? id : name));
  }

  const fs::path ws = dir_ / "ws";
  ASSERT_EQ(RunToEnd(RunArgs(field, ws), dir_ / "run.log"), 0) << Slurp(dir_ / "run.log");
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_TRUE(record.complete);
  EXPECT_TRUE(record.skipped.empty()) << record.skipped.front().reason;
  for (const char* stage :
       {"validate", "slam", "associate", "fuse", "densify", "analyze", "eval", "report"}) {
    RunRecord copy = record;
    ASSERT_NE(copy.Stage(stage), nullptr) << stage;
    EXPECT_EQ(copy.Stage(stage)->status, "done") << stage;
  }
  EXPECT_TRUE(fs::exists(ws / "fused" / id / "poses.tum"));
  EXPECT_TRUE(fs::exists(ws / "dense" / (id + ".ply")));
  EXPECT_NE(Slurp(ws / "analysis" / "site_heights.csv").find(id), std::string::npos);
  EXPECT_NE(Slurp(ws / "fused" / "colmap" / "images.txt").find("2016-06-10_fr\xc3\xbch/row00/"),
            std::string::npos);
  const json metrics = json::parse(Slurp(ws / "eval" / "metrics.json"));
  EXPECT_EQ(metrics["fused"]["overall"]["num_evaluated"].get<int>(), 1);
  EXPECT_NE(Slurp(ws / "report.html").find(id), std::string::npos);
}

// The dispatch between two stages of a cluster run (pipeline/cluster_run.h), with an sbatch that
// only records what it is asked: units killed while running are submitted again, units whose
// submissions are used up are reported as failed, and without a solved pass the run stops
// after slam, as the local run does.
TEST_F(SeasonRunTest, TheClusterDispatchRetriesKilledUnitsAndReportsThoseOutOfAttempts) {
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 2);
  const fs::path sbatch = dir_ / "sbatch";
  std::ofstream(sbatch) << "#!/bin/sh\n"
                           "n=$(cat \"$0.count\" 2>/dev/null || echo 100)\n"
                           "n=$((n + 1)); echo $n > \"$0.count\"\n"
                           "echo \"$@\" >> \"$0.log\"\n"
                           "echo \"$n\"\n";
  fs::permissions(sbatch, fs::perms::owner_all);
  SlurmOptions slurm;
  slurm.sbatch = sbatch.string();
  slurm.max_attempts = 2;
  slurm.crop4d = Crop4dBinary();
  RunOptions options;
  options.config.eval = "never";
  const fs::path ws = dir_ / "ws";
  const ClusterSubmission submission = SubmitSeason(field.string(), ws.string(), options, slurm);
  ASSERT_EQ(submission.job_ids, (std::vector<std::string>{"101", "102"}));
  std::string log = Slurp(dir_ / "sbatch.log");
  EXPECT_NE(log.find("--array=0-0"), std::string::npos) << log;
  EXPECT_NE(log.find("--dependency=afterany:101"), std::string::npos) << log;
  EXPECT_NE(log.find("task dispatch --workspace " + ws.string() + " --stage passes"),
            std::string::npos)
      << log;

  // The validation runs (in this process, as its job would), then the passes are submitted.
  ASSERT_EQ(RunClusterTask(ws.string(), "validate", 0), 0);
  EXPECT_EQ(DispatchStage(ws.string(), "passes"), (std::vector<std::string>{"103", "104"}));
  const fs::path passes = ws / "cluster" / "passes";
  auto set_state = [&](int i, const std::string& state, int submissions) {
    json t = json::parse(Slurp(passes / ("task-" + std::to_string(i) + ".json")));
    t["state"] = state;
    t["submissions"] = submissions;
    std::ofstream(passes / ("task-" + std::to_string(i) + ".json")) << t.dump();
  };
  // Unit 0 was killed while running; unit 1 never started and has no submission left.
  set_state(0, "running", 1);
  set_state(1, "waiting", 2);
  EXPECT_EQ(DispatchStage(ws.string(), "slam"), (std::vector<std::string>{"105", "106"}));
  log = Slurp(dir_ / "sbatch.log");
  // Unit 0 alone, again, after the first array of the passes.
  const std::size_t again = log.rfind("--job-name=crop4d-passes ");
  ASSERT_NE(again, std::string::npos) << log;
  EXPECT_NE(log.find("--job-name=crop4d-passes "), again) << log;
  EXPECT_NE(log.find("--array=0-0 ", again), std::string::npos) << log;
  ClusterStatus status = ReadClusterStatus(ws.string());
  ASSERT_EQ(status.stages[1].stage, "passes");
  EXPECT_EQ(status.stages[1].tasks[0].state, "failed");
  EXPECT_FALSE(status.stages[1].tasks[0].gave_up);
  EXPECT_EQ(status.stages[1].tasks[0].submissions, 2);
  EXPECT_TRUE(status.stages[1].tasks[1].gave_up);
  EXPECT_NE(status.stages[1].tasks[1].message.find("never started"), std::string::npos);
  EXPECT_FALSE(status.finished);

  // Unit 0 killed again: given up too; no session has a pass, so the run stops after slam.
  set_state(0, "running", 2);
  EXPECT_TRUE(DispatchStage(ws.string(), "slam").empty());
  status = ReadClusterStatus(ws.string());
  EXPECT_TRUE(status.finished);
  EXPECT_TRUE(status.stopped);
  EXPECT_FALSE(status.Complete());
  const std::string table = FormatClusterStatus(status);
  EXPECT_NE(table.find("stopped"), std::string::npos) << table;
  EXPECT_NE(table.find("killed while running"), std::string::npos) << table;
  const RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_FALSE(record.complete);
  EXPECT_EQ(record.skipped.size(), 2u);
  RunRecord copy = record;
  EXPECT_EQ(copy.Stage("validate")->status, "done");
  EXPECT_EQ(copy.Stage("passes")->status, "failed");
  EXPECT_EQ(copy.Stage("fuse")->status, "not run");
}

// The tiny field through the Slurm executor (pipeline/cluster_run.h) on a one-node cluster
// (scripts/local-slurm.sh; root and Debian's slurm-wlm, which scripts/install-deps.sh installs):
// with one thread per task its products are those of the local run to the byte, and a task
// killed while it runs (scancel) is run again with the same result.
class SlurmRunTest : public SeasonRunTest {
 protected:
  void SetUp() override {
    if (::geteuid() != 0) GTEST_SKIP() << "the one-node Slurm cluster needs root";
    if (std::system("command -v sbatch >/dev/null && command -v slurmd >/dev/null") != 0) {
      GTEST_SKIP() << "Slurm is not installed (scripts/install-deps.sh)";
    }
    SeasonRunTest::SetUp();
    const std::string script = std::string(CROP4D_SOURCE_DIR) + "/scripts/local-slurm.sh";
    started_cluster_ = std::system((script + " status >/dev/null 2>&1").c_str()) != 0;
    ASSERT_EQ(std::system((script + " start >/dev/null").c_str()), 0) << "no cluster: " << script;
    ::setenv("SLURM_CONF", "/tmp/crop4d-slurm/slurm.conf", 1);
  }
  void TearDown() override {
    if (started_cluster_) {
      const std::string script = std::string(CROP4D_SOURCE_DIR) + "/scripts/local-slurm.sh";
      EXPECT_EQ(std::system((script + " stop >/dev/null").c_str()), 0);
    }
    if (!dir_.empty()) SeasonRunTest::TearDown();
  }
  bool started_cluster_ = false;
};

// The products of a workspace without the cluster run's own records.
std::map<std::string, std::string> ProductsOutsideCluster(const fs::path& ws) {
  std::map<std::string, std::string> products = Products(ws);
  std::erase_if(products, [](const auto& p) { return p.first.rfind("cluster/", 0) == 0; });
  return products;
}

// The products of a clustered or parallel run in `ws` (its cluster/ records aside) are those of
// the serial reference to the byte, and its record says it completed, with slam run and both
// sessions densified.
void ExpectTheSerialRunsProducts(const fs::path& ws) {
  const auto expected = Products(TheSerialReference().ws);
  ExpectSameProducts(expected, ProductsOutsideCluster(ws));
  EXPECT_TRUE(expected.count("analysis/site_heights.csv"));
  RunRecord record = ReadRunRecord((ws / "run.json").string());
  EXPECT_TRUE(record.complete);
  ASSERT_NE(record.Stage("slam"), nullptr);
  EXPECT_EQ(record.Stage("slam")->status, "done");
  ASSERT_NE(record.Stage("densify"), nullptr);
  EXPECT_EQ(record.Stage("densify")->done, 2);
}

TEST_F(SlurmRunTest, TheTinyFieldGivesTheLocalRunsOutputsAndAKilledTaskRunsAgain) {
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 2);
  const std::vector<std::string> extra = {"--threads", "1", "--eval", "never"};

  const fs::path ws = dir_ / "cluster";
  std::vector<std::string> cluster = extra;
  cluster.insert(cluster.end(), {"--executor", "slurm", "--cpus-per-task", "1"});
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, cluster), dir_ / "cluster.log"), 0)
      << Slurp(dir_ / "cluster.log");

  // The first slam task seen running is cancelled.
  std::string killed_task, killed_job;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::minutes(10);
  while (killed_job.empty() && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    const json plan = json::parse(Slurp(ws / "cluster" / "season.json"), nullptr, false);
    ASSERT_FALSE(plan.is_object() && plan.value("finished", false))
        << "the run finished before a slam task was seen running";
    if (!fs::is_directory(ws / "cluster" / "slam")) continue;
    for (const auto& entry : fs::directory_iterator(ws / "cluster" / "slam")) {
      const std::string name = entry.path().filename().string();
      if (name.rfind("task-", 0) != 0 || name.find(".run.") != std::string::npos ||
          entry.path().extension() != ".json") {
        continue;
      }
      const json state = json::parse(Slurp(entry.path()), nullptr, false);
      if (state.is_object() && state.value("state", "") == "running") {
        killed_task = name;
        killed_job = state.value("job", "");
        break;
      }
    }
  }
  ASSERT_FALSE(killed_job.empty()) << "no slam task was seen running";
  ASSERT_EQ(std::system(("scancel " + killed_job).c_str()), 0) << killed_job;

  ASSERT_EQ(RunToEnd({"status", ws.string(), "--wait", "--poll", "0.5"}, dir_ / "status.log"), 0)
      << Slurp(dir_ / "status.log");
  const json state = json::parse(Slurp(ws / "cluster" / "slam" / killed_task));
  EXPECT_EQ(state["state"], "done") << killed_task;
  EXPECT_EQ(state["attempts"].get<int>(), 2) << killed_task << " of job " << killed_job;

  ExpectTheSerialRunsProducts(ws);
}

// crop4d run --jobs (cluster_run.h RunSeasonInParallel): the work units side by side as
// `crop4d task run` processes on this machine; with one thread per task its products are those
// of the serial run to the byte.
TEST_F(SeasonRunTest, UnitsSideBySideOnOneMachineGiveTheSerialRunsOutputs) {
  const fs::path field = dir_ / "field";
  MakeFieldView(field, 2);
  const std::vector<std::string> extra = {"--threads", "1", "--eval", "never"};
  const fs::path ws = dir_ / "parallel";
  std::vector<std::string> parallel = extra;
  parallel.insert(parallel.end(), {"--jobs", "2"});
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, parallel), dir_ / "parallel.log"), 0)
      << Slurp(dir_ / "parallel.log");

  ExpectTheSerialRunsProducts(ws);
  // Every slam unit ran once, as its own process.
  const json units = json::parse(Slurp(ws / "cluster" / "slam" / "units.json"));
  ASSERT_GE(units["units"].size(), 4u);
  for (std::size_t i = 0; i < units["units"].size(); ++i) {
    const json state =
        json::parse(Slurp(ws / "cluster" / "slam" / ("task-" + std::to_string(i) + ".json")));
    EXPECT_EQ(state["state"], "done") << i;
    EXPECT_EQ(state["attempts"].get<int>(), 1) << i;
  }
  // Run again: everything is up to date.
  ASSERT_EQ(RunToEnd(RunArgs(field, ws, parallel), dir_ / "again.log"), 0)
      << Slurp(dir_ / "again.log");
  ExpectSameProducts(Products(TheSerialReference().ws), ProductsOutsideCluster(ws));
}

}  // namespace
}  // namespace crop4d::pipeline
