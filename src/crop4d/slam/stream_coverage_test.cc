#include "crop4d/slam/stream_coverage.h"

#include <gtest/gtest.h>

#include <cmath>

namespace crop4d::slam {
namespace {

std::vector<Timestamp> Seconds(const std::vector<double>& seconds) {
  std::vector<Timestamp> out;
  for (double s : seconds) out.push_back(SecondsToTimestamp(s));
  return out;
}

GpsFixWorld FixWithSigma(double sigma_h) {
  GpsFixWorld fix;
  fix.sigma_h = sigma_h;
  return fix;
}

TEST(FindTimeGapsTest, RegularSamplesHaveNoGapOverTheThreshold) {
  const std::vector<Timestamp> times = Seconds({0.0, 0.1, 0.2, 0.3, 0.4, 0.5});
  const TimeGaps gaps = FindTimeGaps(times, times.front(), times.back(), 0.5);
  EXPECT_NEAR(gaps.longest_s, 0.1, 1e-9);
  EXPECT_EQ(gaps.count_over, 0);
}

TEST(FindTimeGapsTest, CountsTheGapsOverTheThresholdAndFindsTheLongest) {
  const std::vector<Timestamp> times = Seconds({0.0, 0.1, 1.1, 1.2, 3.2, 3.3});
  const TimeGaps gaps = FindTimeGaps(times, times.front(), times.back(), 0.5);
  EXPECT_NEAR(gaps.longest_s, 2.0, 1e-9);
  EXPECT_EQ(gaps.count_over, 2);
}

TEST(FindTimeGapsTest, TheSpansEndsBoundTheFirstAndLastGap) {
  // Samples only in the middle of [0, 10]: 4 s before the first, 5 s after the last.
  const std::vector<Timestamp> times = Seconds({-3.0, 4.0, 4.5, 5.0, 12.0});
  const TimeGaps gaps = FindTimeGaps(times, SecondsToTimestamp(0.0), SecondsToTimestamp(10.0), 2.0);
  EXPECT_NEAR(gaps.longest_s, 5.0, 1e-9);
  EXPECT_EQ(gaps.count_over, 2);
}

TEST(FindTimeGapsTest, NoSampleInTheSpanIsOneGapOverIt) {
  const TimeGaps gaps = FindTimeGaps({}, SecondsToTimestamp(1.0), SecondsToTimestamp(4.0), 2.0);
  EXPECT_NEAR(gaps.longest_s, 3.0, 1e-9);
  EXPECT_EQ(gaps.count_over, 1);
}

TEST(MedianSigmaHTest, IsInfiniteWithoutFixes) { EXPECT_TRUE(std::isinf(MedianSigmaH({}))); }

// An RTK receiver in float for 55 % of a session (sigma_h 0.15 m against 0.02 m fixed): its
// median is the float's, its first quartile the fixed one's.
TEST(MedianSigmaHTest, AQuantileOfAReceiverMostlyInFloat) {
  std::vector<GpsFixWorld> fixes;
  for (int i = 0; i < 45; ++i) fixes.push_back(FixWithSigma(0.02));
  for (int i = 0; i < 55; ++i) fixes.push_back(FixWithSigma(0.15));
  EXPECT_DOUBLE_EQ(MedianSigmaH(fixes), 0.15);
  EXPECT_DOUBLE_EQ(SigmaHQuantile(fixes, 0.25), 0.02);
  EXPECT_DOUBLE_EQ(SigmaHQuantile(fixes, 0.0), 0.02);
  EXPECT_DOUBLE_EQ(SigmaHQuantile(fixes, 1.0), 0.15);
  EXPECT_TRUE(std::isinf(SigmaHQuantile({}, 0.25)));
}

TEST(MedianSigmaHTest, TakesTheMiddleOfAnOddCountAndTheUpperMedianOfAnEvenOne) {
  EXPECT_DOUBLE_EQ(MedianSigmaH({FixWithSigma(0.5), FixWithSigma(0.02), FixWithSigma(3.0)}), 0.5);
  EXPECT_DOUBLE_EQ(
      MedianSigmaH({FixWithSigma(0.5), FixWithSigma(0.02), FixWithSigma(3.0), FixWithSigma(0.01)}),
      0.5);
}

}  // namespace
}  // namespace crop4d::slam
