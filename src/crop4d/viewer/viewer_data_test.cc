#include "crop4d/viewer/viewer_data.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <nlohmann/json.hpp>
#include <thread>

#include "crop4d/core/error.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/viewer/static_viewer.h"
#include "crop4d/viewer/viewer_data_test_util.h"

namespace crop4d::viewer {
namespace {

namespace fs = std::filesystem;
using io::testing::ReadText;
using io::testing::TempDir;
using json = nlohmann::json;

ViewerDataOptions SmallTiles() {
  ViewerDataOptions o;
  o.octree.max_points_per_node = 300;
  o.octree.grid_cells = 8;
  return o;
}

TEST(ViewerDataTest, TilesHoldEveryPointOfEachSessionAndSceneDescribesTheSeason) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws);
  const ViewerDataSummary summary = WriteViewerData(ws, ws + "/viewer", SmallTiles());
  ASSERT_EQ(summary.sessions.size(), 2u);
  EXPECT_EQ(summary.sites, 2u);
  const json scene = json::parse(ReadText(ws + "/viewer/scene.json"));
  ASSERT_EQ(scene["sessions"].size(), 2u);
  EXPECT_EQ(scene["sessions"][0]["date"], "2016-06-10");
  EXPECT_EQ(scene["sessions"][1]["date"], "2016-06-24");
  EXPECT_EQ(scene["sessions"][0]["trajectory"].size(), 20u);
  EXPECT_EQ(scene["report"], "report.html");
  for (const json& session : scene["sessions"]) {
    const io::PlyPointCloud cloud =
        io::ReadPly(ws + "/dense/" + session["id"].get<std::string>() + ".ply");
    const json index =
        json::parse(ReadText(ws + "/viewer/" + session["octree"].get<std::string>()));
    std::size_t total = 0;
    Eigen::AlignedBox3d decoded;
    for (const json& node : index["nodes"]) {
      const std::string path = ws + "/viewer/clouds/" + session["id"].get<std::string>() + "/" +
                               node["name"].get<std::string>() + ".bin";
      const Tile tile = DecodeTile(ReadText(path), path);
      EXPECT_EQ(tile.positions.size(), node["count"].get<std::size_t>());
      for (std::size_t k = 0; k < tile.positions.size(); ++k) decoded.extend(tile.Position(k));
      total += tile.positions.size();
    }
    EXPECT_EQ(total, cloud.size());
    Eigen::AlignedBox3d truth;
    for (const Eigen::Vector3d& p : cloud.points) truth.extend(p);
    EXPECT_LT((decoded.min() - truth.min()).cwiseAbs().maxCoeff(), 1e-3);
    EXPECT_LT((decoded.max() - truth.max()).cwiseAbs().maxCoeff(), 1e-3);
  }
  // Sites: position from their plants, heights per date, the fit where there is one.
  const json& s1 = scene["sites"][0];
  EXPECT_EQ(s1["id"], "s1");
  EXPECT_NEAR(s1["x"].get<double>(), 1.0, 1e-9);
  EXPECT_NEAR(s1["y"].get<double>(), 2.1, 1e-9);
  EXPECT_NEAR(s1["heights"]["2016-06-24"].get<double>(), 0.40, 1e-12);
  EXPECT_NEAR(s1["growth"]["asymptote_m"].get<double>(), 0.55, 1e-12);
  EXPECT_FALSE(scene["sites"][1].contains("growth"));
}

TEST(ViewerDataTest, TerrainFollowsTheSoilAndTopsGrowWithThePlants) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws, 40000);
  WriteViewerData(ws, ws + "/viewer", SmallTiles());
  const json scene = json::parse(ReadText(ws + "/viewer/scene.json"));
  const json& g = scene["grid"];
  const int nx = g["nx"], ny = g["ny"];
  const double cell = g["cell"];
  const std::string bytes = ReadText(ws + "/viewer/grids.bin");
  ASSERT_EQ(bytes.size(), 3u * nx * ny * sizeof(float));
  std::vector<float> layers(3u * nx * ny);
  std::memcpy(layers.data(), bytes.data(), bytes.size());
  const auto at = [&](int layer, double x, double y) {
    const int i = int((x - g["min"][0].get<double>()) / cell);
    const int j = int((y - g["min"][1].get<double>()) / cell);
    return layers[std::size_t(layer) * nx * ny + std::size_t(j) * nx + i];
  };
  // Soil z = 0.02 x: the terrain within a few millimetres away from the plants, and no hole.
  for (double x : {0.25, 2.05, 2.75})
    for (double y : {1.05, 5.05, 9.05}) EXPECT_NEAR(at(0, x, y), 0.02 * x, 0.006) << x << "," << y;
  for (std::size_t k = 0; k < std::size_t(nx) * ny; ++k) ASSERT_FALSE(std::isnan(layers[k]));
  // Plants of 0.1 m and 0.4 m at (1, 4): the top rises by about 0.3 m between the dates.
  const double growth = at(2, 1.0, 4.0) - at(1, 1.0, 4.0);
  EXPECT_GT(growth, 0.2);
  EXPECT_LT(growth, 0.35);
}

// With the field folder: the terrain is the analysis DTM (ellipsoidal heights in UTM, placed in
// ENU with the field's origin) and the sites sit at their declared centres.
TEST(ViewerDataTest, FieldGivesTheAnalysisTerrainAndTheDeclaredSites) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws, 20000);
  const geometry::GeodeticPoint origin{31.47, -83.53, 100.0};
  io::testing::WriteText(dir / "field/field.yaml",
                         "name: t\norigin: {lat: 31.47, lon: -83.53, alt: 100}\n"
                         "sites:\n  - {id: s1, x: 1.05, y: 2.5, radius: 0.4}\n");
  // A terrain 0.25 + 0.01 y above the ENU plane (ellipsoidal heights chosen so).
  const io::FieldUtm utm(origin);
  const io::UtmGrid grid =
      utm.GridCovering(Eigen::AlignedBox2d(Eigen::Vector2d(-1, -1), Eigen::Vector2d(4, 11)), 0.05);
  std::vector<float> heights(grid.num_cells());
  for (int row = 0; row < grid.height; ++row)
    for (int col = 0; col < grid.width; ++col) {
      const Eigen::Vector2d en = grid.CellCentre(col, row);
      const Eigen::Vector3d at_alt = utm.EnuFromUtm(en.x(), en.y(), origin.alt_m);
      const double target = 0.25 + 0.01 * at_alt.y();
      heights[std::size_t(row) * grid.width + col] = float(origin.alt_m + target - at_alt.z());
    }
  io::WriteGeoTiff(ws + "/analysis/dtm.tif", grid, heights);
  ViewerDataOptions options = SmallTiles();
  options.field = dir / "field";
  const ViewerDataSummary summary = WriteViewerData(ws, ws + "/viewer", options);
  EXPECT_EQ(summary.terrain_source, "analysis/dtm.tif");
  const json scene = json::parse(ReadText(ws + "/viewer/scene.json"));
  const json& g = scene["grid"];
  const int nx = g["nx"], ny = g["ny"];
  std::vector<float> terrain(std::size_t(nx) * ny);
  std::memcpy(terrain.data(), ReadText(ws + "/viewer/grids.bin").data(), terrain.size() * 4);
  const double cell = g["cell"];
  for (int j = 0; j < ny; j += 7)
    for (int i = 0; i < nx; i += 5) {
      const double y = g["min"][1].get<double>() + (j + 0.5) * cell;
      // Within the DTM's 5 cm cells (0.5 mm of slope) and float precision.
      EXPECT_NEAR(terrain[std::size_t(j) * nx + i], 0.25 + 0.01 * y, 1e-3) << i << "," << j;
    }
  ASSERT_FALSE(scene["sites"].empty());
  EXPECT_EQ(scene["sites"][0]["id"], "s1");
  EXPECT_DOUBLE_EQ(scene["sites"][0]["x"].get<double>(), 1.05);
  EXPECT_DOUBLE_EQ(scene["sites"][0]["y"].get<double>(), 2.5);
  EXPECT_NEAR(scene["sites"][0]["heights"]["2016-06-24"].get<double>(), 0.40, 1e-12);
  // Without the field, the terrain comes from the earliest cloud.
  EXPECT_EQ(WriteViewerData(ws, ws + "/viewer", SmallTiles()).terrain_source, "the earliest cloud");
}

TEST(ViewerDataTest, TilesAreRebuiltOnlyWhenTheCloudChanges) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws);
  EXPECT_TRUE(WriteViewerData(ws, ws + "/viewer", SmallTiles()).sessions[0].rebuilt);
  const ViewerDataSummary again = WriteViewerData(ws, ws + "/viewer", SmallTiles());
  EXPECT_FALSE(again.sessions[0].rebuilt);
  EXPECT_FALSE(again.sessions[1].rebuilt);
  std::this_thread::sleep_for(std::chrono::milliseconds(20));
  io::WritePly(ws + "/dense/2016-06-24.ply", testing::FieldCloud(1000, 0.5, 99));
  const ViewerDataSummary changed = WriteViewerData(ws, ws + "/viewer", SmallTiles());
  EXPECT_FALSE(changed.sessions[0].rebuilt);
  EXPECT_TRUE(changed.sessions[1].rebuilt);
  EXPECT_EQ(changed.sessions[1].points, 1000u);
  // No temporary folder is left behind.
  for (const auto& e : fs::directory_iterator(ws + "/viewer/clouds"))
    EXPECT_EQ(e.path().filename().string().find(".tmp"), std::string::npos);
}

TEST(ViewerDataTest, SparseCloudWhenNoDenseAndClearErrorWithoutAnyCloud) {
  TempDir dir;
  const std::string ws = dir / "ws";
  fs::create_directories(ws);
  try {
    WriteViewerData(ws, ws + "/viewer");
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("no cloud"), std::string::npos) << e.what();
  }
  io::WritePly(ws + "/fused/2016-06-10/sparse.ply", testing::FieldCloud(500, 0.2, 1));
  const ViewerDataSummary summary = WriteViewerData(ws, ws + "/viewer");
  ASSERT_EQ(summary.sessions.size(), 1u);
  EXPECT_EQ(summary.sessions[0].source, "fused/2016-06-10/sparse.ply");
  EXPECT_EQ(summary.sessions[0].date, "2016-06-10");  // no analysis: dated by its id
}

TEST(ViewerDataTest, MalformedTablesNameTheFileAndLine) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws);
  io::testing::WriteText(ws + "/analysis/site_heights.csv",
                         "site_id,session,date,height_m,cover,volume_m3,n_points\n"
                         "s1,2016-06-10,2016-06-10,tall,,,\n");
  try {
    WriteViewerData(ws, ws + "/viewer", SmallTiles());
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("site_heights.csv"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("height_m"), std::string::npos) << e.what();
  }
}

// A site without a height on a date (no canopy there: an empty height_m, as analyze writes it)
// has no point on that date; the other dates are kept.
TEST(ViewerDataTest, ASiteWithoutAHeightOnADateIsLeftOutOnThatDate) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws);
  io::testing::WriteText(ws + "/analysis/site_heights.csv",
                         "site_id,session,date,height_m,cover,volume_m3,n_points\n"
                         "s1,2016-06-10,2016-06-10,,0.000,0.00000,0\n"
                         "s1,2016-06-24,2016-06-24,0.4000,0.600,0.00900,90\n");
  WriteViewerData(ws, ws + "/viewer", SmallTiles());
  const json scene = json::parse(ReadText(ws + "/viewer/scene.json"));
  bool found = false;
  for (const json& site : scene["sites"]) {
    if (site["id"] != "s1") continue;
    found = true;
    EXPECT_FALSE(site["heights"].contains("2016-06-10")) << site.dump();
    EXPECT_DOUBLE_EQ(site["heights"]["2016-06-24"].get<double>(), 0.4);
  }
  EXPECT_TRUE(found) << scene["sites"].dump();
}

TEST(ViewerDataTest, StaticViewerHasThePageTheDataAndTheReport) {
  TempDir dir;
  const std::string ws = dir / "ws";
  testing::WriteSmallWorkspace(ws);
  WriteStaticViewer(ws, dir / "site", SmallTiles());
  EXPECT_TRUE(fs::is_regular_file(dir / "site/index.html"));
  EXPECT_TRUE(fs::is_regular_file(dir / "site/app/viewer.js"));
  EXPECT_TRUE(fs::is_regular_file(dir / "site/ws/viewer/scene.json"));
  EXPECT_TRUE(fs::is_regular_file(dir / "site/ws/viewer/grids.bin"));
  EXPECT_EQ(ReadText(dir / "site/ws/report.html"), ReadText(ws + "/report.html"));
  EXPECT_NE(ReadText(dir / "site/index.html").find("app/viewer.js"), std::string::npos);
  EXPECT_FALSE(fs::exists(ws + "/viewer"));  // the workspace is only read
}

}  // namespace
}  // namespace crop4d::viewer
