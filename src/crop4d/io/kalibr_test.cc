#include "crop4d/io/kalibr.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/euroc_import.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

using testing::ReplaceInFile;
using testing::TempDir;
using testing::WriteText;

// A camera chain of two cameras with example values of our own: cam0 looks along the IMU's x
// axis (camera z = IMU x, camera x = −IMU y, camera y = −IMU z), 5 cm ahead and 2 cm to the left
// of the IMU.
constexpr const char* kCamchain = R"(cam0:
  T_cam_imu:
  - [0.0, -1.0, 0.0, 0.02]
  - [0.0, 0.0, -1.0, 0.01]
  - [1.0, 0.0, 0.0, -0.05]
  - [0.0, 0.0, 0.0, 1.0]
  cam_overlaps: [1]
  camera_model: pinhole
  distortion_coeffs: [-0.21, 0.045, 0.0007, -0.0003]
  distortion_model: radtan
  intrinsics: [612.5, 611.75, 321.25, 243.5]
  resolution: [640, 480]
  rostopic: /rig/left/image_raw
  timeshift_cam_imu: 0.0123456789
cam1:
  T_cam_imu:
  - [0.0, -1.0, 0.0, -0.08]
  - [0.0, 0.0, -1.0, 0.01]
  - [1.0, 0.0, 0.0, -0.05]
  - [0.0, 0.0, 0.0, 1.0]
  T_cn_cnm1:
  - [1.0, 0.0, 0.0, -0.1]
  - [0.0, 1.0, 0.0, 0.0]
  - [0.0, 0.0, 1.0, 0.0]
  - [0.0, 0.0, 0.0, 1.0]
  cam_overlaps: [0]
  camera_model: pinhole
  distortion_coeffs: [0.0, 0.0, 0.0, 0.0]
  distortion_model: none
  intrinsics: [600.0, 600.0, 320.0, 240.0]
  resolution: [640, 480]
  rostopic: /rig/right/image_raw
  timeshift_cam_imu: -0.002
)";

constexpr const char* kImuYaml = R"(imu0:
  accelerometer_noise_density: 0.0021
  accelerometer_random_walk: 0.00031
  gyroscope_noise_density: 0.00018
  gyroscope_random_walk: 2.2e-05
  model: calibrated
  rostopic: /rig/imu
  time_offset: 0.0
  update_rate: 250.0
)";

class KalibrTest : public ::testing::Test {
 protected:
  std::string Write(const std::string& name, const std::string& text) {
    WriteText(dir_ / name, text);
    return dir_ / name;
  }
  // The InputError's message for a broken camera chain.
  std::string CamchainError(const std::string& text) {
    try {
      ReadKalibrCamchain(Write("broken.yaml", text));
    } catch (const InputError& e) {
      return e.what();
    }
    ADD_FAILURE() << "accepted:\n" << text;
    return "";
  }
  static std::string Replaced(std::string text, const std::string& from, const std::string& to) {
    const std::size_t at = text.find(from);
    EXPECT_NE(at, std::string::npos) << from;
    if (at != std::string::npos) text.replace(at, from.size(), to);
    return text;
  }
  TempDir dir_;
};

TEST_F(KalibrTest, ReadsTheCameraChainAndInvertsTCamImu) {
  const std::vector<KalibrCamera> cameras = ReadKalibrCamchain(Write("camchain.yaml", kCamchain));
  ASSERT_EQ(cameras.size(), 2u);
  const KalibrCamera& cam0 = cameras[0];
  EXPECT_EQ(cam0.sensor.name, "cam0");
  EXPECT_EQ(cam0.sensor.camera.width, 640);
  EXPECT_EQ(cam0.sensor.camera.height, 480);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.fx, 612.5);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.fy, 611.75);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.cx, 321.25);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.cy, 243.5);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.k1, -0.21);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.k2, 0.045);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.p1, 0.0007);
  EXPECT_DOUBLE_EQ(cam0.sensor.camera.p2, -0.0003);
  EXPECT_EQ(cam0.rostopic, "/rig/left/image_raw");
  EXPECT_EQ(cam0.overlaps, std::vector<int>{1});
  // 0.0123456789 s, rounded to the nanosecond; Kalibr's t_imu = t_cam + shift.
  EXPECT_EQ(cam0.time_shift_ns, 12'345'679);
  EXPECT_EQ(cam0.ToImuClock(1'000'000'000), 1'012'345'679);
  EXPECT_EQ(cameras[1].time_shift_ns, -2'000'000);

  // T_BS = body_from_camera: a point 2 m in front of the camera (camera z) lies on the IMU's
  // x axis. Check with T_cam_imu itself: x_cam = T_cam_imu x_imu, so x_imu = T_BS x_cam.
  Eigen::Matrix4d camera_from_imu;
  camera_from_imu << 0, -1, 0, 0.02, 0, 0, -1, 0.01, 1, 0, 0, -0.05, 0, 0, 0, 1;
  const Eigen::Vector3d point_in_imu(2.3, -0.4, 0.7);
  const Eigen::Vector3d point_in_camera = (camera_from_imu * point_in_imu.homogeneous()).head<3>();
  const Eigen::Vector3d back = cam0.sensor.body_from_sensor * point_in_camera;
  EXPECT_NEAR((back - point_in_imu).norm(), 0.0, 1e-12);
  // The camera centre in the body frame: 5 cm ahead, 2 cm to the left (+y), 1 cm up.
  EXPECT_NEAR(
      (cam0.sensor.body_from_sensor.translation() - Eigen::Vector3d(0.05, 0.02, 0.01)).norm(), 0.0,
      1e-12);
  // cam1: distortion 'none' gives zero coefficients.
  EXPECT_EQ(cameras[1].sensor.camera.k1, 0.0);
  EXPECT_DOUBLE_EQ(cameras[1].sensor.camera.fx, 600.0);
}

TEST_F(KalibrTest, ReadsTheImuNoiseAndAppliesTIB) {
  const KalibrImu imu = ReadKalibrImu(Write("imu.yaml", kImuYaml));
  EXPECT_DOUBLE_EQ(imu.sensor.accelerometer_noise_density, 0.0021);
  EXPECT_DOUBLE_EQ(imu.sensor.accelerometer_random_walk, 0.00031);
  EXPECT_DOUBLE_EQ(imu.sensor.gyroscope_noise_density, 0.00018);
  EXPECT_DOUBLE_EQ(imu.sensor.gyroscope_random_walk, 2.2e-05);
  EXPECT_DOUBLE_EQ(imu.update_rate_hz, 250.0);
  EXPECT_EQ(imu.rostopic, "/rig/imu");
  EXPECT_FALSE(imu.has_imu_from_body);
  // Kalibr's input form: the same keys at the top level.
  const KalibrImu top =
      ReadKalibrImu(Write("imu_top.yaml",
                          "accelerometer_noise_density: 0.01\naccelerometer_random_walk: 0.0002\n"
                          "gyroscope_noise_density: 0.0005\ngyroscope_random_walk: 4.0e-06\n"
                          "rostopic: /imu\nupdate_rate: 200.0\n"));
  EXPECT_DOUBLE_EQ(top.sensor.accelerometer_noise_density, 0.01);

  // With T_i_b (imu_from_body: the IMU 10 cm above the body origin, turned 90° about z), the
  // cameras move into the body frame: body_from_camera = T_i_b⁻¹ · T_cam_imu⁻¹.
  const std::string with_tib =
      Write("imu_tib.yaml", std::string(kImuYaml) +
                                "  T_i_b:\n  - [0.0, 1.0, 0.0, 0.0]\n  - [-1.0, 0.0, 0.0, 0.0]\n"
                                "  - [0.0, 0.0, 1.0, -0.1]\n  - [0.0, 0.0, 0.0, 1.0]\n");
  const KalibrCalibration calibration = ReadKalibr(Write("camchain.yaml", kCamchain), with_tib);
  ASSERT_TRUE(calibration.imu);
  EXPECT_TRUE(calibration.imu->has_imu_from_body);
  // A point in the camera → IMU (through T_cam_imu) → body (through T_i_b⁻¹).
  const Eigen::Vector3d point_in_camera(0.3, -0.2, 4.0);
  const Eigen::Vector3d point_in_imu(4.0 + 0.05, -0.3 + 0.02, 0.2 + 0.01);
  Eigen::Matrix4d imu_from_body;
  imu_from_body << 0, 1, 0, 0, -1, 0, 0, 0, 0, 0, 1, -0.1, 0, 0, 0, 1;
  const Eigen::Vector3d point_in_body =
      (imu_from_body.inverse() * point_in_imu.homogeneous()).head<3>();
  const KalibrCamera* cam0 = calibration.FindCamera("cam0");
  ASSERT_NE(cam0, nullptr);
  EXPECT_NEAR((cam0->sensor.body_from_sensor * point_in_camera - point_in_body).norm(), 0.0, 1e-12);
}

TEST_F(KalibrTest, ApplyOverridesNamedSensorsAndKeepsRates) {
  const KalibrCalibration calibration =
      ReadKalibr(Write("camchain.yaml", kCamchain), Write("imu.yaml", kImuYaml));
  std::map<std::string, CameraSensor> cameras;
  cameras["cam0"].rate_hz = 20.0;
  cameras["cam0"].camera.width = 640;
  cameras["cam0"].camera.height = 480;
  cameras["cam2"].rate_hz = 5.0;  // not in the chain: left alone
  cameras["cam2"].camera.fx = 100;
  std::map<std::string, ImuSensor> imus;
  imus["imu0"].rate_hz = 400.0;
  const std::vector<std::string> lines = ApplyKalibr(calibration, &cameras, &imus);
  EXPECT_DOUBLE_EQ(cameras["cam0"].camera.fx, 612.5);
  EXPECT_DOUBLE_EQ(cameras["cam0"].rate_hz, 20.0);
  EXPECT_DOUBLE_EQ(cameras["cam2"].camera.fx, 100.0);
  EXPECT_DOUBLE_EQ(imus["imu0"].gyroscope_noise_density, 0.00018);
  EXPECT_DOUBLE_EQ(imus["imu0"].rate_hz, 400.0);
  // cam0, cam2 (kept), cam1 (not imported), imu0.
  EXPECT_EQ(lines.size(), 4u);
  // Images of another size than the calibration's are refused.
  cameras["cam0"].camera.width = 1280;
  EXPECT_THROW(ApplyKalibr(calibration, &cameras, &imus), InputError);
}

TEST_F(KalibrTest, MalformedFilesNameTheKeyAndTheLine) {
  // A missing key.
  std::string message =
      CamchainError(Replaced(kCamchain, "  intrinsics: [612.5, 611.75, 321.25, 243.5]\n", ""));
  EXPECT_NE(message.find("cam0.intrinsics"), std::string::npos) << message;
  EXPECT_NE(message.find("broken.yaml:2:"), std::string::npos) << message;  // cam0's map
  // A T_cam_imu that is not rigid (a scaled rotation), on line 2.
  message = CamchainError(Replaced(kCamchain, "[0.0, -1.0, 0.0, 0.02]", "[0.0, -1.2, 0.0, 0.02]"));
  EXPECT_NE(message.find("cam0.T_cam_imu"), std::string::npos) << message;
  EXPECT_NE(message.find("not a rigid transform"), std::string::npos) << message;
  EXPECT_NE(message.find("broken.yaml:3:"), std::string::npos) << message;
  // A reflection (det −1).
  message = CamchainError(Replaced(kCamchain, "[1.0, 0.0, 0.0, -0.05]", "[-1.0, 0.0, 0.0, -0.05]"));
  EXPECT_NE(message.find("cam0.T_cam_imu"), std::string::npos) << message;
  // A 3x4 matrix, and a row of 3 numbers.
  message = CamchainError(
      Replaced(kCamchain, "  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: [1]", "  cam_overlaps: [1]"));
  EXPECT_NE(message.find("cam0.T_cam_imu"), std::string::npos) << message;
  EXPECT_NE(message.find("found 3 rows"), std::string::npos) << message;
  message = CamchainError(Replaced(kCamchain, "[0.0, 0.0, -1.0, 0.01]", "[0.0, 0.0, -1.0]"));
  EXPECT_NE(message.find("row 2 has 3 numbers"), std::string::npos) << message;
  // A last row that is not [0, 0, 0, 1].
  message = CamchainError(Replaced(kCamchain, "  - [0.0, 0.0, 0.0, 1.0]\n  cam_overlaps: [1]",
                                   "  - [0.0, 0.0, 0.1, 1.0]\n  cam_overlaps: [1]"));
  EXPECT_NE(message.find("last row"), std::string::npos) << message;
  // Non-positive focal length; principal point outside the image.
  message = CamchainError(Replaced(kCamchain, "[612.5, 611.75,", "[-612.5, 611.75,"));
  EXPECT_NE(message.find("cam0.intrinsics"), std::string::npos) << message;
  message = CamchainError(Replaced(kCamchain, "321.25, 243.5]", "921.25, 243.5]"));
  EXPECT_NE(message.find("principal point"), std::string::npos) << message;
  // The fisheye model: a clear refusal.
  message = CamchainError(
      Replaced(kCamchain, "distortion_model: radtan", "distortion_model: equidistant"));
  EXPECT_NE(message.find("cam0.distortion_model"), std::string::npos) << message;
  EXPECT_NE(message.find("no fisheye model"), std::string::npos) << message;
  // Another camera model.
  message = CamchainError(Replaced(kCamchain, "camera_model: pinhole", "camera_model: omni"));
  EXPECT_NE(message.find("cam0.camera_model"), std::string::npos) << message;
  // A wrong number of distortion coefficients.
  message = CamchainError(Replaced(kCamchain, "[-0.21, 0.045, 0.0007, -0.0003]", "[-0.21, 0.045]"));
  EXPECT_NE(message.find("cam0.distortion_coeffs"), std::string::npos) << message;
  // No camera at all.
  message = CamchainError("imu0:\n  rostopic: /imu\n");
  EXPECT_NE(message.find("cam0"), std::string::npos) << message;

  // imu.yaml: a missing noise value, a negative one, a non-rigid T_i_b.
  const std::string imu = Write("imu.yaml", kImuYaml);
  ReplaceInFile(imu, "  gyroscope_random_walk: 2.2e-05\n", "");
  try {
    ReadKalibrImu(imu);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("imu0.gyroscope_random_walk"), std::string::npos)
        << e.what();
  }
  const std::string negative = Write("imu_negative.yaml", kImuYaml);
  ReplaceInFile(negative, "0.0021", "-0.0021");
  EXPECT_THROW(ReadKalibrImu(negative), InputError);
  const std::string bad_tib =
      Write("imu_bad_tib.yaml", std::string(kImuYaml) +
                                    "  T_i_b:\n  - [2.0, 0.0, 0.0, 0.0]\n  - [0.0, 1.0, 0.0, 0.0]\n"
                                    "  - [0.0, 0.0, 1.0, 0.0]\n  - [0.0, 0.0, 0.0, 1.0]\n");
  try {
    ReadKalibrImu(bad_tib);
    FAIL();
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("imu0.T_i_b"), std::string::npos) << e.what();
  }
  EXPECT_THROW(ReadKalibr("", ""), InputError);
}

TEST_F(KalibrTest, OverridesAnEurocSequencesCalibrationAndShiftsItsImages) {
  // A sequence of our own: cam0 with 3 images (640 × 480, other intrinsics) and imu0.
  const std::string mav0 = dir_ / "seq/mav0";
  constexpr Timestamp kT0 = 1403715273262142976;
  CameraSensor camera;
  camera.rate_hz = 20;
  camera.camera = {640, 480, 450, 450, 320, 240};
  WriteCameraSensorYaml(mav0 + "/cam0/sensor.yaml", camera);
  std::vector<ImageEntry> images;
  for (int k = 0; k < 3; ++k) {
    images.push_back({kT0 + k * 50'000'000, std::to_string(kT0 + k * 50'000'000) + ".png"});
    WriteText(mav0 + "/cam0/data/" + images.back().filename, "not decoded by the import");
  }
  WriteImageCsv(mav0 + "/cam0/data.csv", images);
  ImuSensor imu;
  imu.rate_hz = 200;
  WriteImuSensorYaml(mav0 + "/imu0/sensor.yaml", imu);
  std::vector<ImuSample> samples;
  for (int k = 0; k <= 40; ++k) {
    samples.push_back({kT0 + k * 5'000'000, Eigen::Vector3d::Zero(), Eigen::Vector3d(0, 0, 9.81)});
  }
  WriteImuCsv(mav0 + "/imu0/data.csv", samples);

  EurocImportOptions options;
  options.sequence_folder = mav0;
  options.field_folder = dir_ / "field";
  options.kalibr = ReadKalibr(Write("camchain.yaml", kCamchain), Write("imu.yaml", kImuYaml));
  const EurocImportSummary summary = ImportEuroc(options);
  EXPECT_FALSE(summary.kalibr_lines.empty());
  EXPECT_NE(FormatEurocImportSummary(summary).find("timeshift_cam_imu"), std::string::npos);
  const Session session(dir_ / "field/sessions/2014-06-25");
  const CameraSensor* cam0 = session.FindCamera("cam0");
  ASSERT_NE(cam0, nullptr);
  EXPECT_DOUBLE_EQ(cam0->camera.fx, 612.5);
  EXPECT_DOUBLE_EQ(cam0->camera.k1, -0.21);
  EXPECT_DOUBLE_EQ(cam0->rate_hz, 20.0);  // the sequence's own rate
  EXPECT_NEAR((cam0->body_from_sensor.translation() - Eigen::Vector3d(0.05, 0.02, 0.01)).norm(),
              0.0, 1e-9);
  // Image times moved onto the IMU clock by timeshift_cam_imu; the files are the same.
  const std::vector<ImageEntry> imported = session.ReadImageList("cam0");
  ASSERT_EQ(imported.size(), 3u);
  for (int k = 0; k < 3; ++k) {
    EXPECT_EQ(imported[k].t, images[k].t + 12'345'679);
    EXPECT_EQ(imported[k].filename, images[k].filename);
  }
  EXPECT_DOUBLE_EQ(session.FindImu("imu0")->gyroscope_noise_density, 0.00018);
  EXPECT_DOUBLE_EQ(session.FindImu("imu0")->rate_hz, 200.0);
  // A calibration of another image size is refused, and nothing is written.
  options.field_folder = dir_ / "field2";
  options.kalibr = ReadKalibr(
      Write("camchain_small.yaml",
            Replaced(Replaced(kCamchain, "resolution: [640, 480]", "resolution: [320, 240]"),
                     "321.25, 243.5]", "161.25, 123.5]")),
      "");
  EXPECT_THROW(ImportEuroc(options), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir_ / "field2"));
}

}  // namespace
}  // namespace crop4d::io
