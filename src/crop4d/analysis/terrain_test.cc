#include "crop4d/analysis/terrain.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/analysis/analysis_test_util.h"

namespace crop4d::analysis {
namespace {

using testing_util::BedHeight;
using testing_util::SampleGround;

TEST(GridSpecTest, CoveringSnapsAndCovers) {
  const Eigen::AlignedBox2d box(Eigen::Vector2d(-0.33, 1.02), Eigen::Vector2d(2.71, 3.49));
  const GridSpec g = GridSpec::Covering(box, 0.05);
  ASSERT_EQ(g.Check(), "");
  EXPECT_NEAR(g.origin.x(), -0.35, 1e-12);
  EXPECT_NEAR(g.origin.y(), 1.0, 1e-12);
  EXPECT_GE(g.Node(g.width - 1, g.height - 1).x(), 2.71 - 1e-12);
  EXPECT_GE(g.Node(g.width - 1, g.height - 1).y(), 3.49 - 1e-12);
  EXPECT_LT(g.Node(g.width - 2, g.height - 2).x(), 2.71);
}

TEST(TerrainModelTest, BilinearBetweenNodesAndNanOutside) {
  GridSpec g;
  g.origin = {0, 0};
  g.cell_m = 1.0;
  g.width = 2;
  g.height = 2;
  const TerrainModel m(g, {0.0f, 1.0f, 2.0f, 3.0f});
  EXPECT_NEAR(m.Height(0.5, 0.5), 1.5, 1e-6);
  EXPECT_NEAR(m.Height(1.0, 1.0), 3.0, 1e-6);
  EXPECT_TRUE(std::isnan(m.Height(1.1, 0.5)));
  const TerrainModel holes(g, {0.0f, NAN, 2.0f, 3.0f});
  EXPECT_TRUE(std::isnan(holes.Height(0.5, 0.5)));
  EXPECT_NEAR(holes.Coverage(), 0.75, 1e-12);
}

// A tilted field with raised beds every 0.91 m, sampled with 2 mm noise; young plants (green
// points up to 12 cm above the ground) and 5 % of unflagged clutter above the ground (leaves the
// colour test missed). The DTM must follow the beds within a few millimetres, where one plane
// per site is centimetres off.
TEST(BuildTerrainTest, FollowsTiltedBedsAndIgnoresWhatIsAbove) {
  std::mt19937_64 rng(7);
  std::vector<Eigen::Vector3d> points;
  std::vector<std::uint8_t> veg;
  SampleGround(Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 3)), 1500, 0.002, &rng,
               &points, &veg);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const std::size_t ground_count = points.size();
  for (std::size_t i = 0; i < ground_count / 20; ++i) {  // unflagged clutter above the ground
    const double x = 3 * u(rng), y = 3 * u(rng);
    points.emplace_back(x, y, BedHeight(x, y) + 0.03 + 0.2 * u(rng));
    veg.push_back(0);
  }
  for (int plant = 0; plant < 20; ++plant) {  // plants on the bed crests, flagged
    const double x = 0.91 * (plant % 3), y = 0.2 + 0.15 * plant;
    for (int k = 0; k < 60; ++k) {
      const double a = 2 * M_PI * u(rng), r = 0.05 * std::sqrt(u(rng));
      points.emplace_back(x + r * std::cos(a), y + r * std::sin(a),
                          BedHeight(x, y) + 0.12 * (1 - r / 0.05));
      veg.push_back(1);
    }
  }
  TerrainSummary summary;
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(0.3, 0.3), Eigen::Vector2d(2.7, 2.7));
  const TerrainModel dtm = BuildTerrain({{&points, &veg}}, bounds, TerrainOptions{}, &summary);
  EXPECT_EQ(summary.nodes_fitted, summary.nodes);
  double sum2 = 0.0, worst = 0.0;
  int n = 0;
  for (int j = 0; j < dtm.grid().height; ++j) {
    for (int i = 0; i < dtm.grid().width; ++i) {
      const Eigen::Vector2d q = dtm.grid().Node(i, j);
      const double e = dtm.At(i, j) - BedHeight(q.x(), q.y());
      sum2 += e * e;
      worst = std::max(worst, std::abs(e));
      ++n;
    }
  }
  EXPECT_LT(std::sqrt(sum2 / n), 0.0025);
  EXPECT_LT(worst, 0.008);
  EXPECT_NEAR(summary.residual_scale_m, 0.002, 0.0015);

  // Between a crest and a furrow, one plane per 0.4 m site cannot follow the bed's curvature
  // over the site; the DTM can.
  double plane_worst = 0.0, dtm_worst = 0.0;
  for (double x = 0.1; x < 0.85; x += 0.05) {
    const std::optional<GroundPlane> plane =
        FitSiteGroundPlane({&points, &veg}, Eigen::Vector2d(0.5 + x, 1.5), 0.4, PlaneOptions{});
    ASSERT_TRUE(plane.has_value());
    for (double d = -0.3; d <= 0.3; d += 0.1) {
      const double truth = BedHeight(0.5 + x + d, 1.5);
      plane_worst = std::max(plane_worst, std::abs(plane->Height(0.5 + x + d, 1.5) - truth));
      dtm_worst = std::max(dtm_worst, std::abs(dtm.Height(0.5 + x + d, 1.5) - truth));
    }
  }
  EXPECT_LT(dtm_worst, 0.008);
  EXPECT_GT(plane_worst, 0.015);
}

// Later sessions fill what the first did not see, but only with soil clear of their plants.
TEST(BuildTerrainTest, LaterSessionsFillHolesWithUncoveredSoil) {
  std::mt19937_64 rng(3);
  const Eigen::AlignedBox2d all(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 3));
  std::vector<Eigen::Vector3d> first, later;
  std::vector<std::uint8_t> first_veg, later_veg;
  SampleGround(all, 1000, 0.002, &rng, &first, &first_veg);
  // The first session did not see x > 2 m.
  std::vector<Eigen::Vector3d> seen;
  for (const Eigen::Vector3d& p : first) {
    if (p.x() < 2.0) seen.push_back(p);
  }
  first = seen;
  first_veg.assign(first.size(), 0);
  SampleGround(all, 1000, 0.002, &rng, &later, &later_veg);
  // A later canopy at (2.5, 1.5) with soil-coloured (unflagged) leaves under flagged ones is
  // kept out by the clearance test.
  for (int k = 0; k < 400; ++k) {
    const double dx = 0.001 * (k % 20) - 0.01, dy = 0.001 * (k / 20) - 0.01;
    later.emplace_back(2.5 + dx, 1.5 + dy, BedHeight(2.5, 1.5) + 0.25);
    later_veg.push_back(1);
    later.emplace_back(2.5 + dx, 1.5 + dy + 0.0005, BedHeight(2.5, 1.5) + 0.02);
    later_veg.push_back(0);
  }
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(0.3, 0.3), Eigen::Vector2d(2.7, 2.7));
  TerrainOptions options;
  options.max_fill_distance_m = 0.0;
  TerrainSummary only_first;
  const TerrainModel a = BuildTerrain({{&first, &first_veg}}, bounds, options, &only_first);
  EXPECT_TRUE(std::isnan(a.Height(2.5, 1.0)));
  options.max_fill_distance_m = 1.0;
  TerrainSummary both;
  const TerrainModel b =
      BuildTerrain({{&first, &first_veg}, {&later, &later_veg}}, bounds, options, &both);
  EXPECT_GT(both.ground_points_later, 0u);
  EXPECT_NEAR(b.Height(2.5, 1.0), BedHeight(2.5, 1.0), 0.005);
  EXPECT_NEAR(b.Height(2.5, 1.5), BedHeight(2.5, 1.5), 0.005);
}

// A session added to a TerrainBuilder can be freed: what the builder keeps of each later
// session is at most one point per thinning cell, however dense the session's cloud, and the
// model stays on the ground.
TEST(TerrainBuilderTest, KeepsAtMostOnePointPerCellOfEachLaterSession) {
  std::mt19937_64 rng(5);
  const Eigen::AlignedBox2d all(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2));
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(0.3, 0.3), Eigen::Vector2d(1.7, 1.7));
  TerrainOptions options;
  TerrainBuilder builder(bounds, options);
  std::vector<Eigen::Vector3d> first;
  std::vector<std::uint8_t> first_veg;
  SampleGround(all, 2000, 0.002, &rng, &first, &first_veg);
  builder.AddSession({&first, &first_veg});
  // Three later sessions of 40 000 points per m², 16 per 2 cm cell: each is freed once added.
  const double cells = (1.4 + 2 * options.fit_radius_m) * (1.4 + 2 * options.fit_radius_m) /
                       (options.thin_cell_m * options.thin_cell_m);
  for (int k = 0; k < 3; ++k) {
    std::vector<Eigen::Vector3d> later;
    std::vector<std::uint8_t> later_veg;
    SampleGround(all, 40000, 0.002, &rng, &later, &later_veg);
    builder.AddSession({&later, &later_veg});
  }
  TerrainSummary summary;
  const TerrainModel dtm = builder.Finish(&summary);
  EXPECT_GT(summary.ground_points_later, 2.0 * cells);
  EXPECT_LE(summary.ground_points_later, 3.0 * (cells + 2 * (1.8 / options.thin_cell_m) + 1));
  double worst = 0.0;
  for (double x = 0.35; x < 1.65; x += 0.1) {
    for (double y = 0.35; y < 1.65; y += 0.1) {
      worst = std::max(worst, std::abs(dtm.Height(x, y) - BedHeight(x, y)));
    }
  }
  EXPECT_LT(worst, 0.003);
}

// A session given a tile at a time, each tile holding its part of the axis and TileReach
// around it, adds what the whole session adds: the model is the same.
TEST(TerrainBuilderTest, SessionsInTilesGiveTheModelOfWholeSessions) {
  std::mt19937_64 rng(9);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  const Eigen::AlignedBox2d all(Eigen::Vector2d(0, 0), Eigen::Vector2d(4, 1.5));
  std::vector<std::vector<Eigen::Vector3d>> points(2);
  std::vector<std::vector<std::uint8_t>> veg(2);
  for (int s = 0; s < 2; ++s) {
    SampleGround(all, 3000, 0.002, &rng, &points[s], &veg[s]);
    for (int i = 0; i < 3000; ++i) {  // canopy over the crests: green and soil-coloured leaves
      const double x = 0.91 * static_cast<int>(5 * u(rng)) + (s + 1) * 0.1 * (u(rng) - 0.5);
      const double y = 1.5 * u(rng);
      points[s].emplace_back(x, y, BedHeight(x, y) + 0.05 + 0.1 * s + 0.05 * u(rng));
      veg[s].push_back(u(rng) < 0.7 ? 1 : 0);
    }
  }
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(0.2, 0.2), Eigen::Vector2d(3.8, 1.3));
  const TerrainOptions options;
  TerrainSummary whole_summary, tiled_summary;
  const TerrainModel whole =
      BuildTerrain({{&points[0], &veg[0]}, {&points[1], &veg[1]}}, bounds, options, &whole_summary);

  // The sessions in tiles of 0.87 to 1.03 m along x, each holding the points within `reach`
  // around its part of the axis.
  const double edges[] = {-1e9, 1.03, 1.9, 2.87, 1e9};
  const auto in_tiles = [&](double reach, TerrainSummary* summary) {
    TerrainBuilder builder(bounds, options);
    for (int s = 0; s < 2; ++s) {
      builder.BeginSession();
      for (int t = 0; t < 4; ++t) {
        std::vector<Eigen::Vector3d> tile;
        std::vector<std::uint8_t> tile_veg;
        for (std::size_t i = 0; i < points[s].size(); ++i) {
          const double x = points[s][i].x();
          if (x >= edges[t] - reach && x <= edges[t + 1] + reach) {
            tile.push_back(points[s][i]);
            tile_veg.push_back(veg[s][i]);
          }
        }
        builder.AddTile({&tile, &tile_veg}, 0, edges[t], edges[t + 1]);
      }
      builder.EndSession();
    }
    return builder.Finish(summary);
  };
  const auto largest_difference = [&](const TerrainModel& m) {
    double worst = 0.0;
    for (std::size_t k = 0; k < whole.heights().size(); ++k) {
      if (std::isfinite(m.heights()[k]) && std::isfinite(whole.heights()[k])) {
        worst = std::max(worst, static_cast<double>(std::abs(m.heights()[k] - whole.heights()[k])));
      }
    }
    return worst;
  };
  const TerrainModel tiled = in_tiles(TerrainBuilder::TileReach(options), &tiled_summary);
  EXPECT_EQ(tiled_summary.ground_points_first, whole_summary.ground_points_first);
  EXPECT_EQ(tiled_summary.ground_points_later, whole_summary.ground_points_later);
  EXPECT_GT(whole_summary.ground_points_later, 0u);
  ASSERT_EQ(tiled.heights().size(), whole.heights().size());
  std::size_t known = 0;
  for (std::size_t k = 0; k < whole.heights().size(); ++k) {
    ASSERT_EQ(std::isfinite(tiled.heights()[k]), std::isfinite(whole.heights()[k])) << k;
    known += std::isfinite(whole.heights()[k]) ? 1 : 0;
  }
  EXPECT_GT(known, whole.heights().size() / 2);
  EXPECT_LT(largest_difference(tiled), 1e-6);
  // Tiles without the reach around them would not: the ground filter and the clearance test
  // lose their neighbours at the tiles' ends.
  EXPECT_GT(largest_difference(in_tiles(0.0, nullptr)), 1e-4);
}

// A late session alone (the earliest one missing or left out): the canopy hides the bed crests,
// and soil-coloured points (shaded leaves, stems) lie at its height. The ground filter keeps them
// out, and the crests are fitted from the soil on both sides.
TEST(BuildTerrainTest, ALateSessionAloneFindsTheSoilUnderItsCanopy) {
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::vector<Eigen::Vector3d> late;
  std::vector<std::uint8_t> late_veg;
  SampleGround(Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(3, 3)), 2000, 0.002, &rng,
               &late, &late_veg);
  const auto under_canopy = [](double x) {
    const double d = std::remainder(x, 0.91);
    return std::abs(d) < 0.12;
  };
  std::vector<Eigen::Vector3d> seen;
  for (const Eigen::Vector3d& p : late) {
    if (!under_canopy(p.x())) seen.push_back(p);
  }
  late = seen;
  late_veg.assign(late.size(), 0);
  for (int i = 0; i < 6000; ++i) {  // canopy over the crests: green on top, soil-coloured below
    const double x = 0.91 * static_cast<int>(4 * u(rng)) + 0.24 * (u(rng) - 0.5);
    const double y = 3 * u(rng);
    const bool top = u(rng) < 0.4;
    late.emplace_back(x, y, BedHeight(x, y) + (top ? 0.22 : 0.12) + 0.05 * u(rng));
    late_veg.push_back(top ? 1 : 0);
  }
  const Eigen::AlignedBox2d bounds(Eigen::Vector2d(0.3, 0.3), Eigen::Vector2d(2.7, 2.7));
  const auto crest_error = [&](const TerrainOptions& options) {
    const TerrainModel dtm = BuildTerrain({{&late, &late_veg}}, bounds, options);
    double worst = 0.0;
    for (double y = 0.5; y < 2.5; y += 0.25) {
      for (double x : {0.91, 1.82}) {
        worst = std::max(worst, std::abs(dtm.Height(x, y) - BedHeight(x, y)));
      }
    }
    return worst;
  };
  EXPECT_LT(crest_error(TerrainOptions{}), 0.01);
  TerrainOptions unfiltered;
  unfiltered.ground_filter.window_m = 0.0;
  EXPECT_GT(crest_error(unfiltered), 0.03);
}

TEST(BuildTerrainTest, NoGroundPointsGiveAnEmptyModelNotACrash) {
  std::vector<Eigen::Vector3d> points = {{0, 0, 0}, {1, 1, 0.1}};
  std::vector<std::uint8_t> veg = {1, 1};
  TerrainSummary summary;
  const TerrainModel m = BuildTerrain(
      {{&points, &veg}, {}}, Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(1, 1)),
      TerrainOptions{}, &summary);
  EXPECT_EQ(summary.nodes_fitted, 0u);
  EXPECT_EQ(m.Coverage(), 0.0);
  EXPECT_TRUE(std::isnan(m.Height(0.5, 0.5)));
  EXPECT_FALSE(FitSiteGroundPlane({&points, &veg}, {0.5, 0.5}, 1.0, PlaneOptions{}).has_value());
}

TEST(TerrainOptionsTest, CheckRejectsBadValues) {
  TerrainOptions o;
  EXPECT_EQ(o.Check(), "");
  o.fit_radius_m = 0.01;  // smaller than a cell
  EXPECT_NE(o.Check(), "");
  o = TerrainOptions{};
  o.min_points = 3;
  EXPECT_NE(o.Check(), "");
  PlaneOptions p;
  p.inlier_threshold_m = 0.0;
  EXPECT_NE(p.Check(), "");
}

}  // namespace
}  // namespace crop4d::analysis
