// `crop4d eval` on the outputs of the later stages: association files, fused trajectories and
// clouds, row-SLAM clouds, in a temporary workspace and field whose true geometry is the fake
// scene of truth_test_util.h (its depth maps stored in the field as the simulator's --depth
// maps, so nothing is rendered).

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "crop4d/association/association_file.h"
#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/eval/truth_test_util.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_priors.h"
#include "crop4d/workspace/pass_summary.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;
using association::CrossMatch;
using association::PassAssociation;

constexpr const char* kS1 = "2016-06-10";
constexpr const char* kS2 = "2016-06-24";  // rain before it

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// `n` points on the flat ground z = dz over [−1, 2] × [0, 5], on a jittered grid.
std::vector<Eigen::Vector3d> GroundCloud(double dz, int n_side = 40) {
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n_side; ++i) {
    for (int j = 0; j < n_side; ++j) {
      const double x = -1.0 + 3.0 * (i + 0.5 + 0.3 * std::sin(7.0 * j)) / n_side;
      const double y = 5.0 * (j + 0.5 + 0.3 * std::cos(5.0 * i)) / n_side;
      points.emplace_back(x, y, dz + 0.001 * std::sin(13.0 * i + 17.0 * j));
    }
  }
  return points;
}

void WritePly(const std::string& path, const std::vector<Eigen::Vector3d>& points) {
  io::PlyPointCloud cloud;
  cloud.points = points;
  io::WritePly(path, cloud);
}

class StageEvalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    sim::SimConfig config = sim::PresetConfig("tiny");
    config.sessions = {{kS1, false}, {kS2, true}};
    io::WriteFileAtomic(field() + "/ground_truth/simulate.yaml", sim::SimConfigToYaml(config));
    truth_.camera = config.camera.Intrinsics();
    // Session 1: row00 driven north from (0, 0), row01 south from (0.9, 4.5); session 2: row00
    // north from (0.05, 0.1). Ten images each, 0.1 m apart.
    AddPass(kS1, 0, 0.0, 0.0, 0.0, 0.1);
    AddPass(kS1, 100, 0.9, 4.5, M_PI, -0.1);
    AddPass(kS2, 0, 0.05, 0.1, 0.0, 0.1);
    for (const char* s : {kS1, kS2}) {
      io::WriteTum(field() + "/ground_truth/" + s + "/cam0_poses.tum", truth_poses_[s]);
      // One plant in the middle; terrain flat.
      testing::WriteFile(field() + "/ground_truth/" + s + "/plants.csv",
                         "id,row,x,y,height_m,canopy_radius_m\n0,0,0.5000,2.5000,0.1,0.2\n");
    }
    std::string terrain = "x,y,z\n";
    for (int iy = 0; iy <= 16; ++iy) {
      for (int ix = 0; ix <= 12; ++ix) {
        terrain += fmt::format("{:.4f},{:.4f},0.00000\n", -2.0 + 0.5 * ix, -1.0 + 0.5 * iy);
      }
    }
    testing::WriteFile(field() + "/ground_truth/terrain.csv", terrain);

    const workspace::Layout ws(workspace());
    fs::create_directories(ws.SessionDir(kS1));
    fs::create_directories(ws.SessionDir(kS2));
    workspace::WritePassList(ws.PassList(kS1).string(),
                             {slam::RowPass{.id = "row00", .row = 0, .direction = 1},
                              slam::RowPass{.id = "row01", .row = 1, .direction = -1}});
    workspace::WritePassList(ws.PassList(kS2).string(),
                             {slam::RowPass{.id = "row00", .row = 0, .direction = 1}});
  }

  void AddPass(const std::string& session, int first, double x, double y, double heading,
               double step) {
    for (int k = 0; k < 10; ++k) {
      const Timestamp t = Time(first + k);
      const geometry::Rigid3 pose = testing::DownwardCamera(x, y + k * step, heading);
      truth_poses_[session].push_back({t, pose});
      truth_.AddImage(session, t, pose);
    }
  }
  static Timestamp Time(int k) { return testing::kStart + k * 100'000'000LL; }

  // The field's depth maps (as `crop4d simulate --depth` writes them) of the matched images.
  void WriteDepthMaps(const PassAssociation& pa) {
    for (const CrossMatch& m : pa.matches) {
      for (const auto& [session, t] : {std::pair{pa.a.session, m.t_a}, {pa.b.session, m.t_b}}) {
        const std::string path =
            field() + "/ground_truth/" + session + "/cam0_depth/" + std::to_string(t) + ".png";
        if (fs::exists(path)) continue;
        geometry::PinholeRadTan camera;
        geometry::Rigid3 pose;
        ASSERT_TRUE(truth_.TrueCamera(session, t, &camera, &pose));
        WriteDepthPng(path, truth_.scene.Render(camera, pose));
      }
    }
  }

  CrossMatch Match(const std::string& sa, Timestamp ta, const Eigen::Vector3d& pa,
                   const std::string& sb, Timestamp tb, const Eigen::Vector3d& pb) {
    CrossMatch m;
    m.t_a = ta;
    m.t_b = tb;
    Eigen::Vector2d xa, xb;
    EXPECT_TRUE(truth_.Project(sa, ta, pa, &xa));
    EXPECT_TRUE(truth_.Project(sb, tb, pb, &xb));
    m.xa = static_cast<float>(xa.x());
    m.ya = static_cast<float>(xa.y());
    m.xb = static_cast<float>(xb.x());
    m.yb = static_cast<float>(xb.y());
    return m;
  }

  // robust/: row00 × row01 of session 1 (opposite directions), 3 correct + 1 wrong;
  // naive/: row00 of session 1 × row00 of session 2 (after rain), 1 correct + 1 wrong.
  void WriteAssociations() {
    PassAssociation rows;
    rows.a = {kS1, "row00"};
    rows.b = {kS1, "row01"};
    rows.method = "robust";
    for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.3, 2.5, 0), Eigen::Vector3d(0.6, 2.9, 0),
                                     Eigen::Vector3d(0.2, 3.1, 0)}) {
      rows.matches.push_back(Match(kS1, Time(2), p, kS1, Time(103), p));
    }
    rows.matches.push_back(Match(kS1, Time(2), Eigen::Vector3d(0.3, 2.5, 0), kS1, Time(104),
                                 Eigen::Vector3d(0.3, 2.8, 0)));
    PassAssociation sessions;
    sessions.a = {kS1, "row00"};
    sessions.b = {kS2, "row00"};
    sessions.method = "naive";
    sessions.matches.push_back(Match(kS1, Time(5), Eigen::Vector3d(-0.3, 2.4, 0), kS2, Time(5),
                                     Eigen::Vector3d(-0.3, 2.4, 0)));
    sessions.matches.push_back(Match(kS1, Time(5), Eigen::Vector3d(-0.3, 2.4, 0), kS2, Time(5),
                                     Eigen::Vector3d(0.3, 2.4, 0)));
    for (const PassAssociation* pa : {&rows, &sessions}) {
      WriteDepthMaps(*pa);
      association::WriteAssociationFile(workspace() + "/associations/" + pa->method + "/" +
                                            association::AssociationFileName(pa->a, pa->b),
                                        *pa);
    }
  }

  // Fused poses 1 cm east of the truth, fused clouds (session 2 2 cm higher), row-SLAM clouds
  // (session 2 5 cm higher).
  void WriteFusedAndClouds() {
    for (const char* s : {kS1, kS2}) {
      io::WriteTum(workspace() + "/fused/" + s + "/poses.tum",
                   testing::Offset(truth_poses_[s], Eigen::Vector3d(0.01, 0.0, 0.0)));
      const bool second = std::string(s) == kS2;
      WritePly(workspace() + "/fused/" + s + "/sparse.ply", GroundCloud(second ? 0.02 : 0.0));
      WritePly(workspace() + "/sessions/" + s + "/rows/row00/landmarks.ply",
               GroundCloud(second ? 0.05 : 0.0));
    }
    // Points on the plant and far above the ground are not ground.
    std::vector<Eigen::Vector3d> extra = GroundCloud(0.0);
    extra.emplace_back(0.5, 2.5, 0.1);
    extra.emplace_back(-0.5, 1.0, 0.5);
    WritePly(workspace() + "/sessions/" + kS1 + "/rows/row01/landmarks.ply", extra);
  }

  WorkspaceEvalOptions NoRendering() const {
    WorkspaceEvalOptions options;
    options.render_depth = false;
    return options;
  }

  std::string workspace() const { return dir_ / "ws"; }
  std::string field() const { return dir_ / "field"; }

  testing::PidTempDir dir_;
  testing::FakeTruth truth_;
  std::map<std::string, std::vector<io::StampedPose>> truth_poses_;
};

TEST_F(StageEvalTest, EvaluatesAssociationsFusionAndClouds) {
  WriteAssociations();
  WriteFusedAndClouds();
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field(), NoRendering());

  // Association precision per file, per type × method and per method.
  ASSERT_TRUE(eval.association.has_value());
  const WorkspaceAssociationEval& assoc = *eval.association;
  ASSERT_TRUE(assoc.error.empty()) << assoc.error;
  EXPECT_EQ(assoc.num_files, 2);
  ASSERT_EQ(assoc.eval.files.size(), 2u);
  const AssociationFileEval& naive = assoc.eval.files[0];  // "naive/..." sorts first
  const AssociationFileEval& robust = assoc.eval.files[1];
  ASSERT_TRUE(naive.ok()) << naive.error;
  ASSERT_TRUE(robust.ok()) << robust.error;
  EXPECT_EQ(naive.file.rfind("associations/naive/", 0), 0u) << naive.file;
  EXPECT_EQ(naive.type, PairType::kCrossSessionAfterRain);
  EXPECT_EQ(naive.counts.correct, 1);
  EXPECT_EQ(naive.counts.incorrect, 1);
  EXPECT_EQ(robust.type, PairType::kCrossRowOppositeDirection);
  EXPECT_EQ(robust.layout_b.row, 1);
  EXPECT_EQ(robust.layout_b.direction, -1);
  EXPECT_EQ(robust.counts.correct, 3);
  EXPECT_EQ(robust.counts.incorrect, 1);
  EXPECT_EQ(robust.counts.unknown, 0);
  EXPECT_EQ(assoc.eval.depth.from_field, 5);
  EXPECT_EQ(assoc.eval.depth.rendered, 0);
  EXPECT_EQ(assoc.eval.images, 5);
  // The passes have no row SLAM files here: the ceiling says so for both pairs of passes.
  ASSERT_EQ(assoc.ceiling.errors.size(), 2u);
  EXPECT_NE(assoc.ceiling.errors[0].find("crop4d slam"), std::string::npos)
      << assoc.ceiling.errors[0];
  EXPECT_TRUE(assoc.ceiling.groups.empty());

  // Fused trajectories: 1 cm raw, nothing after alignment.
  ASSERT_TRUE(eval.fused.has_value());
  ASSERT_EQ(eval.fused->sessions.size(), 2u);
  EXPECT_EQ(eval.fused->sessions[0].session, kS1);
  EXPECT_EQ(eval.fused->num_evaluated, 2);
  EXPECT_EQ(eval.fused->num_poses, 30);
  EXPECT_NEAR(eval.fused->ate_raw_m.rmse, 0.01, 1e-5);
  EXPECT_LT(eval.fused->ate_aligned_joint_m.rmse, 1e-5);
  EXPECT_LT(eval.fused->ate_aligned_m.rmse, 1e-5);

  // Ground misalignment: row SLAM 5 cm, fused 2 cm (session 2 above session 1).
  ASSERT_EQ(eval.clouds.size(), 2u);
  const CloudSetEval& rows = eval.clouds[0];
  const CloudSetEval& fused = eval.clouds[1];
  EXPECT_EQ(rows.label, "row_slam");
  EXPECT_EQ(fused.label, "fused");
  ASSERT_TRUE(rows.error.empty()) << rows.error;
  ASSERT_EQ(rows.sessions.size(), 2u);
  EXPECT_EQ(rows.sessions[0].files.size(), 2u);
  EXPECT_EQ(rows.sessions[0].points, 2 * 1600 + 2);
  // The plant's footprint (radius 0.2 + 0.05) and the point 50 cm up are not ground.
  EXPECT_LT(rows.sessions[0].ground_points, 2 * 1600);
  EXPECT_GT(rows.sessions[0].ground_points, 2 * 1500);
  ASSERT_EQ(rows.misalignment.pairs.size(), 1u);
  EXPECT_NEAR(rows.misalignment.pooled.median_m, 0.05, 0.002);
  EXPECT_NEAR(rows.misalignment.pooled.signed_median_m, -0.05, 0.002);
  EXPECT_NEAR(fused.misalignment.pooled.median_m, 0.02, 0.002);
  EXPECT_NEAR(fused.misalignment.pairs[0].stats.p90_m, 0.02, 0.003);
  EXPECT_LT(fused.misalignment.pooled_self.median_m, 0.002);

  // metrics.json holds the sections.
  const nlohmann::json j = nlohmann::json::parse(Slurp(WriteWorkspaceEval(eval)));
  const nlohmann::json& a = j["association"];
  EXPECT_TRUE(a["error"].is_null());
  EXPECT_EQ(a["options"]["max_distance_m"], 0.02);
  ASSERT_EQ(a["by_type"].size(), 2u);
  EXPECT_EQ(a["by_type"][0]["type"], "cross_row_opposite_direction");
  EXPECT_EQ(a["by_type"][0]["method"], "robust");
  EXPECT_EQ(a["by_type"][0]["correct"], 3);
  EXPECT_DOUBLE_EQ(a["by_type"][0]["precision"].get<double>(), 0.75);
  EXPECT_EQ(a["by_type"][0]["within_coarse"], 3);  // the wrong one is 30 cm off
  EXPECT_EQ(a["options"]["near_depth_m"], 5.0);
  EXPECT_LE(a["by_type"][0]["correct_near"].get<int>(), 3);
  EXPECT_LE(a["by_type"][0]["correct_near"].get<int>(), a["by_type"][0]["known_near"].get<int>());
  EXPECT_EQ(a["by_type"][1]["type"], "cross_session_after_rain");
  EXPECT_EQ(a["by_method"].size(), 2u);
  EXPECT_EQ(a["files"][1]["b"]["pass"], "row01");
  EXPECT_EQ(a["files"][1]["b"]["direction"], -1);
  EXPECT_EQ(a["depth_maps"]["from_field"], 5);
  EXPECT_EQ(a["ceiling"]["errors"].size(), 2u);
  EXPECT_EQ(j["fused"]["overall"]["num_evaluated"], 2);
  EXPECT_NEAR(j["fused"]["overall"]["ate_raw_m"]["rmse"].get<double>(), 0.01, 1e-5);
  EXPECT_TRUE(j["fused"]["sessions"][0]["metrics"]["ate_aligned_m"]["rmse"].is_number());
  EXPECT_NEAR(j["ground_misalignment"]["fused"]["pooled"]["median_m"].get<double>(), 0.02, 0.002);
  EXPECT_EQ(j["ground_misalignment"]["row_slam"]["pairs"][0]["a"], kS1);
  EXPECT_TRUE(j["ground_misalignment"]["options"]["radius_m"].is_number());
  EXPECT_EQ(j["ground_misalignment"]["fused"]["self"].size(), 2u);
  EXPECT_TRUE(j["ground_misalignment"]["fused"]["pooled_self"]["median_m"].is_number());

  // The table.
  const std::string table = FormatWorkspaceEvalTable(eval);
  for (const char* text : {"association precision", "row opposite dir", "session+rain", "75.00",
                           "50.00", "5 from the field", "ground misalignment", "row_slam", "5.00",
                           "-5.00", "2.00", "all pairs", "ATE raw cm", "ceiling not counted"}) {
    EXPECT_NE(table.find(text), std::string::npos) << text << "\n" << table;
  }
}

TEST_F(StageEvalTest, AFusedSessionWithoutGpsIsAlignedByHeadingAndShift) {
  // Session 1's passes say its frame is a convention (no GPS): its fused poses, 1 cm off, are
  // aligned by heading and shift first; session 2 keeps its 1 cm.
  WriteFusedAndClouds();
  const workspace::Layout ws(workspace());
  fs::create_directories(ws.PassDir(kS1, "row00"));
  workspace::WritePassSummary(ws.PassSummary(kS1, "row00").string(),
                              {{"pose_frame", "camera"},
                               {"sensors", "cam+imu"},
                               {"fingerprint", "f"},
                               {"problem", workspace::ToJson(workspace::PassPriors{})},
                               {"trust", {"origin_by_convention"}}});
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field(), NoRendering());
  ASSERT_TRUE(eval.fused.has_value());
  ASSERT_EQ(eval.fused->sessions.size(), 2u);
  EXPECT_TRUE(eval.fused->sessions[0].frame_by_convention);
  EXPECT_LT(eval.fused->sessions[0].metrics.ate_raw_m.rmse, 1e-6);
  EXPECT_FALSE(eval.fused->sessions[1].frame_by_convention);
  EXPECT_NEAR(eval.fused->sessions[1].metrics.ate_raw_m.rmse, 0.01, 1e-5);
}

TEST_F(StageEvalTest, SectionsAppearOnlyWithTheirInputs) {
  // Only fused outputs: no row pass needed, no association section.
  WriteFusedAndClouds();
  fs::remove_all(workspace() + "/sessions");
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field(), NoRendering());
  EXPECT_TRUE(eval.passes.empty());
  EXPECT_FALSE(eval.association.has_value());
  ASSERT_TRUE(eval.fused.has_value());
  ASSERT_EQ(eval.clouds.size(), 1u);  // fused only: no row-SLAM clouds
  const nlohmann::json j = nlohmann::json::parse(WorkspaceEvalJson(eval));
  EXPECT_FALSE(j.contains("association"));
  EXPECT_TRUE(j.contains("fused"));
  EXPECT_FALSE(j["ground_misalignment"].contains("row_slam"));
  const std::string table = FormatWorkspaceEvalTable(eval);
  EXPECT_EQ(table.find("sensors"), std::string::npos) << table;  // no pass table

  // Switched off.
  WorkspaceEvalOptions off = NoRendering();
  off.fused = false;
  EXPECT_THROW(EvaluateWorkspace(workspace(), field(), off), InputError);
}

TEST_F(StageEvalTest, AssociationProblemsAreReportedPerFile) {
  WriteAssociations();
  // A corrupt file, and a same-session pair whose pass is not in passes.csv.
  testing::WriteFile(workspace() + "/associations/robust/zz_broken.bin", "C4DASSO");
  PassAssociation unknown;
  unknown.a = {kS1, "row00"};
  unknown.b = {kS1, "row07"};
  unknown.method = "robust";
  association::WriteAssociationFile(workspace() + "/associations/robust/zz_unknown.bin", unknown);
  const WorkspaceEval eval = EvaluateWorkspace(workspace(), field(), NoRendering());
  ASSERT_TRUE(eval.association.has_value());
  const AssociationEval& a = eval.association->eval;
  ASSERT_EQ(a.files.size(), 4u);
  EXPECT_EQ(a.num_failed, 2);
  EXPECT_FALSE(a.files[2].ok());
  EXPECT_FALSE(a.files[3].ok());
  EXPECT_NE(a.files[3].error.find("row07"), std::string::npos) << a.files[3].error;
  EXPECT_TRUE(a.files[0].ok());

  // Without depth maps in the field and no rendering, every match is unknown.
  fs::remove_all(field() + "/ground_truth/" + kS1 + "/cam0_depth");
  const WorkspaceEval no_depth = EvaluateWorkspace(workspace(), field(), NoRendering());
  const AssociationFileEval& robust = no_depth.association->eval.files[1];
  EXPECT_EQ(robust.counts.unknown, robust.counts.matches);
  EXPECT_EQ(robust.counts.unknown_no_truth, robust.counts.matches);
  EXPECT_GT(no_depth.association->eval.depth.unavailable, 0);

  // A session filter leaves out the cross-session file.
  WorkspaceEvalOptions one = NoRendering();
  one.sessions = {kS1};
  const WorkspaceEval filtered = EvaluateWorkspace(workspace(), field(), one);
  for (const AssociationFileEval& f : filtered.association->eval.files) {
    EXPECT_NE(f.b.session, kS2) << f.file;
  }

  // Without simulate.yaml: the section says why.
  fs::remove(field() + "/ground_truth/simulate.yaml");
  const WorkspaceEval no_config = EvaluateWorkspace(workspace(), field(), NoRendering());
  ASSERT_TRUE(no_config.association.has_value());
  EXPECT_NE(no_config.association->error.find("simulate.yaml"), std::string::npos)
      << no_config.association->error;
  EXPECT_NE(FormatWorkspaceEvalTable(no_config).find("not evaluated"), std::string::npos);
}

}  // namespace
}  // namespace crop4d::eval
