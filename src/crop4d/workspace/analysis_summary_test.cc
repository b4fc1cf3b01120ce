// The analysis summary: written and read back to the same JSON; another schema, a missing field
// and a cut file are InputErrors asking to rerun analyze.

#include "crop4d/workspace/analysis_summary.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <fstream>

#include "crop4d/core/error.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

AnalysisSummary Example() {
  AnalysisSummary s;
  s.fingerprint = "123";
  s.version = "0.1";
  s.options = {{"cloud", "auto"}, {"canopy", {{"min_height_m", 0.02}}}};
  s.area_min = {-1.0, -2.0};
  s.area_max = {10.0, 20.0};
  AnalysisSessionRecord r;
  r.session = "2016-06-01";
  r.date = "2016-06-01";
  r.cloud = "dense/2016-06-01.ply";
  r.dense = true;
  r.points = 1000;
  r.plants = 12;
  r.vegetation_fraction = 0.25;
  r.vegetation_threshold = std::nan("");  // written as null
  s.sessions = {r};
  s.quality = {{"sessions", json::array()}};
  s.terrain.nodes = 50;
  s.site_notes = {{"a", "2016-06-01", "no vegetation within the site"}};
  s.outputs = {"analysis/site_heights.csv"};
  s.seconds = 1.5;
  return s;
}

TEST(AnalysisSummaryTest, WrittenAndReadBackToTheSameJson) {
  const json j = AnalysisSummaryJson(Example());
  EXPECT_EQ(j.at("sessions").at(0).at("points"), 1000);
  // NaN is written as null.
  EXPECT_NE(j.dump().find("\"vegetation_threshold\":null"), std::string::npos) << j.dump();
  EXPECT_EQ(j.at("site_notes").at(0).at("note"), "no vegetation within the site");
  const AnalysisSummary back = AnalysisSummaryFromJson(json::parse(j.dump()), "summary.json");
  EXPECT_EQ(back.sessions.at(0).cloud, "dense/2016-06-01.ply");
  EXPECT_TRUE(std::isnan(back.sessions.at(0).vegetation_threshold));
  EXPECT_EQ(back.area_max[1], 20.0);
  EXPECT_EQ(AnalysisSummaryJson(back).dump(), j.dump());
}

TEST(AnalysisSummaryTest, WritesTheFileWithItsOutputsAndReadsIt) {
  const fs::path dir = fs::temp_directory_path() / ("crop4d_summary_" + std::to_string(getpid()));
  fs::remove_all(dir);
  const Layout ws(dir);
  fs::create_directories(ws.AnalysisDir());
  std::ofstream(ws.SiteHeights()) << "site_id\n";
  WriteAnalysisSummary(ws, Example());
  const AnalysisSummary back = ReadAnalysisSummary(ws.AnalysisSummary());
  EXPECT_EQ(back.fingerprint, "123");
  std::ifstream in(ws.AnalysisSummary());
  const json j = json::parse(in);
  EXPECT_TRUE(j.dump().find("site_heights.csv") != std::string::npos);
  fs::remove_all(dir);
}

TEST(AnalysisSummaryTest, AnotherSchemaAMissingFieldOrACutFileAsksToRerunAnalyze) {
  json j = AnalysisSummaryJson(Example());
  j["schema"] = 2;
  try {
    AnalysisSummaryFromJson(j, "WS/analysis/summary.json");
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "WS/analysis/summary.json");
    EXPECT_NE(std::string(e.what()).find("schema 2"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("crop4d analyze"), std::string::npos) << e.what();
  }
  j = AnalysisSummaryJson(Example());
  j.erase("terrain");
  EXPECT_THROW(AnalysisSummaryFromJson(j, "s.json"), InputError);
  j = AnalysisSummaryJson(Example());
  j["sessions"][0].erase("points");
  EXPECT_THROW(AnalysisSummaryFromJson(j, "s.json"), InputError);

  const fs::path cut = fs::temp_directory_path() / ("crop4d_cut_" + std::to_string(getpid()));
  const std::string text = AnalysisSummaryJson(Example()).dump(2);
  std::ofstream(cut) << text.substr(0, text.size() / 2);
  try {
    ReadAnalysisSummary(cut);
    ADD_FAILURE();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crop4d analyze"), std::string::npos) << e.what();
  }
  fs::remove(cut);
}

}  // namespace
}  // namespace crop4d::workspace
