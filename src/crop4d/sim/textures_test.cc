#include "crop4d/sim/textures.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdlib>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace crop4d::sim {
namespace {

SoilTextureOptions Small() {
  SoilTextureOptions options;
  options.size_px = 512;
  options.extent_m = 0.5;  // the same texel size as the 4096² / 4 m default
  return options;
}

double MeanAbsDiff(const cv::Mat& a, const cv::Mat& b) {
  cv::Mat diff;
  cv::absdiff(a, b, diff);
  const cv::Scalar m = cv::mean(diff);
  return (m[0] + m[1] + m[2]) / 3.0;
}

TEST(SoilTextureTest, DeterministicAndRerandomisedByRain) {
  const cv::Mat a = GenerateSoilTexture(Small());
  const cv::Mat b = GenerateSoilTexture(Small());
  ASSERT_EQ(a.type(), CV_8UC4);
  ASSERT_EQ(a.rows, 512);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  SoilTextureOptions rained = Small();
  rained.epoch = 1;
  const cv::Mat c = GenerateSoilTexture(rained);
  EXPECT_GT(MeanAbsDiff(a, c), 15.0);
  // Rain smooths the clods: less local contrast.
  auto contrast = [](const cv::Mat& rgba) {
    cv::Mat gray, lap;
    cv::cvtColor(rgba, gray, cv::COLOR_RGBA2GRAY);
    cv::Laplacian(gray, lap, CV_32F);
    return cv::mean(cv::abs(lap))[0];
  };
  SoilTextureOptions much_later = Small();
  much_later.epoch = 6;
  EXPECT_LT(contrast(GenerateSoilTexture(much_later)), contrast(a));
}

TEST(SoilTextureTest, TilesSeamlessly) {
  const cv::Mat t = GenerateSoilTexture(Small());
  // Across the wrap-around seam neighbouring texels differ as much as anywhere else.
  cv::Mat gray;
  cv::cvtColor(t, gray, cv::COLOR_RGBA2GRAY);
  gray.convertTo(gray, CV_32F);
  double seam = 0.0, inside = 0.0;
  for (int y = 0; y < gray.rows; ++y) {
    seam += std::abs(gray.at<float>(y, 0) - gray.at<float>(y, gray.cols - 1));
    for (int x = 0; x + 1 < gray.cols; ++x) {
      inside += std::abs(gray.at<float>(y, x) - gray.at<float>(y, x + 1)) / (gray.cols - 1.0);
    }
  }
  EXPECT_LT(seam, 1.5 * inside);
}

TEST(SoilTextureTest, PeriodicNoiseWraps) {
  const cv::Mat n = PeriodicValueNoise(256, 16, 3);
  double seam = 0.0, inside = 0.0, max_abs = 0.0;
  for (int y = 0; y < 256; ++y) {
    seam += std::abs(n.at<float>(y, 0) - n.at<float>(y, 255));
    for (int x = 0; x + 1 < 256; ++x) {
      inside += std::abs(n.at<float>(y, x) - n.at<float>(y, x + 1)) / 255.0;
      max_abs = std::max(max_abs, static_cast<double>(std::abs(n.at<float>(y, x))));
    }
  }
  EXPECT_LT(seam, 2.0 * inside);
  EXPECT_LT(max_abs, 1.3);
}

TEST(SoilTextureTest, MacroAndFoliage) {
  const cv::Mat macro = GenerateSoilMacroTexture(1, 64);
  ASSERT_EQ(macro.type(), CV_8UC4);
  const cv::Scalar mean = cv::mean(macro);
  EXPECT_NEAR(mean[1], 200.0, 30.0);  // colour multiplier ≈ 1 (×255/200)
  const cv::Mat foliage = GenerateFoliageTexture(1, 256, 64);
  const cv::Scalar f = cv::mean(foliage);
  EXPECT_GT(f[1], f[0]);  // green
  EXPECT_GT(f[1], f[2]);
}

// The CPU sampler the renderer uses for the soil macro texture per vertex must sample as the GPU
// did per pixel: texel centres exact, GL_REPEAT in both directions (negative coordinates too),
// bilinear between neighbours across the texture's edge.
TEST(SampleRepeatTest, BilinearWithRepeatWrappingAndTexelCentres) {
  cv::Mat rgba(6, 8, CV_8UC4);
  cv::RNG rng(7);
  rng.fill(rgba, cv::RNG::UNIFORM, 0, 256);
  const int w = rgba.cols, h = rgba.rows;
  std::uint8_t out[4];
  for (int j = 0; j < h; ++j) {
    for (int i = 0; i < w; ++i) {
      SampleRepeat(rgba, (i + 0.5) / w, (j + 0.5) / h, out);
      const cv::Vec4b& texel = rgba.at<cv::Vec4b>(j, i);
      for (int c = 0; c < 4; ++c) ASSERT_EQ(out[c], texel[c]) << i << "," << j;
    }
  }
  // Half-way between the last and the first column, on the centre of row 2: their mean.
  SampleRepeat(rgba, 0.0, 2.5 / h, out);
  for (int c = 0; c < 4; ++c) {
    const double mean = 0.5 * (rgba.at<cv::Vec4b>(2, w - 1)[c] + rgba.at<cv::Vec4b>(2, 0)[c]);
    EXPECT_LE(std::abs(out[c] - mean), 0.5) << c;
  }
  // Against OpenCV's bilinear remap with wrapping, at coordinates far outside [0, 1) and
  // negative, which must give what their fraction gives. OpenCV rounds the sampling position to
  // 1/32 texel, so on this random texture (neighbours up to 255 apart) it may differ by up to 4
  // levels; half a texel off or a wrong wrap would differ by tens.
  const double us[] = {-3.17, -0.01, 0.33, 0.999, 1.0, 7.61};
  const double vs[] = {-11.9, -0.5, 0.07, 0.5, 2.96};
  for (const double u : us) {
    for (const double v : vs) {
      cv::Mat map_x(1, 1, CV_32F), map_y(1, 1, CV_32F), sampled;
      const double fu = u - std::floor(u), fv = v - std::floor(v);
      map_x.at<float>(0, 0) = static_cast<float>(fu * w - 0.5);
      map_y.at<float>(0, 0) = static_cast<float>(fv * h - 0.5);
      cv::remap(rgba, sampled, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_WRAP);
      SampleRepeat(rgba, u, v, out);
      std::uint8_t in_unit[4];
      SampleRepeat(rgba, fu, fv, in_unit);
      for (int c = 0; c < 4; ++c) {
        EXPECT_EQ(out[c], in_unit[c]) << u << "," << v;
        EXPECT_LE(std::abs(out[c] - sampled.at<cv::Vec4b>(0, 0)[c]), 4) << u << "," << v;
      }
    }
  }
}

// Share of texels whose colour differs between two RGBA textures.
double ChangedFraction(const cv::Mat& a, const cv::Mat& b) {
  int changed = 0;
  for (int r = 0; r < a.rows; ++r) {
    for (int c = 0; c < a.cols; ++c) {
      const cv::Vec4b x = a.at<cv::Vec4b>(r, c), y = b.at<cv::Vec4b>(r, c);
      changed += x[0] != y[0] || x[1] != y[1] || x[2] != y[2];
    }
  }
  return static_cast<double>(changed) / (a.rows * a.cols);
}

TEST(SoilTextureTest, SoilChangesLocallyAndPartiallyBetweenSessions) {
  const SoilTextureOptions base_options = Small();
  const cv::Mat base = GenerateSoilTexture(base_options);
  SoilChangeOptions change;
  change.fraction = 0.2;
  change.patch_m = 0.05;
  // The mask covers exactly the fraction, in patches (most renewed texels have renewed
  // neighbours).
  const cv::Mat mask = SoilChangeMask(512, 0.5, 0.05, 0.2, 9);
  EXPECT_EQ(cv::countNonZero(mask), std::llround(0.2 * 512 * 512));
  int inner = 0;
  for (int r = 1; r < 511; ++r) {
    for (int c = 1; c < 511; ++c) {
      if (mask.at<std::uint8_t>(r, c) && mask.at<std::uint8_t>(r - 1, c) &&
          mask.at<std::uint8_t>(r + 1, c) && mask.at<std::uint8_t>(r, c - 1) &&
          mask.at<std::uint8_t>(r, c + 1)) {
        ++inner;
      }
    }
  }
  EXPECT_GT(inner, 0.8 * cv::countNonZero(mask));
  // Level 0 is the epoch's own texture; every later session renews about `fraction` of it.
  EXPECT_EQ(MeanAbsDiff(ApplySoilChange(base_options, base, 0, change), base), 0.0);
  cv::Mat previous = base;
  for (int level = 1; level <= 3; ++level) {
    const cv::Mat now = ApplySoilChange(base_options, base, level, change);
    const double between = ChangedFraction(previous, now);
    EXPECT_GT(between, 0.15) << level;
    EXPECT_LT(between, 0.21) << level;
    previous = now;
  }
  // Most of the pattern survives two sessions: ≈ 1 − (1 − 0.2)² = 36 % has changed.
  const double two = ChangedFraction(base, ApplySoilChange(base_options, base, 2, change));
  EXPECT_GT(two, 0.28);
  EXPECT_LT(two, 0.40);
  // Drying brightens the soil by the configured fraction per session.
  change.fraction = 0.0;
  change.drying = 0.03;
  const cv::Mat dry = ApplySoilChange(base_options, base, 2, change);
  const double gain = cv::mean(dry)[1] / cv::mean(base)[1];
  EXPECT_NEAR(gain, 1.06, 0.01);
}

}  // namespace
}  // namespace crop4d::sim
