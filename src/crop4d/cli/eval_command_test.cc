// End-to-end tests of `crop4d eval`: run the real binary on a workspace and field ground truth
// in a temp folder and check the exit code, the table and metrics.json.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>

#include "crop4d/eval/eval_test_util.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::cli {
namespace {

namespace fs = std::filesystem;
using eval::testing::PidTempDir;
using io::testing::ReadText;

struct EvalRunResult {
  int exit_code = -1;
  std::string out, err;
};

std::string EvalBinary() {
  const char* override_path = std::getenv("CROP4D_TEST_BINARY");
  return override_path != nullptr ? override_path : std::string(CROP4D_BINARY_DIR) + "/crop4d";
}

std::string Q(const std::string& s) { return "'" + s + "'"; }

class EvalCommandTest : public ::testing::Test {
 public:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(EvalBinary())) << EvalBinary();
    eval::testing::WriteWorkspaceAndTruth(workspace(), field());
  }
  std::string workspace() const { return dir_ / "ws"; }
  std::string field() const { return dir_ / "field"; }
  EvalRunResult Run(const std::string& args) {
    const std::string out = dir_ / "stdout.txt", err = dir_ / "stderr.txt";
    const std::string command = Q(EvalBinary()) + " " + args + " >" + Q(out) + " 2>" + Q(err);
    const int status = std::system(command.c_str());
    EvalRunResult r;
    r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    r.out = ReadText(out);
    r.err = ReadText(err);
    return r;
  }
  std::string Args() const {
    return "eval --workspace " + Q(workspace()) + " --truth " + Q(field());
  }

 protected:
  PidTempDir dir_;
};

TEST_F(EvalCommandTest, PrintsTheTableAndWritesMetricsJson) {
  const EvalRunResult r = Run(Args());
  EXPECT_EQ(r.exit_code, 0) << r.err;
  EXPECT_NE(r.out.find("ATE raw cm"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("cam+imu+rtk"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("3.00"), std::string::npos) << r.out;
  EXPECT_NE(r.err.find("pass 2016-05-26/0 not evaluated: "), std::string::npos) << r.err;
  EXPECT_NE(r.err.find("eval: 2 of 3 passes evaluated"), std::string::npos) << r.err;
  const std::string path = workspace() + "/eval/metrics.json";
  ASSERT_TRUE(fs::exists(path)) << r.err;
  const nlohmann::json j = nlohmann::json::parse(ReadText(path));
  EXPECT_EQ(j["passes"].size(), 3u);
  EXPECT_NEAR(j["passes"][0]["metrics"]["ate_raw_m"]["rmse"].get<double>(), 0.03, 1e-5);
  EXPECT_EQ(j["overall"]["num_evaluated"], 2);
}

TEST_F(EvalCommandTest, OutputOptionsAndStrict) {
  const std::string out = dir_ / "m/metrics.json";
  const EvalRunResult r =
      Run(Args() + " --output " + Q(out) + " --rpe-distance 0 --session 2016-05-25 --strict");
  EXPECT_EQ(r.exit_code, 0) << r.err;
  const nlohmann::json j = nlohmann::json::parse(ReadText(out));
  EXPECT_EQ(j["passes"].size(), 2u);
  EXPECT_EQ(j["options"]["rpe_distance_m"], 0.0);
  EXPECT_EQ(j["passes"][0]["metrics"]["rpe"]["pairs"], 1);
  EXPECT_FALSE(fs::exists(workspace() + "/eval/metrics.json"));

  // --strict with a pass that cannot be evaluated: exit 2, metrics still written.
  const EvalRunResult strict = Run(Args() + " --strict");
  EXPECT_EQ(strict.exit_code, 2) << strict.err;
  EXPECT_TRUE(fs::exists(workspace() + "/eval/metrics.json"));
}

TEST_F(EvalCommandTest, FieldWithoutGroundTruthExitsTwo) {
  fs::remove_all(field() + "/ground_truth");
  const EvalRunResult r = Run(Args());
  EXPECT_EQ(r.exit_code, 2);
  EXPECT_NE(r.err.find("error: " + field() + "/ground_truth: ground truth folder not found"),
            std::string::npos)
      << r.err;
  EXPECT_FALSE(fs::exists(workspace() + "/eval/metrics.json"));
}

TEST_F(EvalCommandTest, HelpAndUsage) {
  const EvalRunResult help = Run("eval --help");
  EXPECT_EQ(help.exit_code, 0);
  for (const char* option : {"--workspace", "--truth", "--output", "--session", "--rpe-distance",
                             "--max-dt", "--strict", "Example", "Exit code"}) {
    EXPECT_NE(help.out.find(option), std::string::npos) << option << "\n" << help.out;
  }
  EXPECT_NE(Run("--help").out.find("eval"), std::string::npos);
  EXPECT_EQ(Run("eval --workspace " + Q(workspace())).exit_code, 2);  // --truth is required
  EXPECT_EQ(Run(Args() + " --rpe-distance -1").exit_code, 2);
}

}  // namespace
}  // namespace crop4d::cli
