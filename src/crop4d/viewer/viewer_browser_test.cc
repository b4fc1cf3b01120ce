// The viewer page in headless Chromium against `crop4d view` on a small workspace
// (viewer_data_test_util.h): no console error, every date in the page's state, the time slider
// switches dates, two dates overlay, change colouring and measuring work
// (viewer/test/browser_check.cjs). Fails, never skips, when node or chromium is missing.

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

#include "crop4d/io/test_helpers.h"
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

TEST(ViewerBrowserTest, LoadsWithoutErrorAndTheSliderSwitchesDates) {
  const std::string node = CROP4D_NODE;
  const char* chromium_env = std::getenv("CROP4D_CHROMIUM");
  const std::string chromium = chromium_env != nullptr ? chromium_env : "/usr/bin/chromium";
  ASSERT_TRUE(Executable(node)) << "node not found at " << node
                                << ": install it with scripts/install-deps.sh";
  ASSERT_TRUE(Executable(chromium)) << "chromium not found at " << chromium
                                    << ": install it with scripts/install-deps.sh";
  ASSERT_TRUE(fs::is_directory(fs::path(CROP4D_VIEWER_NODE_MODULES) / "playwright-core"))
      << "playwright-core missing from " << CROP4D_VIEWER_NODE_MODULES << " (the build's npm ci)";
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws, 20000);
  ViewProcess view(ws);
  std::string log;
  const std::string url = view.Url(&log);
  ASSERT_FALSE(url.empty()) << "crop4d view printed no URL:\n" << log;
  EXPECT_NE(log.find("2 measurement sites"), std::string::npos) << log;
  const std::string command =
      "NODE_PATH=" + ShellQuote(CROP4D_VIEWER_NODE_MODULES) + " CROP4D_CHROMIUM=" +
      ShellQuote(chromium) + " " + ShellQuote(node) + " " +
      ShellQuote(std::string(CROP4D_SOURCE_DIR) + "/viewer/test/browser_check.cjs") + " " +
      ShellQuote(url) + " '[\"2016-06-10\",\"2016-06-24\"]' 2>&1";
  FILE* pipe = ::popen(command.c_str(), "r");
  ASSERT_NE(pipe, nullptr);
  std::string output;
  std::array<char, 4096> buffer;
  while (std::fgets(buffer.data(), buffer.size(), pipe) != nullptr) output += buffer.data();
  const int status = ::pclose(pipe);
  EXPECT_EQ(status, 0) << output;
  EXPECT_NE(output.find("viewer check ok"), std::string::npos) << output;
}

}  // namespace
}  // namespace crop4d::viewer
