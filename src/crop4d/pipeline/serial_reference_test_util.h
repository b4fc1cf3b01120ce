#pragma once

// The tiny simulated field with three sessions, views of it with fewer sessions, `crop4d` as a
// child process, and the serial run of its first two sessions that the end-to-end tests compare
// their runs with (season_run_test.cc) and show in the viewer (viewer_browser_test.cc), made once
// per build of crop4d. For tests only.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/io/test_helpers.h"
#include "crop4d/sim/cached_field_test_util.h"
#include "crop4d/sim/sim_config.h"

extern char** environ;

namespace crop4d::pipeline::testing {

namespace fs = std::filesystem;
using io::testing::Crop4dBinary;

// The tiny preset with a third session (no rain: the sessions register), simulated once per
// build tree.
inline const fs::path& ThreeSessionField() {
  static const fs::path path = [] {
    sim::SimConfig config = sim::PresetConfig("tiny");
    config.sessions = {{"2016-06-10", false}, {"2016-06-24", false}, {"2016-07-08", false}};
    return fs::path(sim::testing::CachedSimulatedField("tiny_three_sessions", config));
  }();
  return path;
}

inline std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

inline const std::vector<std::string> kSessionIds = {"2016-06-10", "2016-06-24", "2016-07-08"};

// A view of the field with the sessions `ids` only: field.yaml rewritten, the rest linked (the
// session folders and the ground truth are shared, read-only).
inline void MakeFieldViewOf(const fs::path& view, const std::vector<std::string>& ids) {
  const fs::path source = ThreeSessionField();
  fs::create_directories(view / "sessions");
  std::string yaml = Slurp(source / "field.yaml");
  for (const std::string& id : kSessionIds) {
    if (std::find(ids.begin(), ids.end(), id) != ids.end()) continue;
    const std::string line = "  - \"" + id + "\"\n";
    const std::size_t at = yaml.find(line);
    ASSERT_NE(at, std::string::npos) << line;
    yaml.erase(at, line.size());
  }
  std::ofstream(view / "field.yaml") << yaml;
  for (const std::string& id : ids) {
    if (!fs::exists(view / "sessions" / id)) {
      fs::create_directory_symlink(fs::absolute(source / "sessions" / id), view / "sessions" / id);
    }
  }
  if (!fs::exists(view / "ground_truth")) {
    fs::create_directory_symlink(fs::absolute(source / "ground_truth"), view / "ground_truth");
  }
}

// A view of the field with only its first `num_sessions` sessions.
inline void MakeFieldView(const fs::path& view, int num_sessions) {
  MakeFieldViewOf(
      view, std::vector<std::string>(kSessionIds.begin(), kSessionIds.begin() + num_sessions));
}

// Starts `crop4d args...` with output to `log`; returns its pid.
inline pid_t Start(const std::vector<std::string>& args, const fs::path& log) {
  std::vector<std::string> all = {Crop4dBinary()};
  all.insert(all.end(), args.begin(), args.end());
  std::vector<char*> argv;
  for (std::string& a : all) argv.push_back(a.data());
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = -1;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  return rc == 0 ? pid : -1;
}

// Runs to the end; returns the exit code (-1 when killed by a signal).
inline int RunToEnd(const std::vector<std::string>& args, const fs::path& log) {
  const pid_t pid = Start(args, log);
  if (pid < 0) return -2;
  int status = 0;
  waitpid(pid, &status, 0);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

inline constexpr const char* kTestConfig = "densify: {cell_m: 0.015}\n";

// The serial run (`--threads 1 --eval never`) of the field's first two sessions, the reference
// of the tests that compare a resumed, truncated, clustered or parallel run with it: its field
// view, configuration and workspace. It is run once per build of crop4d
// (sim::testing::CachedTestFolder: the serial run was a third of such a test's time).
struct SerialReference {
  fs::path field, config, ws;
  std::vector<std::string> Args(const std::vector<std::string>& extra = {}) const {
    std::vector<std::string> args = {"run",      field.string(),  "--workspace", ws.string(),
                                     "--config", config.string(), "-q",          "--threads",
                                     "1",        "--eval",        "never"};
    args.insert(args.end(), extra.begin(), extra.end());
    return args;
  }
};

inline const SerialReference& TheSerialReference() {
  static const SerialReference reference = [] {
    const std::string key =
        "crop4d " + sim::testing::BuiltFileStamp(Crop4dBinary()) + "\nconfig " + kTestConfig;
    const fs::path folder =
        sim::testing::CachedTestFolder("serial_reference", key, [](const std::string& made) {
          const SerialReference r{fs::path(made) / "field", fs::path(made) / "config.yaml",
                                  fs::path(made) / "ws"};
          MakeFieldView(r.field, 2);
          std::ofstream(r.config) << kTestConfig;
          const fs::path log = fs::path(made) / "run.log";
          const bool ok = RunToEnd(r.Args(), log) == 0;
          if (!ok) ADD_FAILURE() << "the serial reference run failed: " << Slurp(log);
          return ok;
        });
    return SerialReference{folder / "field", folder / "config.yaml", folder / "ws"};
  }();
  return reference;
}

}  // namespace crop4d::pipeline::testing
