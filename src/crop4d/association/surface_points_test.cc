#include "crop4d/association/surface_points.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>

#include "crop4d/association/association_test_util.h"
#include "crop4d/eval/quantile.h"  // header only

namespace crop4d::association {
namespace {

using testing::kDegree;

// ---------------------------------------------------------------------------------------------
// A step in hand-made geometry: a camera 2 m above the edge of a 0.5 m slab, looking straight
// down; features on a pixel grid; every other feature is a landmark at its true point.

// The true point of a pixel: the slab's top (x ≥ 0, z = 0.5) or the ground (x < 0, z = 0).
Eigen::Vector3d StepPoint(const geometry::PinholeRadTan& camera,
                          const geometry::Rigid3& world_from_camera, const Eigen::Vector2d& pixel) {
  Eigen::Vector3d ray;
  EXPECT_TRUE(camera.Unproject(pixel, &ray));
  const Eigen::Vector3d d = world_from_camera.RotationMatrix() * ray;
  const Eigen::Vector3d c = world_from_camera.translation();
  const Eigen::Vector3d on_top = c + (0.5 - c.z()) / d.z() * d;
  if (on_top.x() >= 0) return on_top;
  return c + (0.0 - c.z()) / d.z() * d;
}

TEST(SurfacePointsTest, AStepGivesNoPointOrAnUncertaintyThatCoversTheError) {
  const geometry::PinholeRadTan camera = testing::DemoCamera();
  const geometry::Rigid3 pose =
      testing::ForwardLookingPose({0, 0, 2.0}, 90 * kDegree, 90 * kDegree);
  features::FeatureSet features;
  features.image_width = camera.width;
  features.image_height = camera.height;
  std::vector<LandmarkObservation> landmarks;
  std::vector<Eigen::Vector3d> positions;
  std::vector<Eigen::Vector3d> truth;
  int index = 0;
  for (int y = 40; y < camera.height - 40; y += 10) {
    for (int x = 40; x < camera.width - 40; x += 10, ++index) {
      const Eigen::Vector2d pixel(x, y);
      features.keypoints.push_back(
          {static_cast<float>(x), static_cast<float>(y), 4.f, 0.f, 0.01f, 0});
      truth.push_back(StepPoint(camera, pose, pixel));
      if ((x / 10 + y / 10) % 2 == 0) {
        landmarks.push_back({index, truth.back(), static_cast<std::int32_t>(positions.size())});
        positions.push_back(truth.back());
      }
    }
  }
  const LocalPlanes planes(positions);
  SurfacePointOptions options;
  const std::vector<LandmarkObservation> points =
      SurfacePoints(camera, pose, features, landmarks, planes, options);

  const int without_landmark = static_cast<int>(features.size() - landmarks.size());
  EXPECT_GT(static_cast<int>(points.size()), without_landmark * 7 / 10);
  EXPECT_LT(static_cast<int>(points.size()), without_landmark);  // the edge refuses some
  int near_edge = 0;
  for (const LandmarkObservation& p : points) {
    EXPECT_EQ(p.landmark, -1);
    EXPECT_GE(p.sigma_along_ray_m, options.min_sigma_m);
    EXPECT_LE(p.sigma_along_ray_m, options.max_sigma_m);
    const double error = (p.position_world - truth[p.feature]).norm();
    EXPECT_LE(error, 3 * p.sigma_along_ray_m)
        << "feature " << p.feature << " at " << features.Point(p.feature).transpose();
    if (std::abs(truth[p.feature].x()) < 0.03) ++near_edge;
    // A point of the image's landmarks is never a surface point.
    for (const LandmarkObservation& l : landmarks) ASSERT_NE(l.feature, p.feature);
  }
  // Right at the edge the neighbours lie on both levels, 0.5 m apart in range: no point there.
  EXPECT_EQ(near_edge, 0);
}

TEST(SurfacePointsTest, NothingToPlaceWithoutLandmarksOrNeighbours) {
  const geometry::PinholeRadTan camera = testing::DemoCamera();
  const geometry::Rigid3 pose =
      testing::ForwardLookingPose({0, 0, 2.0}, 90 * kDegree, 90 * kDegree);
  features::FeatureSet features;
  features.keypoints.push_back({100.f, 100.f, 4.f, 0.f, 0.01f, 0});
  features.keypoints.push_back({500.f, 400.f, 4.f, 0.f, 0.01f, 0});
  const LocalPlanes no_planes(std::vector<Eigen::Vector3d>{});
  EXPECT_TRUE(SurfacePoints(camera, pose, features, {}, no_planes, {}).empty());
  // One landmark, far (in pixels) from the other feature: too few neighbours within reach.
  const Eigen::Vector3d point = StepPoint(camera, pose, {100, 100});
  const std::vector<LandmarkObservation> one = {{0, point, 0}};
  const LocalPlanes planes(std::vector<Eigen::Vector3d>{point});
  SurfacePointOptions options;
  options.num_neighbors = 1;
  EXPECT_TRUE(SurfacePoints(camera, pose, features, one, planes, options).empty());
  options.max_pixel_distance_px = 1000;  // now it reaches: the ground orientation through it
  const std::vector<LandmarkObservation> placed =
      SurfacePoints(camera, pose, features, one, planes, options);
  ASSERT_EQ(placed.size(), 1u);
  EXPECT_EQ(placed[0].feature, 1);
  EXPECT_NEAR(placed[0].position_world.z(), point.z(), 1e-9);

  options.max_sigma_m = options.min_sigma_m / 2;
  EXPECT_NE(options.Check(), "");
}

// ---------------------------------------------------------------------------------------------
// Rendered ground seen by the demo field's camera: a third of the features are landmarks (as
// row SLAM tracks only some), the others are placed on the ground and matched too.

struct SparseScene {
  geometry::PinholeRadTan camera;
  testing::GroundTexture texture;
  testing::View a;
  std::vector<LandmarkObservation> landmarks;  // every third ground feature
  std::unique_ptr<LocalPlanes> planes;
};

const SparseScene& Scene() {
  static const std::unique_ptr<SparseScene> scene = [] {
    auto s = std::make_unique<SparseScene>();
    s->camera = testing::DemoCamera();
    s->texture = testing::MakeGroundTexture(testing::TextureKind::kRandom, 5);
    s->a = testing::MakeView(s->texture, s->camera,
                             testing::ForwardLookingPose({6, 2, 1.5}, 90 * kDegree));
    const std::vector<LandmarkObservation> all =
        testing::GroundLandmarks(s->a, s->camera, 5.0, 0.01, 2, nullptr);
    std::vector<Eigen::Vector3d> positions;
    for (std::size_t k = 0; k < all.size(); k += 3) {
      s->landmarks.push_back(
          {all[k].feature, all[k].position_world, static_cast<std::int32_t>(positions.size())});
      positions.push_back(all[k].position_world);
    }
    s->planes = std::make_unique<LocalPlanes>(std::move(positions));
    return s;
  }();
  return *scene;
}

TEST(SurfacePointsTest, FeaturesWithoutALandmarkLandOnTheGround) {
  const SparseScene& s = Scene();
  const std::vector<LandmarkObservation> points =
      SurfacePoints(s.camera, s.a.world_from_camera, s.a.features, s.landmarks, *s.planes, {});
  std::vector<double> errors;
  int covered = 0;
  for (const LandmarkObservation& p : points) {
    const auto truth =
        testing::GroundPoint(s.camera, s.a.world_from_camera, s.a.features.Point(p.feature), 100);
    ASSERT_TRUE(truth.has_value());
    const double error = (p.position_world - *truth).norm();
    errors.push_back(error);
    if (error <= 3 * p.sigma_along_ray_m) ++covered;
  }
  // Most of the other ground features within 5 m get a point (two landmarks to one).
  EXPECT_GT(points.size(), s.landmarks.size());
  EXPECT_LT(eval::Quantile(&errors, 0.5), 0.01);
  EXPECT_LT(eval::Quantile(&errors, 0.95), 0.04);
  EXPECT_GT(covered, static_cast<int>(points.size()) * 95 / 100);
}

// Matched into a second view, the surface points add correct matches at the landmarks'
// precision: across sessions (the same row, 10 cm and 1° apart) and across rows (0.9 m, 10°, with
// the warp).
TEST(SurfacePointsTest, SurfacePointsAddCorrectMatches) {
  const SparseScene& s = Scene();
  const std::vector<LandmarkObservation> points =
      SurfacePoints(s.camera, s.a.world_from_camera, s.a.features, s.landmarks, *s.planes, {});
  std::vector<LandmarkObservation> with_points = s.landmarks;
  with_points.insert(with_points.end(), points.begin(), points.end());
  struct Case {
    Eigen::Vector3d position;
    double heading_deg;
  };
  for (const Case& c : {Case{{6.08, 2.06, 1.5}, 91.0}, Case{{6.9, 2.3, 1.5}, 100.0}}) {
    const testing::View b = testing::MakeView(
        s.texture, s.camera, testing::ForwardLookingPose(c.position, c.heading_deg * kDegree));
    RobustPairInput input;
    input.camera_a = &s.camera;
    input.world_from_camera_a = testing::Perturb(s.a.world_from_camera, 0.02, 0.2 * kDegree);
    input.features_a = &s.a.features;
    input.planes = s.planes.get();
    input.image_a = &s.a.image;
    input.camera_b = &s.camera;
    input.world_from_camera_b = testing::Perturb(b.world_from_camera, -0.02, -0.2 * kDegree);
    input.features_b = &b.features;
    const RobustMatcher matcher{RobustMatcher::Options()};
    input.landmarks_a = &s.landmarks;
    const testing::MatchQuality only_landmarks =
        testing::Evaluate(s.a, b, s.camera, matcher.Match(input).matches);
    input.landmarks_a = &with_points;
    const AssociationResult result = matcher.Match(input);
    const testing::MatchQuality both = testing::Evaluate(s.a, b, s.camera, result.matches);
    SCOPED_TRACE(::testing::Message()
                 << "view b at " << c.position.transpose() << ": " << only_landmarks.correct
                 << " correct with landmarks, " << both.correct << " with surface points too");
    EXPECT_GE(both.precision(), 0.95) << both.wrong << " wrong";
    EXPECT_GT(both.correct, 2 * only_landmarks.correct);
    int from_points = 0;
    for (const LandmarkMatch& m : result.matches) from_points += m.landmark < 0 ? 1 : 0;
    EXPECT_GT(from_points, both.correct / 2);
  }
}

}  // namespace
}  // namespace crop4d::association
