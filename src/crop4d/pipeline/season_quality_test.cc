#include "crop4d/pipeline/season_quality.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

PassFacts Pass(const std::string& session, const std::string& pass, const std::string& sensors,
               double imu_gap_s = 0.005) {
  return {session, pass, PositioningOf(sensors), sensors, imu_gap_s};
}

TEST(SeasonQualityTest, PositioningFromTheSensorSet) {
  EXPECT_EQ(PositioningOf("cam+imu+rtk"), Positioning::kRtk);
  EXPECT_EQ(PositioningOf("imu+rtk"), Positioning::kRtk);
  EXPECT_EQ(PositioningOf("cam+imu+gps"), Positioning::kGps);
  EXPECT_EQ(PositioningOf("cam+imu"), Positioning::kNone);
  EXPECT_EQ(PositioningOf(""), Positioning::kNone);
}

TEST(SeasonQualityTest, ASessionWithoutTheRtkTheOthersHaveIsDegraded) {
  const SeasonQuality q =
      GradeSeason({Pass("a", "row00", "cam+imu+gps"), Pass("a", "row01", "cam+imu+rtk"),
                   Pass("b", "row00", "cam+imu+rtk"), Pass("c", "row00", "cam+imu+rtk")},
                  QualityOptions{});
  EXPECT_EQ(q.standard, Positioning::kRtk);
  ASSERT_EQ(q.sessions.size(), 3u);
  EXPECT_FALSE(q.sessions[0].trusted);
  ASSERT_EQ(q.sessions[0].reasons.size(), 1u);
  EXPECT_EQ(q.sessions[0].reasons[0],
            "positioned with a metre-level GPS (cam+imu+gps) while 2 of 3 sessions have RTK");
  EXPECT_TRUE(q.sessions[1].trusted);
  EXPECT_FALSE(q.Protects("a"));
  EXPECT_TRUE(q.Protects("b"));
  EXPECT_TRUE(q.Protects("not graded"));
  ASSERT_EQ(q.Degraded().size(), 1u);
  EXPECT_EQ(q.Degraded()[0]->session, "a");
}

TEST(SeasonQualityTest, TheStandardIsWhatHalfOfTheSessionsHave) {
  // One RTK session of three: the standard is a metre-level GPS, and only the session
  // without any GPS falls below it.
  const SeasonQuality q = GradeSeason(
      {Pass("a", "r", "cam+imu+rtk"), Pass("b", "r", "cam+imu+gps"), Pass("c", "r", "cam+imu")},
      QualityOptions{});
  EXPECT_EQ(q.standard, Positioning::kGps);
  EXPECT_TRUE(q.sessions[0].trusted);
  EXPECT_TRUE(q.sessions[1].trusted);
  EXPECT_FALSE(q.sessions[2].trusted);
  // Two sessions, one with RTK: RTK is the standard.
  EXPECT_EQ(
      GradeSeason({Pass("a", "r", "cam+imu+rtk"), Pass("b", "r", "cam+imu+gps")}, {}).standard,
      Positioning::kRtk);
}

TEST(SeasonQualityTest, AnImuGapNamesItsPass) {
  const SeasonQuality q =
      GradeSeason({Pass("a", "row00", "cam+imu+rtk"), Pass("b", "row00", "cam+imu+rtk"),
                   Pass("b", "row01", "cam+imu+rtk", 5.0), Pass("b", "row02", "cam+imu+rtk", 0.9)},
                  QualityOptions{});
  EXPECT_TRUE(q.sessions[0].trusted);
  ASSERT_FALSE(q.sessions[1].trusted);
  ASSERT_EQ(q.sessions[1].reasons.size(), 1u);
  EXPECT_EQ(q.sessions[1].reasons[0], "pass row01: no IMU sample for 5.0 s (more than 1.0 s)");
}

// A pass whose row SLAM left the GPS track (2016-07-23 row00 of a 16-session field before the
// session solve took a receiver in float: 43 of 43 fixes rejected) degrades its session; a few
// rejected multipath outliers do not.
TEST(SeasonQualityTest, APassWhoseSolveRejectedMostOfItsFixesNamesItsPass) {
  PassFacts diverged = Pass("b", "row00", "cam+imu+rtk");
  diverged.gps_fixes = 43;
  diverged.gps_rejected = 43;
  PassFacts outliers = Pass("a", "row00", "cam+imu+rtk");
  outliers.gps_fixes = 75;
  outliers.gps_rejected = 3;
  PassFacts half = Pass("a", "row01", "cam+imu+rtk");
  half.gps_fixes = 40;
  half.gps_rejected = 20;
  const SeasonQuality q = GradeSeason({outliers, half, diverged}, QualityOptions{});
  EXPECT_TRUE(q.sessions[0].trusted);
  ASSERT_FALSE(q.sessions[1].trusted);
  ASSERT_EQ(q.sessions[1].reasons.size(), 1u);
  EXPECT_EQ(q.sessions[1].reasons[0],
            "pass row00: row SLAM rejected 43 of its 43 GPS fixes as outliers (more than 50 %): "
            "its solve left the GPS track");
  QualityOptions strict;
  strict.max_gps_rejected_share = 0.02;
  EXPECT_FALSE(GradeSeason({outliers, half, diverged}, strict).sessions[0].trusted);
}

TEST(SeasonQualityTest, WhenNoSessionIsTrustedEverySessionIsUsed) {
  const SeasonQuality q =
      GradeSeason({Pass("a", "r", "cam+imu+rtk", 3.0), Pass("b", "r", "cam+imu+rtk", 2.0)}, {});
  EXPECT_FALSE(q.any_trusted);
  EXPECT_EQ(q.Degraded().size(), 2u);
  EXPECT_TRUE(q.Protects("a"));
  EXPECT_TRUE(q.Protects("b"));
}

TEST(SeasonQualityTest, FactsFromARowSlamSummary) {
  workspace::PassSummary summary;
  summary.sensors = "cam+imu+gps";
  summary.longest_imu_gap_s = 4.5;
  summary.json = {{"back_end", {{"gps_factors", 48}, {"gps_rejected", 48}}}};
  const PassFacts f = PassFactsOf("2016-06-10", "row01", summary);
  EXPECT_EQ(f.gps_fixes, 48);
  EXPECT_EQ(f.gps_rejected, 48);
  EXPECT_EQ(f.session, "2016-06-10");
  EXPECT_EQ(f.pass, "row01");
  EXPECT_EQ(f.positioning, Positioning::kGps);
  EXPECT_DOUBLE_EQ(f.longest_imu_gap_s, 4.5);
}

TEST(SeasonQualityTest, TheGradesSurviveTheirFileAndADamagedFileIsNamed) {
  const fs::path ws = fs::path(::testing::TempDir()) / ("quality_" + std::to_string(getpid()));
  fs::remove_all(ws);
  // No file (a workspace fused by an older crop4d): every session protects.
  EXPECT_TRUE(ReadSeasonQuality(ws.string()).Protects("a"));
  const SeasonQuality q =
      GradeSeason({Pass("a", "r", "cam+imu+gps"), Pass("b", "r", "cam+imu+rtk", 2.0),
                   Pass("c", "r", "imu+rtk")},
                  QualityOptions{});
  fs::create_directories(ws / "fused");
  std::ofstream(SeasonQualityPath(ws.string())) << SeasonQualityToJson(q).dump(2);
  const SeasonQuality back = ReadSeasonQuality(ws.string());
  EXPECT_EQ(SeasonQualityToJson(back), SeasonQualityToJson(q));
  EXPECT_FALSE(back.Protects("a"));
  EXPECT_TRUE(back.Protects("c"));
  std::ofstream(SeasonQualityPath(ws.string())) << "{\"standard\": \"rtk\"";
  try {
    ReadSeasonQuality(ws.string());
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("quality.json"), std::string::npos) << e.what();
  }
  fs::remove_all(ws);
}

TEST(SeasonQualityTest, CheckRejectsBadOptions) {
  QualityOptions o;
  EXPECT_EQ(o.Check(), "");
  o.max_imu_gap_s = 0;
  EXPECT_NE(o.Check(), "");
  EXPECT_DEATH(GradeSeason({}, o), "max_imu_gap_s");
  o = QualityOptions{};
  o.max_gps_rejected_share = 1.5;
  EXPECT_NE(o.Check(), "");
}

}  // namespace
}  // namespace crop4d::pipeline
