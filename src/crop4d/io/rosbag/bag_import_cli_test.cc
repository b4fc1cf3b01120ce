// `crop4d import --bag` end to end: runs the crop4d binary on bags written by the test and checks
// exit codes, what it prints and that the imported field validates.

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cstdlib>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/rosbag/ros_bag.h"
#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::Crop4dBinary;
using testing::ReadText;
using testing::RunCommand;
using testing::ShellQuote;
using testing::TempDir;
using testing::WriteText;

using RunResult = io::testing::CommandResult;

RunResult RunCrop4d(const TempDir& dir, const std::string& args) {
  return RunCommand(dir, Crop4dBinary(), args);
}

class BagImportCliTest : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(fs::exists(Crop4dBinary())) << Crop4dBinary();
    WriteSampleField(dir_ / "original");
    // The sample session's camera and IMU as a bag (lz4 chunks).
    const Session session(session_folder());
    BagWriter bag(bag_path(), BagCompression::kLz4);
    for (const ImageEntry& e : session.ReadImageList("cam0")) {
      const cv::Mat image = cv::imread(session.ImagePath("cam0", e.filename));
      RosImage m;
      m.stamp = e.t;
      m.width = static_cast<std::uint32_t>(image.cols);
      m.height = static_cast<std::uint32_t>(image.rows);
      m.encoding = "bgr8";
      m.step = m.width * 3;
      m.data.assign(image.data, image.data + m.step * m.height);
      bag.Write("/camera/image_raw", e.t, m);
    }
    for (const ImuSample& s : session.ReadImu("imu0")) {
      RosImu m;
      m.stamp = s.t;
      m.angular_velocity = {s.gyro.x(), s.gyro.y(), s.gyro.z()};
      m.linear_acceleration = {s.accel.x(), s.accel.y(), s.accel.z()};
      bag.Write("/imu/data", s.t, m);
    }
    bag.Close();
  }
  std::string session_folder() const { return dir_ / "original/sessions/2016-05-25"; }
  std::string bag_path() const { return dir_ / "drive.bag"; }
  std::string SensorYaml(const std::string& sensor) const {
    return "--sensor-yaml " + sensor + "=" +
           ShellQuote(session_folder() + "/" + sensor + "/sensor.yaml");
  }
  TempDir dir_;
};

TEST_F(BagImportCliTest, ImportsAndTheFieldValidates) {
  const RunResult run = RunCrop4d(
      dir_, "import --bag " + ShellQuote(bag_path()) + " --out " + ShellQuote(dir_ / "field") +
                " --topic cam0=/camera/image_raw " + SensorYaml("cam0") + " " + SensorYaml("imu0"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  EXPECT_NE(run.out.find("cam0"), std::string::npos) << run.out;
  EXPECT_NE(run.out.find("/imu/data (sensor_msgs/Imu)"), std::string::npos) << run.out;
  EXPECT_EQ(ReadText(dir_ / "field/sessions/2016-05-25/imu0/data.csv"),
            ReadText(session_folder() + "/imu0/data.csv"));
  const RunResult validate = RunCrop4d(dir_, "validate " + ShellQuote(dir_ / "field"));
  EXPECT_EQ(validate.exit_code, 0) << validate.err << validate.out;
}

TEST_F(BagImportCliTest, KalibrCalibrationAppliesToABag) {
  WriteText(dir_ / "camchain.yaml",
            "cam0:\n"
            "  T_cam_imu:\n"
            "  - [1.0, 0.0, 0.0, 0.0]\n"
            "  - [0.0, 0.0, -1.0, 0.05]\n"
            "  - [0.0, 1.0, 0.0, -0.1]\n"
            "  - [0.0, 0.0, 0.0, 1.0]\n"
            "  camera_model: pinhole\n"
            "  distortion_coeffs: [-0.05, 0.01, 0.0, 0.0]\n"
            "  distortion_model: radtan\n"
            "  intrinsics: [25.6, 25.7, 16.1, 12.2]\n"
            "  resolution: [32, 24]\n"
            "  timeshift_cam_imu: 0.001\n");
  const RunResult run = RunCrop4d(dir_, "import --bag " + ShellQuote(bag_path()) + " --out " +
                                            ShellQuote(dir_ / "field") + " --kalibr-camchain " +
                                            ShellQuote(dir_ / "camchain.yaml"));
  ASSERT_EQ(run.exit_code, 0) << run.err;
  const Session imported(dir_ / "field/sessions/2016-05-25");
  const CameraSensor* camera = imported.FindCamera("cam0");
  ASSERT_NE(camera, nullptr);
  EXPECT_EQ(camera->camera.fy, 25.7);
  EXPECT_NEAR(camera->body_from_sensor.translation().z(), 0.05, 1e-12);
  // Image times + timeshift_cam_imu (1 ms), onto the IMU clock.
  const std::vector<ImageEntry> original = Session(session_folder()).ReadImageList("cam0");
  const std::vector<ImageEntry> shifted = imported.ReadImageList("cam0");
  ASSERT_EQ(shifted.size(), original.size());
  EXPECT_EQ(shifted.front().t, original.front().t + 1000000);
  // --sensor-yaml and Kalibr for the same camera: a conflict.
  const RunResult both =
      RunCrop4d(dir_, "import --bag " + ShellQuote(bag_path()) + " --out " +
                          ShellQuote(dir_ / "field2") + " --kalibr-camchain " +
                          ShellQuote(dir_ / "camchain.yaml") + " " + SensorYaml("cam0"));
  EXPECT_EQ(both.exit_code, 2);
  EXPECT_NE(both.err.find("cam0 is also given with --sensor-yaml"), std::string::npos) << both.err;
}

TEST_F(BagImportCliTest, MissingTopicExitsWithTwoAndListsTheTopics) {
  const RunResult run = RunCrop4d(dir_, "import --bag " + ShellQuote(bag_path()) + " --out " +
                                            ShellQuote(dir_ / "field") +
                                            " --topic imu0=/imu/missing " + SensorYaml("cam0"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("/imu/missing"), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("/camera/image_raw (sensor_msgs/Image, "), std::string::npos) << run.err;
  EXPECT_NE(run.err.find("/imu/data (sensor_msgs/Imu, "), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "field/field.yaml"));
}

TEST_F(BagImportCliTest, TruncatedBagAndBadOptionsExitWithTwo) {
  const std::string bytes = ReadText(bag_path());
  WriteText(dir_ / "cut.bag", bytes.substr(0, bytes.size() / 2));
  RunResult run = RunCrop4d(dir_, "import --bag " + ShellQuote(dir_ / "cut.bag") + " --out " +
                                      ShellQuote(dir_ / "field") + " " + SensorYaml("cam0"));
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("not a readable ROS 1 bag"), std::string::npos) << run.err;

  run = RunCrop4d(dir_, "import --bag " + ShellQuote(bag_path()) + " --out " +
                            ShellQuote(dir_ / "field") + " --stamp sometimes");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--stamp"), std::string::npos) << run.err;

  run = RunCrop4d(dir_, "import --bag " + ShellQuote(bag_path()) + " --out " +
                            ShellQuote(dir_ / "field") + " --topic imu0");
  EXPECT_EQ(run.exit_code, 2);
  EXPECT_NE(run.err.find("--topic"), std::string::npos) << run.err;
  EXPECT_FALSE(fs::exists(dir_ / "field/field.yaml"));
}

}  // namespace
}  // namespace crop4d::io
