#include "crop4d/fusion/camera_refinement.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/camera_test_util.h"

namespace crop4d::fusion {
namespace {

TEST(CameraRefinement, PassesWithTheSameCalibrationShareOneCamera) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  geometry::PinholeRadTan other_lens = camera;
  other_lens.k2 += 1e-9;
  const geometry::Rigid3 mount(geometry::ExpQuat(Eigen::Vector3d(0.1, -1.2, 0.3)),
                               Eigen::Vector3d(0.4, 0.0, 1.5));
  std::vector<slam::RowOptimiser::Input> passes(5);
  for (slam::RowOptimiser::Input& pass : passes) {
    pass.camera = &camera;
    pass.body_from_camera = mount;
  }
  passes[1].camera = &other_lens;
  passes[2].camera = nullptr;  // no camera: in no group
  passes[4].body_from_camera = geometry::Rigid3(mount.rotation(), Eigen::Vector3d(0.4, 0.0, 1.6));
  const std::vector<RigCamera> cameras = GroupPassesByCamera(passes);
  ASSERT_EQ(cameras.size(), 3u);
  EXPECT_EQ(cameras[0].passes, (std::vector<int>{0, 3}));
  EXPECT_EQ(cameras[1].passes, (std::vector<int>{1}));
  EXPECT_EQ(cameras[2].passes, (std::vector<int>{4}));
  EXPECT_EQ(cameras[1].camera.k2, other_lens.k2);
  EXPECT_TRUE(SameIntrinsics(cameras[0].camera, camera));
  EXPECT_FALSE(SameIntrinsics(cameras[1].camera, camera));
}

TEST(CameraRefinement, RayAnglesMeasureHowFarACalibrationTurnsTheRays) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  const geometry::Rigid3 mount(geometry::ExpQuat(Eigen::Vector3d(0.1, -1.2, 0.3)),
                               Eigen::Vector3d(0.4, 0.0, 1.5));
  EXPECT_EQ(RayAngleRmsDeg(camera, mount, camera, mount), 0.0);
  // The mount turned by 0.5° about the optical axis's normal (camera x): every ray turns by
  // 0.5° times the sine of its angle to that axis, so a little less than 0.5° on average.
  const double angle = 0.5 * M_PI / 180.0;
  const geometry::Rigid3 turned(mount.rotation() * geometry::ExpQuat(Eigen::Vector3d(angle, 0, 0)),
                                mount.translation() + Eigen::Vector3d(1, 2, 3));
  const double turned_deg = RayAngleRmsDeg(camera, mount, camera, turned);
  EXPECT_GT(turned_deg, 0.45);
  EXPECT_LE(turned_deg, 0.5 + 1e-9);
  // The principal point moved by f tan(0.2°) to the right: rays near the centre turn by 0.2°.
  geometry::PinholeRadTan shifted = camera;
  shifted.cx += camera.fx * std::tan(0.2 * M_PI / 180.0);
  const double shifted_deg = RayAngleRmsDeg(camera, mount, shifted, mount);
  EXPECT_GT(shifted_deg, 0.1);
  EXPECT_LT(shifted_deg, 0.2);
}

TEST(CameraRefinement, OptionChecksNameTheOption) {
  EXPECT_EQ(CalibrationRefinementOptions().Check(), "");
  CalibrationRefinementOptions o;
  o.min_cross_observations = -1;
  EXPECT_EQ(o.Check(), "min_cross_observations: must be >= 0 (got -1)");
  o = CalibrationRefinementOptions();
  o.focal_sigma_px = 0;
  EXPECT_EQ(o.Check(), "focal_sigma_px: must be > 0 (got 0)");
}

}  // namespace
}  // namespace crop4d::fusion
