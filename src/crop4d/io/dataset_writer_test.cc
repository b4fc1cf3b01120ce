// Round trips: everything the writers produce, the reader reads back exactly.

#include "crop4d/io/dataset_writer.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> FilesIn(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(folder)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

TEST(AtomicFileTest, CommitReplacesAndLeavesNoTemporaryFile) {
  testing::TempDir dir;
  const std::string path = dir / "a/b/out.txt";
  WriteFileAtomic(path, "first");
  WriteFileAtomic(path, "second");
  EXPECT_EQ(testing::ReadText(path), "second");
  EXPECT_EQ(FilesIn(dir / "a/b"), std::vector<std::string>{"out.txt"});
}

TEST(AtomicFileTest, WithoutCommitNothingAppears) {
  testing::TempDir dir;
  {
    AtomicFile file(dir / "out.txt");
    file.stream() << "partial";
  }
  EXPECT_TRUE(FilesIn(dir.path()).empty());
}

TEST(AtomicFileTest, StaleTemporaryFilesOfAKilledWriterAreRemoved) {
  testing::TempDir dir;
  WriteFileAtomic(dir / "keep.ply", "kept");
  WriteFileAtomic(dir / "sub/keep.json", "kept");
  // What a process killed before Commit() leaves (AtomicFile's own names), and look-alikes.
  std::ofstream(dir / "keep.ply.tmp.123.0") << "partial";
  std::ofstream(dir / "sub/keep.json.tmp.4567.12") << "partial";
  std::ofstream(dir / "notes.tmp.txt") << "user file";
  std::ofstream(dir / "a.tmp.12.x") << "user file";
  EXPECT_EQ(RemoveStaleTemporaryFiles(dir.path()), 2);
  EXPECT_EQ(FilesIn(dir.path()),
            (std::vector<std::string>{"a.tmp.12.x", "keep.ply", "notes.tmp.txt", "sub"}));
  EXPECT_EQ(FilesIn(dir / "sub"), std::vector<std::string>{"keep.json"});
  EXPECT_EQ(RemoveStaleTemporaryFiles(dir / "missing"), 0);
}

TEST(AtomicFileTest, FolderAsTargetIsAnInputError) {
  testing::TempDir dir;
  fs::create_directories(dir / "taken");
  EXPECT_THROW(WriteFileAtomic(dir / "taken", "x"), InputError);
}

TEST(DatasetWriterTest, FieldYamlRoundTrip) {
  testing::TempDir dir;
  FieldInfo field;
  field.name = "North \"plot\"\nwith: colon";
  field.origin = {33.77561234567, -84.39631234567, 290.123};
  field.rows = {{0, {0.0, 0.0}, {0.0, 50.5}}, {3, {2.7, -1.25}, {2.7, 49.0}}};
  field.sites = {{"s01", {0.1, 5.0}, 0.5}, {"plot #2", {-3.5, 12.25}, 0.3}};
  field.sessions = {"2016-05-25", "2016-06-01"};
  WriteFieldYaml(dir / "field.yaml", field);
  Diagnostics diag;
  const FieldInfo read = ReadFieldYaml(dir / "field.yaml", &diag);
  EXPECT_EQ(diag.error_count() + diag.warning_count(), 0u);
  EXPECT_EQ(read.name, field.name);
  EXPECT_EQ(read.origin.lat_deg, field.origin.lat_deg);
  EXPECT_EQ(read.origin.lon_deg, field.origin.lon_deg);
  EXPECT_EQ(read.origin.alt_m, field.origin.alt_m);
  ASSERT_EQ(read.rows.size(), 2u);
  EXPECT_EQ(read.rows[1].index, 3);
  EXPECT_EQ(read.rows[1].start_enu, Eigen::Vector2d(2.7, -1.25));
  EXPECT_EQ(read.rows[1].end_enu, Eigen::Vector2d(2.7, 49.0));
  ASSERT_EQ(read.sites.size(), 2u);
  EXPECT_EQ(read.sites[1].id, "plot #2");
  EXPECT_EQ(read.sites[1].center_enu, Eigen::Vector2d(-3.5, 12.25));
  EXPECT_EQ(read.sites[1].radius_m, 0.3);
  EXPECT_EQ(read.sessions, field.sessions);
}

TEST(DatasetWriterTest, SessionYamlRoundTrip) {
  testing::TempDir dir;
  SessionInfo session;
  session.id = "morning";
  session.date = FromDate(2016, 6, 1);
  session.notes = "overcast; 'wet' soil";
  session.rain_before = true;
  WriteSessionYaml(dir / "session.yaml", session);
  const SessionInfo read = ReadSessionYaml(dir / "session.yaml", "morning");
  EXPECT_EQ(read.id, "morning");
  EXPECT_EQ(read.date, session.date);
  EXPECT_EQ(read.notes, session.notes);
  EXPECT_TRUE(read.rain_before);
}

TEST(DatasetWriterTest, SensorYamlRoundTrips) {
  testing::TempDir dir;
  const geometry::Rigid3 body_from_sensor(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(0.1, -0.02, 0.3));

  CameraSensor cam;
  cam.name = "cam0";
  cam.rate_hz = 7.5;
  cam.camera = {1280, 960, 1100.5, 1101.25, 640.5, 480.25, -0.1, 0.02, 1e-4, -2e-4, 0.003};
  cam.body_from_sensor = body_from_sensor;
  WriteCameraSensorYaml(dir / "cam0/sensor.yaml", cam);
  Diagnostics diag;
  const CameraSensor cam_read = ReadCameraSensorYaml(dir / "cam0/sensor.yaml", &diag);
  EXPECT_EQ(cam_read.name, "cam0");
  EXPECT_EQ(cam_read.rate_hz, 7.5);
  EXPECT_EQ(cam_read.camera.width, 1280);
  EXPECT_EQ(cam_read.camera.height, 960);
  EXPECT_EQ(cam_read.camera.fx, 1100.5);
  EXPECT_EQ(cam_read.camera.fy, 1101.25);
  EXPECT_EQ(cam_read.camera.cx, 640.5);
  EXPECT_EQ(cam_read.camera.cy, 480.25);
  EXPECT_EQ(cam_read.camera.k1, -0.1);
  EXPECT_EQ(cam_read.camera.k2, 0.02);
  EXPECT_EQ(cam_read.camera.p1, 1e-4);
  EXPECT_EQ(cam_read.camera.p2, -2e-4);
  EXPECT_EQ(cam_read.camera.k3, 0.003);
  EXPECT_TRUE(cam_read.body_from_sensor.Matrix().isApprox(body_from_sensor.Matrix(), 1e-12));
  EXPECT_FALSE(cam_read.height_above_ground_m.has_value());
  // The optional camera height round-trips; a height that is not one is an error on its line.
  cam.height_above_ground_m = 1.42;
  WriteCameraSensorYaml(dir / "cam0/sensor.yaml", cam);
  EXPECT_EQ(ReadCameraSensorYaml(dir / "cam0/sensor.yaml", &diag).height_above_ground_m, 1.42);
  EXPECT_FALSE(diag.HasErrors());
  cam.height_above_ground_m = -0.5;
  WriteCameraSensorYaml(dir / "cam0/sensor.yaml", cam);
  try {
    Diagnostics bad;
    ReadCameraSensorYaml(dir / "cam0/sensor.yaml", &bad);
    ADD_FAILURE() << "a negative camera height was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("height_above_ground_m"), std::string::npos) << e.what();
  }

  ImuSensor imu;
  imu.name = "imu0";
  imu.rate_hz = 167;
  imu.gyroscope_noise_density = 1.6968e-04;
  imu.gyroscope_random_walk = 1.9393e-05;
  imu.accelerometer_noise_density = 2.0e-3;
  imu.accelerometer_random_walk = 3.0e-3;
  imu.body_from_sensor = body_from_sensor;
  WriteImuSensorYaml(dir / "imu0/sensor.yaml", imu);
  const ImuSensor imu_read = ReadImuSensorYaml(dir / "imu0/sensor.yaml", &diag);
  EXPECT_EQ(imu_read.rate_hz, 167);
  EXPECT_EQ(imu_read.gyroscope_noise_density, 1.6968e-04);
  EXPECT_EQ(imu_read.gyroscope_random_walk, 1.9393e-05);
  EXPECT_EQ(imu_read.accelerometer_noise_density, 2.0e-3);
  EXPECT_EQ(imu_read.accelerometer_random_walk, 3.0e-3);
  EXPECT_TRUE(imu_read.body_from_sensor.Matrix().isApprox(body_from_sensor.Matrix(), 1e-12));

  MagSensor mag;
  mag.rate_hz = 110;
  WriteMagSensorYaml(dir / "mag0/sensor.yaml", mag);
  EXPECT_EQ(ReadMagSensorYaml(dir / "mag0/sensor.yaml", &diag).rate_hz, 110);

  GpsSensor gps;
  gps.kind = GpsKind::kStandard;
  gps.rate_hz = 4;
  gps.antenna_in_body = Eigen::Vector3d(0.05, -0.1, 0.95);
  gps.default_sigma_h = 1.5;
  gps.default_sigma_v = 3.5;
  WriteGpsSensorYaml(dir / "gps1/sensor.yaml", gps);
  const GpsSensor gps_read = ReadGpsSensorYaml(dir / "gps1/sensor.yaml", &diag);
  EXPECT_EQ(gps_read.name, "gps1");
  EXPECT_EQ(gps_read.kind, GpsKind::kStandard);
  EXPECT_EQ(gps_read.rate_hz, 4);
  EXPECT_EQ(gps_read.antenna_in_body, gps.antenna_in_body);
  EXPECT_EQ(gps_read.default_sigma_h, 1.5);
  EXPECT_EQ(gps_read.default_sigma_v, 3.5);
  EXPECT_EQ(diag.error_count() + diag.warning_count(), 0u);
}

TEST(DatasetWriterTest, CsvRoundTripsAreExact) {
  testing::TempDir dir;
  std::vector<ImuSample> imu = {
      {1464184800000000001, {0.1, -1e-7, 3.0000000000000004}, {0, 9.80665, -1.0 / 3.0}},
      {1464184800005988024, {1, 2, 3}, {4, 5, 6}}};
  WriteImuCsv(dir / "imu.csv", imu);
  std::vector<ImuSample> imu_read;
  ReadImuCsv(
      dir / "imu.csv", [&](const ImuSample& s, std::int64_t) { imu_read.push_back(s); }, nullptr);
  ASSERT_EQ(imu_read.size(), 2u);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(imu_read[i].t, imu[i].t);
    EXPECT_EQ(imu_read[i].gyro, imu[i].gyro);
    EXPECT_EQ(imu_read[i].accel, imu[i].accel);
  }
  std::vector<GpsSample> gps(1);
  gps[0].t = 1464184800200000000;
  gps[0].position = {33.775612345678901, -84.396312345678901, 290.0625};
  gps[0].sigma_h = 0.021;
  gps[0].sigma_v = 0.043;
  gps[0].fix = GpsFix::kRtkFloat;
  WriteGpsCsv(dir / "gps.csv", gps);
  std::vector<GpsSample> gps_read;
  ReadGpsCsv(
      dir / "gps.csv", [&](const GpsSample& s, std::int64_t) { gps_read.push_back(s); }, nullptr);
  ASSERT_EQ(gps_read.size(), 1u);
  EXPECT_EQ(gps_read[0].position.lat_deg, gps[0].position.lat_deg);
  EXPECT_EQ(gps_read[0].position.lon_deg, gps[0].position.lon_deg);
  EXPECT_EQ(gps_read[0].position.alt_m, 290.0625);
  EXPECT_EQ(gps_read[0].sigma_h, 0.021);
  EXPECT_EQ(gps_read[0].sigma_v, 0.043);
  EXPECT_EQ(gps_read[0].fix, GpsFix::kRtkFloat);
  std::vector<MagSample> mag = {{5, {22.5, -0.125, -42}}};
  WriteMagCsv(dir / "mag.csv", mag);
  std::vector<MagSample> mag_read;
  ReadMagCsv(
      dir / "mag.csv", [&](const MagSample& s, std::int64_t) { mag_read.push_back(s); }, nullptr);
  ASSERT_EQ(mag_read.size(), 1u);
  EXPECT_EQ(mag_read[0].field_ut, mag[0].field_ut);
  std::vector<ImageEntry> images = {{10, "10.png", 0}, {20, "sub/20.png", 0}};
  WriteImageCsv(dir / "cam.csv", images);
  EXPECT_EQ(testing::ReadText(dir / "cam.csv"),
            "#timestamp [ns],filename\n10,10.png\n20,sub/20.png\n");
}

}  // namespace
}  // namespace crop4d::io
