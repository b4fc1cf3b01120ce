#include "crop4d/association/prealignment.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <map>
#include <random>

#include "crop4d/association/association_test_util.h"

namespace crop4d::association {
namespace {

using testing::DemoCamera;
using testing::ForwardLookingPose;
using testing::kDegree;

// A pass in memory: its cameras, and for each image the features of the scene points it sees
// (keypoint at the projection, the point's own descriptor), each a cloud point of the pass.
struct SyntheticPass {
  geometry::PinholeRadTan camera = DemoCamera();
  std::vector<geometry::Rigid3> poses;
  std::vector<features::FeatureSet> features;
  // Cloud point of (image, feature), in the pass's frame.
  std::map<std::pair<int, int>, Eigen::Vector3d> cloud;

  PreAlignmentPass View() const {
    return {&camera, &poses, &features,
            [this](int image, int feature) -> std::optional<Eigen::Vector3d> {
              const auto it = cloud.find({image, feature});
              if (it == cloud.end()) return std::nullopt;
              return it->second;
            }};
  }
};

struct Scene {
  std::vector<Eigen::Vector3d> points;  // true world
  std::vector<std::array<std::uint8_t, features::kDescriptorSize>> descriptors;
};

// Ground with plants (0 to 0.4 m high) along a 16 m row, one random descriptor per point.
Scene MakeScene(unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> x(-2.0, 18.0), y(-3.0, 3.0), z(0.0, 0.4);
  std::uniform_int_distribution<int> byte(0, 255);
  Scene scene;
  for (int i = 0; i < 3000; ++i) {
    scene.points.emplace_back(x(rng), y(rng), z(rng));
    scene.descriptors.emplace_back();
    for (auto& d : scene.descriptors.back()) d = static_cast<std::uint8_t>(byte(rng));
  }
  return scene;
}

// A pass driven along +x at y = `y` (true world), placed in its own frame by `frame_from_world`
// (what a wrong GPS does to a pass).
SyntheticPass MakePass(const Scene& scene, double y, const geometry::Rigid3& frame_from_world) {
  SyntheticPass pass;
  for (int k = 0; k < 30; ++k) {
    const geometry::Rigid3 world_from_camera =
        ForwardLookingPose(Eigen::Vector3d(0.5 * k, y, 1.5), 0.0);
    pass.poses.push_back(frame_from_world * world_from_camera);
    features::FeatureSet f;
    f.image_width = pass.camera.width;
    f.image_height = pass.camera.height;
    for (std::size_t i = 0; i < scene.points.size(); ++i) {
      const Eigen::Vector3d p_camera = world_from_camera.Inverse() * scene.points[i];
      Eigen::Vector2d pixel;
      if (p_camera.norm() > 6.0 || !pass.camera.Project(p_camera, &pixel) ||
          !pass.camera.IsInImage(pixel, 2.0)) {
        continue;
      }
      pass.cloud[{k, static_cast<int>(f.size())}] = frame_from_world * scene.points[i];
      f.keypoints.push_back(
          {static_cast<float>(pixel.x()), static_cast<float>(pixel.y()), 4.0f, 0.0f, 1.0f, 0});
      f.descriptors.insert(f.descriptors.end(), scene.descriptors[i].begin(),
                           scene.descriptors[i].end());
      f.colors.push_back({100, 100, 100});
    }
    pass.features.push_back(std::move(f));
  }
  return pass;
}

geometry::Rigid3 YawShift(double yaw_rad, const Eigen::Vector3d& t) {
  return geometry::Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ())),
                          t);
}

TEST(PreAlignmentTest, RecoversTheTransformBetweenTwoPassesFrames) {
  const Scene scene = MakeScene(3);
  const SyntheticPass a = MakePass(scene, 0.0, geometry::Rigid3());
  // Pass b of the neighbouring track, its GPS 1.2 m and 3° off.
  const geometry::Rigid3 b_from_world = YawShift(3 * kDegree, Eigen::Vector3d(0.8, -0.9, 0.2));
  const SyntheticPass b = MakePass(scene, 0.4, b_from_world);
  PreAlignmentOptions options;
  const fusion::PassAlignment alignment = PreAlignPasses(a.View(), b.View(), options);
  ASSERT_TRUE(alignment.ok);
  const geometry::Rigid3 error = alignment.b_from_a * b_from_world.Inverse();
  EXPECT_LT(error.translation().norm(), 0.01);
  EXPECT_LT(Eigen::AngleAxisd(error.rotation()).angle(), 0.05 * kDegree);
  EXPECT_GE(alignment.num_inliers, options.alignment.min_inliers);
}

TEST(PreAlignmentTest, PassesFartherApartThanTheRadiusAreNotAligned) {
  const Scene scene = MakeScene(4);
  const SyntheticPass a = MakePass(scene, 0.0, geometry::Rigid3());
  const SyntheticPass b = MakePass(scene, 0.0, YawShift(0.0, Eigen::Vector3d(0, 8.0, 0)));
  PreAlignmentOptions options;
  options.radius_m = 5.0;
  EXPECT_TRUE(PreAlignmentImagePairs(a.poses, b.poses, options).empty());
  EXPECT_FALSE(PreAlignPasses(a.View(), b.View(), options).ok);
}

TEST(PreAlignmentTest, ImagePairsSamplePassBDenserAndSkipOppositeHeadings) {
  std::vector<geometry::Rigid3> a, b, b_reversed;
  for (int k = 0; k < 19; ++k) {
    a.push_back(ForwardLookingPose(Eigen::Vector3d(0.1 * k, 0, 1.5), 0.0));
    b.push_back(ForwardLookingPose(Eigen::Vector3d(0.1 * k, 0.5, 1.5), 0.0));
    b_reversed.push_back(ForwardLookingPose(Eigen::Vector3d(0.1 * k, 0.5, 1.5), M_PI));
  }
  PreAlignmentOptions options;
  options.stride = 9;
  const auto pairs = PreAlignmentImagePairs(a, b, options);
  // Images 0, 9, 18 of a; 0, 3, ..., 18 of b (all within 5 m).
  ASSERT_EQ(pairs.size(), 3u * 7u);
  EXPECT_EQ(pairs[1], std::make_pair(0, 3));
  EXPECT_EQ(pairs.back(), std::make_pair(18, 18));
  EXPECT_TRUE(PreAlignmentImagePairs(a, b_reversed, options).empty());
}

TEST(PreAlignmentTest, GroundHeightIsTheLowerQuartileOfTheCloudElseBelowTheCamera) {
  EXPECT_DOUBLE_EQ(GroundHeight({0.4, 0.0, 0.3, 0.1, 0.2, 0.5, 0.6, 0.7}, 1.5), 0.2);
  EXPECT_DOUBLE_EQ(GroundHeight({}, 2.0), 2.0 - kFallbackCameraHeightM);
  EXPECT_DOUBLE_EQ(GroundHeight({}, std::nullopt), 0.0);
}

TEST(PreAlignmentTest, CheckNamesTheWrongOption) {
  PreAlignmentOptions options;
  EXPECT_EQ(options.Check(), "");
  options.radius_m = 0;
  EXPECT_NE(options.Check().find("radius_m"), std::string::npos);
}

}  // namespace
}  // namespace crop4d::association
