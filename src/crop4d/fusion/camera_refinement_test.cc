#include "crop4d/fusion/camera_refinement.h"

#include <gtest/gtest.h>

#include <cmath>
#include <deque>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/camera_test_util.h"

namespace crop4d::fusion {
namespace {

// The mount of the tests' camera on the body.
geometry::Rigid3 TestMount() {
  return geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.1, -1.2, 0.3)),
                          Eigen::Vector3d(0.4, 0.0, 1.5));
}

// `n` passes of `camera` at TestMount().
std::vector<slam::RowOptimiser::Input> PassesOf(const geometry::PinholeRadTan& camera, int n) {
  std::vector<slam::RowOptimiser::Input> passes(n);
  for (slam::RowOptimiser::Input& pass : passes) {
    pass.camera = &camera;
    pass.body_from_camera = TestMount();
  }
  return passes;
}

TEST(CameraRefinement, PassesWithTheSameCalibrationShareOneCamera) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  geometry::PinholeRadTan other_lens = camera;
  other_lens.k2 += 1e-9;
  const geometry::Rigid3 mount = TestMount();
  std::vector<slam::RowOptimiser::Input> passes = PassesOf(camera, 5);
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

// Passes set apart (an incremental fuse's held session) never share a camera with the others,
// though their calibration is the same; among themselves they group as usual.
TEST(CameraRefinement, PassesSetApartGetCamerasOfTheirOwn) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  const std::vector<slam::RowOptimiser::Input> passes = PassesOf(camera, 4);
  const std::vector<RigCamera> cameras = GroupPassesByCamera(passes, {true, false, true, false});
  ASSERT_EQ(cameras.size(), 2u);
  EXPECT_EQ(cameras[0].passes, (std::vector<int>{0, 2}));
  EXPECT_EQ(cameras[1].passes, (std::vector<int>{1, 3}));
  EXPECT_TRUE(SameIntrinsics(cameras[1].camera, camera));
  EXPECT_EQ(GroupPassesByCamera(passes, {false, false, false, false}).size(), 1u);
  EXPECT_THROW(GroupPassesByCamera(passes, {true}), std::invalid_argument);
}

TEST(CameraRefinement, ASecondSolveHoldsTheCamerasTheFirstRefined) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  geometry::PinholeRadTan other = camera;
  other.fx += 5.0;
  const geometry::Rigid3 mount = TestMount();
  std::vector<slam::RowOptimiser::Input> passes = PassesOf(camera, 3);
  passes[2].camera = &other;  // another camera, not refined
  // The first solve (passes 0 and 1 alone) refined the camera.
  RefinedCalibration refined;
  refined.passes = {0, 1};
  refined.refined = true;
  refined.written_camera = camera;
  refined.written_body_from_camera = mount;
  refined.camera = camera;
  refined.camera.cx += 0.7;
  refined.body_from_camera = geometry::Rigid3(
      mount.rotation() * geometry::ExpQuat(Eigen::Vector3d(0.004, 0, 0)), mount.translation());
  refined.num_cross_observations = 5000;
  std::deque<geometry::PinholeRadTan> storage;
  // A pass kept (an incremental fuse's held pass) keeps its camera.
  std::vector<slam::RowOptimiser::Input> kept = passes;
  UseRefinedCalibrations({refined}, &kept, &storage, {false, true, false});
  EXPECT_NE(kept[0].camera, &camera);
  EXPECT_EQ(kept[1].camera, &camera);
  EXPECT_TRUE(kept[1].body_from_camera.rotation().isApprox(mount.rotation()));
  UseRefinedCalibrations({refined}, &passes, &storage);
  for (int p : {0, 1}) {
    ASSERT_NE(passes[p].camera, &camera);
    EXPECT_TRUE(SameIntrinsics(*passes[p].camera, refined.camera));
    EXPECT_TRUE(
        passes[p].body_from_camera.rotation().isApprox(refined.body_from_camera.rotation()));
  }
  EXPECT_EQ(passes[2].camera, &other);
  EXPECT_TRUE(passes[2].body_from_camera.rotation().isApprox(mount.rotation()));

  // The second solve held both cameras as given: the refined one is reported as refined from
  // what was written, the other as it was.
  RefinedCalibration held_refined;
  held_refined.passes = {0, 1};
  held_refined.written_camera = held_refined.camera = *passes[0].camera;
  held_refined.written_body_from_camera = held_refined.body_from_camera =
      passes[0].body_from_camera;
  held_refined.num_cross_observations = 6000;
  RefinedCalibration held_other;
  held_other.passes = {2};
  held_other.written_camera = held_other.camera = other;
  held_other.written_body_from_camera = held_other.body_from_camera = mount;
  std::vector<RefinedCalibration> second = {held_refined, held_other};
  ReportRefinedCalibrations({refined}, &second);
  EXPECT_TRUE(second[0].refined);
  EXPECT_TRUE(SameIntrinsics(second[0].written_camera, camera));
  EXPECT_TRUE(SameIntrinsics(second[0].camera, refined.camera));
  EXPECT_NEAR(second[0].RotationChangeDeg(), 0.004 * 180.0 / M_PI, 1e-9);
  EXPECT_EQ(second[0].num_cross_observations, 6000);
  EXPECT_FALSE(second[1].refined);
  EXPECT_TRUE(SameIntrinsics(second[1].written_camera, other));
}

TEST(CameraRefinement, RayAnglesMeasureHowFarACalibrationTurnsTheRays) {
  const geometry::PinholeRadTan camera = slam::testing::DistortedTestCamera();
  const geometry::Rigid3 mount = TestMount();
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
