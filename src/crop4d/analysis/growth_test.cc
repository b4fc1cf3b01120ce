// Growth curves: a known logistic recovered from its samples, the four-session case before the
// plateau, an outlier, and the expected failures (too few points, no growth).

#include "crop4d/analysis/growth.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace crop4d::analysis {
namespace {

std::vector<GrowthObservation> Sample(const LogisticCurve& curve, double first, double step,
                                      int n) {
  std::vector<GrowthObservation> obs;
  for (int i = 0; i < n; ++i) {
    const double day = first + step * i;
    obs.push_back({day, curve.Evaluate(day)});
  }
  return obs;
}

TEST(LogisticCurveTest, EvaluatesKnownValues) {
  const LogisticCurve c{0.8, 0.1, 40.0};
  EXPECT_TRUE(c.valid());
  EXPECT_DOUBLE_EQ(c.Evaluate(40.0), 0.4);
  EXPECT_NEAR(c.Evaluate(40.0 + std::log(3.0) / 0.1), 0.6, 1e-12);  // 1/(1+1/3) = 3/4
  EXPECT_NEAR(c.Evaluate(1e6), 0.8, 1e-12);                         // no overflow
  EXPECT_NEAR(c.Evaluate(-1e6), 0.0, 1e-12);
  EXPECT_DOUBLE_EQ(c.MaxGrowthRate(), 0.02);
  EXPECT_DOUBLE_EQ(c.GrowthRate(40.0), 0.02);
  EXPECT_FALSE(LogisticCurve().valid());
  EXPECT_TRUE(std::isnan(LogisticCurve().Evaluate(3.0)));
}

TEST(FitGrowthTest, RecoversANoiselessLogistic) {
  // Days of the year 105..189, fastest growth on day 150 (45 days after the first sample).
  const LogisticCurve shifted{0.9, 0.1, 150.0};
  std::vector<GrowthObservation> obs = Sample(shifted, 105.0, 12.0, 8);
  std::swap(obs[1], obs[5]);  // any order
  const GrowthFit fit = FitGrowth(obs);
  ASSERT_EQ(fit.status, GrowthFit::Status::kFitted) << fit.message;
  EXPECT_EQ(fit.num_points, 8);
  EXPECT_NEAR(fit.curve.asymptote_m, 0.9, 0.009);
  EXPECT_NEAR(fit.curve.rate_per_day, 0.1, 0.001);
  EXPECT_NEAR(fit.curve.midpoint_day, 150.0, 1.5);          // 1% of the day value
  EXPECT_NEAR(fit.curve.midpoint_day - 105.0, 45.0, 0.45);  // 1% of the time from the start
  EXPECT_LT(fit.rmse_m, 1e-5);
  EXPECT_FALSE(fit.asymptote_at_bound);
  EXPECT_NEAR(fit.curve.MaxGrowthRate(), 0.0225, 2e-4);
  ASSERT_EQ(fit.intervals.size(), 7u);
  EXPECT_DOUBLE_EQ(fit.intervals[0].day_from, 105.0);
  EXPECT_DOUBLE_EQ(fit.intervals[0].day_to, 117.0);
  EXPECT_NEAR(fit.intervals[0].rate_m_per_day,
              (shifted.Evaluate(117.0) - shifted.Evaluate(105.0)) / 12.0, 1e-12);
}

// The demo field: 4 sessions 14 days apart, still before the plateau.
TEST(FitGrowthTest, FourSessionsBeforeThePlateauAreInterpolated) {
  const std::vector<GrowthObservation> obs = {{0, 0.08}, {14, 0.16}, {28, 0.28}, {42, 0.38}};
  const GrowthFit fit = FitGrowth(obs);
  ASSERT_EQ(fit.status, GrowthFit::Status::kFitted) << fit.message;
  EXPECT_LT(fit.rmse_m, 0.01) << fit.message;
  for (const GrowthObservation& o : obs) {
    EXPECT_NEAR(fit.curve.Evaluate(o.day), o.height_m, 0.01) << o.day;
  }
  // A sensible curve: K above the tallest observation and within its bound, the fastest
  // growth near the observed growth rates (0.57..0.86 cm/day).
  EXPECT_GT(fit.curve.asymptote_m, 0.38);
  EXPECT_LE(fit.curve.asymptote_m, 3.0 * 0.38 + 1e-9);
  EXPECT_GT(fit.curve.MaxGrowthRate(), 0.006);
  EXPECT_LT(fit.curve.MaxGrowthRate(), 0.02);
  ASSERT_EQ(fit.intervals.size(), 3u);
  EXPECT_NEAR(fit.intervals[0].rate_m_per_day, 0.08 / 14.0, 1e-12);
  EXPECT_NEAR(fit.intervals[1].rate_m_per_day, 0.12 / 14.0, 1e-12);
  EXPECT_NEAR(fit.intervals[2].rate_m_per_day, 0.10 / 14.0, 1e-12);
}

TEST(FitGrowthTest, AnOutlierDoesNotPullTheCurve) {
  const LogisticCurve truth{0.8, 0.12, 40.0};
  std::vector<GrowthObservation> obs = Sample(truth, 0.0, 8.0, 11);  // days 0..80
  std::mt19937 rng(5);
  std::normal_distribution<double> noise(0.0, 0.005);
  for (GrowthObservation& o : obs) o.height_m += noise(rng);
  obs[6].height_m += 0.2;  // day 48: a mis-registered session
  const GrowthFit fit = FitGrowth(obs);
  ASSERT_EQ(fit.status, GrowthFit::Status::kFitted) << fit.message;
  EXPECT_NEAR(fit.curve.asymptote_m, 0.8, 0.04) << fit.message;
  EXPECT_NEAR(fit.curve.rate_per_day, 0.12, 0.015) << fit.message;
  EXPECT_NEAR(fit.curve.midpoint_day, 40.0, 2.0) << fit.message;
  // The outlier keeps its residual.
  EXPECT_GT(obs[6].height_m - fit.curve.Evaluate(obs[6].day), 0.15);

  // Plain least squares is pulled further.
  GrowthOptions plain;
  plain.robust_loss_m = 0.0;
  const GrowthFit ls = FitGrowth(obs, plain);
  ASSERT_TRUE(ls.curve.valid()) << ls.message;
  EXPECT_GT(std::abs(ls.curve.Evaluate(48.0) - truth.Evaluate(48.0)),
            std::abs(fit.curve.Evaluate(48.0) - truth.Evaluate(48.0)));
}

TEST(FitGrowthTest, FewerThanThreePointsGiveIntervalsOnly) {
  const GrowthFit fit = FitGrowth({{14, 0.16}, {0, 0.08}});
  EXPECT_EQ(fit.status, GrowthFit::Status::kTooFewPoints);
  EXPECT_FALSE(fit.ok());
  EXPECT_NE(fit.message.find("2 valid observations"), std::string::npos) << fit.message;
  EXPECT_FALSE(fit.curve.valid());
  EXPECT_TRUE(std::isnan(fit.rmse_m));
  ASSERT_EQ(fit.intervals.size(), 1u);
  EXPECT_DOUBLE_EQ(fit.intervals[0].day_from, 0.0);
  EXPECT_DOUBLE_EQ(fit.intervals[0].height_to_m, 0.16);
  EXPECT_NEAR(fit.intervals[0].rate_m_per_day, 0.08 / 14.0, 1e-12);

  // Three observations on two days are too few as well; the same-day pair has no interval.
  const GrowthFit same_day = FitGrowth({{0, 0.08}, {14, 0.16}, {14, 0.17}});
  EXPECT_EQ(same_day.status, GrowthFit::Status::kTooFewPoints);
  EXPECT_EQ(same_day.num_points, 3);
  EXPECT_EQ(same_day.intervals.size(), 1u);

  EXPECT_EQ(FitGrowth({}).status, GrowthFit::Status::kTooFewPoints);
  EXPECT_TRUE(FitGrowth({}).intervals.empty());
}

TEST(FitGrowthTest, NaNHeightsAreSkipped) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  std::vector<GrowthObservation> obs = {{0, 0.08},  {7, nan},   {14, 0.16},
                                        {28, 0.28}, {42, 0.38}, {50, nan}};
  const GrowthFit fit = FitGrowth(obs);
  EXPECT_EQ(fit.num_points, 4);
  ASSERT_EQ(fit.status, GrowthFit::Status::kFitted) << fit.message;
  EXPECT_EQ(fit.intervals.size(), 3u);
  const GrowthFit clean = FitGrowth({{0, 0.08}, {14, 0.16}, {28, 0.28}, {42, 0.38}});
  EXPECT_NEAR(fit.curve.asymptote_m, clean.curve.asymptote_m, 1e-9);
  EXPECT_NEAR(fit.rmse_m, clean.rmse_m, 1e-12);

  const GrowthFit two_left = FitGrowth({{0, 0.1}, {14, nan}, {28, 0.3}});
  EXPECT_EQ(two_left.status, GrowthFit::Status::kTooFewPoints);
  EXPECT_EQ(two_left.num_points, 2);
}

// Decreasing heights (lodging, a harvest, a bad session) are not growth: no curve, the
// intervals say what happened.
TEST(FitGrowthTest, DecreasingHeightsAreNotGrowing) {
  const GrowthFit fit = FitGrowth({{0, 0.4}, {14, 0.35}, {28, 0.3}, {42, 0.2}});
  EXPECT_EQ(fit.status, GrowthFit::Status::kNotGrowing);
  EXPECT_NE(fit.message.find("do not increase"), std::string::npos) << fit.message;
  EXPECT_FALSE(fit.curve.valid());
  ASSERT_EQ(fit.intervals.size(), 3u);
  EXPECT_LT(fit.intervals[2].rate_m_per_day, 0.0);

  EXPECT_EQ(FitGrowth({{0, 0.0}, {14, 0.0}, {28, 0.0}}).status, GrowthFit::Status::kNotGrowing);
  EXPECT_EQ(FitGrowth({{0, 0.2}, {14, 0.2}, {28, 0.2}}).status, GrowthFit::Status::kNotGrowing);
}

// Grows, then falls (e.g. a senescing crop): still a curve, the fall is a residual.
TEST(FitGrowthTest, GrowthThenFallIsFitted) {
  const GrowthFit fit = FitGrowth({{0, 0.1}, {14, 0.3}, {28, 0.5}, {42, 0.45}});
  EXPECT_TRUE(fit.curve.valid()) << fit.message;
  EXPECT_EQ(fit.status, GrowthFit::Status::kFitted) << fit.message;
  EXPECT_GT(fit.curve.asymptote_m, 0.4);
  EXPECT_LT(fit.curve.asymptote_m, 0.6);
}

// A step between two sessions: the rate stays at its bound, the curve finite.
TEST(FitGrowthTest, AStepStaysFinite) {
  const GrowthFit fit = FitGrowth({{0, 0.1}, {14, 0.1}, {28, 0.5}, {42, 0.5}});
  ASSERT_TRUE(fit.curve.valid()) << fit.message;
  EXPECT_LE(fit.curve.rate_per_day, GrowthOptions().max_rate_per_day * (1 + 1e-9));
  EXPECT_GT(fit.curve.midpoint_day, 14.0);
  EXPECT_LT(fit.curve.midpoint_day, 28.0);
  EXPECT_TRUE(std::isfinite(fit.rmse_m));
}

TEST(GrowthOptionsTest, CheckRejectsBadOptions) {
  EXPECT_EQ(GrowthOptions().Check(), "");
  GrowthOptions o;
  o.robust_loss_m = -0.01;
  EXPECT_NE(o.Check(), "");
  o = GrowthOptions();
  o.max_iterations = 0;
  EXPECT_NE(o.Check(), "");
  o = GrowthOptions();
  o.max_asymptote_factor = 0.9;
  EXPECT_NE(o.Check(), "");
  o = GrowthOptions();
  o.max_rate_per_day = 0.0;
  EXPECT_NE(o.Check(), "");
  o = GrowthOptions();
  o.robust_loss_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_NE(o.Check(), "");
  EXPECT_STREQ(GrowthStatusName(GrowthFit::Status::kNotGrowing), "not_growing");
}

}  // namespace
}  // namespace crop4d::analysis
