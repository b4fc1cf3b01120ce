#include "crop4d/association/footprint.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/association/association_test_util.h"

namespace crop4d::association {
namespace {

using testing::DemoCamera;
using testing::ForwardLookingPose;
using testing::kDegree;

bool Contains(const Footprint& footprint, const Eigen::Vector2d& point) {
  const auto& p = footprint.polygon;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const Eigen::Vector2d edge = p[(i + 1) % p.size()] - p[i];
    const Eigen::Vector2d to_point = point - p[i];
    if (edge.x() * to_point.y() - edge.y() * to_point.x() < 0) return false;  // right of a CCW edge
  }
  return true;
}

TEST(GroundFootprintTest, DemoCameraSeesTheGroundAheadUpToTheRange) {
  const geometry::PinholeRadTan camera = DemoCamera();
  const geometry::Rigid3 pose = ForwardLookingPose({10, 20, 1.5}, 90 * kDegree);
  FootprintOptions options;
  options.max_range_m = 6.0;
  const Footprint footprint = GroundFootprint(camera, pose, 0.0, options);
  ASSERT_FALSE(footprint.empty());
  ASSERT_GE(footprint.polygon.size(), 3u);
  // Counter-clockwise with a positive area, every vertex within the range.
  for (const Eigen::Vector2d& v : footprint.polygon) {
    EXPECT_LE((v - Eigen::Vector2d(10, 20)).norm(), 6.0 + 1e-6);
    EXPECT_TRUE(footprint.bounds.contains(v));
  }
  // The ground seen at the image centre (1.5 m / tan 35° ahead) is inside; the ground behind the
  // camera and beyond the range is not. The bottom of the image sees 0.4 m ahead.
  EXPECT_TRUE(Contains(footprint, {10, 20 + 1.5 / std::tan(35 * kDegree)}));
  EXPECT_TRUE(Contains(footprint, {10, 20.6}));
  EXPECT_FALSE(Contains(footprint, {10, 20.2}));
  EXPECT_FALSE(Contains(footprint, {10, 19}));
  EXPECT_FALSE(Contains(footprint, {10, 26.5}));
  // The horizon is in view, so the far edge is the range arc, seen over the horizontal field of
  // view (97° at the centre row, more at the horizon with the barrel distortion): the area is
  // close to that of a sector of radius 6 m.
  int on_arc = 0;
  for (const Eigen::Vector2d& v : footprint.polygon) {
    on_arc += std::abs((v - Eigen::Vector2d(10, 20)).norm() - 6.0) < 1e-4;
  }
  EXPECT_GT(on_arc, 10);
  EXPECT_GT(footprint.area_m2, 0.5 * 6.0 * 6.0 * 90 * kDegree);
  EXPECT_LT(footprint.area_m2, 0.5 * 6.0 * 6.0 * 130 * kDegree);

  // Under the ground or looking at the sky: no footprint.
  EXPECT_TRUE(GroundFootprint(camera, pose, 2.0, options).empty());
  const geometry::Rigid3 up = ForwardLookingPose({10, 20, 1.5}, 90 * kDegree, -80 * kDegree);
  EXPECT_TRUE(GroundFootprint(camera, up, 0.0, options).empty());
}

TEST(GroundFootprintTest, OverlapOfIdenticalAdjacentAndDisjointViews) {
  const geometry::PinholeRadTan camera = DemoCamera();
  const geometry::Rigid3 pose = ForwardLookingPose({10, 20, 1.5}, 90 * kDegree);
  const Footprint a = GroundFootprint(camera, pose, 0.0);
  EXPECT_NEAR(FootprintOverlap(a, a), 1.0, 1e-6);

  // The next row (0.76 m to the side), and a bit further along it.
  const Footprint side =
      GroundFootprint(camera, ForwardLookingPose({10.76, 20, 1.5}, 90 * kDegree), 0.0);
  const Footprint ahead =
      GroundFootprint(camera, ForwardLookingPose({10.76, 22, 1.5}, 90 * kDegree), 0.0);
  const double overlap_side = FootprintOverlap(a, side);
  const double overlap_ahead = FootprintOverlap(a, ahead);
  EXPECT_GT(overlap_side, 0.5);
  EXPECT_LT(overlap_side, 1.0);
  EXPECT_GT(overlap_ahead, 0.0);
  EXPECT_LT(overlap_ahead, overlap_side);
  EXPECT_NEAR(FootprintOverlap(side, a), overlap_side, 1e-6);  // symmetric

  // Far away, or an empty footprint: no overlap.
  const Footprint far =
      GroundFootprint(camera, ForwardLookingPose({60, 20, 1.5}, 90 * kDegree), 0.0);
  EXPECT_EQ(FootprintOverlap(a, far), 0.0);
  EXPECT_EQ(FootprintOverlap(a, Footprint()), 0.0);

  // A lower camera with the same view sees a smaller footprint nested in a's: overlap 1 (the
  // measure is relative to the smaller one).
  const Footprint nested = GroundFootprint(
      camera, ForwardLookingPose({10, 20 + 0.5 / std::tan(35 * kDegree), 1.0}, 90 * kDegree), 0.0,
      FootprintOptions{.max_range_m = 3.0});
  EXPECT_GT(FootprintOverlap(a, nested), 0.95);
}

// Two passes along neighbouring rows, 0.76 m apart, images every 0.3 m with different phases.
struct TwoRows {
  std::vector<geometry::Rigid3> a, b;
};
TwoRows MakeTwoRows(double heading_b_deg) {
  TwoRows rows;
  for (int i = 0; i < 60; ++i) {
    rows.a.push_back(ForwardLookingPose({0, 0.3 * i, 1.5}, 90 * kDegree));
  }
  for (int j = 0; j < 70; ++j) {
    rows.b.push_back(
        ForwardLookingPose({0.76, -1.0 + 0.3 * j + 0.12, 1.5}, heading_b_deg * kDegree));
  }
  return rows;
}

TEST(SelectImagePairsTest, PicksTheTrueNeighbour) {
  const geometry::PinholeRadTan camera = DemoCamera();
  const TwoRows rows = MakeTwoRows(90);
  PairSelectionOptions options;
  options.min_overlap = 0.3;
  options.max_pairs_per_image = 1;
  const std::vector<ImagePair> pairs =
      SelectImagePairs(rows.a, rows.b, camera, camera, 0.0, options);
  ASSERT_EQ(pairs.size(), rows.a.size());
  for (const ImagePair& pair : pairs) {
    // b_j is at y = 0.3 j − 0.88: the nearest along the row to a_i (y = 0.3 i) is j = i + 3.
    EXPECT_EQ(pair.image_b, pair.image_a + 3) << pair.image_a;
    EXPECT_GT(pair.overlap, 0.8);
    EXPECT_LE(pair.overlap, 1.0);
  }

  // Two per image, sorted by overlap, every other image of a.
  options.max_pairs_per_image = 2;
  options.stride = 2;
  const std::vector<ImagePair> two = SelectImagePairs(rows.a, rows.b, camera, camera, 0.0, options);
  ASSERT_EQ(two.size(), 2 * ((rows.a.size() + 1) / 2));
  for (std::size_t k = 0; k < two.size(); k += 2) {
    EXPECT_EQ(two[k].image_a % 2, 0);
    EXPECT_EQ(two[k].image_a, two[k + 1].image_a);
    EXPECT_EQ(two[k].image_b, two[k].image_a + 3);
    EXPECT_GE(two[k].overlap, two[k + 1].overlap);
    EXPECT_EQ(std::abs(two[k + 1].image_b - two[k].image_b), 1);
  }

  // A strict overlap keeps nothing that does not reach it.
  options.min_overlap = 0.999;
  for (const ImagePair& pair : SelectImagePairs(rows.a, rows.b, camera, camera, 0.0, options)) {
    EXPECT_GE(pair.overlap, 0.999);
  }
}

TEST(SelectImagePairsTest, DisjointPassesGiveNoPairs) {
  const geometry::PinholeRadTan camera = DemoCamera();
  TwoRows rows = MakeTwoRows(90);
  for (geometry::Rigid3& pose : rows.b) {
    pose = geometry::Rigid3(pose.rotation(), pose.translation() + Eigen::Vector3d(30, 0, 0));
  }
  EXPECT_TRUE(SelectImagePairs(rows.a, rows.b, camera, camera, 0.0).empty());
  EXPECT_TRUE(SelectImagePairs(rows.a, {}, camera, camera, 0.0).empty());
}

TEST(SelectImagePairsTest, OppositeDirectionsCanBeExcluded) {
  const geometry::PinholeRadTan camera = DemoCamera();
  // Pass b drives the neighbouring row the other way (boustrophedon).
  const TwoRows rows = MakeTwoRows(-90);
  PairSelectionOptions options;
  const std::vector<ImagePair> pairs =
      SelectImagePairs(rows.a, rows.b, camera, camera, 0.0, options);
  ASSERT_FALSE(pairs.empty());
  // Facing each other, the cameras see the same ground only when b is ahead of a.
  for (const ImagePair& pair : pairs) {
    EXPECT_GT(rows.b[pair.image_b].translation().y(), rows.a[pair.image_a].translation().y());
  }
  options.max_axis_angle_deg = 90;
  EXPECT_TRUE(SelectImagePairs(rows.a, rows.b, camera, camera, 0.0, options).empty());
}

// Adjacent rows of the demo field (0.91 m apart) driven back and forth: the cameras face each
// other. The footprint overlap is largest when they are as far apart as the footprint range
// allows (the ground near either camera is then tiny in the other image); the view overlap picks
// cameras about 2 m apart, which see the ground between them at the same scale.
TEST(SelectImagePairsTest, FacingCamerasArePairedAtAComparableScale) {
  const geometry::PinholeRadTan camera = DemoCamera();
  std::vector<geometry::Rigid3> a, b;
  for (int i = 0; i < 40; ++i) a.push_back(ForwardLookingPose({0, 0.2 * i, 1.5}, 90 * kDegree));
  for (int j = 0; j < 100; ++j) {
    b.push_back(ForwardLookingPose({0.91, -2.0 + 0.2 * j, 1.5}, -90 * kDegree));
  }
  PairSelectionOptions options;
  const std::vector<ImagePair> by_view = SelectImagePairs(a, b, camera, camera, 0.0, options);
  ASSERT_EQ(by_view.size(), a.size());
  for (const ImagePair& pair : by_view) {
    const double ahead = b[pair.image_b].translation().y() - a[pair.image_a].translation().y();
    EXPECT_GT(ahead, 1.5) << pair.image_a;
    EXPECT_LT(ahead, 3.0) << pair.image_a;
    EXPECT_GE(pair.overlap, options.min_overlap);
    EXPECT_NEAR(pair.overlap, ViewOverlap(camera, a[pair.image_a], camera, b[pair.image_b], 0.0),
                1e-12);
  }
  options.max_scale_change = 0;  // by footprint area
  const std::vector<ImagePair> by_area = SelectImagePairs(a, b, camera, camera, 0.0, options);
  ASSERT_FALSE(by_area.empty());
  for (const ImagePair& pair : by_area) {
    EXPECT_GT(b[pair.image_b].translation().y() - a[pair.image_a].translation().y(), 5.0);
  }
}

TEST(ViewOverlapTest, SameViewSideViewAndScaleLimit) {
  const geometry::PinholeRadTan camera = DemoCamera();
  const geometry::Rigid3 a = ForwardLookingPose({10, 20, 1.5}, 90 * kDegree);
  EXPECT_NEAR(ViewOverlap(camera, a, camera, a, 0.0), 1.0, 1e-12);
  // The neighbouring row, same direction: most of the view is shared, symmetrically.
  const geometry::Rigid3 side = ForwardLookingPose({10.91, 20, 1.5}, 90 * kDegree);
  const double overlap_side = ViewOverlap(camera, a, camera, side, 0.0);
  EXPECT_GT(overlap_side, 0.5);
  EXPECT_LT(overlap_side, 1.0);
  EXPECT_NEAR(ViewOverlap(camera, side, camera, a, 0.0), overlap_side, 1e-12);
  // 3 m behind: b sees all of a's ground, a little of b's; the smaller share counts.
  const geometry::Rigid3 behind = ForwardLookingPose({10, 17, 1.5}, 90 * kDegree);
  EXPECT_LT(ViewOverlap(camera, a, camera, behind, 0.0), 0.5);
  // Without the scale condition more ground is shared.
  PairSelectionOptions no_scale;
  no_scale.max_scale_change = 0;
  EXPECT_GT(ViewOverlap(camera, a, camera, behind, 0.0, no_scale),
            ViewOverlap(camera, a, camera, behind, 0.0));
  // No common ground, or no ground at all.
  const geometry::Rigid3 away = ForwardLookingPose({10, 10, 1.5}, -90 * kDegree);
  EXPECT_EQ(ViewOverlap(camera, a, camera, away, 0.0), 0.0);
  EXPECT_EQ(ViewOverlap(camera, a, camera, a, 2.0), 0.0);
}

}  // namespace
}  // namespace crop4d::association
