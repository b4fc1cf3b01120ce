#include <gtest/gtest.h>
#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/resource_usage.h"
#include "crop4d/core/timestamp.h"

namespace crop4d {
namespace {

TEST(Timestamp, SecondsRoundTripKeepsNanoseconds) {
  const Timestamp t = 1464184987123456789;  // 2016-05-25T14:03:07.123456789Z
  EXPECT_EQ(FormatTimestamp(t), "2016-05-25T14:03:07.123456789Z");
  EXPECT_NEAR(TimestampToSeconds(t), 1464184987.123456789, 1e-6);
  EXPECT_NEAR(static_cast<double>(SecondsToTimestamp(TimestampToSeconds(t)) - t), 0.0, 300.0);
  EXPECT_DOUBLE_EQ(DurationSeconds(t, t + 5 * kNanosPerMillisecond), 0.005);
}

TEST(Timestamp, Dates) {
  EXPECT_EQ(FromDate(1970, 1, 1), 0);
  EXPECT_EQ(FromDate(2016, 5, 25), 1464134400LL * kNanosPerSecond);
  Timestamp t = 0;
  ASSERT_TRUE(ParseDate("2016-05-25", &t));
  EXPECT_EQ(FormatDate(t), "2016-05-25");
  EXPECT_FALSE(ParseDate("2016-02-30", &t));
  EXPECT_FALSE(ParseDate("2016-5-25", &t));
  EXPECT_FALSE(ParseDate("2016-05-25x", &t));
  EXPECT_FALSE(ParseDate("", &t));
  EXPECT_EQ(FormatDate(FromDate(1969, 12, 31) + 3600 * kNanosPerSecond), "1969-12-31");
}

TEST(Timestamp, FormatDuration) {
  EXPECT_EQ(FormatDuration(0.25), "250 ms");
  EXPECT_EQ(FormatDuration(12.34), "12.3 s");
  EXPECT_EQ(FormatDuration(245), "4 min 05 s");
  EXPECT_EQ(FormatDuration(3720), "1 h 02 min");
}

TEST(InputError, MessageNamesFileAndLine) {
  const InputError e("imu0/data.csv", 17, "expected 7 columns, found 5");
  EXPECT_STREQ(e.what(), "imu0/data.csv:17: expected 7 columns, found 5");
  EXPECT_EQ(e.line(), 17);
  EXPECT_EQ(InputError("field.yaml", 0, "missing key 'origin'").what(),
            std::string("field.yaml: missing key 'origin'"));
  EXPECT_EQ(InputError("no file").what(), std::string("no file"));
}

TEST(CheckDeathTest, AbortsWithExpression) {
  EXPECT_DEATH(CROP4D_CHECK_MSG(1 + 1 == 3, "arithmetic"), "1 \\+ 1 == 3: arithmetic");
}

TEST(Progress, CountsFromManyThreadsAndReportsRateAndEta) {
  std::vector<std::string> lines;
  Progress::Options options;
  options.log_interval_s = 0.0;
  options.force_tty = 0;
  options.sink = [&](const std::string& l) { lines.push_back(l); };
  {
    Progress progress("work", 4000, "it", options);
    std::vector<std::thread> threads;
    for (int i = 0; i < 4; ++i) {
      threads.emplace_back([&] {
        for (int j = 0; j < 1000; ++j) progress.Add();
      });
    }
    for (auto& t : threads) t.join();
    EXPECT_EQ(progress.done(), 4000u);
    EXPECT_EQ(progress.EtaSeconds(), 0.0);
    EXPECT_GT(progress.Rate(), 0.0);
  }
  ASSERT_FALSE(lines.empty());
  EXPECT_NE(lines.back().find("work: 4000 it in"), std::string::npos) << lines.back();
  for (size_t i = 0; i + 1 < lines.size(); ++i) {
    EXPECT_NE(lines[i].find("ETA"), std::string::npos) << lines[i];
  }
}

TEST(Progress, EtaUnknownWithoutTotal) {
  Progress::Options options;
  options.silent = true;
  Progress progress("x", 0, "it", options);
  progress.Add(3);
  EXPECT_LT(progress.EtaSeconds(), 0.0);
  EXPECT_EQ(progress.done(), 3u);
}

TEST(Progress, TerminalBar) {
  std::vector<std::string> lines;
  Progress::Options options;
  options.force_tty = 1;
  options.sink = [&](const std::string& l) { lines.push_back(l); };
  Progress progress("bar", 10, "img", options);
  std::this_thread::sleep_for(std::chrono::milliseconds(120));
  progress.Add(5);
  ASSERT_EQ(lines.size(), 1u);
  EXPECT_NE(lines[0].find("[###############...............]  50% 5/10 img"), std::string::npos)
      << lines[0];
}

}  // namespace
TEST(LogFile, EveryLineIsOnDiskAsSoonAsItIsLogged) {
  // A run killed with SIGKILL cannot flush: what it logged must already be in the file.
  InitLogging(Verbosity::kQuiet);
  const std::filesystem::path path = std::filesystem::path(::testing::TempDir()) /
                                     ("crop4d_log_" + std::to_string(::getpid()) + ".log");
  std::filesystem::remove(path);
  const spdlog::sink_ptr sink = AddLogFile(path.string());
  ASSERT_NE(sink, nullptr);
  spdlog::info("first line");
  spdlog::debug("second line");
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find("[info] first line\n"), std::string::npos) << text.str();
  EXPECT_NE(text.str().find("[debug] second line\n"), std::string::npos) << text.str();
  RemoveLogSink(sink);
  std::filesystem::remove(path);
}

TEST(ResourceUsage, CpuTimeGrowsWithWorkAndThePeakMemoryRestarts) {
  const double cpu0 = ProcessCpuSeconds();
  // Busy until the process has used 0.15 s of CPU: on a loaded machine 200 ms of wall time can
  // hold less than 0.1 s of CPU. The wall-time cap fails a clock that does not grow.
  volatile double sink = 0;
  const auto start = std::chrono::steady_clock::now();
  while (ProcessCpuSeconds() - cpu0 < 0.15 &&
         std::chrono::steady_clock::now() - start < std::chrono::seconds(20)) {
    for (int i = 0; i < 100000; ++i) sink += 1.0;
  }
  EXPECT_GT(ProcessCpuSeconds() - cpu0, 0.1);

  // 256 MB touched, then returned to the kernel: the peak holds them until it is restarted.
  const std::size_t bytes = 256u << 20;
  void* block = ::mmap(nullptr, bytes, PROT_READ | PROT_WRITE, MAP_PRIVATE | MAP_ANONYMOUS, -1, 0);
  ASSERT_NE(block, MAP_FAILED);
  std::memset(block, 1, bytes);
  const double peak = PeakResidentMemoryMb();
  ::munmap(block, bytes);
  EXPECT_GT(peak, 256 * 1.048);
  ASSERT_TRUE(ResetPeakResidentMemory());
  EXPECT_LT(PeakResidentMemoryMb(), peak - 200);
}

}  // namespace crop4d
