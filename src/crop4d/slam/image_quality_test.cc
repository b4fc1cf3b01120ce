#include "crop4d/slam/image_quality.h"

#include <gtest/gtest.h>

#include <cmath>

namespace crop4d::slam {
namespace {

TEST(ImageSigmaScalesTest, ImagesLessSharpThanTheirNeighboursAreDownWeighted) {
  const ImageWeightOptions options;
  // Equal images: all 1.
  for (double scale : ImageSigmaScales(std::vector<double>(40, 50.0), options)) {
    EXPECT_EQ(scale, 1.0);
  }
  // One image with a quarter of the gradient energy (blurred): sigma × 2; its neighbours keep
  // 1, and so does a sharper one (never up-weighted).
  std::vector<double> sharpness(40, 50.0);
  sharpness[20] = 12.5;
  sharpness[0] = 30.0;  // at the start: the window shifts inwards, the reference is still 50
  sharpness[30] = 200.0;
  const std::vector<double> scales = ImageSigmaScales(sharpness, options);
  ASSERT_EQ(scales.size(), sharpness.size());
  EXPECT_DOUBLE_EQ(scales[20], 2.0);
  EXPECT_DOUBLE_EQ(scales[0], std::sqrt(50.0 / 30.0));
  EXPECT_EQ(scales[30], 1.0);
  EXPECT_EQ(scales[19], 1.0);
  EXPECT_EQ(scales[21], 1.0);
}

TEST(ImageSigmaScalesTest, TheSceneMayChangeAlongThePass) {
  // Sharpness triples smoothly along the pass (soil, then plants): no image is singled out,
  // since each is compared with the images around it.
  std::vector<double> sharpness;
  for (int i = 0; i < 100; ++i) sharpness.push_back(20.0 * std::pow(3.0, i / 99.0));
  for (double scale : ImageSigmaScales(sharpness, ImageWeightOptions())) EXPECT_LT(scale, 1.05);
}

TEST(ImageSigmaScalesTest, UnmeasuredImagesDisabledAndTheCap) {
  ImageWeightOptions options;
  // Not measured (0): 1, and no reference for the others.
  std::vector<double> sharpness(20, 0.0);
  sharpness[5] = 10.0;
  sharpness[6] = 40.0;
  std::vector<double> scales = ImageSigmaScales(sharpness, options);
  EXPECT_EQ(scales[0], 1.0);
  EXPECT_DOUBLE_EQ(scales[5], std::sqrt(4.0));  // the median of {10, 40} is 40
  EXPECT_EQ(scales[6], 1.0);
  // Far worse: capped.
  sharpness.assign(20, 100.0);
  sharpness[10] = 0.01;
  EXPECT_DOUBLE_EQ(ImageSigmaScales(sharpness, options)[10], options.max_sigma_scale);
  // Off: every image weighs the same.
  options.enabled = false;
  for (double scale : ImageSigmaScales(sharpness, options)) EXPECT_EQ(scale, 1.0);
  EXPECT_TRUE(ImageSigmaScales({}, ImageWeightOptions()).empty());
}

TEST(ImageSigmaScalesTest, OptionsAreChecked) {
  ImageWeightOptions options;
  EXPECT_TRUE(options.Check().empty());
  options.window = 4;
  EXPECT_NE(options.Check().find("window"), std::string::npos);
  options = ImageWeightOptions();
  options.max_sigma_scale = 0.5;
  EXPECT_NE(options.Check().find("max_sigma_scale"), std::string::npos);
}

}  // namespace
}  // namespace crop4d::slam
