#include "crop4d/slam/track_profile.h"

#include <gtest/gtest.h>

#include <stdexcept>

namespace crop4d::slam {
namespace {

// Cameras driven south (given in travel order) along x = 2 + 0.01·s, height 1.5 + 0.02·s, in a
// frame heading north from (2, 0).
TEST(TrackProfile, InterpolatesTheCameraWhereItPassedAPoint) {
  std::vector<Eigen::Vector3d> centres;
  for (int k = 10; k >= 0; --k) centres.emplace_back(2.0 + 0.01 * k, k, 1.5 + 0.02 * k);
  const TrackProfile track(centres, Eigen::Vector2d(2.0, 0.0), Eigen::Vector2d(0.0, 3.0));
  EXPECT_DOUBLE_EQ(track.min_s(), 0.0);
  EXPECT_DOUBLE_EQ(track.max_s(), 10.0);
  // Across = up × along: west is positive for a northward heading.
  const Eigen::Vector3d p(1.5, 4.25, 0.0);
  EXPECT_NEAR(track.Along(p), 4.25, 1e-12);
  EXPECT_NEAR(track.Across(p), 0.5, 1e-12);
  const TrackProfile::Position at = track.At(4.25);
  EXPECT_NEAR(at.l, -0.0425, 1e-12);
  EXPECT_NEAR(at.z, 1.585, 1e-12);
  EXPECT_NEAR(track.At(7.0).z, 1.64, 1e-12);  // on a camera
  // Beyond the ends: the end cameras.
  EXPECT_NEAR(track.At(-3.0).z, 1.5, 1e-12);
  EXPECT_NEAR(track.At(12.0).l, -0.1, 1e-12);
  // Point() inverts Along() and Across().
  const Eigen::Vector3d q = track.Point(track.Along(p), track.Across(p), 0.7);
  EXPECT_NEAR((q - Eigen::Vector3d(1.5, 4.25, 0.7)).norm(), 0.0, 1e-12);
}

TEST(TrackProfile, RejectsNoCameraOrNoDirection) {
  EXPECT_THROW(TrackProfile({}, Eigen::Vector2d::Zero(), Eigen::Vector2d::UnitX()),
               std::invalid_argument);
  EXPECT_THROW(
      TrackProfile({Eigen::Vector3d::Zero()}, Eigen::Vector2d::Zero(), Eigen::Vector2d::Zero()),
      std::invalid_argument);
}

}  // namespace
}  // namespace crop4d::slam
