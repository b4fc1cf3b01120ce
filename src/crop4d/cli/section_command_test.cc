// End-to-end tests of `crop4d section`: run the real binary on a workspace with row SLAM and
// fused clouds in a temp folder and check the exit code, the messages and the PNG.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <string>

#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::cli {
namespace {

namespace fs = std::filesystem;
using io::testing::Crop4dBinary;
using io::testing::ShellQuote;

// Ground at height z from x0 to x1 every 1 cm, three points at y = 10 and 10 ± 0.02.
io::PlyPointCloud Ground(double x0, double x1, double z) {
  io::PlyPointCloud cloud;
  const int n = static_cast<int>(std::lround((x1 - x0) / 0.01));
  for (int i = 0; i <= n; ++i) {
    for (double dy : {-0.02, 0.0, 0.02}) cloud.points.emplace_back(x0 + i * 0.01, 10.0 + dy, z);
  }
  return cloud;
}

class SectionCommandTest : public ::testing::Test {
 public:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(Crop4dBinary())) << Crop4dBinary();
    // Session 1: two row SLAM clouds; session 2: a fused cloud (and a row cloud, not used);
    // session 3: nothing.
    io::WritePly(ws() + "/sessions/2016-06-01/rows/row00/landmarks.ply", Ground(1.0, 2.0, 0.0));
    io::WritePly(ws() + "/sessions/2016-06-01/rows/row01/landmarks.ply", Ground(2.0, 3.0, 0.0));
    io::WritePly(ws() + "/sessions/2016-06-10/rows/row00/landmarks.ply", Ground(1.0, 3.0, 5.0));
    io::WritePly(ws() + "/fused/2016-06-10/sparse.ply", Ground(1.0, 3.0, 0.2));
    fs::create_directories(ws() + "/sessions/2016-06-20");
    io::testing::WriteText(field() + "/field.yaml",
                           "name: test\norigin: {lat: 33.7756, lon: -84.3963, alt: 290}\n"
                           "rows:\n  - {index: 0, start: [1.5, 0], end: [1.5, 20]}\n"
                           "  - {index: 1, start: [2.5, 0], end: [2.5, 20]}\n");
  }
  std::string ws() const { return dir_ / "ws"; }
  std::string field() const { return dir_ / "field"; }
  std::string png() const { return dir_ / "out/section.png"; }

  struct Result {
    int exit_code = -1;
    std::string err;
  };
  Result Run(const std::string& args) {
    const std::string err = dir_ / "stderr.txt";
    const std::string command =
        ShellQuote(Crop4dBinary()) + " section " + args + " >/dev/null 2>" + ShellQuote(err);
    const int status = std::system(command.c_str());
    return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, io::testing::ReadText(err)};
  }

 protected:
  io::testing::TempDir dir_;
};

TEST_F(SectionCommandTest, DrawsARowSectionFromFusedAndRowClouds) {
  const Result r = Run("--workspace " + ShellQuote(ws()) + " --field " + ShellQuote(field()) +
                       " --row 1 -o " + ShellQuote(png()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("2016-06-01: 606 points from 2 row SLAM clouds"), std::string::npos)
      << r.err;
  EXPECT_NE(r.err.find("2016-06-10: 603 points from the fused cloud"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("session 2016-06-20: no cloud"), std::string::npos) << r.err;
  // Row 1 at x = 2.5, y = 10 (its middle), ±1.5 m, 0.1 m thick: every point of both sessions.
  EXPECT_NE(r.err.find("section: 1209 points of 2 sessions in the slice"), std::string::npos)
      << r.err;
  ASSERT_TRUE(fs::exists(png()));
  const std::string first = io::testing::ReadText(png());
  EXPECT_EQ(first.substr(1, 3), "PNG");
  // Deterministic.
  ASSERT_EQ(Run("--workspace " + ShellQuote(ws()) + " --field " + ShellQuote(field()) +
                " --row 1 -o " + ShellQuote(png()))
                .exit_code,
            0);
  EXPECT_EQ(io::testing::ReadText(png()), first);
}

TEST_F(SectionCommandTest, SliceByXAndSessionSelection) {
  const Result r =
      Run("--workspace " + ShellQuote(ws()) + " --x 2 --thickness 0.05 --half-length 0.5 " +
          "--sessions 2016-06-10 -o " + ShellQuote(png()));
  ASSERT_EQ(r.exit_code, 0) << r.err;
  // y from the median of the points near x = 2; x from 1.5 to 2.5.
  EXPECT_NE(r.err.find("y = 10.00 m, the median y"), std::string::npos) << r.err;
  EXPECT_EQ(r.err.find("2016-06-01"), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("section: 303 points of 1 session in the slice"), std::string::npos)
      << r.err;
}

TEST_F(SectionCommandTest, NoPointInTheSliceStillWritesTheFigure) {
  const Result r =
      Run("--workspace " + ShellQuote(ws()) + " --x 50 --y 10 -o " + ShellQuote(png()));
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.err.find("no point of any session lies in the slice"), std::string::npos) << r.err;
  EXPECT_TRUE(fs::exists(png()));
}

TEST_F(SectionCommandTest, BadInputIsExitCode2WithAClearMessage) {
  const std::string base = "--workspace " + ShellQuote(ws()) + " -o " + ShellQuote(png()) + " ";
  auto expect_error = [&](const std::string& args, const std::string& what) {
    const Result r = Run(args);
    EXPECT_EQ(r.exit_code, 2) << args << "\n" << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << args << "\n" << r.err;
  };
  expect_error(base + "--row 1", "--row needs --field FIELD");
  expect_error(base + "--row 7 --field " + ShellQuote(field()), "has no row 7 (rows: 0, 1)");
  expect_error(base + "--row 1 --x 2 --field " + ShellQuote(field()),
               "Exactly 1 option from [--row,--x] is required and 2 were given");
  expect_error(base, "Exactly 1 option from [--row,--x] is required");
  expect_error(base + "--x 2 --sessions 2016-06-01,2016-07-01", "session '2016-07-01' is not in");
  expect_error(base + "--x 2 --sessions 2016-06-20", "no point cloud for any session");
  expect_error(base + "--x 2 --thickness 0", "--thickness");
  expect_error("--workspace " + ShellQuote(ws()) + " --x 2 -o " + ShellQuote(dir_ / "a.jpg"),
               "ending in .png");
  expect_error("--workspace " + ShellQuote(dir_ / "nowhere") + " --x 2 -o " + ShellQuote(png()),
               "nowhere");
  fs::remove_all(ws() + "/sessions");
  fs::create_directories(ws());
  expect_error(base + "--x 2", "no sessions/ folder");
  EXPECT_FALSE(fs::exists(png()));
}

}  // namespace
}  // namespace crop4d::cli
