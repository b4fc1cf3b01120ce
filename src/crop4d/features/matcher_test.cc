#include "crop4d/features/matcher.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <random>

#include "crop4d/features/synthetic_plane_test_util.h"

namespace crop4d::features {
namespace {

// ---- Ratio test and mutual check on hand-made data -----------------------------------------

TEST(RatioTestTest, KeepsOnlyDistinctiveNearestNeighbours) {
  const std::vector<TwoNearest> nearest = {
      {4, 10.0f, 7, 100.0f},  // clearly distinctive: kept
      {2, 50.0f, 3, 55.0f},   // ambiguous (ratio 0.91): rejected
      {1, 79.0f, 5, 100.0f},  // ratio 0.79 < 0.8: kept
      {6, 80.0f, 0, 100.0f},  // ratio exactly 0.8: rejected (strict)
      {3, 0.0f, -1, 0.0f},    // no second neighbour: rejected
      {-1, 0.0f, -1, 0.0f},   // nothing to match
  };
  const std::vector<FeatureMatch> matches = ApplyRatioTest(nearest, 0.8);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0], (FeatureMatch{0, 4, 10.0f}));
  EXPECT_EQ(matches[1], (FeatureMatch{2, 1, 79.0f}));
  EXPECT_EQ(ApplyRatioTest(nearest, 0.95).size(), 4u);
}

FeatureSet HandMadeSet(const std::vector<std::vector<std::pair<int, int>>>& descriptors) {
  // Each descriptor: a list of (dimension, value), zero elsewhere.
  FeatureSet set;
  for (const auto& entries : descriptors) {
    set.keypoints.push_back({static_cast<float>(set.keypoints.size()), 0, 2, 0, 1, 0});
    set.colors.push_back({0, 0, 0});
    std::vector<std::uint8_t> d(kDescriptorSize, 0);
    for (const auto& [dim, value] : entries) d[dim] = static_cast<std::uint8_t>(value);
    set.descriptors.insert(set.descriptors.end(), d.begin(), d.end());
  }
  return set;
}

TEST(RatioTestTest, MatchDescriptorsOnHandMadeDescriptors) {
  // a0 is near b1 only; a1 is halfway between b2 and b3 (ambiguous); a2 is near b0 only.
  const FeatureSet a = HandMadeSet({{{0, 200}}, {{5, 100}, {6, 100}}, {{9, 150}, {10, 20}}});
  const FeatureSet b =
      HandMadeSet({{{9, 150}, {10, 30}}, {{0, 195}, {1, 10}}, {{5, 200}}, {{6, 200}}});
  DescriptorMatchOptions options;
  options.cross_check = false;
  const std::vector<FeatureMatch> matches = MatchDescriptors(a, b, options);
  ASSERT_EQ(matches.size(), 2u);
  EXPECT_EQ(matches[0].feature1, 0);
  EXPECT_EQ(matches[0].feature2, 1);
  EXPECT_NEAR(matches[0].distance, std::sqrt(5.0f * 5 + 10 * 10), 1e-3);
  EXPECT_EQ(matches[1].feature1, 2);
  EXPECT_EQ(matches[1].feature2, 0);
  // Mutual check: b2 and b3's nearest in a is a1, but that is ambiguous the other way.
  options.cross_check = true;
  EXPECT_EQ(MatchDescriptors(a, b, options), matches);
}

TEST(RatioTestTest, ExhaustiveMatchingOnHandMadeDescriptors) {
  const FeatureSet a = HandMadeSet({{{0, 200}}, {{5, 100}, {6, 100}}, {{9, 150}, {10, 20}}});
  const FeatureSet b =
      HandMadeSet({{{9, 150}, {10, 30}}, {{0, 195}, {1, 10}}, {{5, 200}}, {{6, 200}}});
  DescriptorMatchOptions flann, exhaustive;
  exhaustive.method = DescriptorMatchOptions::Method::kExhaustive;
  for (bool cross_check : {false, true}) {
    flann.cross_check = exhaustive.cross_check = cross_check;
    const std::vector<FeatureMatch> matches = MatchDescriptors(a, b, exhaustive);
    ASSERT_EQ(matches.size(), 2u);
    EXPECT_EQ(matches, MatchDescriptors(a, b, flann));
    EXPECT_NEAR(matches[0].distance, std::sqrt(5.0f * 5 + 10 * 10), 1e-4);
  }
}

// Random descriptors: the exhaustive search finds the true two nearest neighbours both ways
// (checked against a plain loop), and FLANN with many checks agrees on nearly all matches.
TEST(RatioTestTest, ExhaustiveSearchIsExact) {
  std::mt19937 rng(3);
  std::uniform_int_distribution<int> value(0, 255);
  const auto random_set = [&](int n) {
    FeatureSet set;
    for (int i = 0; i < n; ++i) {
      set.keypoints.push_back({static_cast<float>(i), 0, 2, 0, 1, 0});
      set.colors.push_back({0, 0, 0});
      for (int k = 0; k < kDescriptorSize; ++k) {
        set.descriptors.push_back(static_cast<std::uint8_t>(value(rng)));
      }
    }
    return set;
  };
  FeatureSet a = random_set(150), b = random_set(200);
  // Make some clear matches: b's first 60 descriptors are noisy copies of a's.
  for (int i = 0; i < 60; ++i) {
    for (int k = 0; k < kDescriptorSize; ++k) {
      b.descriptors[i * kDescriptorSize + k] = static_cast<std::uint8_t>(
          std::clamp(a.descriptors[(2 * i) * kDescriptorSize + k] + value(rng) % 11 - 5, 0, 255));
    }
  }
  DescriptorMatchOptions options;
  options.method = DescriptorMatchOptions::Method::kExhaustive;
  const DescriptorIndex index_b(b, options);
  const std::vector<TwoNearest> nearest = index_b.SearchTwoNearest(a);
  ASSERT_EQ(nearest.size(), a.size());
  for (std::size_t q = 0; q < a.size(); ++q) {
    std::vector<std::pair<double, int>> all;
    for (std::size_t j = 0; j < b.size(); ++j) {
      double d2 = 0;
      for (int k = 0; k < kDescriptorSize; ++k) {
        const double d = a.Descriptor(q)[k] - b.Descriptor(j)[k];
        d2 += d * d;
      }
      all.emplace_back(d2, static_cast<int>(j));
    }
    std::sort(all.begin(), all.end());
    EXPECT_EQ(nearest[q].index1, all[0].second);
    EXPECT_EQ(nearest[q].index2, all[1].second);
    EXPECT_NEAR(nearest[q].distance1, std::sqrt(all[0].first), 1e-3);
    EXPECT_NEAR(nearest[q].distance2, std::sqrt(all[1].first), 1e-3);
  }
  const std::vector<FeatureMatch> exact = MatchDescriptors(a, b, options);
  EXPECT_EQ(exact.size(), 60u);
  for (const FeatureMatch& m : exact) EXPECT_EQ(m.feature1, 2 * m.feature2);
  DescriptorMatchOptions flann;
  flann.num_checks = 512;
  EXPECT_EQ(MatchDescriptors(a, b, flann), exact);
}

TEST(RatioTestTest, MutualMatchesNeedAgreementBothWays) {
  const std::vector<FeatureMatch> ab = {{0, 3, 1}, {1, 2, 1}, {2, 2, 1}, {4, 9, 1}};
  const std::vector<FeatureMatch> ba = {{3, 0, 1}, {2, 2, 1}};
  const std::vector<FeatureMatch> mutual = MutualMatches(ab, ba);
  ASSERT_EQ(mutual.size(), 2u);
  EXPECT_EQ(mutual[0].feature1, 0);
  EXPECT_EQ(mutual[1].feature1, 2);
}

TEST(MatcherTest, SequentialSchedule) {
  const std::vector<std::pair<int, int>> pairs = SequentialPairs(5, 2);
  const std::vector<std::pair<int, int>> expected = {{0, 1}, {0, 2}, {1, 2}, {1, 3},
                                                     {2, 3}, {2, 4}, {3, 4}};
  EXPECT_EQ(pairs, expected);
  EXPECT_EQ(SequentialPairs(10, 4).size(), 4u * 6 + 3 + 2 + 1);
  EXPECT_TRUE(SequentialPairs(1, 4).empty());
}

// ---- Geometric verification on a 3D scene -----------------------------------------------------

struct TwoViewScene {
  std::vector<Eigen::Vector2d> points1, points2;
  std::vector<bool> is_outlier;
};

// Random points in a 3D volume seen by two cameras 0.5 m apart (non-planar, so F is unique),
// 0.3 px noise, and a fraction of the correspondences replaced by random pixels.
TwoViewScene MakeTwoViewScene(int n, double outlier_fraction, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::normal_distribution<double> noise(0, 0.3);
  const double f = 500, cx = 320, cy = 240;
  const Eigen::Matrix3d R2 =
      Eigen::AngleAxisd(0.1, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  const Eigen::Vector3d t2(-0.5, 0.05, 0.1);  // camera2_from_camera1 translation
  TwoViewScene scene;
  while (static_cast<int>(scene.points1.size()) < n) {
    const Eigen::Vector3d X(1.5 * uniform(rng), 1.0 * uniform(rng), 4 + 2 * uniform(rng));
    const Eigen::Vector3d Y = R2 * X + t2;
    const Eigen::Vector2d x1(f * X.x() / X.z() + cx, f * X.y() / X.z() + cy);
    const Eigen::Vector2d x2(f * Y.x() / Y.z() + cx, f * Y.y() / Y.z() + cy);
    if (x1.x() < 0 || x1.x() > 640 || x1.y() < 0 || x1.y() > 480 || x2.x() < 0 || x2.x() > 640 ||
        x2.y() < 0 || x2.y() > 480) {
      continue;
    }
    const bool outlier = (uniform(rng) + 1) / 2 < outlier_fraction;
    scene.points1.push_back(x1 + Eigen::Vector2d(noise(rng), noise(rng)));
    scene.points2.push_back(
        outlier ? Eigen::Vector2d(320 + 320 * uniform(rng), 240 + 240 * uniform(rng))
                : x2 + Eigen::Vector2d(noise(rng), noise(rng)));
    scene.is_outlier.push_back(outlier);
  }
  return scene;
}

class EpipolarTest : public ::testing::TestWithParam<EpipolarVerificationOptions::Method> {};

TEST_P(EpipolarTest, RansacRemovesInjectedOutliers) {
  const TwoViewScene scene = MakeTwoViewScene(400, 0.3, 3);
  EpipolarVerificationOptions options;
  options.method = GetParam();
  const EpipolarGeometry geometry = EstimateEpipolarGeometry(scene.points1, scene.points2, options);
  ASSERT_TRUE(geometry.verified);
  std::vector<bool> inlier(scene.points1.size(), false);
  for (int i : geometry.inliers) inlier[i] = true;
  int true_kept = 0, num_true = 0, outliers_kept = 0, num_outliers = 0;
  for (std::size_t i = 0; i < inlier.size(); ++i) {
    if (scene.is_outlier[i]) {
      ++num_outliers;
      outliers_kept += inlier[i];
    } else {
      ++num_true;
      true_kept += inlier[i];
    }
  }
  ASSERT_GT(num_outliers, 80);
  EXPECT_GE(true_kept, 0.95 * num_true);
  // A random pixel lies within 2 px of its epipolar line by chance now and then (about 1 in
  // 100 for a 480-px image); the rest must go.
  EXPECT_LE(outliers_kept, 0.05 * num_outliers);
  EXPECT_TRUE(std::is_sorted(geometry.inliers.begin(), geometry.inliers.end()));
  // The true correspondences satisfy the estimated F.
  double sum = 0;
  for (std::size_t i = 0; i < inlier.size(); ++i) {
    if (!scene.is_outlier[i])
      sum += SampsonDistance(geometry.F, scene.points1[i], scene.points2[i]);
  }
  EXPECT_LT(sum / num_true, 0.6);
  // Deterministic.
  const EpipolarGeometry again = EstimateEpipolarGeometry(scene.points1, scene.points2, options);
  EXPECT_EQ(again.inliers, geometry.inliers);
}

INSTANTIATE_TEST_SUITE_P(Methods, EpipolarTest,
                         ::testing::Values(EpipolarVerificationOptions::Method::kRansac8Point,
                                           EpipolarVerificationOptions::Method::kRansac7Point),
                         [](const auto& info) {
                           return info.param == EpipolarVerificationOptions::Method::kRansac8Point
                                      ? "Ransac8Point"
                                      : "Ransac7Point";
                         });

TEST(MatcherTest, TooFewOrNoCorrespondencesAreNotVerified) {
  const TwoViewScene scene = MakeTwoViewScene(12, 0.0, 5);
  EpipolarVerificationOptions options;  // min_num_inliers 20 > 12
  EXPECT_FALSE(EstimateEpipolarGeometry(scene.points1, scene.points2, options).verified);
  EXPECT_FALSE(EstimateEpipolarGeometry({}, {}, options).verified);
  // Pure noise: no consistent geometry.
  const TwoViewScene noise = MakeTwoViewScene(60, 1.0, 6);
  const EpipolarGeometry geometry = EstimateEpipolarGeometry(noise.points1, noise.points2, options);
  EXPECT_FALSE(geometry.verified);
  EXPECT_TRUE(geometry.inliers.empty() || geometry.inliers.size() < 20u);
}

TEST(MatcherTest, SampsonDistanceOfAPointOffItsEpipolarLine) {
  // Pure x translation: F = [t]x with t = (1, 0, 0); epipolar lines are rows y = const.
  Eigen::Matrix3d F;
  F << 0, 0, 0, 0, 0, -1, 0, 1, 0;
  EXPECT_NEAR(SampsonDistance(F, {10, 20}, {50, 20}), 0.0, 1e-12);
  // 3 px off in y in image 2: the first-order distance splits it between the two images.
  EXPECT_NEAR(SampsonDistance(F, {10, 20}, {50, 23}), 3.0 / std::sqrt(2.0), 1e-9);
}

TEST(MatcherTest, CameraModelUndistortsBeforeVerification) {
  // A strong barrel lens; the same 3D points seen from two poses, with identical random
  // descriptors so that matching pairs them all.
  geometry::PinholeRadTan camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 500;
  camera.cx = 319.5;
  camera.cy = 239.5;
  camera.k1 = -0.3;
  camera.k2 = 0.08;
  const Eigen::Matrix3d R2 =
      Eigen::AngleAxisd(0.08, Eigen::Vector3d(0.1, 1, 0.2).normalized()).toRotationMatrix();
  const Eigen::Vector3d t2(-0.4, 0.03, 0.1);
  std::mt19937 rng(9);
  std::uniform_real_distribution<double> uniform(-1, 1);
  std::uniform_int_distribution<int> byte(0, 255);
  FeatureSet a, b;
  while (a.size() < 300) {
    const Eigen::Vector3d X(2.5 * uniform(rng), 1.8 * uniform(rng), 4 + 1.5 * uniform(rng));
    Eigen::Vector2d x1, x2;
    if (!camera.Project(X, &x1) || !camera.Project(R2 * X + t2, &x2) || !camera.IsInImage(x1) ||
        !camera.IsInImage(x2)) {
      continue;
    }
    for (auto [set, x] : {std::pair{&a, x1}, std::pair{&b, x2}}) {
      set->keypoints.push_back({static_cast<float>(x.x()), static_cast<float>(x.y()), 3, 0, 1, 0});
      set->colors.push_back({0, 0, 0});
    }
    for (int d = 0; d < kDescriptorSize; ++d) {
      const auto value = static_cast<std::uint8_t>(byte(rng));
      a.descriptors.push_back(value);
      b.descriptors.push_back(value);
    }
  }
  PairMatcher::Options options;
  options.verification.max_error_px = 1.0;
  const PairMatches with_camera = PairMatcher(options, &camera).Match(0, a, 1, b);
  ASSERT_EQ(with_camera.summary.num_putative, 300);
  for (const FeatureMatch& m : with_camera.matches) EXPECT_EQ(m.feature1, m.feature2);
  EXPECT_TRUE(with_camera.summary.verified);
  EXPECT_GE(with_camera.summary.num_inliers, 297);
  // F is that of the undistorted pixels: K⁻ᵀ [t]ₓ R K⁻¹ (H&Z eq. 9.12), up to scale and sign.
  Eigen::Matrix3d t_cross;
  t_cross << 0, -t2.z(), t2.y(), t2.z(), 0, -t2.x(), -t2.y(), t2.x(), 0;
  const Eigen::Matrix3d K_inv = camera.K().inverse();
  Eigen::Matrix3d F_true = K_inv.transpose() * t_cross * R2 * K_inv;
  F_true /= F_true.norm();
  const double error = std::min((with_camera.F - F_true).norm(), (with_camera.F + F_true).norm());
  EXPECT_LT(error, 1e-3);
  // Without the lens model fewer matches satisfy the pinhole epipolar constraint to 1 px.
  const PairMatches without_camera = PairMatcher(options).Match(0, a, 1, b);
  EXPECT_LT(without_camera.summary.num_inliers, with_camera.summary.num_inliers);
}

// ---- The textured plane ---------------------------------------------------------------------

const testing::PlaneScene& Scene() {
  static const testing::PlaneScene scene = [] {
    testing::PlaneSceneOptions options;
    options.num_views = 4;
    return testing::MakePlaneScene(options);
  }();
  return scene;
}

const std::vector<FeatureSet>& SceneFeatures() {
  static const std::vector<FeatureSet> features = [] {
    std::vector<FeatureSet> out;
    FeatureExtractor::Options options;
    options.max_num_features = 2500;
    const FeatureExtractor extractor(options);
    for (const cv::Mat& view : Scene().views) out.push_back(extractor.Extract(view));
    return out;
  }();
  return features;
}

TEST(MatcherTest, PlaneInliersAgreeWithTrueHomography) {
  const PairMatcher matcher(PairMatcher::Options{});
  for (int j : {1, 3}) {
    const PairMatches pair = matcher.Match(0, SceneFeatures()[0], j, SceneFeatures()[j]);
    ASSERT_TRUE(pair.summary.verified) << j;
    EXPECT_EQ(pair.image1, 0);
    EXPECT_EQ(pair.image2, j);
    EXPECT_GT(pair.summary.num_inliers, 200) << j;
    EXPECT_GE(pair.summary.num_putative, pair.summary.num_inliers);
    int good = 0;
    for (const FeatureMatch& m : pair.InlierMatches()) {
      const Eigen::Vector2d predicted =
          Scene().Transfer(0, j, SceneFeatures()[0].Point(m.feature1));
      if ((predicted - SceneFeatures()[j].Point(m.feature2)).norm() < 2.0) ++good;
    }
    EXPECT_GE(good, 0.95 * pair.summary.num_inliers) << j;
  }
}

TEST(MatcherTest, PlaneRansacRemovesInjectedWrongMatches) {
  const FeatureSet& a = SceneFeatures()[0];
  const FeatureSet& b = SceneFeatures()[1];
  const std::vector<FeatureMatch> matches = MatchDescriptors(a, b, DescriptorMatchOptions{});
  std::vector<Eigen::Vector2d> points1, points2;
  std::vector<bool> injected;
  for (const FeatureMatch& m : matches) {
    points1.push_back(a.Point(m.feature1));
    points2.push_back(b.Point(m.feature2));
    injected.push_back(false);
  }
  // Wrong matches: random features of b at least 20 px from the true transfer.
  std::mt19937 rng(11);
  std::uniform_int_distribution<int> pick_a(0, static_cast<int>(a.size()) - 1);
  std::uniform_int_distribution<int> pick_b(0, static_cast<int>(b.size()) - 1);
  const int num_injected = static_cast<int>(matches.size()) / 3;
  while (std::count(injected.begin(), injected.end(), true) < num_injected) {
    const int i = pick_a(rng), j = pick_b(rng);
    if ((Scene().Transfer(0, 1, a.Point(i)) - b.Point(j)).norm() < 20) continue;
    points1.push_back(a.Point(i));
    points2.push_back(b.Point(j));
    injected.push_back(true);
  }
  const EpipolarGeometry geometry =
      EstimateEpipolarGeometry(points1, points2, EpipolarVerificationOptions{});
  ASSERT_TRUE(geometry.verified);
  int injected_kept = 0;
  for (int i : geometry.inliers) injected_kept += injected[i];
  // A plane makes F ambiguous (any F = H⁻ᵀ[s]ₓ fits it), so a wrong match survives when it
  // happens to lie near its epipolar line; nearly all must still go.
  EXPECT_LE(injected_kept, 0.1 * num_injected);
  EXPECT_GE(static_cast<double>(geometry.inliers.size() - injected_kept), 0.9 * matches.size());
}

TEST(MatcherTest, DescriptorIndexIsReproducible) {
  const DescriptorMatchOptions options;
  const DescriptorIndex index1(SceneFeatures()[1], options);
  const DescriptorIndex index2(SceneFeatures()[1], options);
  EXPECT_EQ(index1.size(), SceneFeatures()[1].size());
  const std::vector<TwoNearest> r1 = index1.SearchTwoNearest(SceneFeatures()[0]);
  const std::vector<TwoNearest> r2 = index2.SearchTwoNearest(SceneFeatures()[0]);
  ASSERT_EQ(r1.size(), r2.size());
  for (std::size_t i = 0; i < r1.size(); ++i) {
    EXPECT_EQ(r1[i].index1, r2[i].index1);
    EXPECT_EQ(r1[i].index2, r2[i].index2);
  }
  // An empty set matches nothing.
  const DescriptorIndex empty(FeatureSet{}, options);
  for (const TwoNearest& n : empty.SearchTwoNearest(SceneFeatures()[0])) EXPECT_EQ(n.index1, -1);
}

}  // namespace
}  // namespace crop4d::features
