#include "crop4d/eval/time_offset_eval.h"

#include <gtest/gtest.h>

#include "crop4d/core/error.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::eval {
namespace {

using io::testing::TempDir;
using io::testing::WriteText;

TEST(TimeOffsetEval, MeanOfCaptureMinusStampOverThePassImages) {
  TempDir dir;
  WriteText(dir / "cam0_exposure.csv",
            "#timestamp [ns],capture [ns],gain,exposure [s]\n"
            "1000000000,1024000000,1.0,0.004\n"
            "2000000000,2026000000,1.1,0.004\n"
            "3000000000,3100000000,0.9,0.004\n");
  const auto captures = ReadCaptureInstants(dir / "cam0_exposure.csv");
  ASSERT_EQ(captures.size(), 3u);
  // The third image is not in the pass; a stamp without a capture instant is skipped.
  const auto offset = TrueTimeOffset({1000000000, 2000000000, 5000000000}, captures);
  ASSERT_TRUE(offset.has_value());
  EXPECT_NEAR(*offset, 0.025, 1e-12);
  EXPECT_FALSE(TrueTimeOffset({5000000000}, captures).has_value());
}

TEST(TimeOffsetEval, MalformedFilesNameTheLine) {
  TempDir dir;
  const auto expect_error = [&](const std::string& text, const std::string& what) {
    WriteText(dir / "f.csv", text);
    try {
      ReadCaptureInstants(dir / "f.csv");
      ADD_FAILURE() << "no error for: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  expect_error("#h\n1000,2000\n1x00,2000\n", ":3");
  expect_error("1000\n", ":1");
  expect_error("1000,\n", ":1");
  expect_error("1000,2000\n1000,3000\n", "appears twice");
  EXPECT_THROW(ReadCaptureInstants(dir / "missing.csv"), InputError);
}

}  // namespace
}  // namespace crop4d::eval
