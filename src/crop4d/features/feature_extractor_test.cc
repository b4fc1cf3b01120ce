#include "crop4d/features/feature_extractor.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/features/synthetic_plane_test_util.h"

namespace crop4d::features {
namespace {

const testing::PlaneScene& Scene() {
  static const testing::PlaneScene scene = [] {
    testing::PlaneSceneOptions options;
    options.num_views = 2;
    return testing::MakePlaneScene(options);
  }();
  return scene;
}

TEST(FeatureExtractorTest, FindsSortedConsistentFeaturesOnTexture) {
  const cv::Mat& image = Scene().views[0];
  const FeatureSet features = FeatureExtractor(FeatureExtractor::Options()).Extract(image);
  EXPECT_GT(features.size(), 500u);
  EXPECT_TRUE(features.IsConsistent());
  EXPECT_EQ(features.image_width, image.cols);
  EXPECT_EQ(features.image_height, image.rows);
  for (std::size_t i = 0; i < features.size(); ++i) {
    const Keypoint& k = features.keypoints[i];
    EXPECT_GE(k.x, -0.5f);
    EXPECT_GE(k.y, -0.5f);
    EXPECT_LE(k.x, image.cols - 0.5f);
    EXPECT_LE(k.y, image.rows - 0.5f);
    EXPECT_GT(k.size, 0.0f);
    if (i > 0) {
      EXPECT_GE(features.keypoints[i - 1].response, k.response);
    }
  }
  // Colours are the image's, as RGB.
  int close = 0;
  for (std::size_t i = 0; i < features.size(); ++i) {
    const Keypoint& k = features.keypoints[i];
    const cv::Vec3b bgr =
        image.at<cv::Vec3b>(static_cast<int>(std::lround(k.y)), static_cast<int>(std::lround(k.x)));
    const auto& rgb = features.colors[i];
    if (std::abs(rgb[0] - bgr[2]) < 40 && std::abs(rgb[1] - bgr[1]) < 40 &&
        std::abs(rgb[2] - bgr[0]) < 40) {
      ++close;
    }
  }
  EXPECT_GT(close, static_cast<int>(0.9 * features.size()));
}

TEST(FeatureExtractorTest, IsDeterministicAndHonoursMaxFeatures) {
  FeatureExtractor::Options options;
  const FeatureExtractor extractor(options);
  const cv::Mat& image = Scene().views[1];
  EXPECT_EQ(extractor.Extract(image), extractor.Extract(image));
  options.max_num_features = 100;
  const FeatureSet few = FeatureExtractor(options).Extract(image);
  EXPECT_EQ(few.size(), 100u);
  // Grey input gives the same keypoints as colour input.
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(FeatureExtractor(options).Extract(gray).keypoints, few.keypoints);
}

// Gaussian blobs at known sub-pixel centres (pixel centres at integer coordinates) are found
// where they are, at full resolution and downscaled: no systematic offset.
TEST(FeatureExtractorTest, KeypointsAreCentredOnBlobs) {
  std::vector<cv::Point2d> centres;
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j)
      centres.emplace_back(60 + 120 * i + 0.1 * i, 60 + 120 * j + 0.13 * j);
  }
  cv::Mat image(780, 780, CV_8U);
  for (int y = 0; y < image.rows; ++y) {
    for (int x = 0; x < image.cols; ++x) {
      double v = 20;
      for (const cv::Point2d& c : centres) {
        v += 200 * std::exp(-((x - c.x) * (x - c.x) + (y - c.y) * (y - c.y)) / (2 * 6.0 * 6.0));
      }
      image.at<std::uint8_t>(y, x) = cv::saturate_cast<std::uint8_t>(v);
    }
  }
  for (const int max_size : {0, 390}) {
    FeatureExtractor::Options options;
    options.max_image_size = max_size;
    const FeatureSet features = FeatureExtractor(options).Extract(image);
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    int found = 0;
    for (const cv::Point2d& c : centres) {
      double best = 1e9;
      Eigen::Vector2d offset;
      for (const Keypoint& k : features.keypoints) {
        const Eigen::Vector2d d(k.x - c.x, k.y - c.y);
        if (d.norm() < best) {
          best = d.norm();
          offset = d;
        }
      }
      if (best < 2.0) {
        sum += offset;
        ++found;
      }
    }
    ASSERT_GE(found, 30) << "max_image_size " << max_size;
    const Eigen::Vector2d mean = sum / found;
    EXPECT_LT(mean.norm(), 0.06) << "max_image_size " << max_size << ": mean offset "
                                 << mean.transpose();
  }
}

TEST(FeatureExtractorTest, DownscaledExtractionReportsFullResolutionPixels) {
  FeatureExtractor::Options options;
  options.max_image_size = 320;  // half resolution
  const cv::Mat& image = Scene().views[0];
  const FeatureSet half = FeatureExtractor(options).Extract(image);
  ASSERT_GT(half.size(), 100u);
  // The same texture point must be found at full resolution: nearly all downscaled keypoints
  // have a full-resolution keypoint within 2 px.
  const FeatureSet full = FeatureExtractor(FeatureExtractor::Options()).Extract(image);
  int near = 0;
  for (const Keypoint& k : half.keypoints) {
    for (const Keypoint& f : full.keypoints) {
      if (std::hypot(k.x - f.x, k.y - f.y) < 2.0) {
        ++near;
        break;
      }
    }
  }
  EXPECT_GT(near, static_cast<int>(0.7 * half.size()));
  float max_x = 0;
  for (const Keypoint& k : half.keypoints) max_x = std::max(max_x, k.x);
  EXPECT_GT(max_x, image.cols * 0.8f);
}

TEST(FeatureExtractorTest, GridSpreadsTheBudgetOverTheImage) {
  // Texture on the left half only is strong, on the right half weak: the strongest-first rule
  // takes nearly all features on the left; the grid gives the right half its share.
  cv::Mat image = Scene().views[0].clone();
  cv::Mat right = image(cv::Rect(image.cols / 2, 0, image.cols - image.cols / 2, image.rows));
  right.convertTo(right, -1, 0.25, 96);
  FeatureExtractor::Options options;
  options.max_num_features = 400;
  const auto right_share = [&](const FeatureSet& f) {
    int n = 0;
    for (const Keypoint& k : f.keypoints) n += k.x >= image.cols / 2 ? 1 : 0;
    return static_cast<double>(n) / f.size();
  };
  const FeatureSet strongest = FeatureExtractor(options).Extract(image);
  options.spatial_grid_cells = 4;
  const FeatureExtractor grid_extractor(options);
  const FeatureSet grid = grid_extractor.Extract(image);
  ASSERT_EQ(strongest.size(), 400u);
  ASSERT_EQ(grid.size(), 400u);
  EXPECT_TRUE(grid.IsConsistent());
  EXPECT_LT(right_share(strongest), 0.3);
  EXPECT_GT(right_share(grid), 0.4);
  // Sorted strongest first, deterministic, and the descriptors are those of the full
  // extraction for the same keypoints.
  for (std::size_t i = 1; i < grid.size(); ++i) {
    EXPECT_GE(grid.keypoints[i - 1].response, grid.keypoints[i].response);
  }
  EXPECT_EQ(grid_extractor.Extract(image), grid);
  FeatureExtractor::Options all_options;
  all_options.max_num_features = 0;
  const FeatureSet all = FeatureExtractor(all_options).Extract(image);
  int same = 0;
  for (std::size_t i = 0; i < grid.size(); ++i) {
    for (std::size_t j = 0; j < all.size(); ++j) {
      if (all.keypoints[j] == grid.keypoints[i]) {
        same +=
            std::equal(grid.Descriptor(i), grid.Descriptor(i) + kDescriptorSize, all.Descriptor(j))
                ? 1
                : 0;
        break;
      }
    }
  }
  EXPECT_GT(same, static_cast<int>(0.95 * grid.size()));
  // Fewer keypoints than the budget: all of them.
  options.max_num_features = 100000;
  EXPECT_EQ(FeatureExtractor(options).Extract(image).size(), all.size());
}

TEST(FeatureExtractorTest, SharpnessIsTheWorstDirectionsGradientEnergy) {
  // Stripes: texture across one direction only, none along it.
  cv::Mat stripes(240, 512, CV_8UC1);
  for (int v = 0; v < stripes.rows; ++v) {
    for (int u = 0; u < stripes.cols; ++u) {
      stripes.at<std::uint8_t>(v, u) = static_cast<std::uint8_t>(128 + 60 * std::sin(0.3 * u));
    }
  }
  EXPECT_LT(ImageSharpness(stripes), 1e-6);
  EXPECT_EQ(ImageSharpness(cv::Mat(50, 50, CV_8UC1, cv::Scalar(90))), 0.0);
  EXPECT_EQ(ImageSharpness(cv::Mat()), 0.0);
  // Crossed stripes: the structure tensor is diagonal, its smaller entry the energy across the
  // weaker stripes.
  cv::Mat crossed(240, 512, CV_8UC1);
  for (int v = 0; v < crossed.rows; ++v) {
    for (int u = 0; u < crossed.cols; ++u) {
      crossed.at<std::uint8_t>(v, u) =
          static_cast<std::uint8_t>(128 + 60 * std::sin(0.3 * u) + 30 * std::sin(0.3 * v));
    }
  }
  cv::Mat crossed_t;
  cv::transpose(crossed, crossed_t);
  const double s = ImageSharpness(crossed);
  EXPECT_GT(s, 10.0);
  EXPECT_NEAR(ImageSharpness(crossed_t), s, 0.05 * s);  // the direction does not matter

  // The extractor records it; motion blur over 7 pixels, in any direction, and an exposure 30 %
  // short lower it.
  const cv::Mat& image = Scene().views[0];
  const FeatureExtractor extractor(FeatureExtractor::Options{});
  cv::Mat gray;
  cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  const FeatureSet sharp = extractor.Extract(image);
  EXPECT_FLOAT_EQ(sharp.sharpness, static_cast<float>(ImageSharpness(gray)));
  EXPECT_GT(sharp.sharpness, 10.0f);
  for (const cv::Size kernel : {cv::Size(7, 1), cv::Size(1, 7)}) {
    cv::Mat blurred;
    cv::blur(image, blurred, kernel);
    EXPECT_LT(extractor.Extract(blurred).sharpness, 0.75f * sharp.sharpness) << kernel;
  }
  cv::Mat dark;
  image.convertTo(dark, -1, 0.7);
  EXPECT_NEAR(extractor.Extract(dark).sharpness, 0.49f * sharp.sharpness, 0.05f * sharp.sharpness);
}

TEST(FeatureExtractorTest, EmptyAndFlatImagesGiveNoFeatures) {
  const FeatureExtractor extractor(FeatureExtractor::Options{});
  EXPECT_TRUE(extractor.Extract(cv::Mat()).empty());
  const FeatureSet flat = extractor.Extract(cv::Mat(100, 100, CV_8UC3, cv::Scalar(90, 90, 90)));
  EXPECT_TRUE(flat.empty());
  EXPECT_TRUE(flat.IsConsistent());
}

TEST(FeatureExtractorTest, OptionsHashFollowsOptions) {
  FeatureExtractor::Options a, b;
  EXPECT_EQ(a.Check(), "");
  EXPECT_EQ(a.Hash(), b.Hash());
  b.contrast_threshold *= 2;
  EXPECT_NE(a.Hash(), b.Hash());
  b = a;
  b.max_num_features = 10;
  EXPECT_NE(a.Hash(), b.Hash());
  b = a;
  b.spatial_grid_cells = 4;
  EXPECT_NE(a.Hash(), b.Hash());
  b.num_octave_layers = 0;
  EXPECT_NE(b.Check(), "");
}

}  // namespace
}  // namespace crop4d::features
