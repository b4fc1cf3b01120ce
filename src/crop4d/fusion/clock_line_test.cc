#include "crop4d/fusion/clock_line.h"

#include <gtest/gtest.h>

#include <memory>

namespace crop4d::fusion {
namespace {

TEST(ClockLine, FitRecoversALineAndNeedsTwoPoints) {
  // 25 ms at t_ref, drifting 20 ppm: 0.02 s per 1000 s.
  const std::vector<double> t = {0.0, 0.1, 0.25, 0.4};
  std::vector<double> td;
  for (const double x : t) td.push_back(0.025 + 0.02 * x);
  const auto line = FitClockLine(t, td);
  ASSERT_TRUE(line.has_value());
  EXPECT_NEAR((*line)[0], 0.025, 1e-12);
  EXPECT_NEAR((*line)[1], 0.02, 1e-12);
  // Passes at one instant: their mean, no drift.
  const auto flat = FitClockLine({0.2, 0.2, 0.2}, {0.01, 0.02, 0.03});
  ASSERT_TRUE(flat.has_value());
  EXPECT_NEAR((*flat)[0], 0.02, 1e-12);
  EXPECT_EQ((*flat)[1], 0.0);
  EXPECT_FALSE(FitClockLine({0.1}, {0.02}).has_value());
  EXPECT_FALSE(FitClockLine({0.1, 0.2}, {0.02}).has_value());
}

TEST(ClockLine, FactorResidualAndJacobians) {
  const double dt_ks = 0.3, sigma = 0.001;
  std::unique_ptr<ceres::CostFunction> cost(ClockLineFactor::Create(dt_ks, sigma));
  double td = 0.031;
  double line[2] = {0.025, 0.02};
  const double* params[2] = {&td, line};
  double residual = 0, j_td = 0, j_line[2] = {0, 0};
  double* jacobians[2] = {&j_td, j_line};
  ASSERT_TRUE(cost->Evaluate(params, &residual, jacobians));
  EXPECT_NEAR(residual, (0.031 - 0.025 - 0.02 * 0.3) / sigma, 1e-9);
  EXPECT_NEAR(j_td, 1.0 / sigma, 1e-9);
  EXPECT_NEAR(j_line[0], -1.0 / sigma, 1e-9);
  EXPECT_NEAR(j_line[1], -dt_ks / sigma, 1e-9);
}

}  // namespace
}  // namespace crop4d::fusion
