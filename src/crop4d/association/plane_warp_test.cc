#include "crop4d/association/plane_warp.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "crop4d/association/association_test_util.h"

namespace crop4d::association {
namespace {

using testing::kDegree;

float Distance(const std::uint8_t* a, const std::uint8_t* b) {
  float sum = 0;
  for (int k = 0; k < features::kDescriptorSize; ++k) {
    const float d = static_cast<float>(a[k]) - static_cast<float>(b[k]);
    sum += d * d;
  }
  return std::sqrt(sum);
}

double Median(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// The ground plane z = 0 in camera a's frame, as a warp request for feature f.
WarpRequest GroundRequest(const geometry::Rigid3& world_from_camera_a, int feature) {
  const geometry::Rigid3 camera_a_from_world = world_from_camera_a.Inverse();
  WarpRequest request;
  request.feature = feature;
  request.normal_in_a = camera_a_from_world.rotation() * Eigen::Vector3d::UnitZ();
  // Any ground point: the origin of the world.
  request.offset = request.normal_in_a.dot(camera_a_from_world * Eigen::Vector3d::Zero());
  return request;
}

TEST(PlaneTransferTest, AgreesWithProjectingThePlanePoint) {
  const geometry::PinholeRadTan camera = testing::DemoCamera();
  const geometry::Rigid3 pose_a = testing::ForwardLookingPose({6, 2, 1.5}, 90 * kDegree);
  const geometry::Rigid3 pose_b = testing::ForwardLookingPose({7.2, 2.5, 1.4}, 110 * kDegree);
  const WarpRequest plane = GroundRequest(pose_a, 0);
  const PlaneTransfer transfer(camera, camera, pose_b.Inverse() * pose_a, plane.normal_in_a,
                               plane.offset);
  int checked = 0;
  for (double v = 200; v < 480; v += 37) {
    for (double u = 0; u < 640; u += 53) {
      const Eigen::Vector2d pixel_a(u, v);
      const auto ground = testing::GroundPoint(camera, pose_a, pixel_a, 1e3);
      ASSERT_TRUE(ground.has_value());
      Eigen::Vector2d expected_b;
      const bool visible = camera.Project(pose_b.Inverse() * *ground, &expected_b);
      Eigen::Vector2d pixel_b, back;
      ASSERT_EQ(transfer.AToB(pixel_a, &pixel_b), visible);
      if (!visible) continue;
      EXPECT_LT((pixel_b - expected_b).norm(), 1e-6);
      ASSERT_TRUE(transfer.BToA(pixel_b, &back));
      EXPECT_LT((back - pixel_a).norm(), 1e-6);
      ++checked;
    }
  }
  EXPECT_GT(checked, 50);
  // A pixel above the horizon never meets the ground.
  Eigen::Vector2d pixel_b;
  EXPECT_FALSE(transfer.AToB({320, 0}, &pixel_b));
}

// One camera at one pose: every pixel maps onto itself, exactly, also outside the image (where a
// patch near the border reads); another camera object with the same parameters takes the lens
// model's round trip and agrees to its precision.
TEST(PlaneTransferTest, TheSameCameraAtTheSamePoseMapsPixelsOntoThemselves) {
  const geometry::PinholeRadTan camera = testing::DemoCamera();
  const geometry::PinholeRadTan copy = camera;
  const PlaneTransfer identity(camera, camera, geometry::Rigid3::Identity(),
                               Eigen::Vector3d(0.1, -0.2, 1.0), 2.0);
  const PlaneTransfer round_trip(camera, copy, geometry::Rigid3::Identity(),
                                 Eigen::Vector3d(0.1, -0.2, 1.0), 2.0);
  for (const Eigen::Vector2d& pixel : {Eigen::Vector2d(0.25, 0.75), Eigen::Vector2d(320, 240),
                                       Eigen::Vector2d(639.5, 479.5), Eigen::Vector2d(-20, 500)}) {
    Eigen::Vector2d out, approx;
    ASSERT_TRUE(identity.AToB(pixel, &out));
    EXPECT_EQ(out, pixel);
    ASSERT_TRUE(identity.BToA(pixel, &out));
    EXPECT_EQ(out, pixel);
    ASSERT_TRUE(round_trip.AToB(pixel, &approx));
    EXPECT_LT((approx - pixel).norm(), 1e-6);
  }
}

class PlaneWarpTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    camera_ = new geometry::PinholeRadTan(testing::DemoCamera());
    const testing::GroundTexture texture =
        testing::MakeGroundTexture(testing::TextureKind::kRandom, 3);
    view_a_ = new testing::View(testing::MakeView(
        texture, *camera_, testing::ForwardLookingPose({6, 2, 1.5}, 90 * kDegree)));
    // 1 m to the side and turned by 15°: a large viewpoint change of the ground.
    view_b_ = new testing::View(testing::MakeView(
        texture, *camera_, testing::ForwardLookingPose({7, 2, 1.5}, 105 * kDegree)));
  }
  static void TearDownTestSuite() {
    delete camera_;
    delete view_a_;
    delete view_b_;
  }

  // The warp requests of every feature of a on the ground within 5 m.
  static std::vector<WarpRequest> GroundRequests(const testing::View& view) {
    std::vector<WarpRequest> requests;
    for (std::size_t i = 0; i < view.features.size(); ++i) {
      if (testing::GroundPoint(*camera_, view.world_from_camera, view.features.Point(i), 5.0)) {
        requests.push_back(GroundRequest(view.world_from_camera, static_cast<int>(i)));
      }
    }
    return requests;
  }

  // The ground requests of a whose feature has a feature of b within 1.5 px of its true position,
  // and that feature of b (the nearest).
  static void TrueCorrespondences(std::vector<WarpRequest>* requests,
                                  std::vector<std::int32_t>* truth) {
    const geometry::Rigid3 b_from_world = view_b_->world_from_camera.Inverse();
    for (const WarpRequest& request : GroundRequests(*view_a_)) {
      const auto ground = testing::GroundPoint(*camera_, view_a_->world_from_camera,
                                               view_a_->features.Point(request.feature), 5.0);
      Eigen::Vector2d pixel_b;
      if (!camera_->Project(b_from_world * *ground, &pixel_b)) continue;
      std::int32_t best = -1;
      double best_error = 1.5;
      for (std::size_t j = 0; j < view_b_->features.size(); ++j) {
        const double error = (view_b_->features.Point(j) - pixel_b).norm();
        if (error < best_error) {
          best_error = error;
          best = static_cast<std::int32_t>(j);
        }
      }
      if (best < 0) continue;
      requests->push_back(request);
      truth->push_back(best);
    }
  }
  // The warp of a's features into b's view.
  static PlaneWarpInput WarpAToB() {
    PlaneWarpInput input;
    input.camera_a = camera_;
    input.camera_b = camera_;
    input.camera_b_from_camera_a =
        view_b_->world_from_camera.Inverse() * view_a_->world_from_camera;
    input.features_a = &view_a_->features;
    input.image_a = &view_a_->image;
    return input;
  }

  static geometry::PinholeRadTan* camera_;
  static testing::View* view_a_;
  static testing::View* view_b_;
};
geometry::PinholeRadTan* PlaneWarpTest::camera_ = nullptr;
testing::View* PlaneWarpTest::view_a_ = nullptr;
testing::View* PlaneWarpTest::view_b_ = nullptr;

// Warping I1 into itself must give back the descriptors SIFT computed on I1: this pins down the
// patch geometry, the octave/layer convention, the blur and the orientation handling.
TEST_F(PlaneWarpTest, IdentityWarpReproducesTheExtractedDescriptors) {
  const std::vector<WarpRequest> requests = GroundRequests(*view_a_);
  ASSERT_GT(requests.size(), 1000u);
  PlaneWarpInput input;
  input.camera_a = camera_;
  input.camera_b = camera_;
  input.features_a = &view_a_->features;
  input.image_a = &view_a_->image;
  std::vector<std::uint8_t> descriptors;
  const std::vector<WarpedKeypoint> warped =
      ComputeWarpedDescriptors(input, requests, PlaneWarpOptions(), &descriptors);
  ASSERT_EQ(warped.size(), requests.size());
  ASSERT_EQ(descriptors.size(), requests.size() * features::kDescriptorSize);
  std::vector<double> distances;
  for (std::size_t r = 0; r < requests.size(); ++r) {
    if (!warped[r].valid) continue;
    const features::Keypoint& k = view_a_->features.keypoints[requests[r].feature];
    EXPECT_LT((warped[r].pixel_b - Eigen::Vector2d(k.x, k.y)).norm(), 1e-4);
    EXPECT_NEAR(warped[r].size_b, k.size, 1e-3 * k.size);
    EXPECT_NEAR(std::remainder(warped[r].angle_b - k.angle, 360.0), 0.0, 0.05);
    distances.push_back(Distance(descriptors.data() + r * features::kDescriptorSize,
                                 view_a_->features.Descriptor(requests[r].feature)));
  }
  EXPECT_GT(distances.size(), requests.size() * 99 / 100);
  // SIFT's own descriptors differ from these by sub-pixel rounding and the blur of the detected
  // layer; distances of correct matches are typically 100–250, of random pairs ≈ 500.
  EXPECT_LT(Median(distances), 80.0);
}

// The point of the warp: under a large viewpoint change the warped descriptor of a feature of
// I1 is much closer to the descriptor of its true correspondence in I2 than I1's own.
TEST_F(PlaneWarpTest, WarpedDescriptorsMatchBetterUnderALargeViewpointChange) {
  std::vector<WarpRequest> requests;
  std::vector<std::int32_t> truth;  // the feature of b at the true position
  TrueCorrespondences(&requests, &truth);
  ASSERT_GT(requests.size(), 300u);
  const PlaneWarpInput input = WarpAToB();
  std::vector<std::uint8_t> descriptors;
  const std::vector<WarpedKeypoint> warped =
      ComputeWarpedDescriptors(input, requests, PlaneWarpOptions(), &descriptors);
  std::vector<double> warped_distances, unwarped_distances, position_errors;
  int better = 0;
  for (std::size_t r = 0; r < requests.size(); ++r) {
    if (!warped[r].valid) continue;
    const std::uint8_t* true_descriptor = view_b_->features.Descriptor(truth[r]);
    const double w = Distance(descriptors.data() + r * features::kDescriptorSize, true_descriptor);
    const double u = Distance(view_a_->features.Descriptor(requests[r].feature), true_descriptor);
    warped_distances.push_back(w);
    unwarped_distances.push_back(u);
    better += w < u;
    position_errors.push_back((warped[r].pixel_b - view_b_->features.Point(truth[r])).norm());
  }
  const int n = static_cast<int>(warped_distances.size());
  ASSERT_GT(n, static_cast<int>(requests.size()) * 95 / 100);
  EXPECT_LT(Median(position_errors), 1.0);  // the transfer lands on the true feature
  EXPECT_LT(Median(warped_distances), 0.75 * Median(unwarped_distances));
  EXPECT_GT(better, n * 7 / 10);
}

// Upright: after the warp, I1's patch is described at angle 0 of I2's grid, and so is I2's
// keypoint. Where SIFT gave the two keypoints orientations far apart (a blob whose gradient
// histogram has two peaks of similar height), their cached descriptors describe different
// rotations of the same patch; upright, they describe the same one.
TEST_F(PlaneWarpTest, UprightDescriptorsMatchWhereTheOrientationsDisagree) {
  std::vector<WarpRequest> requests;
  std::vector<std::int32_t> truth;
  TrueCorrespondences(&requests, &truth);
  ASSERT_GT(requests.size(), 300u);
  const PlaneWarpInput input = WarpAToB();
  std::vector<std::uint8_t> transferred, upright, upright_b;
  const std::vector<WarpedKeypoint> warped =
      ComputeWarpedDescriptors(input, requests, PlaneWarpOptions(), &transferred);
  PlaneWarpOptions options;
  options.upright = true;
  const std::vector<WarpedKeypoint> warped_upright =
      ComputeWarpedDescriptors(input, requests, options, &upright);
  const std::vector<bool> described = ComputeUprightDescriptors(
      *camera_, view_b_->features, view_b_->image, truth, PlaneWarpOptions(), &upright_b);
  ASSERT_EQ(described.size(), truth.size());
  ASSERT_EQ(upright_b.size(), truth.size() * features::kDescriptorSize);

  // Distances to the true keypoint of I2, where the orientations agree (within 30°) and where
  // they do not.
  std::vector<double> agree_cached, agree_upright, disagree_cached, disagree_upright;
  for (std::size_t r = 0; r < requests.size(); ++r) {
    if (!warped[r].valid || !described[r]) continue;
    ASSERT_TRUE(warped_upright[r].valid);
    EXPECT_EQ(warped_upright[r].angle_b, 0.0f);
    EXPECT_EQ(warped_upright[r].pixel_b, warped[r].pixel_b);
    const double cached = Distance(transferred.data() + r * features::kDescriptorSize,
                                   view_b_->features.Descriptor(truth[r]));
    const double both_upright = Distance(upright.data() + r * features::kDescriptorSize,
                                         upright_b.data() + r * features::kDescriptorSize);
    const double angle_gap = std::abs(
        std::remainder(warped[r].angle_b - view_b_->features.keypoints[truth[r]].angle, 360.0));
    (angle_gap > 30 ? disagree_cached : agree_cached).push_back(cached);
    (angle_gap > 30 ? disagree_upright : agree_upright).push_back(both_upright);
  }
  ASSERT_GT(agree_cached.size(), 200u);
  ASSERT_GT(disagree_cached.size(), 20u);
  // Where the orientations agree, upright is at least as close (measured: median 80 against
  // 131, the two descriptors now come from the same sampling); where they disagree (a third of
  // the pairs), the cached descriptors are as far apart as unrelated ones (485) and the upright
  // ones as close as where they agree (82).
  EXPECT_LT(Median(agree_upright), Median(agree_cached));
  EXPECT_GT(Median(disagree_cached), 400.0);
  EXPECT_LT(Median(disagree_upright), 0.4 * Median(disagree_cached));
  EXPECT_LT(Median(disagree_upright), Median(agree_cached));
}

// I1 may be given at a lower resolution than the features' pixels (e.g. the image the features
// were extracted from after downscaling): the warp samples it at the right place and scale.
TEST(PlaneWarpScaleTest, ReducedResolutionImageGivesTheSameDescriptors) {
  geometry::PinholeRadTan camera = testing::DemoCamera();
  camera.width *= 2;
  camera.height *= 2;
  camera.fx *= 2;
  camera.fy *= 2;
  camera.cx = 2 * camera.cx + 0.5;
  camera.cy = 2 * camera.cy + 0.5;
  const testing::GroundTexture texture =
      testing::MakeGroundTexture(testing::TextureKind::kRandom, 5);
  const geometry::Rigid3 pose = testing::ForwardLookingPose({6, 2, 1.5}, 90 * kDegree);
  const cv::Mat full = testing::RenderGround(texture, camera, pose);
  cv::Mat half;
  cv::resize(full, half, cv::Size(), 0.5, 0.5, cv::INTER_AREA);
  features::FeatureExtractor::Options options;
  options.max_num_features = 600;
  options.max_image_size = 640;  // extracted on `half`, keypoints in full-resolution pixels
  const features::FeatureSet features = features::FeatureExtractor(options).Extract(full);
  ASSERT_EQ(features.image_width, 1280);
  std::vector<WarpRequest> requests;
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (testing::GroundPoint(camera, pose, features.Point(i), 5.0)) {
      requests.push_back(GroundRequest(pose, static_cast<int>(i)));
    }
  }
  ASSERT_GT(requests.size(), 300u);
  PlaneWarpInput input;
  input.camera_a = &camera;
  input.camera_b = &camera;
  input.features_a = &features;
  std::vector<double> medians;
  for (const cv::Mat* image : {&full, static_cast<const cv::Mat*>(&half)}) {
    input.image_a = image;
    std::vector<std::uint8_t> descriptors;
    const std::vector<WarpedKeypoint> warped =
        ComputeWarpedDescriptors(input, requests, PlaneWarpOptions(), &descriptors);
    std::vector<double> distances;
    for (std::size_t r = 0; r < requests.size(); ++r) {
      if (warped[r].valid) {
        distances.push_back(Distance(descriptors.data() + r * features::kDescriptorSize,
                                     features.Descriptor(requests[r].feature)));
      }
    }
    EXPECT_GT(distances.size(), requests.size() * 99 / 100);
    medians.push_back(Median(distances));
  }
  EXPECT_LT(medians[0], 90.0);
  EXPECT_LT(medians[1], 90.0);
}

TEST(PlaneWarpOptionsTest, Check) {
  EXPECT_EQ(PlaneWarpOptions().Check(), "");
  PlaneWarpOptions options;
  options.descriptor_sigma = 0.1;
  EXPECT_NE(options.Check(), "");
  options = PlaneWarpOptions();
  options.patches_per_batch = 0;
  EXPECT_NE(options.Check(), "");
}

}  // namespace
}  // namespace crop4d::association
