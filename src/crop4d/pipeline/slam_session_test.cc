// Which receivers the session solve takes as precise (slam_session.h, PreciseFixes).

#include "crop4d/pipeline/slam_session.h"

#include <gtest/gtest.h>

#include <vector>

namespace crop4d::pipeline {
namespace {

std::vector<slam::GpsFixWorld> Fixes(int precise, double precise_sigma, int other,
                                     double other_sigma) {
  std::vector<slam::GpsFixWorld> fixes;
  for (int i = 0; i < precise + other; ++i) {
    slam::GpsFixWorld fix;
    fix.t = SecondsToTimestamp(0.2 * i);
    fix.sigma_h = i < precise ? precise_sigma : other_sigma;
    fixes.push_back(fix);
  }
  return fixes;
}

// An RTK receiver in float (0.15 m) for 55 % of a session still runs the session solve; a
// metre-level receiver (1.8 m) never does, nor one that is fixed for a tenth of the session.
TEST(PreciseFixesTest, AnRtkReceiverMostlyInFloatIsPreciseAMetreLevelOneIsNot) {
  const SlamStageOptions options;
  EXPECT_TRUE(PreciseFixes(options, Fixes(252, 0.02, 304, 0.15)));
  EXPECT_TRUE(PreciseFixes(options, Fixes(556, 0.02, 0, 0.0)));
  EXPECT_FALSE(PreciseFixes(options, Fixes(0, 0.0, 525, 1.8)));
  EXPECT_FALSE(PreciseFixes(options, Fixes(50, 0.02, 450, 0.15)));
  EXPECT_FALSE(PreciseFixes(options, {}));
}

}  // namespace
}  // namespace crop4d::pipeline
