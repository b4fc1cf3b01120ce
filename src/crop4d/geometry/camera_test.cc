#include "crop4d/geometry/camera.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <vector>

namespace crop4d::geometry {
namespace {

// A realistic wide-angle camera (the distortion the issue asks for).
PinholeRadTan TestCamera() {
  PinholeRadTan camera;
  camera.width = 1280;
  camera.height = 960;
  camera.fx = 905.3;
  camera.fy = 903.1;
  camera.cx = 640.2;
  camera.cy = 480.7;
  camera.k1 = -0.28;
  camera.k2 = 0.07;
  camera.p1 = 1e-4;
  camera.p2 = -2e-4;
  return camera;
}

TEST(CameraTest, CheckAcceptsValidAndRejectsBadIntrinsics) {
  EXPECT_EQ(TestCamera().Check(), "");
  auto with = [](auto modify) {
    PinholeRadTan camera = TestCamera();
    modify(camera);
    return camera.Check();
  };
  EXPECT_NE(with([](PinholeRadTan& c) { c.width = 0; }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.height = -5; }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.fx = 0.0; }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.fy = -900.0; }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.k1 = std::numeric_limits<double>::quiet_NaN(); }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.cx = std::numeric_limits<double>::infinity(); }), "");
  EXPECT_NE(with([](PinholeRadTan& c) { c.p2 = std::numeric_limits<double>::infinity(); }), "");
  EXPECT_NE(PinholeRadTan().Check(), "");
}

TEST(CameraTest, IntrinsicMatrix) {
  const PinholeRadTan camera = TestCamera();
  Eigen::Matrix3d expected;
  expected << 905.3, 0.0, 640.2, 0.0, 903.1, 480.7, 0.0, 0.0, 1.0;
  EXPECT_EQ(camera.K(), expected);
}

TEST(CameraTest, DistortMatchesHandComputedValues) {
  // Values worked out from the OpenCV formula in decimal arithmetic, e.g. for (0.3, −0.2):
  // r² = 0.13, radial = 1 − 0.28·0.13 + 0.07·0.0169 = 0.964783,
  // xd = 0.2894349 + 2e-4·0.3·(−0.2) − 2e-4·(0.13 + 0.18) = 0.2893609,
  // yd = −0.1929566 + 1e-4·(0.13 + 0.08) + 2·(−2e-4)·0.3·(−0.2) = −0.1929116.
  const PinholeRadTan camera = TestCamera();
  EXPECT_LT((camera.Distort({0.3, -0.2}) - Eigen::Vector2d(0.2893609, -0.1929116)).norm(), 1e-15);
  EXPECT_LT(
      (camera.Distort({-0.55, 0.41}) - Eigen::Vector2d(-0.48631419786, 0.362502027132)).norm(),
      1e-15);
  EXPECT_EQ(camera.Distort(Eigen::Vector2d::Zero()), Eigen::Vector2d::Zero());
}

TEST(CameraTest, ProjectMatchesOpenCv) {
  PinholeRadTan camera = TestCamera();
  camera.k3 = 0.01;
  const cv::Matx33d K(camera.fx, 0.0, camera.cx, 0.0, camera.fy, camera.cy, 0.0, 0.0, 1.0);
  const std::vector<double> dist = {camera.k1, camera.k2, camera.p1, camera.p2, camera.k3};
  const std::vector<cv::Point3d> points = {
      {0.3, -0.2, 1.0}, {-2.0, 1.5, 4.0}, {0.01, 0.02, 10.0}, {3.0, 2.5, 5.0}, {0.0, 0.0, 2.0}};
  std::vector<cv::Point2d> cv_pixels;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, cv_pixels);
  for (size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector2d pixel;
    ASSERT_TRUE(camera.Project({points[i].x, points[i].y, points[i].z}, &pixel));
    EXPECT_NEAR(pixel.x(), cv_pixels[i].x, 1e-9);
    EXPECT_NEAR(pixel.y(), cv_pixels[i].y, 1e-9);
  }
}

TEST(CameraTest, DistortJacobianMatchesNumericalDifferentiation) {
  PinholeRadTan camera = TestCamera();
  for (const double k3 : {0.0, 0.02}) {
    camera.k3 = k3;
    for (const Eigen::Vector2d& xy :
         {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(0.3, -0.2), Eigen::Vector2d(-0.7, 0.55),
          Eigen::Vector2d(1.1, 0.8), Eigen::Vector2d(-0.05, -0.9)}) {
      // Central differences (Nocedal & Wright, "Numerical Optimization", eq. 8.7).
      const double h = 1e-6;
      Eigen::Matrix2d numerical;
      for (int j = 0; j < 2; ++j) {
        const Eigen::Vector2d d = h * Eigen::Vector2d::Unit(j);
        numerical.col(j) = (camera.Distort(xy + d) - camera.Distort(xy - d)) / (2.0 * h);
      }
      EXPECT_LT((camera.DistortJacobian(xy) - numerical).norm(), 1e-8) << xy.transpose();
    }
  }
}

TEST(CameraTest, UndistortInvertsDistort) {
  const PinholeRadTan camera = TestCamera();
  for (int i = -8; i <= 8; ++i) {
    for (int j = -8; j <= 8; ++j) {
      const Eigen::Vector2d xy(0.125 * i, 0.1 * j);
      Eigen::Vector2d back;
      ASSERT_TRUE(camera.Undistort(camera.Distort(xy), &back)) << xy.transpose();
      EXPECT_LT((back - xy).norm(), 1e-12) << xy.transpose();
    }
  }
}

TEST(CameraTest, UnprojectThenProjectOverImageGrid) {
  const PinholeRadTan camera = TestCamera();
  int count = 0;
  for (int v = 0; v <= camera.height; v += 40) {
    for (int u = 0; u <= camera.width; u += 40) {
      const Eigen::Vector2d pixel(std::min(u, camera.width - 1), std::min(v, camera.height - 1));
      Eigen::Vector3d ray;
      ASSERT_TRUE(camera.Unproject(pixel, &ray)) << pixel.transpose();
      EXPECT_EQ(ray.z(), 1.0);
      for (const double depth : {0.5, 1.0, 30.0}) {
        Eigen::Vector2d reprojected;
        ASSERT_TRUE(camera.Project(depth * ray, &reprojected));
        EXPECT_LT((reprojected - pixel).norm(), 1e-6) << pixel.transpose();
      }
      ++count;
    }
  }
  EXPECT_EQ(count, 25 * 33);
}

TEST(CameraTest, ProjectThenUnprojectRecoversTheRay) {
  const PinholeRadTan camera = TestCamera();
  const Eigen::Vector3d point(-1.2, 0.8, 3.0);
  Eigen::Vector2d pixel;
  ASSERT_TRUE(camera.Project(point, &pixel));
  EXPECT_TRUE(camera.IsInImage(pixel));
  Eigen::Vector3d ray;
  ASSERT_TRUE(camera.Unproject(pixel, &ray));
  EXPECT_LT((ray - point / point.z()).norm(), 1e-12);
  // The optical axis lands on the principal point.
  ASSERT_TRUE(camera.Project({0.0, 0.0, 7.0}, &pixel));
  EXPECT_LT((pixel - Eigen::Vector2d(camera.cx, camera.cy)).norm(), 1e-12);
}

TEST(CameraTest, ProjectRejectsPointsBehindTheCamera) {
  const PinholeRadTan camera = TestCamera();
  Eigen::Vector2d pixel;
  EXPECT_FALSE(camera.Project({0.1, 0.2, -1.0}, &pixel));
  EXPECT_FALSE(camera.Project({0.1, 0.2, 0.0}, &pixel));
  EXPECT_FALSE(camera.Project({0.1, std::numeric_limits<double>::quiet_NaN(), 1.0}, &pixel));
  EXPECT_TRUE(camera.Project({0.1, 0.2, 1e-3}, &pixel));
}

TEST(CameraTest, UndistortFailsPastTheFoldOfABarrelLens) {
  // With k1 = −0.28 and no other terms, r (1 + k1 r²) peaks at 0.727 for r = 1.09: no
  // undistorted point maps to a distorted radius of 0.9.
  PinholeRadTan camera = TestCamera();
  camera.k2 = camera.p1 = camera.p2 = 0.0;
  Eigen::Vector2d xy;
  EXPECT_FALSE(camera.Undistort({0.9, 0.0}, &xy));
  EXPECT_FALSE(camera.Undistort({0.0, -1.5}, &xy));
  EXPECT_TRUE(camera.Undistort({0.6, 0.0}, &xy));
  EXPECT_FALSE(camera.Undistort({std::numeric_limits<double>::quiet_NaN(), 0.0}, &xy));
}

TEST(CameraTest, IsInImageWithMargin) {
  const PinholeRadTan camera = TestCamera();
  EXPECT_TRUE(camera.IsInImage({640.0, 480.0}));
  EXPECT_TRUE(camera.IsInImage({0.0, 0.0}));
  EXPECT_TRUE(camera.IsInImage({1279.0, 959.0}));
  EXPECT_FALSE(camera.IsInImage({-1.0, 10.0}));
  EXPECT_FALSE(camera.IsInImage({10.0, 960.0}));
  EXPECT_FALSE(camera.IsInImage({5.0, 100.0}, 10.0));
  EXPECT_TRUE(camera.IsInImage({15.0, 100.0}, 10.0));
}

}  // namespace
}  // namespace crop4d::geometry
