// The pass list, the pass's priors and its summary: round trips on in-memory data, and the
// errors for malformed, truncated and foreign-version files.
#include "crop4d/workspace/pass_summary.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_priors.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class PassSummaryTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_pass_summary_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Write(const std::string& name, const std::string& text) const {
    const std::string path = (dir_ / name).string();
    std::ofstream(path, std::ios::binary) << text;
    return path;
  }

  // The message of the InputError that `read` throws ("" when it throws none).
  template <typename F>
  static std::string ErrorOf(F read) {
    try {
      read();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  static std::vector<slam::RowPass> Passes() {
    slam::RowPass a;
    a.id = "r03_fwd";
    a.row = 3;
    a.direction = 1;
    a.t_begin = 1'000'000'000;
    a.t_end = 21'500'000'000;
    a.start_world = Eigen::Vector2d(1.25, -3.5);
    a.end_world = Eigen::Vector2d(21.25, -3.75);
    a.length_m = 20.0015;
    slam::RowPass b = a;
    b.id = "r04_back";
    b.row = 4;
    b.direction = -1;
    return {a, b};
  }

  static PassPriors Priors() {
    PassPriors p;
    p.camera = "cam0";
    p.imu = "imu0";
    p.gps = "rtk0";
    p.gps_outages = {{10.5, 3}, {40, 0.25}};
    p.imu_noise_factor = 2.5;
    p.forward_axis_body = Eigen::Vector3d(0.999, 0.01, -0.02);
    p.anchor_state = 7;
    p.anchor_sigma_velocity = 2.0;
    p.still_intervals = {{0, 3}, {10, 12}};
    p.bias_prior_mean << 1e-4, -2e-4, 3e-4, 0.01, -0.02, 0.03;
    p.bias_prior_sigma = Eigen::Matrix<double, 6, 1>::Constant(0.005);
    p.length_prior = std::make_pair(19.75, 0.05);
    return p;
  }

  fs::path dir_;
};

TEST_F(PassSummaryTest, PassListRoundTripsAndKeepsItsHeader) {
  const std::string path = (dir_ / "passes.csv").string();
  WritePassList(path, Passes());
  const std::vector<slam::RowPass> back = ReadPassListFile(path);
  ASSERT_EQ(back.size(), 2u);
  for (std::size_t k = 0; k < back.size(); ++k) {
    EXPECT_EQ(back[k].id, Passes()[k].id);
    EXPECT_EQ(back[k].row, Passes()[k].row);
    EXPECT_EQ(back[k].direction, Passes()[k].direction);
    EXPECT_EQ(back[k].t_begin, Passes()[k].t_begin);
    EXPECT_EQ(back[k].t_end, Passes()[k].t_end);
    EXPECT_TRUE(back[k].start_world.isApprox(Passes()[k].start_world));
    EXPECT_TRUE(back[k].end_world.isApprox(Passes()[k].end_world));
    EXPECT_NEAR(back[k].length_m, Passes()[k].length_m, 1e-9);
  }
  std::ifstream in(path);
  std::string header;
  std::getline(in, header);
  EXPECT_EQ(header, kPassListHeader);
  EXPECT_TRUE(ReadPassListFile((dir_ / "none.csv").string()).empty());
}

TEST_F(PassSummaryTest, PassListRejectsForeignMalformedAndTruncatedFiles) {
  const std::string header = std::string(kPassListHeader) + "\n";
  const std::string line = "r03_fwd,3,1,1000,2000,1,2,3,4,5\n";
  const std::string foreign =
      ErrorOf([&] { ReadPassListFile(Write("a.csv", "pass,row,t_begin\n" + line)); });
  EXPECT_NE(foreign.find("a.csv"), std::string::npos) << foreign;
  EXPECT_NE(foreign.find("crop4d version"), std::string::npos) << foreign;
  EXPECT_NE(foreign.find("crop4d slam"), std::string::npos) << foreign;
  const std::string malformed = ErrorOf(
      [&] { ReadPassListFile(Write("b.csv", header + "r03_fwd,3,x,1000,2000,1,2,3,4,5\n")); });
  EXPECT_NE(malformed.find("b.csv:2"), std::string::npos) << malformed;
  const std::string columns =
      ErrorOf([&] { ReadPassListFile(Write("c.csv", header + "r03_fwd,3,1,1000\n")); });
  EXPECT_NE(columns.find("10 columns"), std::string::npos) << columns;
  const std::string truncated =
      ErrorOf([&] { ReadPassListFile(Write("d.csv", header + line + "r04_back,4,-1,10")); });
  EXPECT_NE(truncated.find("truncated"), std::string::npos) << truncated;
  const std::string empty = ErrorOf([&] { ReadPassListFile(Write("e.csv", "")); });
  EXPECT_NE(empty.find("e.csv"), std::string::npos) << empty;
}

TEST_F(PassSummaryTest, PriorsRoundTripThroughJson) {
  const PassPriors p = Priors();
  EXPECT_EQ(PassPriorsFromJson(json::parse(ToJson(p).dump()), "x"), p);
  // Unset optionals are JSON null and come back unset.
  PassPriors bare;
  bare.camera = "";
  const json j = ToJson(bare);
  EXPECT_TRUE(j.at("forward_axis_body").is_null());
  EXPECT_TRUE(j.at("length_prior").is_null());
  EXPECT_EQ(PassPriorsFromJson(j, "x"), bare);
}

TEST_F(PassSummaryTest, MalformedPriorsNameTheFile) {
  json j = ToJson(Priors());
  j["bias_prior_mean"] = {1, 2, 3};
  EXPECT_NE(ErrorOf([&] { PassPriorsFromJson(j, "s/summary.json"); }).find("s/summary.json"),
            std::string::npos);
  j = ToJson(Priors());
  j.erase("gps_outages");
  EXPECT_NE(ErrorOf([&] { PassPriorsFromJson(j, "f"); }).find("rerun"), std::string::npos);
  j = ToJson(Priors());
  j["imu_noise_factor"] = 0;
  EXPECT_NE(ErrorOf([&] { PassPriorsFromJson(j, "f"); }).find("noise"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { PassPriorsFromJson(json(), "f"); }), "");
}

TEST_F(PassSummaryTest, StillRangesAndFlagsAreInverse) {
  const std::vector<bool> still = {true, true, false, false, true, false, true};
  const auto ranges = StillRanges(still);
  ASSERT_EQ(ranges.size(), 3u);
  EXPECT_EQ(ranges[0], std::make_pair(std::size_t{0}, std::size_t{2}));
  EXPECT_EQ(ranges[2], std::make_pair(std::size_t{6}, std::size_t{7}));
  EXPECT_EQ(StillFlags(ranges, still.size() + 1, "f"), still);
  EXPECT_TRUE(StillFlags({}, 5, "f").empty());
  EXPECT_NE(ErrorOf([&] { StillFlags({{2, 9}}, 5, "f"); }).find("outside"), std::string::npos);
  EXPECT_NE(ErrorOf([&] { StillFlags({{3, 3}}, 5, "f"); }), "");
}

TEST_F(PassSummaryTest, SummaryRoundTripsWithItsSchema) {
  json summary;
  summary["sensors"] = "cam+imu+rtk";
  summary["fingerprint"] = "00ff";
  summary["problem"] = ToJson(Priors());
  summary["trust"] = {"gps_gap"};
  summary["back_end"] = {{"landmarks", 12}};
  const std::string path = (dir_ / "summary.json").string();
  WritePassSummary(path, summary);
  const PassSummary s = ReadPassSummary(path);
  EXPECT_EQ(s.sensors, "cam+imu+rtk");
  EXPECT_EQ(s.fingerprint, "00ff");
  EXPECT_EQ(s.problem, Priors());
  EXPECT_EQ(s.trust, std::vector<std::string>{"gps_gap"});
  EXPECT_EQ(s.json.at("schema").get<int>(), kPassSummarySchema);
  EXPECT_EQ(s.json.at("back_end").at("landmarks").get<int>(), 12);
  EXPECT_FALSE(s.time_offset_s.has_value());
  // An older summary without the IMU gap counts as none.
  EXPECT_EQ(s.longest_imu_gap_s, 0.0);
  summary["longest_imu_gap_s"] = 4.5;
  WritePassSummary(path, summary);
  EXPECT_EQ(ReadPassSummary(path).longest_imu_gap_s, 4.5);

  // The back end's time offset: a number is read, null is "not estimated", text is an error.
  summary["back_end"]["time_offset_s"] = -0.0125;
  WritePassSummary(path, summary);
  EXPECT_EQ(ReadPassSummary(path).time_offset_s, -0.0125);
  summary["back_end"]["time_offset_s"] = nullptr;
  WritePassSummary(path, summary);
  EXPECT_FALSE(ReadPassSummary(path).time_offset_s.has_value());
  summary["back_end"]["time_offset_s"] = "soon";
  WritePassSummary(path, summary);
  EXPECT_NE(ErrorOf([&] { ReadPassSummary(path); }).find(path), std::string::npos);
}

TEST_F(PassSummaryTest, SummaryOfAnotherVersionOrDamagedIsAnInputError) {
  json summary;
  summary["sensors"] = "cam+imu+rtk";
  summary["fingerprint"] = "00ff";
  summary["problem"] = ToJson(Priors());
  // Without a schema (an older crop4d) and with a later one.
  const std::string old_path = Write("old.json", summary.dump());
  const std::string old = ErrorOf([&] { ReadPassSummary(old_path); });
  EXPECT_NE(old.find("old.json"), std::string::npos) << old;
  EXPECT_NE(old.find("another crop4d version"), std::string::npos) << old;
  EXPECT_NE(old.find("crop4d slam --force"), std::string::npos) << old;
  summary["schema"] = kPassSummarySchema + 1;
  EXPECT_NE(ErrorOf([&] { ReadPassSummary(Write("new.json", summary.dump())); }).find("schema"),
            std::string::npos);
  // Truncated, not JSON, missing, a field missing.
  summary["schema"] = kPassSummarySchema;
  const std::string text = summary.dump();
  EXPECT_NE(ErrorOf([&] {
              ReadPassSummary(Write("t.json", text.substr(0, text.size() / 2)));
            }).find("not valid JSON"),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { ReadPassSummary((dir_ / "none.json").string()); }).find("missing"),
            std::string::npos);
  summary.erase("fingerprint");
  EXPECT_NE(ErrorOf([&] { ReadPassSummary(Write("f.json", summary.dump())); }).find("f.json"),
            std::string::npos);
}

}  // namespace
}  // namespace crop4d::workspace
