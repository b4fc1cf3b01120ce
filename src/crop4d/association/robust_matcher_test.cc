#include "crop4d/association/robust_matcher.h"

#include <gtest/gtest.h>

#include <limits>
#include <memory>
#include <thread>

#include "crop4d/association/association_test_util.h"

namespace crop4d::association {
namespace {

using testing::kDegree;

// ---------------------------------------------------------------------------------------------
// The decision rules on hand-made features: one camera pose for both images (no warp), a single
// landmark on the ground, candidates placed and described at will.

class DecisionTest : public ::testing::Test {
 protected:
  void SetUp() override {
    camera_ = testing::DemoCamera();
    pose_ = testing::ForwardLookingPose({0, 0, 1.5}, 90 * kDegree);
    features_a_.image_width = features_b_.image_width = camera_.width;
    features_a_.image_height = features_b_.image_height = camera_.height;
    options_.verify = false;  // a handful of matches cannot be verified by RANSAC
  }

  // A descriptor with one pattern per seed, of norm ≈ 512 like SIFT's.
  static std::vector<std::uint8_t> Descriptor(int seed) {
    std::vector<std::uint8_t> d(features::kDescriptorSize);
    for (int k = 0; k < features::kDescriptorSize; ++k) {
      d[k] = static_cast<std::uint8_t>((k * 37 + seed * 101 + (k * seed) % 13) % 90);
    }
    return d;
  }
  static std::vector<std::uint8_t> Perturbed(std::vector<std::uint8_t> d, int amount) {
    for (int k = 0; k < features::kDescriptorSize; k += 4) d[k] = d[k] + amount;
    return d;
  }
  static void Add(features::FeatureSet* set, const Eigen::Vector2d& pixel,
                  const std::vector<std::uint8_t>& descriptor, float size = 6) {
    set->keypoints.push_back(
        {static_cast<float>(pixel.x()), static_cast<float>(pixel.y()), size, 45.f, 0.01f, 0});
    set->descriptors.insert(set->descriptors.end(), descriptor.begin(), descriptor.end());
    set->colors.push_back({0, 0, 0});
  }
  // A landmark seen by feature `feature` of I1 at `pixel`.
  void AddLandmark(int feature, const Eigen::Vector2d& pixel) {
    const auto ground = testing::GroundPoint(camera_, pose_, pixel, 100);
    ASSERT_TRUE(ground.has_value());
    landmarks_.push_back({feature, *ground, static_cast<std::int32_t>(landmarks_.size())});
  }
  AssociationResult Match() const {
    RobustPairInput input;
    input.camera_a = &camera_;
    input.world_from_camera_a = pose_;
    input.features_a = &features_a_;
    input.landmarks_a = &landmarks_;
    input.camera_b = &camera_;
    input.world_from_camera_b = pose_;
    input.features_b = &features_b_;
    return RobustMatcher(options_).Match(input);
  }

  geometry::PinholeRadTan camera_;
  geometry::Rigid3 pose_;
  features::FeatureSet features_a_, features_b_;
  std::vector<LandmarkObservation> landmarks_;
  RobustMatcher::Options options_;
};

TEST_F(DecisionTest, BoundedSearchIgnoresFarCandidates) {
  const Eigen::Vector2d pixel(320, 300);
  Add(&features_a_, pixel, Descriptor(1));
  AddLandmark(0, pixel);
  // Far from the projection: the identical descriptor. Near: a similar one.
  Add(&features_b_, pixel + Eigen::Vector2d(150, 0), Descriptor(1));
  Add(&features_b_, pixel + Eigen::Vector2d(1.5, -1), Perturbed(Descriptor(1), 12));
  AssociationResult result = Match();
  ASSERT_EQ(result.matches.size(), 1u);
  EXPECT_EQ(result.matches[0].feature_a, 0);
  EXPECT_EQ(result.matches[0].feature_b, 1);
  EXPECT_EQ(result.matches[0].landmark, 0);
  EXPECT_GT(result.matches[0].distance, 0);
  EXPECT_EQ(result.stats.num_projected, 1);
  EXPECT_EQ(result.stats.num_candidates, 1);  // the far feature was never compared
  EXPECT_EQ(result.stats.num_warped, 0);      // no baseline, no warp

  // A box wide enough to hold both: the far identical descriptor wins, so it is the box that
  // keeps it out.
  options_.min_search_radius_px = 200;
  options_.max_search_radius_px = 200;
  options_.max_ratio = 1.0;
  result = Match();
  ASSERT_EQ(result.matches.size(), 1u);
  EXPECT_EQ(result.matches[0].feature_b, 0);

  // Only the far candidate: no match at all with the normal box.
  options_ = RobustMatcher::Options();
  options_.verify = false;
  features_b_.keypoints.pop_back();
  features_b_.colors.pop_back();
  features_b_.descriptors.resize(features::kDescriptorSize);
  result = Match();
  EXPECT_TRUE(result.matches.empty());
  EXPECT_EQ(result.stats.num_with_candidates, 0);
}

TEST_F(DecisionTest, SearchBoxFollowsThePoseUncertainty) {
  const Eigen::Vector2d pixel(320, 300);
  Add(&features_a_, pixel, Descriptor(1));
  AddLandmark(0, pixel);
  // 30 px away: outside the box of RTK-grade poses (8 + 3·(280·0.03/z + 280·0.3°) ≈ 25 px at
  // depth z ≈ 2 m), inside the box of 10 cm poses (≈ 54 px).
  Add(&features_b_, pixel + Eigen::Vector2d(30, 0), Descriptor(1));
  EXPECT_TRUE(Match().matches.empty());
  options_.sigma_position_m = 0.10;
  EXPECT_EQ(Match().matches.size(), 1u);
}

TEST_F(DecisionTest, AmbiguousCandidatesAreRejected) {
  const Eigen::Vector2d pixel(320, 300);
  Add(&features_a_, pixel, Descriptor(1));
  AddLandmark(0, pixel);
  // Two look-alikes 8 px apart (repeated texture inside the box).
  Add(&features_b_, pixel + Eigen::Vector2d(-4, 0), Perturbed(Descriptor(1), 8));
  Add(&features_b_, pixel + Eigen::Vector2d(4, 0), Perturbed(Descriptor(1), 9));
  EXPECT_TRUE(Match().matches.empty());

  // A second keypoint at the same place (SIFT's second orientation) is no rival.
  features_b_ = features::FeatureSet();
  features_b_.image_width = camera_.width;
  features_b_.image_height = camera_.height;
  Add(&features_b_, pixel + Eigen::Vector2d(0.5, 0), Perturbed(Descriptor(1), 8));
  Add(&features_b_, pixel + Eigen::Vector2d(0.5, 0.5), Perturbed(Descriptor(1), 9));
  const AssociationResult result = Match();
  ASSERT_EQ(result.matches.size(), 1u);
  EXPECT_EQ(result.matches[0].feature_b, 0);
}

TEST_F(DecisionTest, DistanceAndScaleLimits) {
  const Eigen::Vector2d pixel(320, 300);
  Add(&features_a_, pixel, Descriptor(1), 6);
  AddLandmark(0, pixel);
  // An unrelated descriptor at the right place is refused by the distance limit.
  Add(&features_b_, pixel, Descriptor(2), 6);
  EXPECT_TRUE(Match().matches.empty());
  // The right descriptor at 3× the expected size is refused by the scale check.
  features_b_.descriptors = Descriptor(1);
  features_b_.keypoints[0].size = 18;
  EXPECT_TRUE(Match().matches.empty());
  options_.max_scale_ratio = 0;
  EXPECT_EQ(Match().matches.size(), 1u);
}

TEST_F(DecisionTest, EachFeatureOfI2KeepsItsBestLandmark) {
  Add(&features_a_, {320, 300}, Descriptor(1));
  Add(&features_a_, {326, 300}, Perturbed(Descriptor(1), 10));
  AddLandmark(0, {320, 300});
  AddLandmark(1, {326, 300});
  Add(&features_b_, {323, 300}, Perturbed(Descriptor(1), 2));
  AssociationResult result = Match();
  ASSERT_EQ(result.matches.size(), 1u);
  EXPECT_EQ(result.matches[0].feature_a, 0);
  EXPECT_EQ(result.stats.num_putative, 1);
  options_.one_to_one = false;
  EXPECT_EQ(Match().matches.size(), 2u);
}

TEST_F(DecisionTest, EmptyInputsGiveNoMatches) {
  AssociationResult result = Match();
  EXPECT_TRUE(result.matches.empty());
  EXPECT_EQ(result.stats.num_landmarks, 0);
  options_.verify = true;
  Add(&features_a_, {320, 300}, Descriptor(1));
  AddLandmark(0, {320, 300});
  result = Match();  // no features in I2
  EXPECT_TRUE(result.matches.empty());
  EXPECT_FALSE(result.stats.verified);
  EXPECT_EQ(result.stats.num_projected, 1);
  const AssociationResult naive =
      NaiveMatch(camera_, features_a_, camera_, features_b_, features::PairMatcher::Options());
  EXPECT_TRUE(naive.matches.empty());
}

TEST(RobustMatcherOptionsTest, Check) {
  EXPECT_EQ(RobustMatcher::Options().Check(), "");
  RobustMatcher::Options options;
  options.max_ratio = 1.5;
  EXPECT_NE(options.Check(), "");
  options = RobustMatcher::Options();
  options.max_scale_ratio = 0.5;
  EXPECT_NE(options.Check(), "");
  options = RobustMatcher::Options();
  options.max_search_radius_px = 1;
  EXPECT_NE(options.Check(), "");
}

// ---------------------------------------------------------------------------------------------
// Rendered ground seen by the demo field's camera from two passes.

struct Scene {
  geometry::PinholeRadTan camera;
  testing::GroundTexture texture;
  testing::View a;
  std::vector<LandmarkObservation> landmarks;
  std::unique_ptr<LocalPlanes> planes;
};

class RenderedPairTest : public ::testing::Test {
 protected:
  // The scenes are rendered on first use and shared by the tests of one process.
  static const Scene& RandomScene() {
    static const std::unique_ptr<Scene> scene = MakeScene(testing::TextureKind::kRandom);
    return *scene;
  }
  static const Scene& PeriodicScene() {
    static const std::unique_ptr<Scene> scene = MakeScene(testing::TextureKind::kPeriodic);
    return *scene;
  }

  // I1: the camera on row x = 6 m, driving north; its landmarks are its features on the ground
  // within 5 m, with 1 cm of triangulation noise.
  static std::unique_ptr<Scene> MakeScene(testing::TextureKind kind) {
    auto scene = std::make_unique<Scene>();
    scene->camera = testing::DemoCamera();
    scene->texture = testing::MakeGroundTexture(kind, 3);
    scene->a = testing::MakeView(scene->texture, scene->camera,
                                 testing::ForwardLookingPose({6, 2, 1.5}, 90 * kDegree));
    std::vector<Eigen::Vector3d> positions;
    scene->landmarks = testing::GroundLandmarks(scene->a, scene->camera, 5.0, 0.01, 1, &positions);
    scene->planes = std::make_unique<LocalPlanes>(std::move(positions));
    return scene;
  }
  static testing::View ViewB(const Scene& scene, const Eigen::Vector3d& position,
                             double heading_deg) {
    return testing::MakeView(scene.texture, scene.camera,
                             testing::ForwardLookingPose(position, heading_deg * kDegree));
  }
  // SLAM poses: the truth with RTK-grade errors (2 cm, 0.2° each, in opposite directions).
  static RobustPairInput Input(const Scene& scene, const testing::View& b) {
    RobustPairInput input;
    input.camera_a = &scene.camera;
    input.world_from_camera_a = testing::Perturb(scene.a.world_from_camera, 0.02, 0.2 * kDegree);
    input.features_a = &scene.a.features;
    input.landmarks_a = &scene.landmarks;
    input.planes = scene.planes.get();
    input.image_a = &scene.a.image;
    input.camera_b = &scene.camera;
    input.world_from_camera_b = testing::Perturb(b.world_from_camera, -0.02, -0.2 * kDegree);
    input.features_b = &b.features;
    input.image_b = &b.image;
    return input;
  }
  static AssociationResult Naive(const Scene& scene, const testing::View& b) {
    return NaiveMatch(scene.camera, scene.a.features, scene.camera, b.features,
                      features::PairMatcher::Options());
  }
};

// The neighbouring row (0.9 m to the side, 0.3 m ahead, turned by 10°).
TEST_F(RenderedPairTest, CrossRowMatchesArePreciseAndMoreThanNaive) {
  const Scene& scene = RandomScene();
  const testing::View b = ViewB(scene, {6.9, 2.3, 1.5}, 100);
  const AssociationResult robust = RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
  const testing::MatchQuality quality = testing::Evaluate(scene.a, b, scene.camera, robust.matches);
  EXPECT_GE(quality.precision(), 0.95) << quality.correct << " correct, " << quality.wrong;
  EXPECT_GT(quality.correct, 600);

  const AssociationStats& stats = robust.stats;
  EXPECT_EQ(stats.num_landmarks, static_cast<int>(scene.landmarks.size()));
  EXPECT_GT(stats.num_projected, stats.num_landmarks / 2);
  EXPECT_LE(stats.num_with_candidates, stats.num_projected);
  EXPECT_GT(stats.num_candidates, stats.num_with_candidates);
  EXPECT_GT(stats.num_warped, stats.num_with_candidates * 9 / 10);  // baseline 0.95 m > 0.5 m
  EXPECT_LT(stats.num_plane_fallbacks, stats.num_with_candidates / 10);
  EXPECT_GE(stats.num_putative, stats.num_inliers);
  EXPECT_EQ(stats.num_inliers, static_cast<int>(robust.matches.size()));
  EXPECT_TRUE(stats.verified);
  EXPECT_NEAR(stats.baseline_m, 0.95, 0.05);
  EXPECT_GT(stats.seconds, 0);
  for (std::size_t k = 0; k < robust.matches.size(); ++k) {
    const LandmarkMatch& m = robust.matches[k];
    EXPECT_EQ(scene.landmarks[m.landmark].feature, m.feature_a);
    if (k > 0) {
      EXPECT_LT(robust.matches[k - 1].feature_a, m.feature_a);
    }
  }

  const AssociationResult naive = Naive(scene, b);
  const testing::MatchQuality naive_quality =
      testing::Evaluate(scene.a, b, scene.camera, naive.matches);
  EXPECT_GT(quality.correct, 3 * naive_quality.correct / 2)
      << quality.correct << " robust vs " << naive_quality.correct << " naive";
  for (const LandmarkMatch& m : naive.matches) EXPECT_EQ(m.landmark, -1);
}

// 1.5 m to the side: the naive matcher finds nothing, the warp makes the difference.
TEST_F(RenderedPairTest, WarpKeepsMatchingWhereNaiveFails) {
  const Scene& scene = RandomScene();
  const testing::View b = ViewB(scene, {7.5, 2, 1.5}, 90);
  const AssociationResult robust = RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
  const testing::MatchQuality quality = testing::Evaluate(scene.a, b, scene.camera, robust.matches);
  EXPECT_GE(quality.precision(), 0.95) << quality.correct << " correct, " << quality.wrong;
  EXPECT_GT(quality.correct, 300);

  RobustMatcher::Options no_warp;
  no_warp.warp_min_baseline_m = std::numeric_limits<double>::infinity();
  const AssociationResult unwarped = RobustMatcher(no_warp).Match(Input(scene, b));
  EXPECT_EQ(unwarped.stats.num_warped, 0);
  const testing::MatchQuality unwarped_quality =
      testing::Evaluate(scene.a, b, scene.camera, unwarped.matches);
  EXPECT_GT(quality.correct, 2 * unwarped_quality.correct);

  const testing::MatchQuality naive_quality =
      testing::Evaluate(scene.a, b, scene.camera, Naive(scene, b).matches);
  EXPECT_GE(quality.correct, 5 * naive_quality.correct);
}

// A periodic ground (0.96 m tiles): every feature has exact copies a period away. The naive
// matcher locks onto the copies (a consistent shift that RANSAC accepts); the bounded search only
// sees the true place.
TEST_F(RenderedPairTest, RepeatedTextureFoolsNaiveButNotTheBoundedSearch) {
  const Scene& scene = PeriodicScene();
  const testing::View b = ViewB(scene, {6.76, 2.2, 1.5}, 90);
  const AssociationResult robust = RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
  const testing::MatchQuality quality = testing::Evaluate(scene.a, b, scene.camera, robust.matches);
  EXPECT_GE(quality.precision(), 0.95) << quality.correct << " correct, " << quality.wrong;
  EXPECT_GT(quality.correct, 500);

  const AssociationResult naive = Naive(scene, b);
  const testing::MatchQuality naive_quality =
      testing::Evaluate(scene.a, b, scene.camera, naive.matches);
  EXPECT_GT(naive_quality.wrong, 100);        // confidently wrong...
  EXPECT_LT(naive_quality.precision(), 0.5);  // ...and mostly so
}

// The adjacent row driven the other way (the demo field's rows, 0.91 m apart): the cameras face
// each other, and the image pair that footprint overlap selects for them (b 6.3 m ahead) sees
// a's near ground, where its landmarks are, from far away at a grazing angle. Facing each other
// 2.2 m apart (what the view overlap selects; footprint_test.cc), both see the ground between
// them at the same scale, rotated by ≈ 180°, and the warped descriptors match it.
TEST_F(RenderedPairTest, OppositeDirectionMatchesFacingCameras) {
  const Scene& scene = RandomScene();
  const testing::View b = ViewB(scene, {6.91, 4.2, 1.5}, -90);
  const AssociationResult robust = RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
  const testing::MatchQuality quality = testing::Evaluate(scene.a, b, scene.camera, robust.matches);
  EXPECT_TRUE(robust.stats.verified);
  EXPECT_GE(quality.precision(), 0.95) << quality.correct << " correct, " << quality.wrong;
  EXPECT_GT(quality.correct, 200);

  const testing::View far = ViewB(scene, {6.91, 8.3, 1.5}, -90);
  const AssociationResult far_robust =
      RobustMatcher(RobustMatcher::Options()).Match(Input(scene, far));
  const testing::MatchQuality far_quality =
      testing::Evaluate(scene.a, far, scene.camera, far_robust.matches);
  EXPECT_GT(quality.correct, 2 * far_quality.correct)
      << quality.correct << " at 2.2 m vs " << far_quality.correct << " at 6.3 m";
}

// After the warp, descriptors compared upright in I2's grid (the default) against descriptors at
// SIFT's orientations (the transferred one for I1, I2's own for its keypoints): SIFT gives a
// third of the true pairs orientations more than 30° apart (plane_warp_test.cc), and upright
// finds them. Without I2's image the matcher falls back to the cached descriptors.
TEST_F(RenderedPairTest, UprightComparisonFindsMoreCorrectMatches) {
  const Scene& scene = RandomScene();
  // The neighbouring row (where the flat ground leaves little to gain: 957 correct matches
  // against 935 measured) and the facing camera of the opposite direction (338 against 250).
  struct Case {
    Eigen::Vector3d position;
    double heading_deg;
    double min_gain;
  };
  for (const Case& c : {Case{{6.9, 2.3, 1.5}, 100.0, 1.0}, Case{{6.91, 4.2, 1.5}, -90.0, 1.2}}) {
    const Eigen::Vector3d& position = c.position;
    const double heading = c.heading_deg;
    const testing::View b = ViewB(scene, position, heading);
    const AssociationResult upright =
        RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
    RobustMatcher::Options transferred_options;
    transferred_options.upright_after_warp = false;
    const AssociationResult transferred = RobustMatcher(transferred_options).Match(Input(scene, b));
    RobustPairInput without_image = Input(scene, b);
    without_image.image_b = nullptr;
    const AssociationResult fallback = RobustMatcher(RobustMatcher::Options()).Match(without_image);
    EXPECT_EQ(fallback.matches, transferred.matches);
    EXPECT_EQ(fallback.stats.num_upright_b, 0);
    EXPECT_EQ(transferred.stats.num_upright_b, 0);
    EXPECT_GT(upright.stats.num_upright_b, 100);
    EXPECT_LE(upright.stats.num_upright_b, static_cast<int>(b.features.size()));

    const testing::MatchQuality q = testing::Evaluate(scene.a, b, scene.camera, upright.matches);
    const testing::MatchQuality t =
        testing::Evaluate(scene.a, b, scene.camera, transferred.matches);
    EXPECT_GE(q.precision(), 0.95) << q.correct << " correct, " << q.wrong;
    EXPECT_GE(q.correct, c.min_gain * t.correct) << q.correct << " upright vs " << t.correct;
  }
}

// Below the warp baseline the cached descriptors are compared directly.
TEST_F(RenderedPairTest, SmallBaselineUsesTheCachedDescriptors) {
  const Scene& scene = RandomScene();
  const testing::View b = ViewB(scene, {6.3, 2.2, 1.5}, 92);
  const AssociationResult robust = RobustMatcher(RobustMatcher::Options()).Match(Input(scene, b));
  EXPECT_LT(robust.stats.baseline_m, 0.5);
  EXPECT_EQ(robust.stats.num_warped, 0);
  const testing::MatchQuality quality = testing::Evaluate(scene.a, b, scene.camera, robust.matches);
  EXPECT_GE(quality.precision(), 0.95);
  EXPECT_GT(quality.correct, 800);
}

// Match is const and stateless: concurrent calls on different pairs give the sequential results.
TEST_F(RenderedPairTest, ConcurrentCallsAreSafe) {
  const Scene& scene = RandomScene();
  const testing::View b1 = ViewB(scene, {6.9, 2.3, 1.5}, 100);
  const testing::View b2 = ViewB(scene, {5.2, 2.5, 1.5}, 80);
  const RobustMatcher matcher{RobustMatcher::Options()};
  const AssociationResult sequential1 = matcher.Match(Input(scene, b1));
  const AssociationResult sequential2 = matcher.Match(Input(scene, b2));
  AssociationResult parallel1, parallel2;
  std::thread t1([&] { parallel1 = matcher.Match(Input(scene, b1)); });
  std::thread t2([&] { parallel2 = matcher.Match(Input(scene, b2)); });
  t1.join();
  t2.join();
  EXPECT_EQ(parallel1.matches, sequential1.matches);
  EXPECT_EQ(parallel2.matches, sequential2.matches);
  EXPECT_GT(sequential2.matches.size(), 100u);
}

}  // namespace
}  // namespace crop4d::association
