// Canopy-height evaluation: hand-built CSVs with known errors, missing estimates, malformed
// files, and the canopy section of a workspace evaluation.

#include "crop4d/eval/canopy_eval.h"

#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/eval/workspace_eval.h"

namespace crop4d::eval {
namespace {

using testing::PidTempDir;
using testing::WriteFile;

constexpr char kTruth[] =
    "site_id,session,date,height_m\n"
    "a,s1,2016-06-01,0.10\n"
    "b,s1,2016-06-01,0.20\n"
    "c,s1,2016-06-01,0.30\n"
    "a,s2,2016-06-15,0.40\n"
    "b,s2,2016-06-15,0.50\n"
    "c,s2,2016-06-15,0.60\n";

// Errors: a/s1 +1 cm, b/s1 -2 cm, c/s1 no estimate (empty height), a/s2 +5 cm, b/s2 0,
// c/s2 no estimate row; x/s2 has no truth.
constexpr char kEstimates[] =
    "site_id,session,date,height_m,cover,volume_m3,n_points\n"
    "a,s1,2016-06-01,0.11,0.2,0.001,120\n"
    "b,s1,2016-06-01,0.18,0.3,0.002,130\n"
    "c,s1,2016-06-01,,0,0,0\n"
    "a,s2,2016-06-15,0.45,0.5,0.01,300\n"
    "b,s2,2016-06-15,0.50,0.5,0.01,310\n"
    "x,s2,2016-06-15,0.30,0.5,0.01,10\n";

class CanopyEvalTest : public ::testing::Test {
 public:
  std::string Write(const std::string& name, const std::string& text) {
    const std::string path = dir_ / name;
    WriteFile(path, text);
    return path;
  }
  // The InputError of reading `text` as estimates (truth when `truth`); fails when none.
  InputError ReadError(const std::string& text, bool truth = false) {
    const std::string path = Write("bad.csv", text);
    try {
      if (truth) {
        ReadSiteTruth(path);
      } else {
        ReadSiteHeights(path);
      }
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      return e;
    }
    ADD_FAILURE() << "no InputError for:\n" << text;
    return InputError("none");
  }

 protected:
  PidTempDir dir_;
};

TEST_F(CanopyEvalTest, ReadsBothFiles) {
  const std::vector<SiteHeight> truth = ReadSiteTruth(Write("truth.csv", kTruth));
  ASSERT_EQ(truth.size(), 6u);
  EXPECT_EQ(truth[3].site_id, "a");
  EXPECT_EQ(truth[3].session, "s2");
  EXPECT_EQ(truth[3].date, "2016-06-15");
  EXPECT_DOUBLE_EQ(truth[3].height_m, 0.40);
  EXPECT_EQ(truth[3].line, 5);
  const std::vector<SiteHeight> est = ReadSiteHeights(Write("est.csv", kEstimates));
  ASSERT_EQ(est.size(), 6u);
  EXPECT_DOUBLE_EQ(est[0].cover, 0.2);
  EXPECT_DOUBLE_EQ(est[0].volume_m3, 0.001);
  EXPECT_EQ(est[0].n_points, 120);
  EXPECT_TRUE(std::isnan(est[2].height_m));  // empty: no estimate
}

TEST_F(CanopyEvalTest, ErrorsAsComputedByHand) {
  const CanopyMethodEval e = EvaluateCanopyHeights(ReadSiteHeights(Write("est.csv", kEstimates)),
                                                   ReadSiteTruth(Write("truth.csv", kTruth)));
  ASSERT_TRUE(e.ok());
  ASSERT_EQ(e.pairs.size(), 6u);
  const CanopyErrorStats& s = e.overall;
  EXPECT_EQ(s.num_truth, 6);
  EXPECT_EQ(s.num_pairs, 4);
  EXPECT_EQ(s.num_missing, 2);
  // Errors +0.01, -0.02, +0.05, 0.
  EXPECT_NEAR(s.rmse_m, std::sqrt((1e-4 + 4e-4 + 25e-4) / 4.0), 1e-12);
  EXPECT_NEAR(s.bias_m, 0.01, 1e-12);
  EXPECT_NEAR(s.mae_m, 0.02, 1e-12);
  EXPECT_NEAR(s.max_abs_error_m, 0.05, 1e-12);
  // Failures: c/s1 missing, a/s2 +5 cm, c/s2 missing.
  EXPECT_EQ(s.num_failures, 3);
  // The interval over the sites with an estimate, a (+1, +5 cm) and b (-2, 0 cm): every draw is
  // aa, ab or bb, so it spans bb's RMSE to aa's.
  EXPECT_EQ(e.rmse_interval.num_sites, 2);
  EXPECT_NEAR(e.rmse_interval.low, std::sqrt(4e-4 / 2.0), 1e-12);
  EXPECT_NEAR(e.rmse_interval.high, std::sqrt(26e-4 / 2.0), 1e-12);
  ASSERT_EQ(e.failures.size(), 3u);
  EXPECT_EQ(e.pairs[e.failures[0]].site_id, "c");
  EXPECT_EQ(e.pairs[e.failures[0]].session, "s1");
  EXPECT_TRUE(e.pairs[e.failures[0]].missing());
  EXPECT_EQ(e.pairs[e.failures[1]].site_id, "a");
  EXPECT_NEAR(e.pairs[e.failures[1]].error_m, 0.05, 1e-12);
  EXPECT_EQ(e.pairs[e.failures[2]].site_id, "c");
  EXPECT_EQ(e.pairs[e.failures[2]].session, "s2");
  EXPECT_TRUE(e.pairs[e.failures[2]].missing());
  // Worst.
  ASSERT_GE(e.worst, 0);
  EXPECT_EQ(e.pairs[e.worst].site_id, "a");
  EXPECT_EQ(e.pairs[e.worst].session, "s2");
  EXPECT_EQ(e.pairs[e.worst].date, "2016-06-15");
  EXPECT_EQ(e.pairs[e.worst].n_points, 300);
  EXPECT_EQ(e.num_without_truth, 1);  // x/s2
  // Per session.
  ASSERT_EQ(e.sessions.size(), 2u);
  const CanopySessionEval& s1 = e.sessions[0];
  EXPECT_EQ(s1.session, "s1");
  EXPECT_EQ(s1.date, "2016-06-01");
  EXPECT_EQ(s1.stats.num_pairs, 2);
  EXPECT_EQ(s1.stats.num_missing, 1);
  EXPECT_NEAR(s1.stats.rmse_m, std::sqrt((1e-4 + 4e-4) / 2.0), 1e-12);
  EXPECT_NEAR(s1.stats.bias_m, -0.005, 1e-12);
  EXPECT_NEAR(s1.stats.max_abs_error_m, 0.02, 1e-12);
  EXPECT_EQ(s1.stats.num_failures, 1);
  const CanopySessionEval& s2 = e.sessions[1];
  EXPECT_EQ(s2.stats.num_pairs, 2);
  EXPECT_EQ(s2.stats.num_missing, 1);
  EXPECT_NEAR(s2.stats.rmse_m, std::sqrt(25e-4 / 2.0), 1e-12);
  EXPECT_NEAR(s2.stats.bias_m, 0.025, 1e-12);
  EXPECT_NEAR(s2.stats.max_abs_error_m, 0.05, 1e-12);
  EXPECT_EQ(s2.stats.num_failures, 2);
}

TEST_F(CanopyEvalTest, OptionsSelectSessionsAndTheLimit) {
  const std::vector<SiteHeight> est = ReadSiteHeights(Write("est.csv", kEstimates));
  const std::vector<SiteHeight> truth = ReadSiteTruth(Write("truth.csv", kTruth));
  CanopyEvalOptions options;
  options.sessions = {"s1"};
  options.max_error_m = 0.015;
  const CanopyMethodEval e = EvaluateCanopyHeights(est, truth, options);
  EXPECT_EQ(e.overall.num_truth, 3);
  EXPECT_EQ(e.overall.num_pairs, 2);
  EXPECT_EQ(e.overall.num_failures, 2);  // b/s1 -2 cm and c/s1 missing
  EXPECT_EQ(e.num_without_truth, 0);
  ASSERT_EQ(e.sessions.size(), 1u);
  options.max_error_m = -1.0;
  EXPECT_NE(options.Check(), "");
}

TEST_F(CanopyEvalTest, NoEstimateAtAll) {
  const CanopyMethodEval e =
      EvaluateCanopyHeights(ReadSiteHeights(Write("est.csv",
                                                  "site_id,session,date,height_m,cover,volume_m3,"
                                                  "n_points\n"
                                                  "a,s1,2016-06-01,,,,\n")),
                            ReadSiteTruth(Write("truth.csv", kTruth)));
  EXPECT_EQ(e.overall.num_pairs, 0);
  EXPECT_EQ(e.overall.num_missing, 6);
  EXPECT_EQ(e.overall.num_failures, 6);
  EXPECT_TRUE(std::isnan(e.overall.rmse_m));
  EXPECT_EQ(e.worst, -1);
}

TEST_F(CanopyEvalTest, EstimatesOfAnotherLayoutAreRefusedTheTruthIsReadByColumnName) {
  // site_heights.csv is crop4d's own table: another header is another version of it.
  const InputError e = ReadError("#session,site_id,height_m,extra\ns1,a,0.12,foo\n");
  EXPECT_NE(e.message().find("crop4d analyze"), std::string::npos) << e.what();
  // The truth: a '#' header, other columns and order; a row without a height is skipped.
  const std::vector<SiteHeight> truth = ReadSiteTruth(
      Write("truth.csv", "#session,site_id,height_m,extra\ns1,a,0.1,foo\ns1,b,,bar\n"));
  ASSERT_EQ(truth.size(), 1u);
  EXPECT_EQ(truth[0].site_id, "a");
  EXPECT_EQ(truth[0].session, "s1");
  EXPECT_DOUBLE_EQ(truth[0].height_m, 0.1);
  EXPECT_TRUE(truth[0].date.empty());
}

TEST_F(CanopyEvalTest, MalformedFilesThrowWithFileAndLine) {
  const std::string header = "site_id,session,date,height_m,cover,volume_m3,n_points\n";
  InputError e = ReadError(header + "a,s1,2016-06-01,0.1,0,0,1\na,s2,2016-06-01,0.1,0\n");
  EXPECT_EQ(e.line(), 3);
  EXPECT_NE(e.message().find("expected 7 fields"), std::string::npos) << e.what();
  e = ReadError(header + "a,s1,2016-06-01,tall,0,0,1\n");
  EXPECT_EQ(e.line(), 2);
  EXPECT_NE(e.message().find("height_m 'tall' is not a finite number"), std::string::npos)
      << e.what();
  e = ReadError(header + "a,s1,2016-06-01,inf,0,0,1\n");
  EXPECT_NE(e.message().find("not a finite number"), std::string::npos) << e.what();
  e = ReadError(header + "a,s1,2016-06-01,0.1,0,0,-3\n");
  EXPECT_NE(e.message().find("n_points"), std::string::npos) << e.what();
  e = ReadError(header + "a,s1,06/01/2016,0.1,0,0,1\n");
  EXPECT_NE(e.message().find("YYYY-MM-DD"), std::string::npos) << e.what();
  e = ReadError(header + "a,s1,2016-06-01,0.1,0,0,1\n\na,s1,2016-06-01,0.2,0,0,1\n");
  EXPECT_EQ(e.line(), 4);
  EXPECT_NE(e.message().find("repeated (first on line 2)"), std::string::npos) << e.what();
  e = ReadError(header + ",s1,2016-06-01,0.1,0,0,1\n");
  EXPECT_NE(e.message().find("empty site_id"), std::string::npos) << e.what();
  e = ReadError("site,session,date,height_m\na,s1,2016-06-01,0.1\n", true);
  EXPECT_EQ(e.line(), 1);
  EXPECT_NE(e.message().find("no column 'site_id'"), std::string::npos) << e.what();
  e = ReadError("", true);
  EXPECT_NE(e.message().find("empty file"), std::string::npos) << e.what();
  EXPECT_THROW(ReadSiteTruth(dir_ / "does_not_exist.csv"), InputError);
}

// The canopy section of a workspace evaluation (with the row passes of the eval fixture).
class WorkspaceCanopyTest : public CanopyEvalTest {
 public:
  void SetUp() override { testing::WriteWorkspaceAndTruth(workspace(), field()); }
  std::string workspace() const { return dir_ / "ws"; }
  std::string field() const { return dir_ / "field"; }
};

TEST_F(WorkspaceCanopyTest, EvaluatesBothMethods) {
  WriteFile(field() + "/ground_truth/site_truth.csv", kTruth);
  WriteFile(workspace() + "/analysis/site_heights.csv", kEstimates);
  // The single plane: every estimate 3 cm low, all present.
  WriteFile(workspace() + "/analysis/site_heights_single_plane.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\n"
            "a,s1,2016-06-01,0.07,,,\nb,s1,2016-06-01,0.17,,,\nc,s1,2016-06-01,0.27,,,\n"
            "a,s2,2016-06-15,0.37,,,\nb,s2,2016-06-15,0.47,,,\nc,s2,2016-06-15,0.57,,,\n");
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  ASSERT_TRUE(eval.canopy.has_value()) << eval.canopy_skipped;
  ASSERT_EQ(eval.canopy->methods.size(), 2u);
  const CanopyMethodEval& ours = eval.canopy->methods[0];
  const CanopyMethodEval& plane = eval.canopy->methods[1];
  EXPECT_EQ(ours.method, "ours");
  EXPECT_EQ(ours.file, "analysis/site_heights.csv");
  EXPECT_NEAR(ours.overall.bias_m, 0.01, 1e-12);
  EXPECT_EQ(plane.method, "single_plane");
  EXPECT_EQ(plane.overall.num_pairs, 6);
  EXPECT_NEAR(plane.overall.bias_m, -0.03, 1e-12);
  EXPECT_NEAR(plane.overall.rmse_m, 0.03, 1e-12);
  EXPECT_EQ(plane.overall.num_failures, 0);

  const nlohmann::json j = nlohmann::json::parse(WorkspaceEvalJson(eval));
  ASSERT_TRUE(j.contains("canopy"));
  const nlohmann::json& c = j["canopy"];
  EXPECT_EQ(c["truth_file"], "ground_truth/site_truth.csv");
  EXPECT_DOUBLE_EQ(c["options"]["max_error_m"].get<double>(), 0.04);
  EXPECT_NEAR(c["ours"]["rmse_m"].get<double>(), std::sqrt(7.5e-4), 1e-12);
  EXPECT_EQ(c["ours"]["num_missing"], 2);
  EXPECT_EQ(c["ours"]["num_failures"], 3);
  EXPECT_EQ(c["ours"]["worst"]["site_id"], "a");
  EXPECT_EQ(c["ours"]["failures"].size(), 3u);
  EXPECT_TRUE(c["ours"]["failures"][0]["estimate_m"].is_null());
  EXPECT_EQ(c["ours"]["sessions"].size(), 2u);
  EXPECT_EQ(c["ours"]["pairs"].size(), 6u);
  EXPECT_NEAR(c["ours"]["rmse_interval_m"]["low"].get<double>(), std::sqrt(2e-4), 1e-12);
  EXPECT_NEAR(c["ours"]["rmse_interval_m"]["high"].get<double>(), std::sqrt(13e-4), 1e-12);
  EXPECT_EQ(c["ours"]["rmse_interval_m"]["num_sites"], 2);
  EXPECT_NEAR(c["single_plane"]["bias_m"].get<double>(), -0.03, 1e-12);

  const std::string table = FormatWorkspaceEvalTable(eval);
  EXPECT_NE(table.find("canopy height per site and session"), std::string::npos) << table;
  EXPECT_NE(table.find("single_plane"), std::string::npos) << table;
  EXPECT_NE(table.find("ours RMSE: 95 % interval 1.41-3.61 cm over its 2 sites"), std::string::npos)
      << table;
  EXPECT_NE(table.find("a s2 (+5.00)"), std::string::npos) << table;
  EXPECT_NE(table.find("ours failures: c s1 no estimate, a s2 +5.00, c s2 no estimate"),
            std::string::npos)
      << table;
}

TEST_F(WorkspaceCanopyTest, SkippedWithANoteWhenFilesAreMissing) {
  WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  EXPECT_FALSE(eval.canopy.has_value());
  EXPECT_NE(eval.canopy_skipped.find("analysis/site_heights.csv"), std::string::npos);
  EXPECT_NE(FormatWorkspaceEvalTable(eval).find("canopy height: not evaluated"), std::string::npos);
  EXPECT_FALSE(nlohmann::json::parse(WorkspaceEvalJson(eval)).contains("canopy"));

  WriteFile(workspace() + "/analysis/site_heights.csv", kEstimates);  // no truth file
  eval = EvaluateWorkspace(workspace(), field());
  EXPECT_FALSE(eval.canopy.has_value());
  EXPECT_NE(eval.canopy_skipped.find("site_truth.csv"), std::string::npos);

  WriteFile(field() + "/ground_truth/site_truth.csv", kTruth);
  WorkspaceEvalOptions options;
  options.canopy = false;
  eval = EvaluateWorkspace(workspace(), field(), options);
  EXPECT_FALSE(eval.canopy.has_value());
  EXPECT_TRUE(eval.canopy_skipped.empty());
}

TEST_F(WorkspaceCanopyTest, MalformedFilesAreTheMethodsErrors) {
  WriteFile(field() + "/ground_truth/site_truth.csv", kTruth);
  WriteFile(workspace() + "/analysis/site_heights.csv",
            "site_id,session,date,height_m,cover,volume_m3,n_points\na,s1,2016-06-01,x,,,\n");
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  ASSERT_TRUE(eval.canopy.has_value());
  ASSERT_EQ(eval.canopy->methods.size(), 1u);
  EXPECT_FALSE(eval.canopy->methods[0].ok());
  EXPECT_NE(eval.canopy->methods[0].error.find("site_heights.csv:2: height_m 'x'"),
            std::string::npos)
      << eval.canopy->methods[0].error;
  const nlohmann::json j = nlohmann::json::parse(WorkspaceEvalJson(eval));
  EXPECT_TRUE(j["canopy"]["ours"]["error"].is_string());
}

// A workspace with canopy heights only (no row pass yet) is still evaluated.
TEST(WorkspaceCanopyOnlyTest, CanopyAloneIsSomethingToEvaluate) {
  PidTempDir dir;
  WriteFile(dir / "field/ground_truth/site_truth.csv", kTruth);
  WriteFile(dir / "ws/analysis/site_heights.csv", kEstimates);
  const WorkspaceEval eval = EvaluateWorkspace(dir / "ws", dir / "field");
  EXPECT_TRUE(eval.passes.empty());
  ASSERT_TRUE(eval.canopy.has_value());
  EXPECT_EQ(eval.canopy->methods[0].overall.num_pairs, 4);
}

}  // namespace
}  // namespace crop4d::eval
