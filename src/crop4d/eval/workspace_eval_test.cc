// Workspace evaluation end to end: a temporary workspace and field ground truth with known
// errors, metrics.json, the table, and the errors for missing or malformed files.

#include "crop4d/eval/workspace_eval.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <nlohmann/json.hpp>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;
using testing::PidTempDir;
using testing::WriteFile;

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

class WorkspaceEvalTest : public ::testing::Test {
 public:
  void SetUp() override { testing::WriteWorkspaceAndTruth(workspace(), field()); }
  std::string workspace() const { return dir_ / "ws"; }
  std::string field() const { return dir_ / "field"; }
  std::string PassDir(const std::string& session, const std::string& pass) const {
    return workspace() + "/sessions/" + session + "/rows/" + pass + "/";
  }
  const PassEval& Find(const WorkspaceEval& eval, const std::string& session,
                       const std::string& pass) {
    for (const PassEval& p : eval.passes) {
      if (p.session == session && p.pass == pass) return p;
    }
    ADD_FAILURE() << "no pass " << session << "/" << pass;
    return eval.passes.front();
  }

 protected:
  PidTempDir dir_;
};

TEST_F(WorkspaceEvalTest, EvaluatesEveryPassAgainstItsTruth) {
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  ASSERT_EQ(eval.passes.size(), 3u);

  // Camera pass: 3 cm east at every image timestamp (exact association).
  const PassEval& camera = Find(eval, "2016-05-25", "0");
  ASSERT_TRUE(camera.ok()) << camera.error;
  EXPECT_EQ(camera.pose_frame, "camera");
  EXPECT_EQ(camera.sensors, "cam+imu+rtk");
  EXPECT_EQ(camera.row, 0);
  EXPECT_EQ(camera.direction, 1);
  EXPECT_EQ(camera.truth_file, "ground_truth/2016-05-25/cam0_poses.tum");
  EXPECT_EQ(camera.estimate_poses, 201);
  EXPECT_EQ(camera.exact, 201);
  EXPECT_EQ(camera.metrics.num_poses, 201);
  EXPECT_NEAR(camera.metrics.ate_raw_m.rmse, 0.03, 1e-5);
  EXPECT_LT(camera.metrics.ate_aligned_m.rmse, 1e-5);
  EXPECT_LT(camera.metrics.rotation_deg.max, 1e-5);
  EXPECT_LT(camera.metrics.rpe_translation_percent.max, 1e-2);
  EXPECT_GT(camera.metrics.rpe_translation_percent.count, 150);

  // Body pass: 1 cm north, at timestamps between the IMU samples (interpolated truth).
  const PassEval& body = Find(eval, "2016-05-25", "1");
  ASSERT_TRUE(body.ok()) << body.error;
  EXPECT_EQ(body.truth_file, "ground_truth/2016-05-25/body_poses.tum");
  EXPECT_EQ(body.interpolated, 96);
  EXPECT_EQ(body.exact, 0);
  EXPECT_EQ(body.dropped_out_of_span, 0);
  EXPECT_NEAR(body.metrics.ate_raw_m.rmse, 0.01, 1e-4);
  EXPECT_LT(body.metrics.ate_aligned_m.rmse, 1e-4);
  EXPECT_LT(body.metrics.rotation_deg.max, 1e-3);

  // The session without ground truth is listed with its error.
  const PassEval& missing = Find(eval, "2016-05-26", "0");
  EXPECT_FALSE(missing.ok());
  EXPECT_NE(missing.error.find("no ground truth for session '2016-05-26'"), std::string::npos)
      << missing.error;
  EXPECT_NE(missing.error.find("cam0_poses.tum"), std::string::npos) << missing.error;

  // Pooled: 201 poses at 3 cm and 96 at 1 cm.
  const OverallEval& o = eval.overall;
  EXPECT_EQ(o.num_passes, 3);
  EXPECT_EQ(o.num_evaluated, 2);
  EXPECT_EQ(o.num_failed, 1);
  EXPECT_EQ(o.num_poses, 297);
  EXPECT_NEAR(o.ate_raw_m.rmse, std::sqrt((201 * 9e-4 + 96 * 1e-4) / 297), 1e-4);
  EXPECT_NEAR(o.ate_raw_m.max, 0.03, 1e-5);
  EXPECT_LT(o.ate_aligned_m.rmse, 1e-4);
  ASSERT_GE(o.worst_pass, 0);
  EXPECT_EQ(eval.passes[o.worst_pass].session, "2016-05-25");
  EXPECT_EQ(eval.passes[o.worst_pass].pass, "0");
}

TEST_F(WorkspaceEvalTest, APassInAFrameSetByConventionIsAlignedByHeadingAndShift) {
  // The camera pass (3 cm east of the truth) as a pass without GPS would say it: its frame is a
  // convention, so the offset is aligned away before the "raw" errors; the table marks it.
  const std::string summary_path = PassDir("2016-05-25", "0") + "summary.json";
  nlohmann::json summary = nlohmann::json::parse(ReadAll(summary_path));
  summary["trust"] = {"heading_by_convention", "origin_by_convention"};
  WriteFile(summary_path, summary.dump());
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  const PassEval& camera = Find(eval, "2016-05-25", "0");
  ASSERT_TRUE(camera.ok()) << camera.error;
  EXPECT_TRUE(camera.frame_by_convention);
  EXPECT_LT(camera.metrics.ate_raw_m.rmse, 1e-5);
  EXPECT_LT(camera.metrics.rotation_deg.max, 1e-5);
  // The other pass keeps its 1 cm.
  EXPECT_NEAR(Find(eval, "2016-05-25", "1").metrics.ate_raw_m.rmse, 0.01, 1e-4);
  const std::string table = FormatWorkspaceEvalTable(eval);
  EXPECT_NE(table.find("0*"), std::string::npos) << table;
  EXPECT_NE(table.find("* no GPS"), std::string::npos) << table;
}

TEST_F(WorkspaceEvalTest, WritesMetricsJson) {
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
  const std::string path = WriteWorkspaceEval(eval);
  EXPECT_EQ(path, workspace() + "/eval/metrics.json");
  const nlohmann::json j = nlohmann::json::parse(ReadAll(path));
  ASSERT_EQ(j["passes"].size(), 3u);
  const nlohmann::json& p0 = j["passes"][0];
  EXPECT_EQ(p0["session"], "2016-05-25");
  EXPECT_EQ(p0["pass"], "0");
  EXPECT_EQ(p0["row"], 0);
  EXPECT_EQ(p0["direction"], 1);
  EXPECT_EQ(p0["sensors"], "cam+imu+rtk");
  EXPECT_TRUE(p0["error"].is_null());
  EXPECT_NEAR(p0["metrics"]["ate_raw_m"]["rmse"].get<double>(), 0.03, 1e-5);
  EXPECT_LT(p0["metrics"]["ate_aligned_m"]["rmse"].get<double>(), 1e-5);
  EXPECT_EQ(p0["metrics"]["num_poses"], 201);
  EXPECT_EQ(p0["metrics"]["rpe"]["distance_m"], 1.0);
  EXPECT_TRUE(p0["metrics"]["rpe"]["translation_percent"]["rmse"].is_number());
  EXPECT_TRUE(p0["metrics"]["rotation_deg"]["rmse"].is_number());
  EXPECT_EQ(p0["metrics"]["truth_from_estimate"]["translation_m"].size(), 3u);
  EXPECT_EQ(p0["association"]["exact"], 201);
  const nlohmann::json& p2 = j["passes"][2];
  EXPECT_TRUE(p2["error"].is_string());
  EXPECT_TRUE(p2["metrics"].is_null());
  EXPECT_EQ(j["overall"]["num_evaluated"], 2);
  EXPECT_EQ(j["overall"]["num_poses"], 297);
  EXPECT_EQ(j["overall"]["worst_pass"]["pass"], "0");
  EXPECT_TRUE(j["overall"]["ate_raw_m"]["rmse"].is_number());
  EXPECT_TRUE(j["overall"]["rpe"]["translation_percent"]["rmse"].is_number());

  // Another path.
  EXPECT_EQ(WriteWorkspaceEval(eval, dir_ / "other/m.json"), dir_ / "other/m.json");
  EXPECT_TRUE(fs::exists(dir_ / "other/m.json"));
}

TEST_F(WorkspaceEvalTest, TableHasOneLinePerPass) {
  const std::string table = FormatWorkspaceEvalTable(EvaluateWorkspace(workspace(), field()));
  std::istringstream lines(table);
  std::vector<std::string> rows;
  for (std::string line; std::getline(lines, line);) rows.push_back(line);
  ASSERT_GE(rows.size(), 5u) << table;
  for (const char* column :
       {"session", "pass", "sensors", "N", "ATE raw cm", "ATE aligned cm", "RPE %", "rot deg"}) {
    EXPECT_NE(rows[0].find(column), std::string::npos) << column << "\n" << table;
  }
  EXPECT_NE(rows[1].find("2016-05-25"), std::string::npos) << table;
  EXPECT_NE(rows[1].find("cam+imu+rtk"), std::string::npos) << table;
  EXPECT_NE(rows[1].find("201"), std::string::npos) << table;
  EXPECT_NE(rows[1].find("3.00"), std::string::npos) << table;  // ATE raw, cm
  EXPECT_NE(rows[2].find("1.00"), std::string::npos) << table;
  EXPECT_NE(rows[3].find("error: "), std::string::npos) << table;
  EXPECT_EQ(rows[4].rfind("all", 0), 0u) << table;
  EXPECT_NE(rows[4].find("2/3"), std::string::npos) << table;
  EXPECT_NE(table.find("worst pass"), std::string::npos) << table;
}

TEST_F(WorkspaceEvalTest, SessionFilterAndOptions) {
  WorkspaceEvalOptions options;
  options.sessions = {"2016-05-25"};
  options.metrics.rpe_distance_m = 0.0;
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field(), options);
  ASSERT_EQ(eval.passes.size(), 2u);
  EXPECT_EQ(eval.overall.num_failed, 0);
  EXPECT_EQ(eval.passes[0].metrics.rpe_translation_percent.count, 1);

  options.sessions = {"2017-01-01"};
  EXPECT_THROW(EvaluateWorkspace(workspace(), field(), options), InputError);

  // Association tolerance below the 10 ms IMU period: the body pass cannot be compared.
  WorkspaceEvalOptions tight;
  tight.max_dt_s = 0.001;
  const WorkspaceEval t = EvaluateWorkspace(workspace(), field(), tight);
  const PassEval& body = Find(t, "2016-05-25", "1");
  EXPECT_FALSE(body.ok());
  EXPECT_NE(body.error.find("none of its 96 poses can be compared"), std::string::npos)
      << body.error;
  EXPECT_NE(body.error.find("96 in gaps"), std::string::npos) << body.error;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "(no InputError)";
}

TEST_F(WorkspaceEvalTest, MissingFoldersAreInputErrors) {
  fs::remove_all(field() + "/ground_truth");
  const std::string no_truth = ErrorOf([&] { EvaluateWorkspace(workspace(), field()); });
  EXPECT_NE(no_truth.find(field() + "/ground_truth: ground truth folder not found"),
            std::string::npos)
      << no_truth;

  const std::string no_ws = ErrorOf([&] { EvaluateWorkspace(dir_ / "nope", field()); });
  EXPECT_NE(no_ws.find("workspace folder not found"), std::string::npos) << no_ws;

  fs::create_directories(dir_ / "empty_ws");
  testing::WriteTruth(field(), "2016-05-25");
  const std::string no_pass = ErrorOf([&] { EvaluateWorkspace(dir_ / "empty_ws", field()); });
  EXPECT_NE(no_pass.find("no row pass in the workspace"), std::string::npos) << no_pass;
}

TEST_F(WorkspaceEvalTest, MalformedPassFilesAreListedWithClearErrors) {
  struct Case {
    const char* name;
    std::function<void()> breakit;
    std::string expected;
  };
  const std::string p = PassDir("2016-05-25", "0");
  // Changes one field of the pass's (valid) summary.
  const auto edit = [&](const std::function<void(nlohmann::json&)>& change) {
    nlohmann::json summary = nlohmann::json::parse(ReadAll(p + "summary.json"));
    change(summary);
    WriteFile(p + "summary.json", summary.dump());
  };
  const std::vector<Case> cases = {
      {"missing summary", [&] { fs::remove(p + "summary.json"); },
       p + "summary.json: missing (run `crop4d slam` first)"},
      {"bad json", [&] { WriteFile(p + "summary.json", "{\"pose_frame\": "); },
       p + "summary.json: not valid JSON"},
      {"not an object", [&] { WriteFile(p + "summary.json", "[1, 2]"); },
       "summary.json: written by another crop4d version (schema none"},
      {"another schema", [&] { edit([](nlohmann::json& j) { j["schema"] = 99; }); },
       "summary.json: written by another crop4d version (schema 99"},
      {"no fingerprint", [&] { edit([](nlohmann::json& j) { j.erase("fingerprint"); }); },
       "summary.json: a missing or mistyped field"},
      {"no pose_frame", [&] { edit([](nlohmann::json& j) { j.erase("pose_frame"); }); },
       "missing required key 'pose_frame'"},
      {"bad pose_frame", [&] { edit([](nlohmann::json& j) { j["pose_frame"] = "imu"; }); },
       "'pose_frame' is 'imu', expected \"camera\" or \"body\""},
      {"row not an integer", [&] { edit([](nlohmann::json& j) { j["row"] = "x"; }); },
       "'row' must be an integer"},
      {"wrong pass", [&] { edit([](nlohmann::json& j) { j["pass"] = "7"; }); },
       "'pass' is '7' but the pass is in rows/0/"},
      {"missing poses", [&] { fs::remove(p + "poses.tum"); }, p + "poses.tum: file not found"},
      {"malformed poses",
       [&] { WriteFile(p + "poses.tum", "# t x\n1464184800.0 1 2 3 0 0 0 1\n1464184800.1 1 2\n"); },
       p + "poses.tum:3: expected 8 numbers"},
      {"empty poses", [&] { WriteFile(p + "poses.tum", "# nothing\n"); },
       p + "poses.tum: holds no pose"},
      {"poses outside the truth",
       [&] { WriteFile(p + "poses.tum", "100.0 1 2 3 0 0 0 1\n101.0 1 2 3 0 0 0 1\n"); },
       "none of its 2 poses can be compared with ground_truth/2016-05-25/cam0_poses.tum (2 "
       "outside the truth's time span"},
      {"malformed truth",
       [&] { WriteFile(field() + "/ground_truth/2016-05-25/cam0_poses.tum", "x\n"); },
       "cam0_poses.tum:1: expected 8 numbers"},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.name);
    fs::remove_all(workspace());
    fs::remove_all(field());
    testing::WriteWorkspaceAndTruth(workspace(), field());
    c.breakit();
    const WorkspaceEval eval = EvaluateWorkspace(workspace(), field());
    const PassEval& broken = Find(eval, "2016-05-25", "0");
    EXPECT_FALSE(broken.ok());
    EXPECT_NE(broken.error.find(c.expected), std::string::npos)
        << "expected: " << c.expected << "\n"
        << broken.error;
    // The other pass of the session is still evaluated.
    EXPECT_TRUE(Find(eval, "2016-05-25", "1").ok()) << Find(eval, "2016-05-25", "1").error;
    EXPECT_EQ(eval.overall.num_failed, 2);
  }
}

TEST(NaturalOrderTest, PassesSortNumerically) {
  PidTempDir dir;
  const std::string ws = dir / "ws", field = dir / "field";
  testing::WriteTruth(field, "s");
  for (const char* pass : {"10", "2", "1"}) {
    testing::WritePass(ws, "s", pass, std::stoi(pass), "cam", "camera",
                       testing::SampleTrajectory(10.0, 5.0, true));
  }
  const WorkspaceEval eval = EvaluateWorkspace(ws, field);
  ASSERT_EQ(eval.passes.size(), 3u);
  EXPECT_EQ(eval.passes[0].pass, "1");
  EXPECT_EQ(eval.passes[1].pass, "2");
  EXPECT_EQ(eval.passes[2].pass, "10");
  for (const PassEval& p : eval.passes) EXPECT_TRUE(p.ok()) << p.error;
  EXPECT_TRUE(dir.path().find(std::to_string(::getpid())) != std::string::npos);
}

}  // namespace
}  // namespace crop4d::eval

namespace crop4d::eval {
namespace {

TEST(AssociationTableTest, RatiosOfTheRobustToTheNaiveCorrectMatchesPerPairType) {
  WorkspaceAssociationEval section;
  section.num_files = 3;
  const auto group = [](PairType type, const char* method, int correct, int correct_near) {
    AssociationGroupEval g;
    g.type = type;
    g.method = method;
    g.files = 1;
    g.counts.matches = g.counts.correct = correct;
    g.counts.known_near = g.counts.correct_near = correct_near;
    return g;
  };
  section.eval.groups = {group(PairType::kCrossRowSameDirection, "robust", 30, 30),
                         group(PairType::kCrossSession, "naive", 20, 8),
                         group(PairType::kCrossSession, "robust", 50, 40)};
  const std::string table = FormatAssociationTable(section);
  // Only the type with both methods gets a ratio: 50 / 20 in all, 40 / 8 near the vehicle.
  EXPECT_NE(table.find("session: 2.50x (5.00x <=5m)"), std::string::npos) << table;
  EXPECT_EQ(table.find("row same dir: "), std::string::npos) << table;
  EXPECT_NE(table.find("correct <=5m"), std::string::npos) << table;
}

}  // namespace
}  // namespace crop4d::eval
