#include "crop4d/core/option_check.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <string>

namespace crop4d {
namespace {

struct Inner {
  double max_depth_m = 10;
  OptionCheck Check() const {
    OptionChecker c;
    c.Greater("max_depth_m", max_depth_m, 0.0);
    return c.Result();
  }
};

struct Outer {
  double cell_m = 0.005;
  int patch_radius = 2;
  double fine_step_m = 0.0025, fine_half_range_m = 0.025;
  Inner inner;
  OptionCheck Check() const {
    OptionChecker c;
    c.Greater("cell_m", cell_m, 0.0)
        .Finite("cell_m", cell_m)
        .InRange("patch_radius", patch_radius, 1, 5)
        .Require(fine_step_m < fine_half_range_m, "fine_step_m", "must be < fine_half_range_m",
                 fine_step_m)
        .Nested("inner", inner.Check());
    return c.Result();
  }
};

TEST(OptionCheck, ValidIsEmptyAndTrue) {
  const OptionCheck check = Outer().Check();
  EXPECT_EQ(check, "");
}

TEST(OptionCheck, ReasonNamesTheOptionTheRuleAndTheValue) {
  Outer o;
  o.cell_m = -1;
  EXPECT_EQ(o.Check(), "cell_m: must be > 0 (got -1)");
  o.cell_m = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(o.Check(), "cell_m: must be > 0 (got nan)");
  o.cell_m = std::numeric_limits<double>::infinity();
  EXPECT_EQ(o.Check(), "cell_m: must be finite (got inf)");
  o = Outer();
  o.patch_radius = 7;
  EXPECT_EQ(o.Check(), "patch_radius: must be in [1, 5] (got 7)");
  o = Outer();
  o.fine_step_m = 0.5;
  EXPECT_EQ(o.Check(), "fine_step_m: must be < fine_half_range_m (got 0.5)");
}

TEST(OptionCheck, FirstFailureWins) {
  Outer o;
  o.cell_m = 0;
  o.patch_radius = 0;
  EXPECT_EQ(o.Check(), "cell_m: must be > 0 (got 0)");
}

TEST(OptionCheck, NestedReasonCarriesTheKeyPrefix) {
  Outer o;
  o.inner.max_depth_m = 0;
  EXPECT_EQ(o.Check(), "inner.max_depth_m: must be > 0 (got 0)");
  // Callers build their own prefix on top.
  EXPECT_EQ("stereo." + o.Check(), "stereo.inner.max_depth_m: must be > 0 (got 0)");
}

}  // namespace
}  // namespace crop4d
