// Ground misalignment on hand-built clouds with a known vertical offset, the ground selection,
// and the truth readers (terrain.csv, plants.csv).

#include "crop4d/eval/ground_misalignment.h"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/eval/quantile.h"

namespace crop4d::eval {
namespace {

double Bumpy(double x, double y) { return 0.05 * std::sin(1.3 * x) * std::cos(0.9 * y) + 0.01 * x; }

// `n` points spread uniformly over [0, 4] × [0, 4] on the surface, plus `dz`, with 2 mm noise.
std::vector<Eigen::Vector3d> Cloud(int n, std::uint32_t seed, double dz,
                                   const std::function<double(double, double)>& height) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> xy(0.0, 4.0);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::vector<Eigen::Vector3d> points;
  for (int i = 0; i < n; ++i) {
    const double x = xy(rng), y = xy(rng);
    points.emplace_back(x, y, height(x, y) + dz + noise(rng));
  }
  return points;
}

TEST(QuantileTest, InterpolatesBetweenRanks) {
  std::vector<double> v = {4.0, 1.0, 3.0, 2.0};
  EXPECT_DOUBLE_EQ(Quantile(&v, 0.5), 2.5);
  EXPECT_DOUBLE_EQ(Quantile(&v, 0.0), 1.0);
  EXPECT_DOUBLE_EQ(Quantile(&v, 1.0), 4.0);
  EXPECT_NEAR(Quantile(&v, 0.9), 3.7, 1e-12);
  std::vector<double> empty;
  EXPECT_TRUE(std::isnan(Quantile(&empty, 0.5)));
}

TEST(GroundMisalignmentTest, MeasuresAKnownVerticalOffset) {
  for (const bool bumpy : {false, true}) {
    SCOPED_TRACE(bumpy ? "bumpy" : "planar");
    const auto height = bumpy ? std::function<double(double, double)>(Bumpy)
                              : [](double x, double y) { return 0.02 * x - 0.01 * y; };
    const std::vector<SessionGround> sessions = {
        {"a", Cloud(4000, 1, 0.0, height)},
        {"b", Cloud(4000, 2, 0.0, height)},
        {"c", Cloud(4000, 3, 0.02, height)}};  // 2 cm higher
    const GroundMisalignment result = ComputeGroundMisalignment(sessions);
    ASSERT_EQ(result.pairs.size(), 3u);
    const MisalignmentStats& ab = result.pairs[0].stats;
    EXPECT_EQ(result.pairs[0].a, "a");
    EXPECT_EQ(result.pairs[0].b, "b");
    EXPECT_EQ(result.pairs[1].b, "c");
    EXPECT_EQ(result.pairs[2].a, "b");
    // Unshifted: only the 2 mm noise (and the curvature within 15 cm on the bumpy ground).
    EXPECT_GT(ab.count, 7000);
    EXPECT_LT(ab.median_m, 0.003);
    EXPECT_LT(ab.p90_m, 0.006);
    EXPECT_NEAR(ab.signed_median_m, 0.0, 0.001);
    // c is 2 cm above: a and b lie 2 cm below it.
    for (int k : {1, 2}) {
      const MisalignmentStats& s = result.pairs[k].stats;
      EXPECT_NEAR(s.median_m, 0.02, 0.002);
      EXPECT_NEAR(s.signed_median_m, -0.02, 0.002);
      EXPECT_GT(s.p90_m, s.median_m);
      EXPECT_LT(s.p90_m, 0.026);
      EXPECT_NEAR(s.mean_abs_m, 0.02, 0.002);
    }
    EXPECT_EQ(result.pooled.count, result.pairs[0].stats.count + result.pairs[1].stats.count +
                                       result.pairs[2].stats.count);
    EXPECT_NEAR(result.pooled.median_m, 0.02, 0.004);  // two of three pairs are offset
    // Each session against itself: the noise only, whatever the offset.
    ASSERT_EQ(result.self.size(), 3u);
    EXPECT_EQ(result.self[2].session, "c");
    for (const SelfMisalignment& self : result.self) {
      EXPECT_GT(self.stats.count, 3900);
      EXPECT_LT(self.stats.median_m, 0.003);
      EXPECT_NEAR(self.stats.signed_median_m, 0.0, 0.001);
    }
    EXPECT_LT(result.pooled_self.median_m, 0.003);
  }
}

TEST(GroundMisalignmentTest, SkipsPointsWithoutEnoughNeighbours) {
  const auto flat = [](double, double) { return 0.0; };
  std::vector<SessionGround> sessions = {
      {"dense", Cloud(4000, 4, 0.0, flat)}, {"sparse", Cloud(20, 5, 0.01, flat)}, {"empty", {}}};
  GroundMisalignmentOptions options;
  options.min_points = 6;
  const GroundMisalignment result = ComputeGroundMisalignment(sessions, options);
  ASSERT_EQ(result.pairs.size(), 3u);
  // dense → sparse: hardly any dense point has 6 sparse neighbours within 15 cm; sparse →
  // dense: all 20 do.
  const MisalignmentStats& ds = result.pairs[0].stats;
  EXPECT_GT(ds.skipped, 3900);
  EXPECT_GE(ds.count, 20);
  EXPECT_NEAR(ds.signed_median_m, -0.01, 0.003);
  // With an empty session: every point of the other is skipped, no distance.
  EXPECT_EQ(result.pairs[1].stats.count, 0);
  EXPECT_EQ(result.pairs[1].stats.skipped, 4000);
  EXPECT_TRUE(std::isnan(result.pairs[1].stats.median_m));

  // Fewer query points: every point still serves as a neighbour.
  options.max_query_points = 100;
  const GroundMisalignment few = ComputeGroundMisalignment({sessions[0], sessions[0]}, options);
  EXPECT_EQ(few.pairs[0].stats.count + few.pairs[0].stats.skipped, 200);
}

TEST(GroundSelectionTest, KeepsSoilAwayFromPlantsAndNearTheTerrain) {
  const TerrainGrid terrain =
      TerrainGrid::FromFunction(0.0, 0.0, 4.0, 4.0, 0.25, [](double x, double) { return 0.1 * x; });
  double z = 0.0;
  ASSERT_TRUE(terrain.Height(1.1, 2.0, &z));
  EXPECT_NEAR(z, 0.11, 1e-12);
  EXPECT_TRUE(terrain.Height(4.0, 4.0, &z));
  EXPECT_FALSE(terrain.Height(4.01, 1.0, &z));
  EXPECT_FALSE(terrain.Height(-0.01, 1.0, &z));

  const std::vector<PlantFootprint> plants = {{Eigen::Vector2d(1.0, 1.0), 0.2},
                                              {Eigen::Vector2d(3.0, 1.0), 0.0}};
  const std::vector<Eigen::Vector3d> points = {
      {1.0, 1.24, 0.10},  // under plant 0's canopy + 5 cm margin
      {1.0, 1.26, 0.10},  // just outside it: ground
      {3.04, 1.0, 0.30},  // within 5 cm of a plant that has not emerged
      {3.2, 1.0, 0.32},   // ground
      {2.0, 2.0, 0.32},   // 12 cm above the terrain (0.2)
      {2.0, 2.0, 0.11},   // 9 cm below it: still ground
      {5.0, 2.0, 0.5},    // outside the terrain grid
  };
  const std::vector<Eigen::Vector3d> ground = SelectGroundPoints(points, plants, terrain);
  ASSERT_EQ(ground.size(), 3u);
  EXPECT_EQ(ground[0], points[1]);
  EXPECT_EQ(ground[1], points[3]);
  EXPECT_EQ(ground[2], points[5]);
}

TEST(TruthFilesTest, ReadsTerrainAndPlants) {
  testing::PidTempDir dir;
  // terrain.csv as the simulator writes it: a header, x fastest.
  std::string text = "x,y,z\n";
  for (int iy = 0; iy < 3; ++iy) {
    for (int ix = 0; ix < 4; ++ix) {
      text += std::to_string(-1.0 + 0.5 * ix) + "," + std::to_string(2.0 + 0.5 * iy) + "," +
              std::to_string(0.01 * ix + 0.1 * iy) + "\n";
    }
  }
  testing::WriteFile(dir / "terrain.csv", text);
  const TerrainGrid terrain = TerrainGrid::Read(dir / "terrain.csv");
  double z = 0.0;
  ASSERT_TRUE(terrain.Height(-0.25, 2.75, &z));
  EXPECT_NEAR(z, 0.01 * 1.5 + 0.1 * 1.5, 1e-9);
  EXPECT_FALSE(terrain.Height(0.6, 2.0, &z));

  testing::WriteFile(dir / "bad.csv", "x,y,z\n0,0,0\n0.5,0,0\n0,0.5\n");
  try {
    TerrainGrid::Read(dir / "bad.csv");
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("bad.csv:4"), std::string::npos) << e.what();
  }
  testing::WriteFile(dir / "ragged.csv", "x,y,z\n0,0,0\n0.5,0,0\n0,0.5,0\n");
  EXPECT_THROW(TerrainGrid::Read(dir / "ragged.csv"), InputError);

  testing::WriteFile(dir / "plants.csv",
                     "id,row,x,y,height_m,canopy_radius_m\n0,0,0.0000,0.1000,0.2,0.15\n"
                     "1,0,0.0000,0.3000,0.0000,0.0000\n");
  const std::vector<PlantFootprint> plants = ReadPlantsCsv(dir / "plants.csv");
  ASSERT_EQ(plants.size(), 2u);
  EXPECT_DOUBLE_EQ(plants[0].canopy_radius_m, 0.15);
  EXPECT_DOUBLE_EQ(plants[1].xy.y(), 0.3);
  testing::WriteFile(dir / "plants_bad.csv", "id,row,x,y,height_m,canopy_radius_m\n0,0,a,1,2,3\n");
  EXPECT_THROW(ReadPlantsCsv(dir / "plants_bad.csv"), InputError);
}

}  // namespace
}  // namespace crop4d::eval
