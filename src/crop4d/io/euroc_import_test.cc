#include "crop4d/io/euroc_import.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/tum.h"
#include "crop4d/io/validator.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

const std::string kEuroc = std::string(CROP4D_SHARED_DATA_DIR) + "/euroc_v101_start";

class EurocImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) /
           ("crop4d_euroc_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // A small sequence of its own: mav0/imu0 (2 s at 100 Hz) and a ground truth of 3 states.
  fs::path WriteSequence() const {
    const fs::path mav0 = dir_ / "seq" / "mav0";
    ImuSensor sensor;
    sensor.rate_hz = 100;
    sensor.gyroscope_noise_density = 1e-4;
    sensor.accelerometer_noise_density = 1e-3;
    sensor.gyroscope_random_walk = 1e-5;
    sensor.accelerometer_random_walk = 1e-3;
    WriteImuSensorYaml((mav0 / "imu0" / "sensor.yaml").string(), sensor);
    std::vector<ImuSample> samples;
    for (int k = 0; k <= 200; ++k) {
      samples.push_back(
          {kT0 + k * 10'000'000, Eigen::Vector3d(0, 0, 0.01), Eigen::Vector3d(0, 0, 9.81)});
    }
    WriteImuCsv((mav0 / "imu0" / "data.csv").string(), samples);
    fs::create_directories(mav0 / "state_groundtruth_estimate0");
    std::ofstream truth(mav0 / "state_groundtruth_estimate0" / "data.csv");
    truth << "#timestamp, p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y "
             "[], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x "
             "[rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], "
             "b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
    for (int k = 0; k < 3; ++k) {
      truth << kT0 + k * 500'000'000 << "," << k * 0.1 << ",2,3,1,0,0,0,0.2,0,0,0.001,0.002,0.003,"
            << "0.01,0.02,0.03\n";
    }
    return mav0.parent_path();
  }

  static constexpr Timestamp kT0 = 1403715273262142976;  // 2014-06-25T16:54:33Z
  fs::path dir_;
};

TEST_F(EurocImportTest, ASequenceOfItsOwnBecomesASessionWithItsGroundTruth) {
  EurocImportOptions options;
  options.sequence_folder = WriteSequence().string();
  options.field_folder = (dir_ / "field").string();
  const EurocImportSummary summary = ImportEuroc(options);
  EXPECT_TRUE(summary.field_created);
  ASSERT_EQ(summary.sensors.size(), 1u);
  EXPECT_EQ(summary.sensors[0].name, "imu0");
  EXPECT_EQ(summary.sensors[0].samples, 201);
  EXPECT_EQ(summary.truth_states, 3);
  // The date of the first sample names the session; the IMU files are the sequence's own.
  const fs::path session = dir_ / "field" / "sessions" / "2014-06-25";
  EXPECT_EQ(summary.session_folder, session.string());
  EXPECT_EQ(fs::file_size(session / "imu0" / "data.csv"),
            fs::file_size(dir_ / "seq" / "mav0" / "imu0" / "data.csv"));
  const FieldInfo field = ReadFieldYaml((dir_ / "field" / "field.yaml").string());
  EXPECT_EQ(field.origin.lat_deg, 0.0);
  const std::vector<StampedPose> truth =
      ReadTum((dir_ / "field" / "ground_truth" / "2014-06-25" / "body_poses.tum").string());
  ASSERT_EQ(truth.size(), 3u);
  EXPECT_EQ(truth[2].t, kT0 + 1'000'000'000);
  EXPECT_NEAR(truth[2].pose.translation().x(), 0.2, 1e-9);
  // The field validates (a warning for the missing GPS and camera, no error).
  const ValidationReport report = ValidateField((dir_ / "field").string());
  EXPECT_EQ(report.errors, 0u);
  // A second import of the same session is refused, and replaced with --overwrite.
  EXPECT_THROW(ImportEuroc(options), InputError);
  options.overwrite = true;
  EXPECT_NO_THROW(ImportEuroc(options));
  // Nothing but the session is left in sessions/ (no staging folder).
  int entries = 0;
  for ([[maybe_unused]] const auto& e : fs::directory_iterator(dir_ / "field" / "sessions")) {
    ++entries;
  }
  EXPECT_EQ(entries, 1);
}

TEST_F(EurocImportTest, BadSequencesAreRefusedAndNothingIsWritten) {
  EurocImportOptions options;
  options.field_folder = (dir_ / "field").string();
  // Not a sequence at all.
  options.sequence_folder = dir_.string();
  EXPECT_THROW(ImportEuroc(options), InputError);
  // A ground truth with a short line: the error names the file and the line.
  const fs::path seq = WriteSequence();
  options.sequence_folder = seq.string();
  {
    std::ofstream truth(seq / "mav0" / "state_groundtruth_estimate0" / "data.csv", std::ios::app);
    truth << kT0 + 2'000'000'000 << ",1,2,3\n";
  }
  try {
    ImportEuroc(options);
    FAIL() << "a malformed ground truth was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("data.csv:5"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(dir_ / "field"));
  // An IMU file with a broken line.
  fs::remove(seq / "mav0" / "state_groundtruth_estimate0" / "data.csv");
  {
    std::ofstream imu(seq / "mav0" / "imu0" / "data.csv", std::ios::app);
    imu << "12,abc\n";
  }
  EXPECT_THROW(ImportEuroc(options), InputError);
  EXPECT_FALSE(fs::exists(dir_ / "field"));
}

TEST_F(EurocImportTest, TheRealSequenceImportsAsItIs) {
  if (!fs::exists(kEuroc + "/mav0/cam0/data.csv")) GTEST_SKIP() << "no " << kEuroc;
  EurocImportOptions options;
  options.sequence_folder = kEuroc;
  options.field_folder = (dir_ / "field").string();
  const EurocImportSummary summary = ImportEuroc(options);
  ASSERT_EQ(summary.sensors.size(), 2u);
  EXPECT_EQ(summary.sensors[0].name, "cam0");
  EXPECT_EQ(summary.sensors[0].samples, 95);
  EXPECT_EQ(summary.sensors[1].samples, 29120);
  EXPECT_EQ(summary.truth_states, 2895);
  // Images byte-identical (linked or copied), camera poses at every image time.
  const fs::path image = fs::path("cam0") / "data" / "1403715273262142976.png";
  EXPECT_EQ(fs::file_size(dir_ / "field" / "sessions" / "2014-06-25" / image),
            fs::file_size(fs::path(kEuroc) / "mav0" / image));
  EXPECT_EQ(
      ReadTum((dir_ / "field" / "ground_truth" / "2014-06-25" / "cam0_poses.tum").string()).size(),
      95u);
  EXPECT_EQ(ValidateField((dir_ / "field").string()).errors, 0u);
}

}  // namespace
}  // namespace crop4d::io
