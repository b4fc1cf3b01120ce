#include "crop4d/workspace/layout.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>

#include "crop4d/core/natural_less.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;

TEST(LayoutTest, EveryArtefactLivesWhereDesignSaysAndPathsAreDistinct) {
  const Layout ws("/w");
  EXPECT_EQ(ws.PassPoses("2016-06-01", "row00").string(),
            "/w/sessions/2016-06-01/rows/row00/poses.tum");
  EXPECT_EQ(ws.PassList("s").string(), "/w/sessions/s/passes.csv");
  EXPECT_EQ(ws.AssociationsDir("robust").string(), "/w/associations/robust");
  EXPECT_EQ(ws.FusedSparse("s").string(), "/w/fused/s/sparse.ply");
  EXPECT_EQ(ws.FusedCamera("s").string(), "/w/fused/s/camera.json");
  EXPECT_EQ(ws.FusedColmapDir().string(), "/w/fused/colmap");
  EXPECT_EQ(ws.DenseCloud("s").string(), "/w/dense/s.ply");
  EXPECT_EQ(ws.DenseSummary("s").string(), "/w/dense/s.json");
  EXPECT_EQ(ws.ChmChange("a", "b").string(), "/w/analysis/chm_change_a_b.tif");
  EXPECT_EQ(ws.Chm("a").string(), "/w/analysis/chm_a.tif");
  EXPECT_EQ(ws.EvalDepthDir("s").string(), "/w/eval/depth/s");

  // No two artefacts share a file.
  const std::vector<fs::path> all = {ws.Config(),
                                     ws.Log(),
                                     ws.RunRecord(),
                                     ws.RunLog(),
                                     ws.Report(),
                                     ws.Lock(),
                                     ws.PassList("s"),
                                     ws.PassMeasurements("s", "p"),
                                     ws.PassFeatures("s", "p"),
                                     ws.PassTracks("s", "p"),
                                     ws.PassStates("s", "p"),
                                     ws.PassInitialPoses("s", "p"),
                                     ws.PassPoses("s", "p"),
                                     ws.PassLandmarks("s", "p"),
                                     ws.PassSummary("s", "p"),
                                     ws.FusedSummary(),
                                     ws.FusedQuality(),
                                     ws.FusedLandmarks(),
                                     ws.FusedPoses("s"),
                                     ws.FusedSparse("s"),
                                     ws.FusedCamera("s"),
                                     ws.DenseCloud("s"),
                                     ws.DenseSummary("s"),
                                     ws.AnalysisSummary(),
                                     ws.SiteHeights(),
                                     ws.SiteHeightsSinglePlane(),
                                     ws.SitePlants(),
                                     ws.Growth(),
                                     ws.Dtm(),
                                     ws.Chm("s"),
                                     ws.ChmChange("s", "t"),
                                     ws.EvalMetrics(),
                                     ws.EvalInputsFingerprint()};
  std::set<fs::path> unique(all.begin(), all.end());
  EXPECT_EQ(unique.size(), all.size());
  for (const fs::path& p : all) EXPECT_EQ(p.string().rfind("/w/", 0), 0u) << p;
}

TEST(LayoutTest, ListsSessionAndPassFoldersSortedAndIgnoresFiles) {
  const fs::path root = fs::path(testing::TempDir()) / "crop4d_layout_test";
  fs::remove_all(root);
  const Layout ws(root);
  EXPECT_TRUE(ws.SessionFolders().empty());
  EXPECT_TRUE(ws.PassFolders("none").empty());
  fs::create_directories(ws.PassDir("2016-07-01", "row01"));
  fs::create_directories(ws.PassDir("2016-07-01", "row00"));
  fs::create_directories(ws.SessionDir("2016-06-01"));
  std::ofstream(ws.SessionsDir() / "stray.txt") << "x";
  std::ofstream(ws.RowsDir("2016-07-01") / "notes.txt") << "x";
  EXPECT_EQ(ws.SessionFolders(), (std::vector<std::string>{"2016-06-01", "2016-07-01"}));
  EXPECT_EQ(ws.PassFolders("2016-07-01"), (std::vector<std::string>{"row00", "row01"}));
  fs::remove_all(root);
}

TEST(LayoutTest, NaturalOrderPutsRow2BeforeRow10) {
  EXPECT_TRUE(NaturalLess("row2", "row10"));
  EXPECT_FALSE(NaturalLess("row10", "row2"));
  EXPECT_TRUE(NaturalLess("row02", "row3"));
  EXPECT_TRUE(NaturalLess("2016-05-9", "2016-05-10"));
  EXPECT_TRUE(NaturalLess("row01", "row1"));  // equal as numbers: plain order decides
  EXPECT_FALSE(NaturalLess("row1", "row1"));
  EXPECT_TRUE(NaturalLess("a", "b"));
  EXPECT_TRUE(NaturalLess("row", "row0"));
}

TEST(LayoutTest, ListsByNameOrInNaturalOrder) {
  const fs::path root = fs::path(testing::TempDir()) / "crop4d_layout_order_test";
  fs::remove_all(root);
  const Layout ws(root);
  EXPECT_TRUE(ws.FusedSessionFolders().empty());
  EXPECT_TRUE(ws.DenseCloudSessions().empty());
  EXPECT_TRUE(ws.DenseSummarySessions().empty());
  for (const char* pass : {"row10", "row2", "row1"}) fs::create_directories(ws.PassDir("s", pass));
  for (const char* session : {"s10", "s9"}) fs::create_directories(ws.FusedSessionDir(session));
  fs::create_directories(ws.FusedColmapDir());
  fs::create_directories(ws.DenseDir());
  for (const char* session : {"s10", "s9"}) std::ofstream(ws.DenseCloud(session)) << "x";
  std::ofstream(ws.DenseSummary("s9")) << "{}";
  std::ofstream(ws.DenseDir() / "notes.txt") << "x";
  using V = std::vector<std::string>;
  EXPECT_EQ(ws.PassFolders("s"), (V{"row1", "row10", "row2"}));
  EXPECT_EQ(ws.PassFolders("s", Layout::Order::kNatural), (V{"row1", "row2", "row10"}));
  EXPECT_EQ(ws.FusedSessionFolders(), (V{"s10", "s9"}));
  EXPECT_EQ(ws.FusedSessionFolders(Layout::Order::kNatural), (V{"s9", "s10"}));
  EXPECT_EQ(ws.DenseCloudSessions(), (V{"s10", "s9"}));
  EXPECT_EQ(ws.DenseCloudSessions(Layout::Order::kNatural), (V{"s9", "s10"}));
  EXPECT_EQ(ws.DenseSummarySessions(), (V{"s9"}));
  fs::remove_all(root);
}

TEST(LayoutTest, ListsTheAnalysisRastersAndTablesInNameOrder) {
  const fs::path root = fs::path(testing::TempDir()) / "crop4d_layout_analysis_test";
  fs::remove_all(root);
  const Layout ws(root);
  EXPECT_TRUE(ws.AnalysisRasters().empty());
  EXPECT_TRUE(ws.AnalysisTables().empty());
  fs::create_directories(ws.PlotsDir());
  for (const fs::path& p : {ws.Dtm(), ws.Chm("s2"), ws.Chm("s10"), ws.ChmChange("s2", "s10"),
                            ws.SiteHeights(), ws.SitePlants(), ws.Growth()}) {
    std::ofstream(p) << "x";
  }
  std::ofstream(ws.AnalysisDir() / "notes.tif") << "x";  // not a raster of the analyze stage
  std::ofstream(ws.AnalysisDir() / "notes.csv") << "x";
  std::ofstream(ws.PlotsDir() / "chm_s1.tif") << "x";
  using P = std::vector<fs::path>;
  EXPECT_EQ(ws.AnalysisRasters(),
            (P{ws.ChmChange("s2", "s10"), ws.Chm("s10"), ws.Chm("s2"), ws.Dtm()}));
  EXPECT_EQ(ws.AnalysisTables(), (P{ws.Growth(), ws.SiteHeights(), ws.SitePlants()}));
  std::ofstream(ws.SiteHeightsSinglePlane()) << "x";
  EXPECT_EQ(ws.AnalysisTables(),
            (P{ws.Growth(), ws.SiteHeights(), ws.SiteHeightsSinglePlane(), ws.SitePlants()}));
  fs::remove_all(root);
}

TEST(LayoutTest, ListsTheStageRecordsSortedByPathAsText) {
  const fs::path root = fs::path(testing::TempDir()) / "crop4d_layout_records_test";
  fs::remove_all(root);
  const Layout ws(root);
  EXPECT_TRUE(ws.StageRecordFiles().empty());
  // "a-b" sorts before "a/" as text (but after "a" as a path element).
  for (const fs::path& p : {ws.PassSummary("a", "p"), ws.PassSummary("a-b", "p"),
                            ws.AssociationsDir("robust") / "a_p__b_p.json", ws.FusedSummary(),
                            ws.FusedQuality(), ws.DenseSummary("a"), ws.AnalysisSummary(),
                            ws.EvalMetrics(), ws.ViewerDir() / "scene.json"}) {
    fs::create_directories(p.parent_path());
    std::ofstream(p) << "{}";
  }
  std::ofstream(ws.DenseCloud("a")) << "x";
  std::ofstream(ws.PassPoses("a", "p")) << "x";
  EXPECT_EQ(
      ws.StageRecordFiles(),
      (std::vector<fs::path>{ws.AnalysisSummary(), ws.AssociationsDir("robust") / "a_p__b_p.json",
                             ws.DenseSummary("a"), ws.FusedQuality(), ws.FusedSummary(),
                             ws.PassSummary("a-b", "p"), ws.PassSummary("a", "p")}));
  fs::remove_all(root);
}

}  // namespace
}  // namespace crop4d::workspace
