#pragma once

// Table-driven tests of option structs' Check() (core/option_check.h): each case breaks one
// option of a valid struct, and the reason must start with that option's key.

#include <gtest/gtest.h>

#include <functional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::testing {

template <class Options>
struct BrokenOption {
  std::string key;  // e.g. "cell_m" or "triangulation.max_depth_m"
  std::function<void(Options&)> breaks;
};

template <class Options>
void ExpectCheckNamesOption(const Options& valid, const std::vector<BrokenOption<Options>>& cases) {
  ASSERT_EQ(std::string(valid.Check()), "");
  for (const BrokenOption<Options>& c : cases) {
    Options o = valid;
    c.breaks(o);
    const std::string why = o.Check();
    EXPECT_EQ(why.substr(0, c.key.size() + 2), c.key + ": ") << "reason: '" << why << "'";
    EXPECT_FALSE(why.empty()) << c.key;
  }
}

}  // namespace crop4d::testing
