// Dense-cloud evaluation: plant tops and soil of hand-built clouds with known errors, the truth
// files' errors, and the dense section of a workspace evaluation.

#include "crop4d/eval/dense_eval.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <cmath>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/ply.h"

namespace crop4d::eval {
namespace {

using testing::PidTempDir;
using testing::WriteFile;

// A tilted bed: the true terrain.
double Ground(double x, double y) { return 0.10 + 0.05 * x - 0.02 * y; }

PlantFootprint Plant(double x, double y, double height, double radius) {
  PlantFootprint p;
  p.xy = Eigen::Vector2d(x, y);
  p.height_m = height;
  p.canopy_radius_m = radius;
  return p;
}

// Plants A (top 3 cm low), B (top 3.5 cm high), C (no point near it: missing) and D (not
// emerged), and the cloud: soil 4 mm above the terrain on a 2 cm grid clear of the canopies,
// leaves below each top, and a point 0.5 m up 10 cm from A's stem (outside the top radius).
struct Scene {
  std::vector<PlantFootprint> plants = {Plant(1.0, 1.0, 0.30, 0.2), Plant(2.0, 1.0, 0.20, 0.15),
                                        Plant(3.0, 1.0, 0.10, 0.1), Plant(3.5, 1.0, 0.0, 0.0)};
  std::vector<Eigen::Vector3d> points;
  int soil_points = 0;

  Scene() {
    for (double x = 0.0; x <= 4.0 + 1e-9; x += 0.02) {
      for (double y = 0.0; y <= 2.0 + 1e-9; y += 0.02) {
        bool clear = true;
        for (const PlantFootprint& p : plants) {
          if ((Eigen::Vector2d(x, y) - p.xy).norm() <= p.canopy_radius_m + 0.06) clear = false;
        }
        if (!clear) continue;
        points.emplace_back(x, y, Ground(x, y) + 0.004);
        ++soil_points;
      }
    }
    points.emplace_back(1.05, 1.02, Ground(1.0, 1.0) + 0.27);  // A's top: 3 cm low
    points.emplace_back(0.98, 0.97, Ground(1.0, 1.0) + 0.20);
    points.emplace_back(1.10, 1.00, Ground(1.0, 1.0) + 0.50);   // 10 cm away
    points.emplace_back(2.00, 0.95, Ground(2.0, 1.0) + 0.235);  // B's top: 3.5 cm high
    points.emplace_back(2.03, 1.00, Ground(2.0, 1.0) + 0.15);
    // Neither a non-finite point nor one far off the field is anyone's top.
    points.emplace_back(std::nan(""), 1.0, 5.0);
    points.emplace_back(1e9, 1e9, 5.0);
  }
};

TerrainGrid Terrain() { return TerrainGrid::FromFunction(-0.5, -0.5, 4.5, 2.5, 0.1, Ground); }

TEST(DenseEvalTest, PlantTopsAndSoilOfAHandBuiltCloud) {
  const Scene scene;
  const DenseSessionEval e = EvaluateDenseCloud(scene.points, scene.plants, Terrain(), {});
  ASSERT_TRUE(e.ok());
  EXPECT_EQ(e.points, static_cast<std::int64_t>(scene.points.size()));
  EXPECT_EQ(e.tops.num_plants, 3);  // D has not emerged
  EXPECT_EQ(e.tops.num_found, 2);
  EXPECT_EQ(e.tops.num_missing, 1);
  ASSERT_EQ(e.top_errors_m.size(), 2u);
  EXPECT_NEAR(e.top_errors_m[0], -0.03, 1e-9);
  EXPECT_NEAR(e.top_errors_m[1], 0.035, 1e-9);
  EXPECT_NEAR(e.tops.median_m, 0.0025, 1e-9);
  EXPECT_NEAR(e.tops.rmse_m, std::sqrt((0.03 * 0.03 + 0.035 * 0.035) / 2), 1e-9);
  EXPECT_DOUBLE_EQ(e.tops.low_share, 0.5);
  EXPECT_DOUBLE_EQ(e.tops.high_share, 0.5);
  EXPECT_DOUBLE_EQ(e.tops.within_share, 0.0);
  // Every soil point and none of the leaves.
  EXPECT_EQ(e.soil.num_points, scene.soil_points);
  EXPECT_NEAR(e.soil.median_m, 0.004, 1e-9);
  EXPECT_NEAR(e.soil.abs_p90_m, 0.004, 1e-9);

  // A wider radius reaches the point 10 cm from A's stem.
  DenseEvalOptions wide;
  wide.top_radius_m = 0.12;
  const DenseSessionEval w = EvaluateDenseCloud(scene.points, scene.plants, Terrain(), wide);
  ASSERT_EQ(w.top_errors_m.size(), 2u);
  EXPECT_NEAR(w.top_errors_m[0], 0.20, 1e-9);
  // A looser tolerance counts both tops as within.
  DenseEvalOptions loose;
  loose.tolerance_m = 0.04;
  EXPECT_DOUBLE_EQ(
      EvaluateDenseCloud(scene.points, scene.plants, Terrain(), loose).tops.within_share, 1.0);
}

TEST(DenseEvalTest, EmptyCloudHasEveryPlantMissingAndNoStatistics) {
  const Scene scene;
  const DenseSessionEval e = EvaluateDenseCloud({}, scene.plants, Terrain(), {});
  EXPECT_EQ(e.tops.num_plants, 3);
  EXPECT_EQ(e.tops.num_missing, 3);
  EXPECT_TRUE(std::isnan(e.tops.median_m));
  EXPECT_TRUE(std::isnan(e.tops.rmse_m));
  EXPECT_EQ(e.soil.num_points, 0);
  EXPECT_TRUE(std::isnan(e.soil.median_m));
}

TEST(DenseEvalTest, OptionsAndPlantsFileAreChecked) {
  DenseEvalOptions o;
  EXPECT_EQ(o.Check(), "");
  o.top_radius_m = 0.0;
  EXPECT_NE(o.Check(), "");
  o = DenseEvalOptions();
  o.tolerance_m = std::nan("");
  EXPECT_NE(o.Check(), "");

  PidTempDir dir;
  WriteFile(dir / "plants.csv", "id,row,x,y,height_m,canopy_radius_m\n0,0,1,1,-0.2,0.1\n");
  try {
    ReadPlantsCsv(dir / "plants.csv");
    ADD_FAILURE() << "a negative height was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("plants.csv:2"), std::string::npos) << e.what();
  }
}

// A workspace with only dense clouds: s1 with its truth, s2 without plants.csv.
class DenseWorkspaceTest : public ::testing::Test {
 public:
  void SetUp() override {
    std::string terrain = "x,y,z\n";
    for (int iy = 0; iy <= 30; ++iy) {
      for (int ix = 0; ix <= 50; ++ix) {
        const double x = -0.5 + 0.1 * ix, y = -0.5 + 0.1 * iy;
        terrain += fmt::format("{:.4f},{:.4f},{:.6f}\n", x, y, Ground(x, y));
      }
    }
    WriteFile(dir_ / "field/ground_truth/terrain.csv", terrain);
    std::string plants = "id,row,x,y,height_m,canopy_radius_m\n";
    int id = 0;
    for (const PlantFootprint& p : scene_.plants) {
      plants += fmt::format("{},0,{},{},{},{}\n", id++, p.xy.x(), p.xy.y(), p.height_m,
                            p.canopy_radius_m);
    }
    WriteFile(dir_ / "field/ground_truth/s1/plants.csv", plants);
    io::PlyPointCloud cloud;
    cloud.points = scene_.points;
    std::filesystem::create_directories(dir_ / "ws/dense");
    io::WritePly(dir_ / "ws/dense/s1.ply", cloud);
    io::WritePly(dir_ / "ws/dense/s2.ply", cloud);
  }

 protected:
  PidTempDir dir_;
  Scene scene_;
};

TEST_F(DenseWorkspaceTest, SectionOfTheWorkspaceEvaluation) {
  const WorkspaceEval eval = EvaluateWorkspace(dir_ / "ws", dir_ / "field", {});
  ASSERT_TRUE(eval.dense.has_value());
  const DenseEval& d = *eval.dense;
  EXPECT_TRUE(d.error.empty()) << d.error;
  ASSERT_EQ(d.sessions.size(), 2u);
  EXPECT_EQ(d.sessions[0].session, "s1");
  EXPECT_EQ(d.sessions[0].file, "dense/s1.ply");
  ASSERT_TRUE(d.sessions[0].ok()) << d.sessions[0].error;
  EXPECT_EQ(d.sessions[0].tops.num_found, 2);
  EXPECT_NE(d.sessions[1].error.find("no true plants for session 's2'"), std::string::npos)
      << d.sessions[1].error;
  // Pooled over the evaluated session only.
  EXPECT_EQ(d.tops.num_plants, 3);
  EXPECT_NEAR(d.tops.median_m, 0.0025, 1e-9);

  const nlohmann::json j = nlohmann::json::parse(WorkspaceEvalJson(eval));
  ASSERT_TRUE(j.contains("dense"));
  EXPECT_EQ(j["dense"]["sessions"][0]["plant_tops"]["num_missing"], 1);
  EXPECT_NEAR(j["dense"]["sessions"][0]["soil"]["median_m"].get<double>(), 0.004, 1e-9);
  EXPECT_TRUE(j["dense"]["sessions"][1]["error"].is_string());
  EXPECT_NEAR(j["dense"]["plant_tops"]["rmse_m"].get<double>(),
              std::sqrt((0.03 * 0.03 + 0.035 * 0.035) / 2), 1e-9);

  const std::string table = FormatWorkspaceEvalTable(eval);
  EXPECT_NE(table.find("dense clouds"), std::string::npos) << table;
  EXPECT_NE(table.find("2/3"), std::string::npos) << table;
  EXPECT_NE(table.find("-2.35"), std::string::npos) << table;  // p10 of the errors, cm

  // Turned off, nothing is left to evaluate.
  WorkspaceEvalOptions off;
  off.dense = false;
  EXPECT_THROW(EvaluateWorkspace(dir_ / "ws", dir_ / "field", off), InputError);
}

TEST_F(DenseWorkspaceTest, MissingTerrainIsTheSectionsError) {
  std::filesystem::remove(dir_ / "field/ground_truth/terrain.csv");
  const WorkspaceEval eval = EvaluateWorkspace(dir_ / "ws", dir_ / "field", {});
  ASSERT_TRUE(eval.dense.has_value());
  EXPECT_NE(eval.dense->error.find("terrain.csv"), std::string::npos) << eval.dense->error;
  EXPECT_TRUE(eval.dense->sessions.empty());
  EXPECT_NE(FormatDenseTable(*eval.dense).find("not evaluated"), std::string::npos);
}

}  // namespace
}  // namespace crop4d::eval
