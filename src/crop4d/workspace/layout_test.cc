#include "crop4d/workspace/layout.h"

#include <gtest/gtest.h>

#include <fstream>
#include <set>

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
                                     ws.PassProblem("s", "p"),
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

}  // namespace
}  // namespace crop4d::workspace
