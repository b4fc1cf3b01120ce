#include "crop4d/analysis/plants.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/analysis/analysis_test_util.h"

namespace crop4d::analysis {
namespace {

using testing_util::BedHeight;
using testing_util::SampleGround;

// Young plants: green domes of `radius` and `height` on a tilted bed field, points every 5 mm.
SessionCloud Domes(const std::vector<Eigen::Vector3d>& plants /* x, y, height */, double radius) {
  SessionCloud cloud;
  std::mt19937_64 rng(1);
  std::vector<Eigen::Vector3d> ground;
  std::vector<std::uint8_t> flags;
  SampleGround(Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2)), 10000, 0.001,
               &rng, &ground, &flags);
  for (const Eigen::Vector3d& p : ground) {
    cloud.points.push_back(p);
    cloud.colors.push_back({150, 126, 104});
    cloud.is_vegetation.push_back(0);
  }
  for (const Eigen::Vector3d& plant : plants) {
    for (double dx = -radius; dx <= radius; dx += 0.005) {
      for (double dy = -radius; dy <= radius; dy += 0.005) {
        const double d2 = dx * dx + dy * dy;
        if (d2 > radius * radius) continue;
        const double x = plant.x() + dx, y = plant.y() + dy;
        cloud.points.emplace_back(
            x, y, BedHeight(x, y) + plant.z() * (1.0 - 0.5 * d2 / (radius * radius)));
        cloud.colors.push_back({70, 100, 50});
        cloud.is_vegetation.push_back(1);
      }
    }
  }
  return cloud;
}

GroundFunction Truth() {
  return [](double x, double y) { return BedHeight(x, y); };
}

TEST(DetectPlantsTest, OneStemPerIslandAtItsTop) {
  const std::vector<Eigen::Vector3d> plants = {
      {0.91, 0.6, 0.08}, {0.91, 0.8, 0.10}, {0.93, 1.0, 0.07}, {0.90, 1.22, 0.09}};
  const SessionCloud cloud = Domes(plants, 0.05);
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  const std::vector<DetectedPlant> found =
      DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{});
  ASSERT_EQ(found.size(), plants.size());
  for (const Eigen::Vector3d& p : plants) {
    double best = 1e9;
    const DetectedPlant* match = nullptr;
    for (const DetectedPlant& f : found) {
      if ((f.stem - p.head<2>()).norm() < best) {
        best = (f.stem - p.head<2>()).norm();
        match = &f;
      }
    }
    EXPECT_LT(best, 0.01);
    EXPECT_NEAR(match->height_m, p.z(), 0.003);
    EXPECT_NEAR(match->area_m2, M_PI * 0.05 * 0.05, 0.004);
  }
}

TEST(DetectPlantsTest, NoiseAndClosedCanopiesAreNotPlants) {
  // A lone green point is not a plant; a canopy of 0.5 × 0.5 m is not one plant either.
  SessionCloud cloud = Domes({{0.5, 0.5, 0.1}}, 0.3);
  cloud.points.emplace_back(1.5, 1.5, BedHeight(1.5, 1.5) + 0.05);
  cloud.colors.push_back({70, 100, 50});
  cloud.is_vegetation.push_back(1);
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  EXPECT_TRUE(DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{}).empty());
}

TEST(DetectPlantsTest, TouchingPlantsAreSplitAtTheirSaddle) {
  // Two young plants 12 cm apart whose leaves overlap by 1 cm make one island of canopy; the
  // lower one's top rises 3 cm above the saddle between them. Each keeps its own stem.
  const std::vector<Eigen::Vector3d> plants = {{0.91, 0.80, 0.10}, {0.91, 0.92, 0.09}};
  const SessionCloud cloud = Domes(plants, 0.065);
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  const std::vector<DetectedPlant> found =
      DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{});
  ASSERT_EQ(found.size(), 2u);
  for (const Eigen::Vector3d& p : plants) {
    const auto match = std::min_element(
        found.begin(), found.end(), [&](const DetectedPlant& a, const DetectedPlant& b) {
          return (a.stem - p.head<2>()).norm() < (b.stem - p.head<2>()).norm();
        });
    EXPECT_LT((match->stem - p.head<2>()).norm(), 0.01);
    EXPECT_NEAR(match->height_m, p.z(), 0.003);
  }
  // Without the split (a prominence no saddle reaches), one island is one plant, at the taller.
  PlantDetectionOptions whole;
  whole.min_prominence_m = 1.0;
  const std::vector<DetectedPlant> one = DetectPlants(cloud, Truth(), area, CanopyOptions{}, whole);
  ASSERT_EQ(one.size(), 1u);
  EXPECT_NEAR(one[0].height_m, 0.10, 0.003);
}

TEST(DetectPlantsTest, ALowBumpOnAPlantIsNotAPlant) {
  // A broad plant (12 cm radius, 10 cm tall) with a small leaf 9 cm from its stem (2 cm radius,
  // 9.5 cm high). The leaf rises 1.2 cm above the saddle between them, less than 15 % of its
  // height: one plant.
  SessionCloud cloud = Domes({{0.91, 1.0, 0.10}}, 0.12);
  const SessionCloud leaf = Domes({{0.91, 1.09, 0.095}}, 0.02);
  for (std::size_t i = 0; i < leaf.points.size(); ++i) {
    if (!leaf.is_vegetation[i]) continue;
    cloud.points.push_back(leaf.points[i]);
    cloud.colors.push_back(leaf.colors[i]);
    cloud.is_vegetation.push_back(1);
  }
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  const std::vector<DetectedPlant> found =
      DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{});
  ASSERT_EQ(found.size(), 1u);
  EXPECT_LT((found[0].stem - Eigen::Vector2d(0.91, 1.0)).norm(), 0.01);
  EXPECT_NEAR(found[0].height_m, 0.10, 0.003);
  // With a prominence of 0.5 cm the leaf would pass for a second plant.
  PlantDetectionOptions low;
  low.min_prominence_m = 0.005;
  low.min_prominence_fraction = 0.0;
  EXPECT_EQ(DetectPlants(cloud, Truth(), area, CanopyOptions{}, low).size(), 2u);
}

// Plants off the declared rows are weeds or noise between them: the stems beyond
// max_row_offset_m from every row's segment go, those beside a row or past its end by less stay.
// The raster filled a part of the cloud at a time (each point once) finds the plants of the
// whole cloud.
TEST(PlantRasterTest, PartsOfACloudGiveThePlantsOfTheWhole) {
  const SessionCloud cloud =
      Domes({{0.4, 0.5, 0.08}, {0.9, 0.52, 0.1}, {1.02, 0.6, 0.07}, {1.5, 1.4, 0.12}}, 0.06);
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0.1, 0.1), Eigen::Vector2d(1.9, 1.9));
  const std::vector<DetectedPlant> whole =
      DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{});
  ASSERT_GE(whole.size(), 3u);
  PlantRaster raster(area, CanopyOptions{}, PlantDetectionOptions{});
  for (const double lo : {0.0, 0.55, 0.97, 1.3}) {  // strips of x, cutting plants in two
    const double hi = lo == 1.3 ? 3.0 : (lo == 0.0 ? 0.55 : (lo == 0.55 ? 0.97 : 1.3));
    SessionCloud part;
    for (std::size_t i = 0; i < cloud.points.size(); ++i) {
      if (cloud.points[i].x() < lo || cloud.points[i].x() >= hi) continue;
      part.points.push_back(cloud.points[i]);
      part.colors.push_back(cloud.colors[i]);
      part.is_vegetation.push_back(cloud.is_vegetation[i]);
    }
    raster.Add(part, Truth());
  }
  const std::vector<DetectedPlant> parts = raster.Detect();
  ASSERT_EQ(parts.size(), whole.size());
  for (std::size_t k = 0; k < whole.size(); ++k) {
    EXPECT_EQ(parts[k].stem, whole[k].stem);
    EXPECT_EQ(parts[k].height_m, whole[k].height_m);
    EXPECT_EQ(parts[k].area_m2, whole[k].area_m2);
  }
}

TEST(PlantsOnRowsTest, StemsFarFromEveryRowGo) {
  io::RowDeclaration a, b;
  a.start_enu = {0.0, 0.0};
  a.end_enu = {0.0, 10.0};
  b.index = 1;
  b.start_enu = {0.9, 0.0};
  b.end_enu = {1.2, 10.0};  // a slanted row
  const std::vector<io::RowDeclaration> rows{a, b};
  auto plant = [](double x, double y) { return DetectedPlant{{x, y}, 0.1, 0.01}; };
  const std::vector<DetectedPlant> found{plant(0.05, 5.0), plant(-0.14, 2.0), plant(0.45, 5.0),
                                         plant(1.1, 5.0),  plant(0.88, 5.0),  plant(0.0, 10.1),
                                         plant(0.0, 10.5), plant(-0.3, 7.0)};
  PlantDetectionOptions options;
  ASSERT_EQ(options.max_row_offset_m, 0.15);
  const std::vector<DetectedPlant> kept = PlantsOnRows(found, rows, options);
  std::vector<Eigen::Vector2d> stems;
  for (const DetectedPlant& p : kept) stems.push_back(p.stem);
  // The slanted row passes x = 1.05 at y = 5: (1.1, 5) lies 5 cm from it, (0.88, 5) 17 cm.
  const std::vector<Eigen::Vector2d> expected{{0.05, 5.0}, {-0.14, 2.0}, {1.1, 5.0}, {0.0, 10.1}};
  ASSERT_EQ(stems.size(), expected.size());
  for (std::size_t k = 0; k < expected.size(); ++k) EXPECT_EQ(stems[k], expected[k]) << k;
  // No rows declared, or the test off: every plant counts.
  EXPECT_EQ(PlantsOnRows(found, {}, options).size(), found.size());
  options.max_row_offset_m = 0;
  EXPECT_EQ(PlantsOnRows(found, rows, options).size(), found.size());
}

TEST(MeasureSiteTest, PlantTopsAreTheMeanOfThePlantsInTheSite) {
  // Three plants in the site (0.08, 0.10, 0.12 m) and a taller one just outside it.
  const SessionCloud cloud =
      Domes({{0.91, 0.8, 0.08}, {0.91, 1.0, 0.10}, {0.91, 1.2, 0.12}, {0.91, 1.5, 0.3}}, 0.05);
  io::Site site;
  site.center_enu = {0.91, 1.0};
  site.radius_m = 0.35;
  const Eigen::AlignedBox2d area(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  std::vector<Eigen::Vector2d> stems;
  for (const DetectedPlant& p :
       DetectPlants(cloud, Truth(), area, CanopyOptions{}, PlantDetectionOptions{})) {
    stems.push_back(p.stem);
  }
  ASSERT_EQ(stems.size(), 4u);
  const SiteCanopy c = MeasureSite(cloud, Truth(), site, CanopyOptions{}, &stems);
  EXPECT_EQ(c.n_peaks, 3);
  EXPECT_NEAR(c.height_m, 0.10, 0.003);
  // Without stems, the crown tops: the tall plant's canopy reaches into the site but its top
  // does not.
  const SiteCanopy peaks = MeasureSite(cloud, Truth(), site, CanopyOptions{}, nullptr);
  EXPECT_NEAR(peaks.height_m, 0.10, 0.01);
}

TEST(MeasureSiteTest, AFalseMatchAboveAPlantIsBoundedByItsTopInTheNextSession) {
  // Two plants, 10 and 12 cm tall; five points of a false match float 15 cm above the first.
  SessionCloud cloud = Domes({{0.91, 0.9, 0.10}, {0.91, 1.1, 0.12}}, 0.05);
  for (int i = 0; i < 5; ++i) {
    const double x = 0.92 + 0.005 * i, y = 0.91;
    cloud.points.emplace_back(x, y, BedHeight(x, y) + 0.25);
    cloud.colors.push_back({70, 100, 50});
    cloud.is_vegetation.push_back(1);
  }
  io::Site site;
  site.center_enu = {0.91, 1.0};
  site.radius_m = 0.35;
  const std::vector<Eigen::Vector2d> stems = {{0.91, 0.9}, {0.91, 1.1}};
  const SiteCanopy alone = MeasureSite(cloud, Truth(), site, CanopyOptions{}, &stems);
  EXPECT_NEAR(alone.height_m, (0.25 + 0.12) / 2, 0.003);
  EXPECT_EQ(alone.n_lowered, 0);
  // The next session's tops (13 and 15 cm) bound these ones (with CanopyOptions::max_shrink_m):
  // the false match is left out, the second plant is below its bound anyway.
  const std::vector<double> bounds = {0.13 + 0.05, 0.15 + 0.05};
  const SiteCanopy bounded = MeasureSite(cloud, Truth(), site, CanopyOptions{}, &stems, &bounds);
  EXPECT_NEAR(bounded.height_m, (0.10 + 0.12) / 2, 0.003);
  EXPECT_EQ(bounded.n_lowered, 1);
  ASSERT_EQ(bounded.plant_tops.size(), 2u);
  EXPECT_NEAR(bounded.plant_tops[0], 0.10, 0.003);
  EXPECT_NEAR(bounded.plant_tops[1], 0.12, 0.003);
  // A bound below every cell of a plant leaves it as it is (the later session lost its top).
  const std::vector<double> below = {0.04, std::nan("")};
  const SiteCanopy kept = MeasureSite(cloud, Truth(), site, CanopyOptions{}, &stems, &below);
  EXPECT_NEAR(kept.plant_tops[0], 0.25, 0.003);
  EXPECT_EQ(kept.n_lowered, 0);
}

}  // namespace
}  // namespace crop4d::analysis
