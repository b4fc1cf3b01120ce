#include "crop4d/association/association_test_util.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <random>

#include "crop4d/core/error.h"

namespace crop4d::association::testing {
namespace {

// Uniform noise on a coarse grid, smoothly interpolated to size × size texels.
cv::Mat NoiseLayer(cv::RNG& rng, int cells, int size, double amplitude) {
  cv::Mat coarse(cells, cells, CV_32FC3);
  rng.fill(coarse, cv::RNG::UNIFORM, cv::Scalar::all(-amplitude), cv::Scalar::all(amplitude));
  cv::Mat fine;
  cv::resize(coarse, fine, cv::Size(size, size), 0, 0, cv::INTER_CUBIC);
  return fine;
}

// Soil: brown with variations at 0.5 m, 10 cm and 2.5 cm, plus stones and leaves of 1–5 cm.
cv::Mat RandomTexture(cv::RNG& rng, int size, double metres_per_texel) {
  const double side_m = size * metres_per_texel;
  cv::Mat texture(size, size, CV_32FC3, cv::Scalar(70, 100, 130));
  texture += NoiseLayer(rng, std::max(2, static_cast<int>(side_m * 2)), size, 30);
  texture += NoiseLayer(rng, std::max(2, static_cast<int>(side_m * 10)), size, 30);
  texture += NoiseLayer(rng, std::max(2, static_cast<int>(side_m * 40)), size, 25);
  const int num_blobs = static_cast<int>(150 * side_m * side_m);
  for (int k = 0; k < num_blobs; ++k) {
    const cv::Point center(rng.uniform(0, size), rng.uniform(0, size));
    const cv::Size axes(rng.uniform(2, 9), rng.uniform(2, 9));
    const bool leaf = rng.uniform(0.0, 1.0) < 0.3;
    const cv::Scalar color =
        leaf ? cv::Scalar(rng.uniform(20, 80), rng.uniform(120, 220), rng.uniform(30, 100))
             : cv::Scalar::all(rng.uniform(40, 230));
    cv::ellipse(texture, center, axes, rng.uniform(0, 180), 0, 360, color, cv::FILLED, cv::LINE_AA);
  }
  cv::GaussianBlur(texture, texture, cv::Size(0, 0), 0.8);
  cv::Mat out;
  texture.convertTo(out, CV_8UC3);
  return out;
}

}  // namespace

geometry::PinholeRadTan DemoCamera() {
  geometry::PinholeRadTan camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 280;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.k1 = -0.05;
  camera.k2 = 0.01;
  return camera;
}

geometry::Rigid3 ForwardLookingPose(const Eigen::Vector3d& position, double heading_rad,
                                    double pitch_down_rad) {
  const Eigen::Vector3d forward(std::cos(heading_rad), std::sin(heading_rad), 0);
  const Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d right = forward.cross(up);
  // Camera axes in the world: x right, y down, z forward (pitched down).
  Eigen::Matrix3d world_from_camera;
  world_from_camera.col(0) = right;
  world_from_camera.col(2) = std::cos(pitch_down_rad) * forward - std::sin(pitch_down_rad) * up;
  world_from_camera.col(1) = world_from_camera.col(2).cross(world_from_camera.col(0));
  return geometry::Rigid3(world_from_camera, position);
}

geometry::Rigid3 Perturb(const geometry::Rigid3& pose, double translation_m, double rotation_rad) {
  const Eigen::Vector3d direction = Eigen::Vector3d(0.6, -0.48, 0.64).normalized();
  const Eigen::Vector3d axis = Eigen::Vector3d(-0.3, 0.8, 0.52).normalized();
  const Eigen::Matrix3d delta = Eigen::AngleAxisd(rotation_rad, axis).toRotationMatrix();
  return geometry::Rigid3(pose.RotationMatrix() * delta,
                          pose.translation() + translation_m * direction);
}

GroundTexture MakeGroundTexture(TextureKind kind, unsigned seed) {
  cv::RNG rng(seed);
  GroundTexture ground;
  ground.metres_per_texel = 0.006;
  cv::Mat level0;
  if (kind == TextureKind::kRandom) {
    level0 = RandomTexture(rng, 2000, ground.metres_per_texel);
  } else {
    const int tile = 160;  // 0.96 m
    level0 = cv::repeat(RandomTexture(rng, tile, ground.metres_per_texel), 13, 13);
  }
  ground.size_m = level0.cols * ground.metres_per_texel;
  cv::buildPyramid(level0, ground.pyramid, 7);
  return ground;
}

std::optional<Eigen::Vector3d> GroundPoint(const geometry::PinholeRadTan& camera,
                                           const geometry::Rigid3& world_from_camera,
                                           const Eigen::Vector2d& pixel, double max_range_m) {
  Eigen::Vector3d ray;
  if (!camera.Unproject(pixel, &ray)) return std::nullopt;
  const Eigen::Vector3d d = world_from_camera.rotation() * ray;
  const Eigen::Vector3d c = world_from_camera.translation();
  if (!(d.z() < -1e-9) || !(c.z() > 0)) return std::nullopt;
  const Eigen::Vector3d p = c + d * (c.z() / -d.z());
  if ((p - c).head<2>().norm() > max_range_m) return std::nullopt;
  return Eigen::Vector3d(p.x(), p.y(), 0.0);
}

cv::Mat RenderGround(const GroundTexture& texture, const geometry::PinholeRadTan& camera,
                     const geometry::Rigid3& world_from_camera, double fog_start_m,
                     double fog_end_m) {
  const int w = camera.width, h = camera.height;
  cv::Mat tex_x(h, w, CV_32F, cv::Scalar(0)), tex_y(h, w, CV_32F, cv::Scalar(0));
  cv::Mat fog(h, w, CV_32F, cv::Scalar(1));
  const Eigen::Matrix3d rotation = world_from_camera.RotationMatrix();
  const Eigen::Vector3d c = world_from_camera.translation();
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      Eigen::Vector3d ray;
      if (!camera.Unproject(Eigen::Vector2d(u, v), &ray)) continue;
      const Eigen::Vector3d d = rotation * ray;
      if (!(d.z() < -1e-9)) continue;
      const double lambda = c.z() / -d.z();
      const Eigen::Vector3d p = c + lambda * d;
      const double range = lambda * d.head<2>().norm();
      tex_x.at<float>(v, u) = static_cast<float>(p.x() / texture.metres_per_texel);
      tex_y.at<float>(v, u) = static_cast<float>(p.y() / texture.metres_per_texel);
      const double t = std::clamp((range - fog_start_m) / (fog_end_m - fog_start_m), 0.0, 1.0);
      fog.at<float>(v, u) = static_cast<float>(t * t * (3 - 2 * t));
    }
  }
  // Mip level per pixel from the texel footprint of one pixel step (the larger axis).
  const int num_levels = static_cast<int>(texture.pyramid.size());
  cv::Mat level(h, w, CV_32F);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const int u2 = u + 1 < w ? u + 1 : u - 1, v2 = v + 1 < h ? v + 1 : v - 1;
      const double du = std::hypot(tex_x.at<float>(v, u2) - tex_x.at<float>(v, u),
                                   tex_y.at<float>(v, u2) - tex_y.at<float>(v, u));
      const double dv = std::hypot(tex_x.at<float>(v2, u) - tex_x.at<float>(v, u),
                                   tex_y.at<float>(v2, u) - tex_y.at<float>(v, u));
      level.at<float>(v, u) = static_cast<float>(
          std::clamp(std::log2(std::max({du, dv, 1e-9})), 0.0, num_levels - 1.001));
    }
  }
  std::vector<cv::Mat> sampled(num_levels);
  for (int l = 0; l < num_levels; ++l) {
    const float scale = 1.0f / static_cast<float>(1 << l);
    cv::remap(texture.pyramid[l], sampled[l], tex_x * scale, tex_y * scale, cv::INTER_LINEAR,
              cv::BORDER_REFLECT_101);
  }
  const cv::Vec3f fog_color(205, 200, 195);
  cv::Mat image(h, w, CV_8UC3);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float lf = level.at<float>(v, u);
      const int l0 = static_cast<int>(lf);
      const float a = lf - l0;
      const cv::Vec3f ground = (1 - a) * cv::Vec3f(sampled[l0].at<cv::Vec3b>(v, u)) +
                               a * cv::Vec3f(sampled[l0 + 1].at<cv::Vec3b>(v, u));
      const float f = fog.at<float>(v, u);
      const cv::Vec3f color = (1 - f) * ground + f * fog_color;
      image.at<cv::Vec3b>(v, u) = cv::Vec3b(cv::saturate_cast<std::uint8_t>(color[0]),
                                            cv::saturate_cast<std::uint8_t>(color[1]),
                                            cv::saturate_cast<std::uint8_t>(color[2]));
    }
  }
  return image;
}

View MakeView(const GroundTexture& texture, const geometry::PinholeRadTan& camera,
              const geometry::Rigid3& world_from_camera, int max_num_features) {
  View view;
  view.world_from_camera = world_from_camera;
  view.image = RenderGround(texture, camera, world_from_camera);
  features::FeatureExtractor::Options options;
  options.max_num_features = max_num_features;
  view.features = features::FeatureExtractor(options).Extract(view.image);
  return view;
}

std::vector<LandmarkObservation> GroundLandmarks(const View& view,
                                                 const geometry::PinholeRadTan& camera,
                                                 double max_range_m, double noise_m, unsigned seed,
                                                 std::vector<Eigen::Vector3d>* positions) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, noise_m);
  std::vector<LandmarkObservation> landmarks;
  if (positions != nullptr) positions->clear();
  for (std::size_t i = 0; i < view.features.size(); ++i) {
    const std::optional<Eigen::Vector3d> ground =
        GroundPoint(camera, view.world_from_camera, view.features.Point(i), max_range_m);
    if (!ground) continue;
    LandmarkObservation observation;
    observation.feature = static_cast<std::int32_t>(i);
    observation.position_world = *ground;
    if (noise_m > 0) {
      // One draw per statement (the order of function arguments is unspecified in C++).
      const double nz = noise(rng), ny = noise(rng), nx = noise(rng);
      observation.position_world += Eigen::Vector3d(nx, ny, nz);
    }
    observation.landmark = static_cast<std::int32_t>(landmarks.size());
    if (positions != nullptr) positions->push_back(observation.position_world);
    landmarks.push_back(observation);
  }
  return landmarks;
}

bool IsCorrectMatch(const View& a, const View& b, const geometry::PinholeRadTan& camera,
                    int feature_a, int feature_b, double tolerance_px) {
  const std::optional<Eigen::Vector3d> ground =
      GroundPoint(camera, a.world_from_camera, a.features.Point(feature_a), 1e3);
  if (!ground) return false;
  Eigen::Vector2d pixel;
  if (!camera.Project(b.world_from_camera.Inverse() * *ground, &pixel)) return false;
  return (pixel - b.features.Point(feature_b)).norm() <= tolerance_px;
}

MatchQuality Evaluate(const View& a, const View& b, const geometry::PinholeRadTan& camera,
                      const std::vector<LandmarkMatch>& matches, double tolerance_px) {
  MatchQuality quality;
  for (const LandmarkMatch& m : matches) {
    if (IsCorrectMatch(a, b, camera, m.feature_a, m.feature_b, tolerance_px)) {
      ++quality.correct;
    } else {
      ++quality.wrong;
    }
  }
  return quality;
}

}  // namespace crop4d::association::testing
