#include "crop4d/workspace/stage_files.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class StageFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("crop4d_stage_files_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "s1");
    Write("poses.tum", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
    Write("s1/cloud.ply", std::string(1000, 'x'));
    json summary;
    summary["fingerprint"] = "42";
    RecordOutputs(&summary, dir_, FilesBelow(dir_));
    Write("summary.json", summary.dump(2));
  }
  void TearDown() override { fs::remove_all(dir_); }

  void Write(const std::string& name, const std::string& text) {
    std::ofstream(dir_ / name, std::ios::binary | std::ios::trunc) << text;
  }
  bool UpToDate(std::string* why = nullptr) const {
    return SummaryUpToDate(dir_ / "summary.json", "42", why);
  }

  fs::path dir_;
};

TEST_F(StageFilesTest, EveryFileButTheSummaryIsRecordedWithSizeAndHash) {
  EXPECT_EQ(FilesBelow(dir_), (std::vector<std::string>{"poses.tum", "s1/cloud.ply"}));
  std::ifstream in(dir_ / "summary.json");
  const json summary = json::parse(in);
  EXPECT_EQ(summary["output_files"]["s1/cloud.ply"]["bytes"], 1000);
  EXPECT_EQ(summary["output_files"]["poses.tum"]["hash"], FileHash(dir_ / "poses.tum"));
  EXPECT_TRUE(UpToDate());
}

TEST_F(StageFilesTest, ATruncatedChangedOrMissingOutputIsNotUpToDate) {
  std::string why;
  Write("poses.tum", "1 0 0 0 0 0 0 1\n");  // a line cut off
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "poses.tum changed size since it was written");
  Write("poses.tum", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 2\n");  // same size, other bytes
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "poses.tum changed since it was written");
  Write("poses.tum", "1 0 0 0 0 0 0 1\n2 1 0 0 0 0 0 1\n");
  EXPECT_TRUE(UpToDate());
  fs::remove(dir_ / "s1/cloud.ply");
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "s1/cloud.ply is missing");
}

TEST_F(StageFilesTest, OtherInputsOrASummaryWithoutOutputsAreNotUpToDate) {
  std::string why;
  EXPECT_FALSE(SummaryUpToDate(dir_ / "summary.json", "43", &why));
  EXPECT_EQ(why, "inputs or options changed");
  Write("summary.json", R"({"fingerprint": "42"})");
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "the summary records no outputs");
  Write("summary.json", R"({"fingerprint": "42", "output_f)");
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "damaged summary");
  fs::remove(dir_ / "summary.json");
  EXPECT_FALSE(UpToDate(&why));
  EXPECT_EQ(why, "no summary");
}

TEST_F(StageFilesTest, AnOutputThatCannotBeReadIsAnErrorWhenRecorded) {
  json summary;
  EXPECT_THROW(RecordOutputs(&summary, dir_, {"no-such-file"}), std::exception);
}

}  // namespace
}  // namespace crop4d::workspace
