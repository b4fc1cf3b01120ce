// The viewer page in headless Chromium against `crop4d view` on a small workspace
// (viewer_data_test_util.h) and on the tiny simulated field's workspace with its dense clouds: no
// console error, every date in the page's state, the time slider switches dates, two dates overlay,
// change colouring and measuring work (viewer/test/browser_check.cjs). Fails, never skips, when
// node or chromium is missing.

#include <gtest/gtest.h>
#include <signal.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <regex>
#include <string>
#include <thread>
#include <utility>

#include "crop4d/io/test_helpers.h"
#include "crop4d/pipeline/serial_reference_test_util.h"
#include "crop4d/viewer/viewer_data_test_util.h"

extern char** environ;

namespace crop4d::viewer {
namespace {

namespace fs = std::filesystem;
using io::testing::ShellQuote;
using io::testing::TempDir;

// `crop4d view` as a child process; stopped (SIGTERM) on destruction.
class ViewProcess {
 public:
  explicit ViewProcess(const std::string& ws) {
    int fds[2];
    if (::pipe(fds) != 0) return;
    posix_spawn_file_actions_t actions;
    posix_spawn_file_actions_init(&actions);
    posix_spawn_file_actions_adddup2(&actions, fds[1], STDOUT_FILENO);
    posix_spawn_file_actions_addclose(&actions, fds[0]);
    const std::string binary = io::testing::Crop4dBinary();
    std::vector<std::string> args = {binary, "view", ws, "--port", "0", "--no-browser"};
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    if (::posix_spawn(&pid_, binary.c_str(), &actions, nullptr, argv.data(), environ) != 0)
      pid_ = -1;
    posix_spawn_file_actions_destroy(&actions);
    ::close(fds[1]);
    out_ = ::fdopen(fds[0], "r");
  }
  ~ViewProcess() {
    if (pid_ > 0) {
      ::kill(pid_, SIGTERM);
      int status = 0;
      ::waitpid(pid_, &status, 0);
    }
    if (out_ != nullptr) std::fclose(out_);
  }
  // The URL it prints, or "" when it exits first (`log` gets what it printed).
  std::string Url(std::string* log) {
    std::array<char, 4096> line;
    const std::regex url(R"((http://127\.0\.0\.1:\d+/))");
    while (out_ != nullptr && std::fgets(line.data(), line.size(), out_) != nullptr) {
      *log += line.data();
      std::smatch m;
      const std::string text = line.data();
      if (std::regex_search(text, m, url)) return m[1];
    }
    return "";
  }

 private:
  pid_t pid_ = -1;
  FILE* out_ = nullptr;
};

bool Executable(const std::string& path) { return ::access(path.c_str(), X_OK) == 0; }

// Serves `ws` with `crop4d view` and runs viewer/test/browser_check.cjs on it; `dates_json`: the
// dates the page must list, `expected_log`: a text `crop4d view` must print.
void CheckInBrowser(const std::string& ws, const std::string& dates_json,
                    const std::string& expected_log) {
  const std::string node = CROP4D_NODE;
  const char* chromium_env = std::getenv("CROP4D_CHROMIUM");
  const std::string chromium = chromium_env != nullptr ? chromium_env : "/usr/bin/chromium";
  ASSERT_TRUE(Executable(node)) << "node not found at " << node
                                << ": install it with scripts/install-deps.sh";
  ASSERT_TRUE(Executable(chromium))
      << "chromium not found at " << chromium << ": install it with scripts/install-deps.sh";
  ASSERT_TRUE(fs::is_directory(fs::path(CROP4D_VIEWER_NODE_MODULES) / "playwright-core"))
      << "playwright-core missing from " << CROP4D_VIEWER_NODE_MODULES << " (the build's npm ci)";
  ViewProcess view(ws);
  std::string log;
  const std::string url = view.Url(&log);
  ASSERT_FALSE(url.empty()) << "crop4d view printed no URL:\n" << log;
  EXPECT_NE(log.find(expected_log), std::string::npos) << log;
  const std::string command =
      "NODE_PATH=" + ShellQuote(CROP4D_VIEWER_NODE_MODULES) +
      " CROP4D_CHROMIUM=" + ShellQuote(chromium) + " " + ShellQuote(node) + " " +
      ShellQuote(std::string(CROP4D_SOURCE_DIR) + "/viewer/test/browser_check.cjs") + " " +
      ShellQuote(url) + " " + ShellQuote(dates_json) + " 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  std::array<char, 4096> buffer;
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) output += buffer.data();
  const int status = ::pclose(pipe);
  EXPECT_EQ(status, 0) << output;
  EXPECT_NE(output.find("viewer check ok"), std::string::npos) << output;
}

TEST(ViewerBrowserTest, LoadsWithoutErrorAndTheSliderSwitchesDates) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws, 20000);
  CheckInBrowser(ws, R"(["2016-06-10","2016-06-24"])", "2 measurement sites");
}

// The same checks on what the pipeline writes: the workspace of `crop4d run` on the tiny
// simulated field's first two sessions, dense clouds included (the end-to-end tests' serial
// reference run, made once per build of crop4d), copied so that nothing can change it.
TEST(ViewerBrowserTest, ShowsTheTinyFieldAsThePipelineWroteIt) {
  const pipeline::testing::SerialReference& reference = pipeline::testing::TheSerialReference();
  ASSERT_TRUE(fs::exists(reference.ws / "dense")) << reference.ws;
  TempDir dir;
  const fs::path ws = dir / "ws";
  fs::copy(reference.ws, ws, fs::copy_options::recursive);
  CheckInBrowser(ws.string(), R"(["2016-06-10","2016-06-24"])", "measurement sites");
}

// Runs `command` through the shell; its output (stdout and stderr) and exit code.
std::pair<std::string, int> RunShell(const std::string& command) {
  FILE* pipe = ::popen((command + " 2>&1").c_str(), "r");
  std::string output;
  std::array<char, 4096> buffer;
  while (pipe != nullptr && std::fgets(buffer.data(), buffer.size(), pipe) != nullptr)
    output += buffer.data();
  const int status = pipe != nullptr ? ::pclose(pipe) : -1;
  return {output, WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

TEST(ViewCommandTest, WorkspaceWithoutCloudsIsBadInputNamingWhatIsMissing) {
  TempDir dir;
  fs::create_directories(dir / "ws");
  const auto [output, code] = RunShell(ShellQuote(io::testing::Crop4dBinary()) + " view " +
                                       ShellQuote(dir / "ws") + " --port 0 --no-browser");
  EXPECT_EQ(code, 2) << output;
  EXPECT_NE(output.find("no cloud to show"), std::string::npos) << output;
}

TEST(ViewCommandTest, ANonLoopbackHostIsServedWithAWarning) {
  TempDir dir;
  testing::WriteSmallWorkspace(dir / "ws", 2000);
  // Stopped by SIGTERM after two seconds: a clean exit (status 0).
  const auto [output, code] =
      RunShell("timeout --preserve-status 2 " + ShellQuote(io::testing::Crop4dBinary()) + " view " +
               ShellQuote(dir / "ws") + " --host 0.0.0.0 --port 0 --no-browser");
  EXPECT_EQ(code, 0) << output;
  EXPECT_NE(output.find("warning: serving on 0.0.0.0"), std::string::npos) << output;
  EXPECT_NE(output.find("crop4d view: serving"), std::string::npos) << output;
}

TEST(ViewCommandTest, ExportViewerWritesTheStaticFolderAndNeedsSomethingToWrite) {
  TempDir dir;
  testing::WriteSmallWorkspace(dir / "ws", 2000);
  const std::string binary = ShellQuote(io::testing::Crop4dBinary());
  const auto [output, code] = RunShell(binary + " export -w " + ShellQuote(dir / "ws") +
                                       " --viewer " + ShellQuote(dir / "site"));
  EXPECT_EQ(code, 0) << output;
  EXPECT_TRUE(fs::is_regular_file(dir / "site/index.html")) << output;
  EXPECT_TRUE(fs::is_regular_file(dir / "site/ws/viewer/scene.json")) << output;
  EXPECT_TRUE(fs::is_regular_file(dir / "site/ws/report.html")) << output;
  const auto [nothing, nothing_code] = RunShell(binary + " export -w " + ShellQuote(dir / "ws"));
  EXPECT_EQ(nothing_code, 2) << nothing;
  EXPECT_NE(nothing.find("--viewer"), std::string::npos) << nothing;
}

}  // namespace
}  // namespace crop4d::viewer
