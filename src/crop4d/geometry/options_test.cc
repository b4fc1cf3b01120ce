// PinholeRadTan::Check() names the intrinsic that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/geometry/camera.h"

namespace crop4d::geometry {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(CameraCheck, NamesTheWrongIntrinsic) {
  PinholeRadTan camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  using C = PinholeRadTan;
  ExpectCheckNamesOption<C>(camera, {{"width", [](C& c) { c.width = 0; }},
                                     {"fy", [](C& c) { c.fy = -1; }},
                                     {"k2", [](C& c) { c.k2 = 0.0 / 0.0; }}});
}

}  // namespace
}  // namespace crop4d::geometry
