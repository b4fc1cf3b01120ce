#include "crop4d/features/synthetic_plane_test_util.h"

#include <Eigen/Geometry>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::features::testing {
namespace {

constexpr double kMetresPerTexel = 0.002;
constexpr int kTextureWidth = 1800;
constexpr int kTextureHeight = 1100;

// Uniform noise of `cells` × `cells·aspect` values, resized smoothly to the texture size.
cv::Mat SmoothNoise(cv::RNG& rng, int cells_x, int cells_y, double amplitude) {
  cv::Mat small(cells_y, cells_x, CV_32FC3);
  rng.fill(small, cv::RNG::UNIFORM, cv::Scalar::all(-amplitude), cv::Scalar::all(amplitude));
  cv::Mat big;
  cv::resize(small, big, cv::Size(kTextureWidth, kTextureHeight), 0, 0, cv::INTER_CUBIC);
  return big;
}

cv::Mat MakeTexture(unsigned seed) {
  cv::RNG rng(seed);
  cv::Mat texture(kTextureHeight, kTextureWidth, CV_32FC3, cv::Scalar(110, 120, 100));
  texture += SmoothNoise(rng, 24, 15, 40);
  texture += SmoothNoise(rng, 120, 73, 35);
  texture += SmoothNoise(rng, 450, 275, 25);
  for (int k = 0; k < 3000; ++k) {
    const cv::Point center(rng.uniform(0, kTextureWidth), rng.uniform(0, kTextureHeight));
    const cv::Size axes(rng.uniform(3, 16), rng.uniform(3, 16));
    const cv::Scalar color(rng.uniform(0, 255), rng.uniform(0, 255), rng.uniform(0, 255));
    cv::ellipse(texture, center, axes, rng.uniform(0, 180), 0, 360, color, cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 1.0);
  cv::Mat out;
  texture.convertTo(out, CV_8UC3);
  return out;
}

}  // namespace

Eigen::Vector2d PlaneScene::Transfer(int i, int j, const Eigen::Vector2d& x) const {
  const Eigen::Vector3d y = view_from_texture[j] * view_from_texture[i].inverse() * x.homogeneous();
  return y.hnormalized();
}

Eigen::Vector2d PlaneScene::ToTexture(int i, const Eigen::Vector2d& x) const {
  return (view_from_texture[i].inverse() * x.homogeneous()).hnormalized();
}

PlaneScene MakePlaneScene(const PlaneSceneOptions& options) {
  PlaneScene scene;
  scene.texture = MakeTexture(options.seed);
  Eigen::Matrix3d K;
  K << options.focal_px, 0, (options.width - 1) / 2.0, 0, options.focal_px,
      (options.height - 1) / 2.0, 0, 0, 1;
  // Texture pixel (u, v) is the plane point (u s, v s, 0).
  const Eigen::Matrix3d plane_from_texture =
      Eigen::Vector3d(kMetresPerTexel, kMetresPerTexel, 1).asDiagonal();
  const double pi = std::acos(-1.0);
  // Nadir camera: x along world x, y along world −y, z along world −z.
  Eigen::Matrix3d world_from_nadir;
  world_from_nadir << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  const double x0 = 1.2, y0 = kTextureHeight * kMetresPerTexel / 2;
  for (int i = 0; i < options.num_views; ++i) {
    const double yaw = ((i % 2) ? 1 : -1) * options.yaw_wobble_deg * pi / 180;
    const Eigen::Matrix3d world_from_camera =
        world_from_nadir * Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() *
        Eigen::AngleAxisd(options.tilt_deg * pi / 180, Eigen::Vector3d::UnitX()).toRotationMatrix();
    const Eigen::Vector3d center(x0 + options.step_m * i, y0 - 0.3, options.height_m);
    const Eigen::Matrix3d camera_from_world = world_from_camera.transpose();
    const Eigen::Vector3d t = -camera_from_world * center;
    Eigen::Matrix3d Rt;
    Rt.col(0) = camera_from_world.col(0);
    Rt.col(1) = camera_from_world.col(1);
    Rt.col(2) = t;
    const Eigen::Matrix3d H = K * Rt * plane_from_texture;
    scene.view_from_texture.push_back(H / H(2, 2));

    // Every view corner must see the texture.
    const Eigen::Matrix3d texture_from_view = H.inverse();
    for (const Eigen::Vector2d& corner :
         {Eigen::Vector2d(0, 0), Eigen::Vector2d(options.width - 1, 0),
          Eigen::Vector2d(0, options.height - 1),
          Eigen::Vector2d(options.width - 1, options.height - 1)}) {
      const Eigen::Vector3d h = texture_from_view * corner.homogeneous();
      CROP4D_CHECK_MSG(h.z() > 0, "view corner above the horizon");
      const Eigen::Vector2d uv = h.hnormalized();
      CROP4D_CHECK_MSG(
          uv.x() > 0 && uv.y() > 0 && uv.x() < kTextureWidth - 1 && uv.y() < kTextureHeight - 1,
          "view leaves the texture");
    }
    cv::Mat H_cv(3, 3, CV_64F);
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 3; ++c) H_cv.at<double>(r, c) = scene.view_from_texture.back()(r, c);
    }
    cv::Mat view;
    cv::warpPerspective(scene.texture, view, H_cv, cv::Size(options.width, options.height),
                        cv::INTER_LINEAR, cv::BORDER_CONSTANT);
    scene.views.push_back(view);
  }
  return scene;
}

}  // namespace crop4d::features::testing
