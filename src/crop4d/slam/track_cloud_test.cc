#include "crop4d/slam/track_cloud.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "crop4d/slam/camera_test_util.h"

namespace crop4d::slam {
namespace {

// Cameras along x looking along +y (z forward), 0.5 m apart.
std::vector<geometry::Rigid3> Cameras(int n) {
  Eigen::Matrix3d world_from_camera;
  world_from_camera << 1, 0, 0, 0, 0, 1, 0, -1, 0;  // camera x→x, y→−z, z→y
  std::vector<geometry::Rigid3> cameras;
  for (int k = 0; k < n; ++k) {
    cameras.emplace_back(Eigen::Quaterniond(world_from_camera), Eigen::Vector3d(0.5 * k, 0, 0));
  }
  return cameras;
}

LandmarkTrack Observe(const geometry::PinholeRadTan& camera,
                      const std::vector<geometry::Rigid3>& cameras, const Eigen::Vector3d& point,
                      const std::vector<int>& images, std::array<std::uint8_t, 3> color) {
  LandmarkTrack track;
  for (int k : images) {
    Eigen::Vector2d pixel;
    EXPECT_TRUE(camera.Project(cameras[k].Inverse() * point, &pixel));
    track.observations.push_back({k, pixel});
  }
  track.color = color;
  return track;
}

TEST(TrackCloudTest, TriangulatedTracksKeepTheirColourLengthAndIndex) {
  const geometry::PinholeRadTan camera = testing::DistortedTestCamera();
  const std::vector<geometry::Rigid3> cameras = Cameras(4);
  const Eigen::Vector3d p0(0.6, 4.0, 0.3), p2(1.1, 3.0, -0.4);
  std::vector<LandmarkTrack> tracks;
  tracks.push_back(Observe(camera, cameras, p0, {0, 1, 3}, {10, 20, 30}));
  // One view only: no point.
  tracks.push_back(Observe(camera, cameras, p0, {2}, {1, 2, 3}));
  tracks.push_back(Observe(camera, cameras, p2, {1, 2}, {200, 100, 50}));
  // A pixel 30 px off in one of its views: fails the reprojection bound.
  LandmarkTrack wrong = Observe(camera, cameras, p2, {0, 1, 2}, {0, 0, 0});
  wrong.observations[1].pixel.x() += 30;
  tracks.push_back(wrong);

  const TrackCloud cloud = TriangulateTrackCloud(camera, cameras, tracks, {});
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.track_indices, (std::vector<int>{0, 2}));
  EXPECT_LT((cloud.points_world[0] - p0).norm(), 1e-6);
  EXPECT_LT((cloud.points_world[1] - p2).norm(), 1e-6);
  EXPECT_EQ(cloud.colors[1], (std::array<std::uint8_t, 3>{200, 100, 50}));
  EXPECT_EQ(cloud.track_lengths, (std::vector<int>{3, 2}));
  EXPECT_LT(cloud.reprojection_errors_px[0], 1e-3);

  const std::vector<TriangulationResult> all = TriangulateTracks(camera, cameras, tracks, {});
  ASSERT_EQ(all.size(), tracks.size());
  EXPECT_EQ(all[1].status, TriangulationStatus::kTooFewViews);
  EXPECT_EQ(all[3].status, TriangulationStatus::kLargeError);
}

}  // namespace
}  // namespace crop4d::slam
