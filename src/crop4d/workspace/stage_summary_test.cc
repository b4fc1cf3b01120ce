// The fused and dense summaries: round trips, and the errors for foreign-version, truncated and
// incomplete files.
#include "crop4d/workspace/stage_summary.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "crop4d/core/error.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class StageSummaryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_stage_summary_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    std::ofstream(Path(name), std::ios::binary) << text;
    return Path(name);
  }
  template <typename F>
  static std::string ErrorOf(F read) {
    try {
      read();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  static json Fused() {
    return {{"fingerprint", "123"},
            {"sessions", {"2016-06-01", "2016-06-15"}},
            {"joint",
             {{"passes", 4},
              {"landmarks", 900},
              {"shared_landmarks", 120},
              {"reprojection_rms_px", 0.75},
              {"converged", true}}},
            {"passes",
             {{{"session", "2016-06-01"}, {"pass", "row00"}, {"time_offset_s", 0.0251}},
              {{"session", "2016-06-15"}, {"pass", "row01"}}}},
            {"seconds", {{"total", 3.5}}}};
  }
  static json Dense() {
    return {{"fingerprint", "9"},
            {"session", "2016-06-01"},
            {"poses", 40},
            {"views", 38},
            {"points", 123456789012}};
  }

  fs::path dir_;
};

TEST_F(StageSummaryTest, FusedSummaryRoundTrips) {
  WriteFusedSummary(Path("summary.json"), Fused());
  const FusedSummary s = ReadFusedSummary(Path("summary.json"));
  EXPECT_EQ(s.fingerprint, "123");
  EXPECT_EQ(s.sessions, (std::vector<std::string>{"2016-06-01", "2016-06-15"}));
  EXPECT_EQ(s.passes, 4);
  EXPECT_EQ(s.landmarks, 900);
  EXPECT_EQ(s.shared_landmarks, 120);
  EXPECT_DOUBLE_EQ(s.reprojection_rms_px, 0.75);
  EXPECT_TRUE(s.converged);
  ASSERT_EQ(s.pass_list.size(), 2u);
  EXPECT_EQ(s.pass_list[0].session, "2016-06-01");
  EXPECT_EQ(s.pass_list[0].pass, "row00");
  EXPECT_EQ(s.pass_list[0].time_offset_s, 0.0251);
  EXPECT_EQ(s.pass_list[1].pass, "row01");
  EXPECT_FALSE(s.pass_list[1].time_offset_s.has_value());
  EXPECT_EQ(s.json.at("schema").get<int>(), kFusedSummarySchema);
  EXPECT_DOUBLE_EQ(s.json.at("seconds").at("total").get<double>(), 3.5);
}

TEST_F(StageSummaryTest, DenseSummaryRoundTrips) {
  WriteDenseSummary(Path("a.json"), Dense());
  const DenseSummary s = ReadDenseSummary(Path("a.json"));
  EXPECT_EQ(s.fingerprint, "9");
  EXPECT_EQ(s.session, "2016-06-01");
  EXPECT_EQ(s.poses, 40);
  EXPECT_EQ(s.views, 38);
  EXPECT_EQ(s.points, 123456789012);
}

TEST_F(StageSummaryTest, ForeignVersionsNameTheFileAndTheStageToRerun) {
  const std::string old = ErrorOf([&] { ReadFusedSummary(Write("old.json", Fused().dump())); });
  EXPECT_NE(old.find("old.json"), std::string::npos) << old;
  EXPECT_NE(old.find("another crop4d version"), std::string::npos) << old;
  EXPECT_NE(old.find("crop4d fuse --force"), std::string::npos) << old;
  json later = Dense();
  later["schema"] = kDenseSummarySchema + 1;
  const std::string newer = ErrorOf([&] { ReadDenseSummary(Write("new.json", later.dump())); });
  EXPECT_NE(newer.find("crop4d densify --force"), std::string::npos) << newer;
  // A fused summary is not a dense one.
  WriteFusedSummary(Path("fused.json"), Fused());
  EXPECT_NE(ErrorOf([&] { ReadDenseSummary(Path("fused.json")); }), "");
}

TEST_F(StageSummaryTest, TruncatedIncompleteAndMissingFilesAreInputErrors) {
  WriteDenseSummary(Path("d.json"), Dense());
  std::string text;
  {
    std::ifstream in(Path("d.json"));
    text.assign(std::istreambuf_iterator<char>(in), {});
  }
  EXPECT_NE(ErrorOf([&] {
              ReadDenseSummary(Write("t.json", text.substr(0, text.size() / 2)));
            }).find("not valid JSON"),
            std::string::npos);
  json incomplete = Fused();
  incomplete["joint"].erase("passes");
  WriteFusedSummary(Path("i.json"), incomplete);
  const std::string missing_field = ErrorOf([&] { ReadFusedSummary(Path("i.json")); });
  EXPECT_NE(missing_field.find("i.json"), std::string::npos) << missing_field;
  EXPECT_NE(missing_field.find("missing or mistyped"), std::string::npos) << missing_field;
  EXPECT_NE(ErrorOf([&] { ReadDenseSummary(Path("none.json")); }).find("missing"),
            std::string::npos);
}

}  // namespace
}  // namespace crop4d::workspace
