#include "crop4d/eval/calibration_eval.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

// As the simulator writes it (sim/simulator.cc): the written T_BS turned 0.3° about the body's
// x axis, the written intrinsics 1.5 px off.
constexpr char kTruth[] = R"(# The rig's true calibration
camera_time_offset_s: -0.025  # image stamp - capture time at session start
camera_clock_drift: 2e-05  # d(stamp - capture)/dt
cam0:
  true_intrinsics: {fx: 600, fy: 600, cx: 320, cy: 240, k1: -0.1, k2: 0.01, p1: 0, p2: 0, k3: 0}
  written_intrinsics: {fx: 601.5, fy: 601.5, cx: 321, cy: 239, k1: -0.105, k2: 0.015, p1: 0, p2: 0, k3: 0}
  true_T_BS: [[0, 0, 1, 0.4], [-1, 0, 0, 0], [0, -1, 0, 1.5], [0, 0, 0, 1]]
  written_T_BS: [[0, 0, 1, 0.41], [-0.999986292247, 0.005235963831, 0, 0], [-0.005235963831, -0.999986292247, 0, 1.5], [0, 0, 0, 1]]
  rotation_error_rad: [0.005236, 0, 0]
)";

class CalibrationEvalTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("crop4d_calibration_eval_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "field" / "ground_truth");
  }
  void TearDown() override { fs::remove_all(dir_); }
  void WriteTruth(const std::string& text) const {
    std::ofstream(dir_ / "field" / "ground_truth" / "calibration_truth.yaml") << text;
  }
  std::string Field() const { return (dir_ / "field").string(); }
  fs::path dir_;
};

TEST_F(CalibrationEvalTest, ReadsTheTruthAndMeasuresTheFusedCameraAgainstIt) {
  EXPECT_FALSE(ReadCalibrationTruth(Field()).has_value());  // an ideal field: no file
  WriteTruth(kTruth);
  const std::optional<CalibrationTruth> truth = ReadCalibrationTruth(Field());
  ASSERT_TRUE(truth.has_value());
  EXPECT_EQ(truth->true_intrinsics.fx, 600.0);
  EXPECT_EQ(truth->written_intrinsics.cy, 239.0);
  EXPECT_EQ(truth->written_intrinsics.k2, 0.015);
  EXPECT_EQ(truth->written_body_from_camera.translation().x(), 0.41);
  EXPECT_NEAR(truth->true_body_from_camera.rotation().angularDistance(
                  truth->written_body_from_camera.rotation()) *
                  180 / M_PI,
              0.3, 1e-6);

  // The fused camera at the truth: no error left; the written one is off.
  const workspace::Layout ws(dir_ / "ws");
  fs::create_directories(ws.FusedSessionDir("s"));
  workspace::FusedCamera fused;
  fused.intrinsics = truth->true_intrinsics;
  fused.intrinsics.width = 640;
  fused.intrinsics.height = 480;
  fused.body_from_camera = truth->true_body_from_camera;
  fused.refined = true;
  workspace::WriteFusedCamera(ws.FusedCamera("s").string(), fused);
  CalibrationError e = EvaluateFusedCalibration(ws.root().string(), "s", *truth);
  EXPECT_TRUE(e.refined);
  EXPECT_LT(e.fused_deg, 1e-6);
  // (A roll about the optical axis — body x is the camera's z — turns the central rays little.)
  EXPECT_GT(e.written_deg, 0.1);
  // Fused as written: the same error as the written calibration.
  fused.intrinsics = truth->written_intrinsics;
  fused.intrinsics.width = 640;
  fused.intrinsics.height = 480;
  fused.body_from_camera = truth->written_body_from_camera;
  fused.refined = false;
  workspace::WriteFusedCamera(ws.FusedCamera("s").string(), fused);
  e = EvaluateFusedCalibration(ws.root().string(), "s", *truth);
  EXPECT_FALSE(e.refined);
  EXPECT_NEAR(e.fused_deg, e.written_deg, 1e-9);
  EXPECT_THROW(EvaluateFusedCalibration(ws.root().string(), "t", *truth), InputError);
}

TEST_F(CalibrationEvalTest, AMalformedTruthIsNamed) {
  std::string text = kTruth;
  text.replace(text.find("[0, 0, 0, 1]]\n  written"), 13, "[0, 0, 1]]");
  WriteTruth(text);
  try {
    ReadCalibrationTruth(Field());
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("calibration_truth.yaml"), std::string::npos) << e.what();
  }
  WriteTruth("cam1: {}\n");
  EXPECT_THROW(ReadCalibrationTruth(Field()), InputError);
}

}  // namespace
}  // namespace crop4d::eval
