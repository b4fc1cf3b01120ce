// Vegetation by colour: the indices on known colours, Otsu's threshold on known samples, and
// the classification of synthetic soil/leaf colour sets with noise.

#include "crop4d/analysis/vegetation.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>

namespace crop4d::analysis {
namespace {

using Color = std::array<std::uint8_t, 3>;

std::uint8_t Clamp8(double v) {
  return static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
}

// Soil of the synthetic field: between bright (149,126,103) and dark (72,60,50) soil, with a
// brightness variation and independent per-channel noise of 2 levels.
Color Soil(std::mt19937& rng) {
  std::uniform_real_distribution<double> mix(0.0, 1.0), brightness(0.7, 1.15);
  std::normal_distribution<double> noise(0.0, 2.0);
  const double m = mix(rng), s = brightness(rng);
  const double base[3] = {149 + m * (72 - 149), 126 + m * (60 - 126), 103 + m * (50 - 103)};
  return {Clamp8(s * base[0] + noise(rng)), Clamp8(s * base[1] + noise(rng)),
          Clamp8(s * base[2] + noise(rng))};
}

// Leaves: between (62,85,44) and (90,110,60), brightness 0.7..1.4, noise of 3 levels.
Color Leaf(std::mt19937& rng) {
  std::uniform_real_distribution<double> mix(0.0, 1.0), brightness(0.7, 1.4);
  std::normal_distribution<double> noise(0.0, 3.0);
  const double m = mix(rng), s = brightness(rng);
  const double base[3] = {62 + m * (90 - 62), 85 + m * (110 - 85), 44 + m * (60 - 44)};
  return {Clamp8(s * base[0] + noise(rng)), Clamp8(s * base[1] + noise(rng)),
          Clamp8(s * base[2] + noise(rng))};
}

// `n` colours, a fraction `leaves` of them leaves (shuffled); `truth` says which.
std::vector<Color> Mixed(int n, double leaves, std::uint32_t seed, std::vector<bool>* truth) {
  std::mt19937 rng(seed);
  std::vector<Color> colors;
  truth->clear();
  const int num_leaves = static_cast<int>(std::lround(leaves * n));
  for (int i = 0; i < n; ++i) {
    const bool leaf = i < num_leaves;
    colors.push_back(leaf ? Leaf(rng) : Soil(rng));
    truth->push_back(leaf);
  }
  // Shuffle both the same way.
  for (int i = n - 1; i > 0; --i) {
    const int j = std::uniform_int_distribution<int>(0, i)(rng);
    std::swap(colors[i], colors[j]);
    const bool t = (*truth)[i];
    (*truth)[i] = (*truth)[j];
    (*truth)[j] = t;
  }
  return colors;
}

double Accuracy(const VegetationClassification& c, const std::vector<bool>& truth) {
  int correct = 0;
  for (std::size_t i = 0; i < truth.size(); ++i) correct += (c.is_vegetation[i] != 0) == truth[i];
  return static_cast<double>(correct) / static_cast<double>(truth.size());
}

TEST(GreennessTest, IndicesOfKnownColours) {
  EXPECT_FLOAT_EQ(Greenness(GreennessIndex::kExG, 0, 255, 0), 2.0f);
  EXPECT_FLOAT_EQ(Greenness(GreennessIndex::kExG, 255, 0, 0), -1.0f);
  EXPECT_FLOAT_EQ(Greenness(GreennessIndex::kExG, 0, 0, 0), 0.0f);  // black
  EXPECT_FLOAT_EQ(Greenness(GreennessIndex::kExG, 90, 90, 90), 0.0f);
  EXPECT_FLOAT_EQ(Greenness(GreennessIndex::kExGR, 0, 0, 0), 0.0f);
  // ExGR of grey: ExG 0, ExR = 1.4/3 - 1/3.
  EXPECT_NEAR(Greenness(GreennessIndex::kExGR, 90, 90, 90), -0.4 / 3.0, 1e-6);
  // Our field's soil and leaves.
  EXPECT_NEAR(Greenness(GreennessIndex::kExG, 149, 126, 103), 0.0, 0.01);
  EXPECT_NEAR(Greenness(GreennessIndex::kExG, 72, 60, 50), 0.0, 0.02);
  EXPECT_NEAR(Greenness(GreennessIndex::kExG, 62, 85, 44), 64.0 / 191.0, 1e-6);
  EXPECT_GT(Greenness(GreennessIndex::kExG, 90, 110, 60), 0.25);
  EXPECT_LT(Greenness(GreennessIndex::kExGR, 149, 126, 103), -0.15);
  EXPECT_GT(Greenness(GreennessIndex::kExGR, 62, 85, 44), 0.25);
  EXPECT_STREQ(GreennessIndexName(GreennessIndex::kExGR), "ExGR");
}

TEST(OtsuTest, SplitsABimodalSampleBetweenTheModes) {
  std::mt19937 rng(7);
  std::normal_distribution<float> soil(0.0f, 0.02f), leaves(0.3f, 0.03f);
  std::vector<float> values;
  for (int i = 0; i < 700; ++i) values.push_back(soil(rng));
  for (int i = 0; i < 300; ++i) values.push_back(leaves(rng));
  const OtsuResult otsu = OtsuThreshold(values);
  EXPECT_EQ(otsu.num_values, 1000u);
  EXPECT_GT(otsu.threshold, 0.08);
  EXPECT_LT(otsu.threshold, 0.22);
  EXPECT_GT(otsu.separability, 0.9);
  EXPECT_LE(otsu.separability, 1.0);
}

TEST(OtsuTest, TwoValuesAreSplitInTheMiddleWithFullSeparability) {
  const OtsuResult otsu = OtsuThreshold({0.0f, 0.0f, 1.0f, 0.0f, 1.0f});
  EXPECT_NEAR(otsu.threshold, 0.5, 1e-9);
  EXPECT_NEAR(otsu.separability, 1.0, 1e-9);
}

// The separability of unimodal distributions, what VegetationOptions::min_separability rests
// on: 2/pi for a Gaussian, 3/4 for a uniform distribution.
TEST(OtsuTest, UnimodalSeparabilityIsBelowTheDefaultMinimum) {
  std::mt19937 rng(3);
  std::normal_distribution<float> gaussian(0.0f, 1.0f);
  std::uniform_real_distribution<float> uniform(-1.0f, 1.0f);
  std::vector<float> g, u;
  for (int i = 0; i < 200000; ++i) {
    g.push_back(gaussian(rng));
    u.push_back(uniform(rng));
  }
  const OtsuResult og = OtsuThreshold(g), ou = OtsuThreshold(u);
  EXPECT_NEAR(og.separability, 2.0 / M_PI, 0.01);
  EXPECT_NEAR(og.threshold, 0.0, 0.1);
  EXPECT_NEAR(ou.separability, 0.75, 0.01);
  EXPECT_LT(og.separability, VegetationOptions().min_separability);
  EXPECT_LT(ou.separability, VegetationOptions().min_separability);
}

TEST(OtsuTest, IgnoresNaNAndSurvivesDegenerateInput) {
  const float nan = std::numeric_limits<float>::quiet_NaN();
  const OtsuResult empty = OtsuThreshold({});
  EXPECT_TRUE(std::isnan(empty.threshold));
  EXPECT_EQ(empty.separability, 0.0);
  EXPECT_EQ(empty.num_values, 0u);
  const OtsuResult only_nan = OtsuThreshold({nan, nan});
  EXPECT_TRUE(std::isnan(only_nan.threshold));
  EXPECT_EQ(only_nan.num_values, 0u);
  const OtsuResult constant = OtsuThreshold({0.2f, 0.2f, nan, 0.2f});
  EXPECT_FLOAT_EQ(static_cast<float>(constant.threshold), 0.2f);
  EXPECT_EQ(constant.separability, 0.0);
  EXPECT_EQ(constant.num_values, 3u);
  const OtsuResult with_nan = OtsuThreshold({0.0f, nan, 1.0f, nan, 0.0f, 1.0f}, 2);
  EXPECT_EQ(with_nan.num_values, 4u);
  EXPECT_NEAR(with_nan.threshold, 0.5, 1e-9);
  EXPECT_NEAR(with_nan.separability, 1.0, 1e-9);
}

TEST(ClassifyVegetationTest, SoilOnlyHasAlmostNoVegetation) {
  std::vector<bool> truth;
  const std::vector<Color> colors = Mixed(20000, 0.0, 11, &truth);
  for (const GreennessIndex index : {GreennessIndex::kExG, GreennessIndex::kExGR}) {
    VegetationOptions options;
    options.index = index;
    const VegetationClassification c = ClassifyVegetation(colors, options);
    ASSERT_EQ(c.is_vegetation.size(), colors.size());
    ASSERT_EQ(c.index.size(), colors.size());
    EXPECT_LT(c.Fraction(), 0.01) << GreennessIndexName(index);
    EXPECT_FALSE(c.automatic) << GreennessIndexName(index) << " eta " << c.separability;
    EXPECT_DOUBLE_EQ(c.threshold, options.min_threshold);
  }
}

TEST(ClassifyVegetationTest, FindsLeavesAmongSoil) {
  for (const GreennessIndex index : {GreennessIndex::kExG, GreennessIndex::kExGR}) {
    for (const double leaves : {0.05, 0.1, 0.3, 0.7}) {
      std::vector<bool> truth;
      const std::vector<Color> colors =
          Mixed(10000, leaves, 100 + static_cast<int>(100 * leaves), &truth);
      VegetationOptions options;
      options.index = index;
      const VegetationClassification c = ClassifyVegetation(colors, options);
      const std::string label =
          std::string(GreennessIndexName(index)) + " leaves " + std::to_string(leaves);
      EXPECT_GE(Accuracy(c, truth), 0.97) << label << " threshold " << c.threshold;
      EXPECT_TRUE(c.automatic) << label << " eta " << c.separability;
      EXPECT_NEAR(c.Fraction(), leaves, 0.02) << label;
      EXPECT_GE(c.threshold, options.min_threshold) << label;
      std::size_t counted = 0;
      for (const std::uint8_t v : c.is_vegetation) counted += v;
      EXPECT_EQ(counted, c.num_vegetation);
    }
  }
}

// Soil, shaded leaves (ExG ~0.3) and sunlit leaves (ExG ~0.7), as in the synthetic field's
// late sessions: Otsu alone splits the two leaf modes; the descent finds the soil boundary.
TEST(ClassifyVegetationTest, SeveralLeafModesAreAllVegetation) {
  std::mt19937 rng(21);
  std::normal_distribution<double> noise(0.0, 3.0);
  std::vector<Color> colors;
  std::vector<bool> truth;
  for (int i = 0; i < 9000; ++i) {
    colors.push_back(Soil(rng));
    truth.push_back(false);
  }
  for (int i = 0; i < 400; ++i) {
    colors.push_back(Leaf(rng));
    truth.push_back(true);
  }
  for (int i = 0; i < 600; ++i) {
    colors.push_back({Clamp8(60 + noise(rng)), Clamp8(130 + noise(rng)), Clamp8(40 + noise(rng))});
    truth.push_back(true);
  }
  const OtsuResult otsu = OtsuThreshold([&] {
    std::vector<float> v;
    for (const Color& c : colors) v.push_back(Greenness(GreennessIndex::kExG, c[0], c[1], c[2]));
    return v;
  }());
  VegetationOptions otsu_only;
  otsu_only.threshold = otsu.threshold;
  EXPECT_LT(Accuracy(ClassifyVegetation(colors, otsu_only), truth), 0.99) << otsu.threshold;
  const VegetationClassification c = ClassifyVegetation(colors);
  EXPECT_TRUE(c.automatic);
  EXPECT_GT(c.threshold, 0.05);
  EXPECT_LT(c.threshold, 0.25);
  EXPECT_GE(Accuracy(c, truth), 0.99);
}

TEST(ClassifyVegetationTest, LeavesOnlyAreAllVegetation) {
  std::vector<bool> truth;
  std::vector<Color> colors = Mixed(5000, 1.0, 5, &truth);
  const VegetationClassification c = ClassifyVegetation(colors);
  EXPECT_GT(c.Fraction(), 0.99);
  // Shaded and sunlit leaves, no soil (a closed canopy): two modes, both plants.
  std::mt19937 rng(8);
  std::normal_distribution<double> noise(0.0, 3.0);
  for (int i = 0; i < 5000; ++i) {
    colors.push_back({Clamp8(60 + noise(rng)), Clamp8(130 + noise(rng)), Clamp8(40 + noise(rng))});
  }
  const VegetationClassification two_modes = ClassifyVegetation(colors);
  EXPECT_GT(two_modes.separability, 0.8);
  EXPECT_FALSE(two_modes.automatic);
  EXPECT_GT(two_modes.Fraction(), 0.99);
}

TEST(ClassifyVegetationTest, ManualThresholdIsRespected) {
  std::vector<bool> truth;
  const std::vector<Color> colors = Mixed(2000, 0.3, 9, &truth);
  VegetationOptions options;
  options.threshold = 0.5;  // above every leaf
  const VegetationClassification c = ClassifyVegetation(colors, options);
  EXPECT_DOUBLE_EQ(c.threshold, 0.5);
  EXPECT_FALSE(c.automatic);
  EXPECT_GT(c.separability, 0.8);  // still reported
  for (std::size_t i = 0; i < colors.size(); ++i) {
    EXPECT_EQ(c.is_vegetation[i] != 0, c.index[i] > 0.5f);
  }
  options.threshold = -0.5;  // below every soil
  EXPECT_EQ(ClassifyVegetation(colors, options).num_vegetation, colors.size());
}

TEST(ClassifyVegetationTest, EmptyAndConstantInput) {
  const VegetationClassification empty = ClassifyVegetation({});
  EXPECT_TRUE(empty.is_vegetation.empty());
  EXPECT_EQ(empty.num_vegetation, 0u);
  EXPECT_EQ(empty.Fraction(), 0.0);
  EXPECT_DOUBLE_EQ(empty.threshold, VegetationOptions().min_threshold);
  const std::vector<Color> green(10, Color{60, 90, 40});
  const VegetationClassification constant = ClassifyVegetation(green);
  EXPECT_EQ(constant.separability, 0.0);
  EXPECT_FALSE(constant.automatic);
  EXPECT_EQ(constant.num_vegetation, 10u);  // above min_threshold
  const std::vector<Color> black(10, Color{0, 0, 0});
  EXPECT_EQ(ClassifyVegetation(black).num_vegetation, 0u);
}

// The colours counted a part at a time (a session read in tiles) give the threshold of the
// whole cloud, and ClassifyVegetation applies it.
TEST(ColourHistogramTest, PartsGiveTheThresholdOfTheWhole) {
  std::vector<bool> truth;
  const std::vector<Color> colors = Mixed(20000, 0.08, 17, &truth);
  const VegetationClassification whole = ClassifyVegetation(colors);
  ASSERT_TRUE(whole.automatic);
  ColourHistogram parts;
  for (std::size_t start = 0; start < colors.size(); start += 3001) {
    const std::size_t end = std::min(colors.size(), start + 3001);
    parts.Add(std::vector<Color>(colors.begin() + start, colors.begin() + end));
  }
  EXPECT_EQ(parts.total(), colors.size());
  const VegetationClassification from_parts = VegetationThreshold(parts);
  EXPECT_EQ(from_parts.threshold, whole.threshold);
  EXPECT_EQ(from_parts.separability, whole.separability);
  EXPECT_EQ(from_parts.automatic, whole.automatic);
  EXPECT_TRUE(from_parts.is_vegetation.empty());
  std::size_t vegetation = 0;
  for (std::size_t i = 0; i < colors.size(); ++i) {
    const bool v = IsVegetationColour(from_parts, GreennessIndex::kExG, colors[i]);
    EXPECT_EQ(v, whole.is_vegetation[i] != 0);
    vegetation += v ? 1 : 0;
  }
  EXPECT_EQ(vegetation, whole.num_vegetation);
  EXPECT_GT(Accuracy(whole, truth), 0.99);
}

// Weights count a value that many times.
TEST(OtsuTest, WeightsCountValuesRepeatedly) {
  const std::vector<float> repeated = {0.1f, 0.1f, 0.1f, 0.2f, 0.8f, 0.8f, 0.9f};
  const OtsuResult a = OtsuThreshold(repeated, 16);
  const OtsuResult b = OtsuThreshold({0.1f, 0.2f, 0.8f, 0.9f, 0.5f}, {3.0, 1.0, 2.0, 1.0, 0.0}, 16);
  EXPECT_EQ(a.threshold, b.threshold);
  EXPECT_EQ(a.separability, b.separability);
  EXPECT_EQ(b.num_values, 7u);
}

TEST(VegetationOptionsTest, CheckRejectsBadOptions) {
  EXPECT_EQ(VegetationOptions().Check(), "");
  VegetationOptions o;
  o.threshold = 0.1;
  EXPECT_EQ(o.Check(), "");
  o.threshold = std::numeric_limits<double>::infinity();
  EXPECT_NE(o.Check(), "");
  o = VegetationOptions();
  o.min_threshold = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.Check(), "");
  o = VegetationOptions();
  o.min_separability = 1.5;
  EXPECT_NE(o.Check(), "");
  o.min_separability = -0.1;
  EXPECT_NE(o.Check(), "");
  o = VegetationOptions();
  o.histogram_bins = 1;
  EXPECT_NE(o.Check(), "");
  o = VegetationOptions();
  o.index = static_cast<GreennessIndex>(7);
  EXPECT_NE(o.Check(), "");
}

}  // namespace
}  // namespace crop4d::analysis
