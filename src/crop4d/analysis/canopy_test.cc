#include "crop4d/analysis/canopy.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/analysis/analysis_test_util.h"

namespace crop4d::analysis {
namespace {

using testing_util::BedHeight;
using testing_util::SampleGround;

struct Box {
  Eigen::Vector2d center;
  double half_side;
  double height;  // of the top above the ground (the top follows the ground's relief)
};

// A tilted bed field over [0, 2]² (10 000 soil points per m²) with green boxes standing on the
// beds, their tops `height` above the ground; the soil under the boxes is not seen.
SessionCloud BoxField(const std::vector<Box>& boxes, std::uint64_t seed) {
  SessionCloud cloud;
  cloud.session = "s";
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector3d> ground;
  std::vector<std::uint8_t> flags;
  SampleGround(Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2)), 10000, 0.002,
               &rng, &ground, &flags);
  for (const Eigen::Vector3d& p : ground) {
    bool under = false;
    for (const Box& b : boxes) {
      under |= (p.head<2>() - b.center).cwiseAbs().maxCoeff() <= b.half_side;
    }
    if (under) continue;
    cloud.points.push_back(p);
    cloud.colors.push_back({150, 126, 104});
    cloud.is_vegetation.push_back(0);
  }
  for (const Box& b : boxes) {
    for (double dx = -b.half_side + 0.0025; dx < b.half_side; dx += 0.005) {
      for (double dy = -b.half_side + 0.0025; dy < b.half_side; dy += 0.005) {
        const double x = b.center.x() + dx, y = b.center.y() + dy;
        cloud.points.emplace_back(x, y, BedHeight(x, y) + b.height);
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

io::Site MakeSite(double x, double y, double radius) {
  io::Site s;
  s.id = "site";
  s.center_enu = {x, y};
  s.radius_m = radius;
  return s;
}

TEST(MeasureSiteTest, BoxesOfKnownHeightOnATiltedBed) {
  // Box centres at cell centres of the site's 2 cm cells: each box covers 5 × 5 cells.
  const std::vector<Box> boxes = {
      {{0.92, 0.81}, 0.05, 0.15}, {{0.92, 1.01}, 0.05, 0.20}, {{0.92, 1.21}, 0.05, 0.25}};
  const SessionCloud cloud = BoxField(boxes, 11);
  const SiteCanopy c = MeasureSite(cloud, Truth(), MakeSite(0.91, 1.0, 0.4), CanopyOptions{});
  EXPECT_EQ(c.n_peaks, 3);
  EXPECT_NEAR(c.height_m, 0.20, 0.001);
  const double site_area = M_PI * 0.4 * 0.4;
  EXPECT_NEAR(c.cover, 0.03 / site_area, 0.1 * 0.03 / site_area);
  EXPECT_NEAR(c.volume_m3, 0.01 * (0.15 + 0.20 + 0.25), 0.1 * 0.006);
  EXPECT_TRUE(c.note.empty());

  CanopyOptions quantile;
  quantile.top = CanopyTop::kQuantile;
  quantile.top_quantile = 1.0;
  EXPECT_NEAR(MeasureSite(cloud, Truth(), MakeSite(0.91, 1.0, 0.4), quantile).height_m, 0.25,
              0.001);
}

TEST(MeasureSiteTest, AboveThePapersSitePlane) {
  // On a site whose soil is planar (between the beds' influence: the field's tilt only), the
  // paper's RANSAC plane recovers the ground and the box height.
  SessionCloud cloud = BoxField({{{0.91, 1.0}, 0.05, 0.10}}, 5);
  const std::optional<GroundPlane> plane =
      FitSiteGroundPlane(cloud.AsGround(), Eigen::Vector2d(0.91, 1.0), 0.4, PlaneOptions{});
  ASSERT_TRUE(plane.has_value());
  EXPECT_GT(plane->inliers, 1000);
  // RANSAC hugs the broad bed crest: within a few millimetres of it at the site centre.
  EXPECT_NEAR(plane->Height(0.91, 1.0), BedHeight(0.91, 1.0), 0.005);
  const GroundFunction plane_ground = [&](double x, double y) { return plane->Height(x, y); };
  EXPECT_NEAR(MeasureSite(cloud, plane_ground, MakeSite(0.91, 1.0, 0.4), CanopyOptions{}).height_m,
              0.10, 0.008);
}

TEST(MeasureSiteTest, NoVegetationGivesNoHeightAndZeroCover) {
  const SessionCloud cloud = BoxField({}, 2);
  const SiteCanopy c = MeasureSite(cloud, Truth(), MakeSite(1.0, 1.0, 0.4), CanopyOptions{});
  EXPECT_TRUE(std::isnan(c.height_m));
  EXPECT_EQ(c.cover, 0.0);
  EXPECT_EQ(c.volume_m3, 0.0);
  EXPECT_GT(c.n_cells, 100);
  EXPECT_EQ(c.note, "no vegetation within the site");
}

TEST(MeasureSiteTest, SiteWithoutPointsIsAClearResult) {
  const SessionCloud cloud = BoxField({{{0.91, 1.0}, 0.05, 0.10}}, 3);
  const SiteCanopy c = MeasureSite(cloud, Truth(), MakeSite(10.0, 10.0, 0.4), CanopyOptions{});
  EXPECT_TRUE(std::isnan(c.height_m));
  EXPECT_TRUE(std::isnan(c.cover));
  EXPECT_EQ(c.n_cells, 0);
  EXPECT_EQ(c.note, "no points within the site");
  // Unknown ground counts as no points too.
  const GroundFunction unknown = [](double, double) { return std::nan(""); };
  EXPECT_EQ(MeasureSite(cloud, unknown, MakeSite(0.91, 1.0, 0.4), CanopyOptions{}).note,
            "no points within the site");
}

TEST(SitePointsTest, TheSitesMeasureOnTheirPointsAsOnTheWholeCloud) {
  // Boxes over the field; sites of different radii, two overlapping, one across the field's
  // edge and one far from any point. The grid of SitePoints has the largest reach as its cell,
  // so the small sites' squares straddle its cell edges.
  const std::vector<Box> boxes = {{{0.31, 0.41}, 0.04, 0.12},
                                  {{0.92, 1.01}, 0.05, 0.20},
                                  {{1.05, 1.2}, 0.03, 0.3},
                                  {{1.7, 1.6}, 0.06, 0.18},
                                  {{1.95, 0.2}, 0.04, 0.1}};
  const SessionCloud cloud = BoxField(boxes, 7);
  const std::vector<io::Site> sites = {MakeSite(0.3, 0.4, 0.1),    MakeSite(0.91, 1.0, 0.35),
                                       MakeSite(1.1, 1.2, 0.15),   MakeSite(1.7, 1.6, 0.2),
                                       MakeSite(1.97, 0.18, 0.12), MakeSite(5.0, 5.0, 0.2)};
  CanopyOptions options;
  options.max_shrink_m = -1;
  const SessionCloud kept = SitePoints(cloud, sites, options);
  EXPECT_EQ(kept.session, cloud.session);
  ASSERT_EQ(kept.colors.size(), kept.points.size());
  ASSERT_EQ(kept.is_vegetation.size(), kept.points.size());
  EXPECT_LT(kept.points.size(), cloud.points.size() / 2);
  // Every point within a site's reach is kept, and only those.
  std::size_t within = 0;
  for (const Eigen::Vector3d& p : cloud.points) {
    for (const io::Site& s : sites) {
      if ((p.head<2>() - s.center_enu).cwiseAbs().maxCoeff() <= SiteReach(s, options)) {
        ++within;
        break;
      }
    }
  }
  EXPECT_EQ(kept.points.size(), within);
  const std::vector<Eigen::Vector2d> stems = {
      {0.31, 0.41}, {0.92, 1.01}, {1.05, 1.2}, {1.7, 1.6}, {1.95, 0.2}};
  for (const CanopyTop top : {CanopyTop::kPlantTops, CanopyTop::kCrownPeaks}) {
    options.top = top;
    for (const io::Site& site : sites) {
      SCOPED_TRACE(site.center_enu.transpose());
      const SiteCanopy whole = MeasureSite(cloud, Truth(), site, options, &stems);
      const SiteCanopy part = MeasureSite(kept, Truth(), site, options, &stems);
      EXPECT_EQ(part.n_cells, whole.n_cells);
      EXPECT_EQ(part.n_points, whole.n_points);
      EXPECT_EQ(part.n_peaks, whole.n_peaks);
      EXPECT_EQ(part.note, whole.note);
      EXPECT_TRUE(part.height_m == whole.height_m ||
                  (std::isnan(part.height_m) && std::isnan(whole.height_m)));
      EXPECT_TRUE(part.cover == whole.cover || (std::isnan(part.cover) && std::isnan(whole.cover)));
      const std::optional<GroundPlane> a =
          FitSiteGroundPlane(cloud.AsGround(), site.center_enu, site.radius_m, PlaneOptions{});
      const std::optional<GroundPlane> b =
          FitSiteGroundPlane(kept.AsGround(), site.center_enu, site.radius_m, PlaneOptions{});
      ASSERT_EQ(a.has_value(), b.has_value());
      if (a) {
        EXPECT_EQ(a->a, b->a);
        EXPECT_EQ(a->inliers, b->inliers);
      }
    }
  }
  EXPECT_TRUE(SitePoints(cloud, {}, options).points.empty());
}

TEST(MeasureSiteTest, LowGreenPointsAreNotCanopy) {
  // Green points 1 cm above the ground (moss, misclassified soil) stay below min_height_m.
  SessionCloud cloud = BoxField({}, 4);
  for (double x = 0.8; x < 1.0; x += 0.01) {
    cloud.points.emplace_back(x, 1.0, BedHeight(x, 1.0) + 0.01);
    cloud.colors.push_back({70, 100, 50});
    cloud.is_vegetation.push_back(1);
  }
  const SiteCanopy c = MeasureSite(cloud, Truth(), MakeSite(0.91, 1.0, 0.4), CanopyOptions{});
  EXPECT_EQ(c.n_canopy_cells, 0);
  EXPECT_TRUE(std::isnan(c.height_m));
}

TEST(CanopyHeightModelTest, BoxTopsGroundZeroAndUnknownNan) {
  const SessionCloud cloud = BoxField({{{1.0, 1.0}, 0.1, 0.3}}, 9);
  std::vector<float> truth_heights;
  GridSpec grid = GridSpec::Covering(
      Eigen::AlignedBox2d(Eigen::Vector2d(-0.5, -0.5), Eigen::Vector2d(2.5, 2.5)), 0.05);
  std::vector<float> dtm(grid.size());
  for (int j = 0; j < grid.height; ++j) {
    for (int i = 0; i < grid.width; ++i) {
      const Eigen::Vector2d q = grid.Node(i, j);
      dtm[j * grid.width + i] = static_cast<float>(BedHeight(q.x(), q.y()));
    }
  }
  const TerrainModel terrain(grid, dtm);
  const std::vector<float> chm = CanopyHeightModel(cloud, terrain, grid, CanopyOptions{});
  auto at = [&](double x, double y) {
    const int i = static_cast<int>(std::lround((x - grid.origin.x()) / grid.cell_m));
    const int j = static_cast<int>(std::lround((y - grid.origin.y()) / grid.cell_m));
    return chm[j * grid.width + i];
  };
  EXPECT_NEAR(at(1.0, 1.0), 0.3, 0.01);
  EXPECT_EQ(at(0.3, 0.3), 0.0f);
  EXPECT_TRUE(std::isnan(at(-0.4, -0.4)));
}

}  // namespace
}  // namespace crop4d::analysis
