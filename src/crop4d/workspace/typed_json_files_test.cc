// The association summaries, WS/fused/quality.json, WS/fused/<s>/camera.json and
// WS/eval/metrics.json: round trips that
// keep the bytes the stages wrote before they had typed readers, and the errors for malformed,
// incomplete and foreign-schema files.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <tuple>

#include "crop4d/core/error.h"
#include "crop4d/workspace/association_summary.h"
#include "crop4d/workspace/eval_metrics.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/json_file.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/season_quality.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

class TypedJsonFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_typed_json_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  std::string Write(const std::string& name, const std::string& text) const {
    fs::create_directories((dir_ / name).parent_path());
    std::ofstream(Path(name), std::ios::binary) << text;
    return Path(name);
  }
  static std::string Read(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream text;
    text << in.rdbuf();
    return text.str();
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
  static bool Has(const std::string& text, const std::string& what) {
    return text.find(what) != std::string::npos;
  }

  // What the associate stage writes for a pair (pipeline/associate_stage.cc).
  static json Association() {
    return {{"a", {{"session", "2016-06-01"}, {"pass", "row00"}}},
            {"b", {{"session", "2016-06-15"}, {"pass", "row01"}}},
            {"type", "cross-session same direction"},
            {"method", "robust"},
            {"image_pairs", 40},
            {"landmarks", 5000},
            {"surface_points", 4000},
            {"projected", 3000},
            {"candidates", 2500},
            {"warped", 2400},
            {"upright_b", 100},
            {"putative", 400},
            {"matches", 321},
            {"prealigned", true},
            {"alignment_inliers", 77},
            {"alignment_shift_m", 0.25},
            {"seconds", 3.25},
            {"seconds_per_image_pair", 3.25 / 40},
            {"options", {{"prealign", "auto"}}},
            {"fingerprint", "42"},
            {"outputs", {{"x.bin", {{"bytes", 10}, {"hash", "1"}}}}}};
  }

  fs::path dir_;
};

TEST_F(TypedJsonFilesTest, AnAssociationSummaryRoundTripsWithTheStagesBytes) {
  const json j = Association();
  const std::string path = Path("associations/robust/p.json");
  fs::create_directories(fs::path(path).parent_path());
  WriteAssociationSummary(path, j);
  EXPECT_EQ(Read(path), j.dump(2) + "\n");  // as the stage writes it: no "schema" at schema 1
  const AssociationSummary s = ReadAssociationSummary(path);
  EXPECT_EQ(s.a, (association::PassRef{"2016-06-01", "row00"}));
  EXPECT_EQ(s.b, (association::PassRef{"2016-06-15", "row01"}));
  EXPECT_EQ(s.type, "cross-session same direction");
  EXPECT_EQ(s.method, "robust");
  EXPECT_EQ(s.fingerprint, "42");
  EXPECT_EQ(s.image_pairs, 40);
  EXPECT_EQ(s.landmarks, 5000);
  EXPECT_EQ(s.surface_points, 4000);
  EXPECT_EQ(s.projected, 3000);
  EXPECT_EQ(s.candidates, 2500);
  EXPECT_EQ(s.warped, 2400);
  EXPECT_EQ(s.upright_b, 100);
  EXPECT_EQ(s.putative, 400);
  EXPECT_EQ(s.matches, 321);
  EXPECT_TRUE(s.prealigned);
  EXPECT_EQ(s.alignment_inliers, 77);
  EXPECT_DOUBLE_EQ(s.alignment_shift_m, 0.25);
  EXPECT_DOUBLE_EQ(s.seconds, 3.25);
  EXPECT_EQ(s.json, j);
}

TEST_F(TypedJsonFilesTest, AFusedCameraRoundTripsToTheLastBitAndRefusesBadFiles) {
  FusedCamera camera;
  camera.intrinsics = {1280,     960,      1101.123456789012, 1090.1 / 3, 640.25,  479.1 / 7,
                       -0.2 / 3, 0.05 / 7, 1e-3 / 3,          -5e-4,      0.01 / 9};
  camera.body_from_camera =
      geometry::Rigid3(Eigen::Quaterniond(0.5, -0.5, 0.5, -0.5) *
                           Eigen::Quaterniond(0.99, 0.01, 0.1 / 3, 0.02).normalized(),
                       Eigen::Vector3d(0.4 / 3, 0.05, 1.5 / 7));
  camera.refined = true;
  camera.rotation_change_deg = 0.3 / 7;
  const std::string path = Path("fused/s/camera.json");
  fs::create_directories(fs::path(path).parent_path());
  WriteFusedCamera(path, camera);
  const FusedCamera back = ReadFusedCamera(path);
  const geometry::PinholeRadTan& a = camera.intrinsics;
  const geometry::PinholeRadTan& b = back.intrinsics;
  EXPECT_EQ(std::tie(a.width, a.height, a.fx, a.fy, a.cx, a.cy, a.k1, a.k2, a.p1, a.p2, a.k3),
            std::tie(b.width, b.height, b.fx, b.fy, b.cx, b.cy, b.k1, b.k2, b.p1, b.p2, b.k3));
  EXPECT_TRUE(back.refined);
  EXPECT_EQ(back.rotation_change_deg, camera.rotation_change_deg);
  EXPECT_EQ(back.body_from_camera.rotation().coeffs(), camera.body_from_camera.rotation().coeffs());
  EXPECT_EQ(back.body_from_camera.translation(), camera.body_from_camera.translation());

  std::string what = ErrorOf([&] { ReadFusedCamera(Path("fused/t/camera.json")); });
  EXPECT_TRUE(Has(what, "fused/t/camera.json") && Has(what, "crop4d fuse")) << what;
  json j = json::parse(Read(path));
  j["intrinsics"].erase("cy");
  what = ErrorOf([&] { ReadFusedCamera(Write("no_cy.json", j.dump())); });
  EXPECT_TRUE(Has(what, "no_cy.json") && Has(what, "crop4d fuse --force")) << what;
  j = json::parse(Read(path));
  j["intrinsics"]["fx"] = -3.0;
  what = ErrorOf([&] { ReadFusedCamera(Write("negative.json", j.dump())); });
  EXPECT_TRUE(Has(what, "negative.json") && Has(what, "fx")) << what;
  j = json::parse(Read(path));
  j["body_from_camera"]["rotation_xyzw"] = {0.0, 0.0, 0.0, 2.0};
  what = ErrorOf([&] { ReadFusedCamera(Write("not_unit.json", j.dump())); });
  EXPECT_TRUE(Has(what, "not_unit.json") && Has(what, "unit quaternion")) << what;
  j = json::parse(Read(path));
  j["schema"] = 2;
  what = ErrorOf([&] { ReadFusedCamera(Write("future.json", j.dump())); });
  EXPECT_TRUE(Has(what, "future.json") && Has(what, "schema")) << what;
}

TEST_F(TypedJsonFilesTest, AssociationSummariesAreListedBesideTheirFiles) {
  const Layout ws(dir_ / "ws");
  EXPECT_TRUE(AssociationSummaries(ws).empty());
  EXPECT_EQ(AssociationSummaryPath(ws.AssociationsDir("robust") / "a__b.bin"),
            ws.AssociationsDir("robust") / "a__b.json");
  for (const char* name : {"robust/b__c.json", "robust/a__b.json", "robust/a__b.bin",
                           "robust/summary.json", "naive/a__b.json", "old.json", "notes.txt"}) {
    Write("ws/associations/" + std::string(name), "{}");
  }
  const std::vector<fs::path> expected = {
      ws.AssociationsRoot() / "old.json", ws.AssociationsDir("naive") / "a__b.json",
      ws.AssociationsDir("robust") / "a__b.json", ws.AssociationsDir("robust") / "b__c.json"};
  EXPECT_EQ(AssociationSummaries(ws), expected);
}

TEST_F(TypedJsonFilesTest, AMalformedOrForeignAssociationSummaryIsNamed) {
  const std::string broken = Write("broken.json", "{\"a\": ");
  std::string what = ErrorOf([&] { ReadAssociationSummary(broken); });
  EXPECT_TRUE(Has(what, "broken.json") && Has(what, "not valid JSON") &&
              Has(what, "crop4d associate --force"))
      << what;
  json incomplete = Association();
  incomplete.erase("matches");
  what = ErrorOf([&] { ReadAssociationSummary(Write("incomplete.json", incomplete.dump())); });
  EXPECT_TRUE(Has(what, "incomplete.json") && Has(what, "missing or mistyped")) << what;
  json foreign = Association();
  foreign["schema"] = 2;
  what = ErrorOf([&] { ReadAssociationSummary(Write("foreign.json", foreign.dump())); });
  EXPECT_TRUE(Has(what, "foreign.json") && Has(what, "another crop4d version (schema 2")) << what;
  what = ErrorOf([&] { ReadAssociationSummary(Write("array.json", "[1]")); });
  EXPECT_TRUE(Has(what, "not a JSON object")) << what;
  what = ErrorOf([&] { ReadAssociationSummary(Path("missing.json")); });
  EXPECT_TRUE(Has(what, "missing")) << what;
}

TEST_F(TypedJsonFilesTest, TheSeasonQualityRoundTripsWithTheFuseStagesBytes) {
  SeasonQuality q;
  q.standard = Positioning::kRtk;
  q.sessions = {{"a", true, {}}, {"b", false, {"positioned with a metre-level GPS"}}};
  const std::string path = Path("quality.json");
  WriteSeasonQuality(path, q);
  // As the fuse stage wrote it before the typed writer existed.
  EXPECT_EQ(Read(path), SeasonQualityToJson(q).dump(2) + "\n");
  const SeasonQuality back = ReadSeasonQuality(path);
  EXPECT_EQ(SeasonQualityToJson(back), SeasonQualityToJson(q));
  EXPECT_EQ(back.standard, Positioning::kRtk);
  EXPECT_TRUE(back.Protects("a"));
  EXPECT_FALSE(back.Protects("b"));
  EXPECT_TRUE(back.Protects("not graded"));
  ASSERT_EQ(back.Degraded().size(), 1u);
  EXPECT_EQ(back.Degraded()[0]->session, "b");
  // No file (a workspace fused by an older crop4d): every session protects.
  EXPECT_TRUE(ReadSeasonQuality(Path("none.json")).sessions.empty());
  EXPECT_TRUE(ReadSeasonQuality(Path("none.json")).Protects("a"));
}

TEST_F(TypedJsonFilesTest, AMalformedOrForeignSeasonQualityIsNamed) {
  std::string what =
      ErrorOf([&] { ReadSeasonQuality(Write("truncated.json", "{\"standard\": \"rtk\"")); });
  EXPECT_TRUE(Has(what, "truncated.json") && Has(what, "crop4d fuse --force")) << what;
  what = ErrorOf([&] {
    ReadSeasonQuality(Write("incomplete.json", R"({"standard": "rtk", "sessions": []})"));
  });
  EXPECT_TRUE(Has(what, "incomplete.json") && Has(what, "missing or mistyped")) << what;
  json foreign = SeasonQualityToJson({});
  foreign["schema"] = 3;
  what = ErrorOf([&] { ReadSeasonQuality(Write("foreign.json", foreign.dump())); });
  EXPECT_TRUE(Has(what, "another crop4d version (schema 3")) << what;
}

TEST_F(TypedJsonFilesTest, EvalMetricsKeepTheirKeyOrderAndHeadlineFigures) {
  nlohmann::ordered_json m;
  m["crop4d_version"] = "0.1.0";
  m["workspace"] = "ws";
  m["passes"] = nlohmann::ordered_json::array();
  m["overall"] = {{"ate_raw_m", {{"rmse", 0.0087}}}};
  m["fused"] = {{"overall", {{"ate_raw_m", {{"rmse", nullptr}}}}}};
  m["canopy"] = {
      {"ours", {{"rmse_m", 0.0213}, {"rmse_interval_m", {{"low", 0.017}, {"high", 0.026}}}}}};
  const std::string path = Path("eval/metrics.json");
  fs::create_directories(fs::path(path).parent_path());
  WriteEvalMetrics(path, m);
  EXPECT_EQ(Read(path), m.dump(2) + "\n");  // the eval's key order, no "schema" at schema 1
  const EvalMetrics back = ReadEvalMetrics(path);
  EXPECT_EQ(back.crop4d_version, "0.1.0");
  EXPECT_EQ(back.pass_ate_raw_rmse_m, 0.0087);
  EXPECT_FALSE(back.fused_ate_raw_rmse_m.has_value());  // null: not evaluated
  EXPECT_FALSE(back.fused_ground_misalignment_median_m.has_value());
  EXPECT_EQ(back.canopy_rmse_m, 0.0213);
  EXPECT_EQ(back.canopy_rmse_low_m, 0.017);
  EXPECT_EQ(back.canopy_rmse_high_m, 0.026);
  EXPECT_EQ(back.json, json::parse(m.dump()));
}

TEST_F(TypedJsonFilesTest, MalformedOrForeignEvalMetricsAreNamed) {
  std::string what = ErrorOf([&] { ReadEvalMetrics(Write("m1.json", "{")); });
  EXPECT_TRUE(Has(what, "m1.json") && Has(what, "crop4d eval --force")) << what;
  what = ErrorOf([&] { ReadEvalMetrics(Write("m2.json", R"({"crop4d_version": "0.1.0"})")); });
  EXPECT_TRUE(Has(what, "m2.json") && Has(what, "missing or mistyped")) << what;
  what = ErrorOf(
      [&] { ReadEvalMetrics(Write("m3.json", R"({"crop4d_version": "0.1.0", "passes": {}})")); });
  EXPECT_TRUE(Has(what, "m3.json") && Has(what, "missing or mistyped")) << what;
  what = ErrorOf([&] {
    ReadEvalMetrics(Write("m4.json", R"({"crop4d_version": "0", "passes": [], "schema": "x"})"));
  });
  EXPECT_TRUE(Has(what, "another crop4d version (schema \"x\"")) << what;
  what = ErrorOf([&] {
    ReadEvalMetrics(
        Write("m5.json", R"({"crop4d_version": "0", "passes": [], "overall": {"ate_raw_m":
              {"rmse": "oops"}}})"));
  });
  EXPECT_TRUE(Has(what, "m5.json") && Has(what, "missing or mistyped")) << what;
}

TEST_F(TypedJsonFilesTest, ALaterSchemaIsStampedAndReadBack) {
  const std::string path = Path("v2.json");
  WriteJsonOfSchema(path, {{"x", 1}}, 2);
  EXPECT_EQ(ReadJsonOfSchema(path, 2, "crop4d x").value("schema", 0), 2);
  EXPECT_TRUE(Has(ErrorOf([&] { ReadJsonOfSchema(path, 1, "crop4d x"); }), "(schema 2, this "));
  WriteJsonOfSchema(path, {{"x", 1}}, 1);
  EXPECT_EQ(Read(path), "{\n  \"x\": 1\n}\n");
}

}  // namespace
}  // namespace crop4d::workspace
