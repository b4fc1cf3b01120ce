#include "crop4d/io/tum.h"

#include <gtest/gtest.h>

#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

TEST(TumTest, RoundTripKeepsNanosecondsAndPoses) {
  testing::TempDir dir;
  std::vector<StampedPose> poses;
  for (int i = 0; i < 5; ++i) {
    StampedPose p;
    p.t = 1464177600123456789LL + i * 133333333LL;
    p.pose = geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.1 * i, -0.2, 0.3)),
                              Eigen::Vector3d(1.5 + i, -2.25, 0.125 * i));
    poses.push_back(p);
  }
  const std::string path = dir / "poses.tum";
  WriteTum(path, poses, "world_from_camera\nsecond comment line");
  const std::string text = testing::ReadText(path);
  EXPECT_EQ(text.rfind("# world_from_camera\n# second comment line\n# t[s] tx", 0), 0u) << text;
  EXPECT_NE(text.find("\n1464177600.123456789 1.500000 -2.250000 0.000000 "), std::string::npos);

  const std::vector<StampedPose> back = ReadTum(path);
  ASSERT_EQ(back.size(), poses.size());
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(back[i].t, poses[i].t);
    EXPECT_LT((back[i].pose.translation() - poses[i].pose.translation()).norm(), 1e-6);
    EXPECT_LT(geometry::AngleBetween(back[i].pose.rotation(), poses[i].pose.rotation()), 1e-8);
  }
}

TEST(TumTest, ParsesTimestampsExactly) {
  Timestamp t = 0;
  ASSERT_TRUE(ParseTumTime("1464177600.5", &t));
  EXPECT_EQ(t, 1464177600500000000LL);
  ASSERT_TRUE(ParseTumTime("12", &t));
  EXPECT_EQ(t, 12 * kNanosPerSecond);
  ASSERT_TRUE(ParseTumTime("-1.000000001", &t));
  EXPECT_EQ(t, -kNanosPerSecond - 1);
  EXPECT_EQ(FormatTumLine(-1, geometry::Rigid3()).substr(0, 12), "-1.999999999");
  for (const char* bad : {"", ".", "1.2.3", "1e9", "abc", "1.0000000001", "12x"}) {
    EXPECT_FALSE(ParseTumTime(bad, &t)) << bad;
  }
}

TEST(TumTest, MalformedLinesNameFileAndLine) {
  testing::TempDir dir;
  const std::string path = dir / "bad.tum";
  auto expect_error = [&](const std::string& body, const std::string& what) {
    testing::WriteText(path, "# header\n1.0 0 0 0 0 0 0 1\n" + body);
    try {
      ReadTum(path);
      ADD_FAILURE() << "no error for: " << body;
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), 3) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
      EXPECT_EQ(e.file(), path);
    }
  };
  expect_error("2.0 0 0 0 0 0 1\n", "expected 8 numbers");
  expect_error("2.0 0 0 0 0 0 0 1 9\n", "expected 8 numbers");
  expect_error("2.0 0 0 x 0 0 0 1\n", "expected 8 numbers");
  expect_error("two 0 0 0 0 0 0 1\n", "not a timestamp");
  expect_error("2.0 0 0 0 0 0 0 0\n", "zero quaternion");
  expect_error("2.0 nan 0 0 0 0 0 1\n", "NaN");
  expect_error("1.0 0 0 0 0 0 0 1\n", "strictly increasing");
  EXPECT_THROW(ReadTum(dir / "missing.tum"), InputError);
}

}  // namespace
}  // namespace crop4d::io
