// A site through the season on hand-built clouds: the stems of the earliest trusted session, the
// next session's tops bounding a floating point, and the paper's plane beside our ground.

#include "crop4d/analysis/site_series.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "crop4d/analysis/analysis_test_util.h"

namespace crop4d::analysis {
namespace {

using testing_util::BedHeight;

// Soil over [0, 2]² (not under the plants) and green square plants of half side 4 cm standing
// `height` above the ground at `stems`.
SessionCloud Plants(const std::vector<Eigen::Vector2d>& stems, double height, std::uint64_t seed) {
  SessionCloud cloud;
  std::mt19937_64 rng(seed);
  std::vector<Eigen::Vector3d> soil;
  std::vector<std::uint8_t> flags;
  testing_util::SampleGround(Eigen::AlignedBox2d(Eigen::Vector2d(0, 0), Eigen::Vector2d(2, 2)),
                             8000, 0.002, &rng, &soil, &flags);
  const auto on_plant = [&](const Eigen::Vector2d& xy) {
    for (const Eigen::Vector2d& s : stems) {
      if ((xy - s).cwiseAbs().maxCoeff() <= 0.04) return true;
    }
    return false;
  };
  for (const Eigen::Vector3d& p : soil) {
    if (on_plant(p.head<2>())) continue;
    cloud.points.push_back(p);
    cloud.colors.push_back({150, 126, 104});
    cloud.is_vegetation.push_back(0);
  }
  for (const Eigen::Vector2d& s : stems) {
    for (double dx = -0.0375; dx < 0.04; dx += 0.005) {
      for (double dy = -0.0375; dy < 0.04; dy += 0.005) {
        const double x = s.x() + dx, y = s.y() + dy;
        cloud.points.emplace_back(x, y, BedHeight(x, y) + height);
        cloud.colors.push_back({70, 100, 50});
        cloud.is_vegetation.push_back(1);
      }
    }
  }
  return cloud;
}

std::vector<DetectedPlant> Found(const std::vector<Eigen::Vector2d>& stems) {
  std::vector<DetectedPlant> out;
  for (const Eigen::Vector2d& s : stems) out.push_back({s, 0.0, 0.0});
  return out;
}

class SiteSeriesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    site_.id = "site";
    site_.center_enu = {1.0, 1.0};
    site_.radius_m = 0.4;
    clouds_ = {Plants(young_, 0.10, 1), Plants(young_, 0.30, 2)};
    // A false match floating 60 cm above the first plant in the first session.
    const Eigen::Vector2d& s = young_[0];
    clouds_[0].points.emplace_back(s.x(), s.y(), BedHeight(s.x(), s.y()) + 0.60);
    clouds_[0].colors.push_back({70, 100, 50});
    clouds_[0].is_vegetation.push_back(1);
    // The first session finds the two young plants (and one outside the site); the second also
    // a leaf cluster of a grown plant, which must not become a plant.
    found_ = {Found({young_[0], young_[1], {1.8, 1.8}}), Found({young_[0], young_[1], {1.0, 1.2}})};
  }

  SiteSeries Measure(const std::vector<bool>& trusted, const CanopyOptions& canopy) const {
    const GroundFunction truth = [](double x, double y) { return BedHeight(x, y); };
    return MeasureSiteSeries(clouds_, trusted, found_, truth, site_, canopy, PlaneOptions{});
  }

  io::Site site_;
  std::vector<Eigen::Vector2d> young_ = {{0.91, 0.91}, {0.91, 1.11}};
  std::vector<SessionCloud> clouds_;
  std::vector<std::vector<DetectedPlant>> found_;
};

TEST_F(SiteSeriesTest, StemsFromTheEarliestSessionAndTopsBoundedByTheNext) {
  const SiteSeries s = Measure({true, true}, CanopyOptions{});
  ASSERT_EQ(s.stems.size(), 2u);
  EXPECT_EQ(s.stems[0], young_[0]);
  EXPECT_EQ(s.stems[1], young_[1]);
  ASSERT_EQ(s.ours.size(), 2u);
  ASSERT_EQ(s.ours[0].plant_tops.size(), 2u);
  // The floating point is above the next session's top + max_shrink_m (0.30 + 0.05): left out.
  EXPECT_NEAR(s.ours[0].plant_tops[0], 0.10, 0.005);
  EXPECT_EQ(s.ours[0].n_lowered, 1);
  EXPECT_NEAR(s.ours[0].height_m, 0.10, 0.005);
  EXPECT_NEAR(s.ours[1].height_m, 0.30, 0.005);
  EXPECT_EQ(s.ours[1].n_lowered, 0);
  // The paper's plane: the site's soil of the first session; heights within a centimetre.
  ASSERT_EQ(s.single_plane.size(), 2u);
  EXPECT_TRUE(s.single_plane[0].note.empty()) << s.single_plane[0].note;
  EXPECT_NEAR(s.single_plane[1].height_m, 0.30, 0.01);
}

TEST_F(SiteSeriesTest, WithoutTheBoundTheFloatingPointIsTheTop) {
  CanopyOptions unbounded;
  unbounded.max_shrink_m = -1;
  EXPECT_NEAR(Measure({true, true}, unbounded).ours[0].plant_tops[0], 0.60, 0.005);
}

TEST_F(SiteSeriesTest, AnUntrustedSessionSetsNeitherStemsNorBounds) {
  // The first session untrusted: the stems come from the second (with its leaf cluster).
  const SiteSeries late = Measure({false, true}, CanopyOptions{});
  EXPECT_EQ(late.stems.size(), 3u);
  // The second untrusted: no bound on the first session's tops.
  const SiteSeries early = Measure({true, false}, CanopyOptions{});
  ASSERT_EQ(early.stems.size(), 2u);
  EXPECT_NEAR(early.ours[0].plant_tops[0], 0.60, 0.005);
  EXPECT_EQ(early.ours[0].n_lowered, 0);
}

TEST_F(SiteSeriesTest, NoSoilAtTheSiteMeansNoPlane) {
  site_.center_enu = {5.0, 5.0};  // outside every cloud
  const SiteSeries s = Measure({true, true}, CanopyOptions{});
  EXPECT_TRUE(s.stems.empty());
  EXPECT_EQ(s.single_plane[0].note, "no ground plane at the site");
  EXPECT_TRUE(std::isnan(s.ours[0].height_m));
}

}  // namespace
}  // namespace crop4d::analysis
