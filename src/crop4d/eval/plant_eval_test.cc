// Plants of the sites: a hand-built field and site_plants.csv with known matches and errors, and
// malformed files.

#include "crop4d/eval/plant_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/eval/canopy_eval.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/io/dataset_writer.h"

namespace crop4d::eval {
namespace {

using testing::PidTempDir;
using testing::WriteFile;

// Site "a" at (1, 1), radius 0.4. True plants: 1 and 2 in the site, 3 in the site but emerged
// only in s2, 4 outside the site.
void WriteField(const std::string& field) {
  io::FieldInfo info;
  info.name = "plants";
  info.origin = {31.47, -83.53, 100.0};
  io::Site site;
  site.id = "a";
  site.center_enu = {1.0, 1.0};
  site.radius_m = 0.4;
  info.sites.push_back(site);
  info.sessions = {"s1", "s2"};
  std::filesystem::create_directories(field + "/sessions/s1");
  std::filesystem::create_directories(field + "/sessions/s2");
  io::WriteFieldYaml(field + "/field.yaml", info);
  WriteFile(field + "/ground_truth/s1/plants.csv",
            "id,row,x,y,height_m,canopy_radius_m\n"
            "1,1,1.00,0.80,0.10,0.05\n"
            "2,1,1.00,1.00,0.12,0.05\n"
            "3,1,1.00,1.20,0.00,0.00\n"
            "4,1,1.00,1.60,0.11,0.05\n");
  WriteFile(field + "/ground_truth/s2/plants.csv",
            "id,row,x,y,height_m,canopy_radius_m\n"
            "1,1,1.00,0.80,0.20,0.10\n"
            "2,1,1.00,1.00,0.22,0.10\n"
            "3,1,1.00,1.20,0.05,0.03\n"
            "4,1,1.00,1.60,0.21,0.10\n");
}

// Found: plant 1 of the site 1 cm from true plant 1, plant 2 3 cm from true plant 2, plant 3
// 10 cm from any true plant. Top errors: plant 1 +1 cm (s1) and +5 cm (s2), plant 2 −2 cm (s1)
// and not seen in s2; plant 3's tops are not counted (no match).
constexpr char kSitePlants[] =
    "site_id,plant,x_m,y_m,session,date,top_m\n"
    "a,1,1.01,0.80,s1,2016-06-01,0.11\n"
    "a,2,1.00,1.03,s1,2016-06-01,0.10\n"
    "a,3,1.10,1.30,s1,2016-06-01,0.30\n"
    "a,1,1.01,0.80,s2,2016-06-15,0.25\n"
    "a,2,1.00,1.03,s2,2016-06-15,\n"
    "a,3,1.10,1.30,s2,2016-06-15,0.30\n";

TEST(PlantEvalTest, MatchesAndTopErrorsOnAHandBuiltField) {
  PidTempDir dir;
  WriteField(dir / "field");
  WriteFile(dir / "ws/analysis/site_plants.csv", kSitePlants);
  PlantEval eval;
  std::string why;
  ASSERT_TRUE(EvaluateSitePlants(dir / "ws", dir / "field", PlantEvalOptions{}, &eval, &why))
      << why;
  EXPECT_EQ(eval.truth_session, "s2");
  ASSERT_EQ(eval.sites.size(), 1u);
  EXPECT_EQ(eval.num_true, 3);  // plants 1, 2 and 3 (emerged by s2); 4 is outside
  EXPECT_EQ(eval.num_found, 3);
  EXPECT_EQ(eval.num_matched, 2);
  EXPECT_NEAR(eval.recall, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(eval.precision, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(eval.median_stem_offset_m, 0.03, 1e-9);
  // Tops: plant 1 +1 cm (s1) and +5 cm (s2), plant 2 −2 cm (s1).
  EXPECT_EQ(eval.num_tops, 3);
  EXPECT_NEAR(eval.top_bias_m, (0.01 + 0.05 - 0.02) / 3, 1e-9);
  EXPECT_NEAR(eval.top_rmse_m, std::sqrt((1e-4 + 25e-4 + 4e-4) / 3), 1e-9);
  EXPECT_EQ(eval.num_top_failures, 1);  // +5 cm
  // One session only: s1 decides which plants exist (plant 3 has not emerged).
  PlantEvalOptions s1;
  s1.sessions = {"s1"};
  ASSERT_TRUE(EvaluateSitePlants(dir / "ws", dir / "field", s1, &eval, &why)) << why;
  EXPECT_EQ(eval.num_true, 2);
  EXPECT_EQ(eval.num_matched, 2);
  EXPECT_EQ(eval.num_tops, 2);
  // The canopy section of a workspace evaluation carries it.
  WriteFile(dir / "field/ground_truth/site_truth.csv", "site_id,session,height_m\na,s1,0.11\n");
  WriteFile(dir / "ws/analysis/site_heights.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\na,s1,2016-06-01,0.105,,,\n");
  CanopyEval canopy;
  ASSERT_TRUE(
      EvaluateWorkspaceCanopy(dir / "ws", dir / "field", CanopyEvalOptions{}, &canopy, &why));
  ASSERT_TRUE(canopy.plants.has_value()) << canopy.plants_skipped;
  EXPECT_EQ(canopy.plants->num_matched, 2);
  EXPECT_NE(FormatCanopyTable(canopy).find("2 of 3 found within 6 cm"), std::string::npos);
}

TEST(PlantEvalTest, SkippedWithoutTheFileOrTheTruth) {
  PidTempDir dir;
  WriteField(dir / "field");
  PlantEval eval;
  std::string why;
  EXPECT_FALSE(EvaluateSitePlants(dir / "ws", dir / "field", PlantEvalOptions{}, &eval, &why));
  EXPECT_NE(why.find("no analysis/site_plants.csv"), std::string::npos) << why;
  WriteFile(dir / "ws/analysis/site_plants.csv",
            "site_id,plant,x_m,y_m,session,date,top_m\na,1,1,1,s9,2016-06-01,0.1\n");
  EXPECT_FALSE(EvaluateSitePlants(dir / "ws", dir / "field", PlantEvalOptions{}, &eval, &why));
  EXPECT_NE(why.find("plants.csv"), std::string::npos) << why;
}

TEST(PlantEvalTest, MalformedFilesNameTheFileAndLine) {
  PidTempDir dir;
  const std::string path = dir / "site_plants.csv";
  const auto expect_error = [&](const std::string& text, const std::string& what, int line) {
    WriteFile(path, text);
    try {
      ReadSitePlants(path);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_EQ(e.line(), line) << e.what();
    }
  };
  const std::string header = "site_id,plant,x_m,y_m,session,date,top_m\n";
  expect_error("site_id,plant,x_m,session,top_m\n", "not the one this crop4d writes", 1);
  expect_error(header + "a,1,1,1,s1,2016-06-01\n", "expected 7 fields", 2);
  expect_error(header + "a,one,1,1,s1,2016-06-01,0.1\n", "plant 'one'", 2);
  expect_error(header + "a,0,1,1,s1,2016-06-01,0.1\n", "plant '0'", 2);
  expect_error(header + "a,1,1,x,s1,2016-06-01,0.1\n", "y_m 'x' is not a finite number", 2);
  expect_error(header + "a,1,1,1,,2016-06-01,0.1\n", "empty session", 2);
  expect_error(header + "a,1,1,1,s1,,0.1\na,1,1,1,s1,,0.2\n", "repeated", 3);
  expect_error(header + "a,1,1,1,s1,,0.1\na,1,1.5,1,s2,,0.2\n", "moved", 3);
  expect_error("", "empty file", 0);
  WriteFile(path, header + "a,1,1,1,s1,,\n");
  const std::vector<SitePlantRow> rows = ReadSitePlants(path);
  ASSERT_EQ(rows.size(), 1u);
  EXPECT_TRUE(std::isnan(rows[0].top_m));
}

}  // namespace
}  // namespace crop4d::eval
