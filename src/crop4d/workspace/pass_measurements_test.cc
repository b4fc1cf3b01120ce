#include "crop4d/workspace/pass_measurements.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/core/file_bytes_test_util.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;
using testing::ReadFileBytes;
using testing::WriteFileBytes;

constexpr Timestamp kSecond = 1'000'000'000;

// Values that use every bit of a double: a round trip that rounds anything fails.
geometry::Rigid3 RandomPose(std::mt19937* rng) {
  std::normal_distribution<double> n;
  const Eigen::Quaterniond q(n(*rng), n(*rng), n(*rng), n(*rng));
  return geometry::Rigid3(q, Eigen::Vector3d(n(*rng), n(*rng), n(*rng)));
}

PassMeasurements Example() {
  std::mt19937 rng(7);
  std::normal_distribution<double> n;
  PassMeasurements p;
  p.image_folder = "sessions/2017-05-01/cam0/data";
  p.camera.emplace();
  io::CameraSensor& cam = p.camera->sensor;
  cam.name = "cam0";
  cam.camera = {1280, 960, 1100.5 + n(rng), 1101.25, 640.1, 480.2, -0.1, 0.01, 1e-4, -2e-4, 1e-3};
  cam.rate_hz = 7.5;
  cam.body_from_sensor = RandomPose(&rng);
  cam.height_above_ground_m = 1.234567;
  for (int i = 0; i < 3; ++i) {
    p.camera->images.push_back(
        {1000 * kSecond + i * 133'333'333, "img" + std::to_string(i) + ".png", 2 + i});
  }
  p.imu.emplace();
  p.imu->sensor = {"imu0", 200.0, 1.7e-4 * (1 + n(rng)), 1.9e-5, 2.0e-3, 3.0e-3, RandomPose(&rng)};
  for (int i = 0; i < 5; ++i) {
    p.imu->samples.push_back({1000 * kSecond + i * 5'000'000, Eigen::Vector3d::Random(),
                              Eigen::Vector3d(n(rng), n(rng), 9.81 + n(rng))});
  }
  p.gps.emplace();
  p.gps->sensor = {
      "gps1", io::GpsKind::kStandard, 10.0, Eigen::Vector3d(0.1, -0.2, 1.5 + n(rng)), 1.5, 3.0};
  p.gps->fixes.push_back(
      {1000 * kSecond, Eigen::Vector3d(n(rng), n(rng), n(rng)), 0.8, 1.6, io::GpsFix::kSingle});
  p.gps->fixes.push_back(
      {1000 * kSecond + kSecond / 10, Eigen::Vector3d(1, 2, 3), 0.02, 0.04, io::GpsFix::kRtkFixed});
  return p;
}

void ExpectSamePose(const geometry::Rigid3& a, const geometry::Rigid3& b) {
  EXPECT_EQ(a.rotation().coeffs(), b.rotation().coeffs());
  EXPECT_EQ(a.translation(), b.translation());
}

// Field by field, with exact equality: the joint problem must see what row SLAM saw.
void ExpectSame(const PassMeasurements& a, const PassMeasurements& b) {
  EXPECT_EQ(a.image_folder, b.image_folder);
  ASSERT_EQ(a.camera.has_value(), b.camera.has_value());
  if (a.camera) {
    const io::CameraSensor& x = a.camera->sensor;
    const io::CameraSensor& y = b.camera->sensor;
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(std::memcmp(&x.camera, &y.camera, sizeof(x.camera)), 0);
    EXPECT_EQ(x.rate_hz, y.rate_hz);
    ExpectSamePose(x.body_from_sensor, y.body_from_sensor);
    EXPECT_EQ(x.height_above_ground_m, y.height_above_ground_m);
    ASSERT_EQ(a.camera->images.size(), b.camera->images.size());
    for (std::size_t i = 0; i < a.camera->images.size(); ++i) {
      EXPECT_EQ(a.camera->images[i].t, b.camera->images[i].t);
      EXPECT_EQ(a.camera->images[i].filename, b.camera->images[i].filename);
      EXPECT_EQ(a.camera->images[i].line, b.camera->images[i].line);
    }
  }
  ASSERT_EQ(a.imu.has_value(), b.imu.has_value());
  if (a.imu) {
    const io::ImuSensor& x = a.imu->sensor;
    const io::ImuSensor& y = b.imu->sensor;
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.rate_hz, y.rate_hz);
    EXPECT_EQ(x.gyroscope_noise_density, y.gyroscope_noise_density);
    EXPECT_EQ(x.gyroscope_random_walk, y.gyroscope_random_walk);
    EXPECT_EQ(x.accelerometer_noise_density, y.accelerometer_noise_density);
    EXPECT_EQ(x.accelerometer_random_walk, y.accelerometer_random_walk);
    ExpectSamePose(x.body_from_sensor, y.body_from_sensor);
    ASSERT_EQ(a.imu->samples.size(), b.imu->samples.size());
    for (std::size_t i = 0; i < a.imu->samples.size(); ++i) {
      EXPECT_EQ(a.imu->samples[i].timestamp, b.imu->samples[i].timestamp);
      EXPECT_EQ(a.imu->samples[i].gyro_body, b.imu->samples[i].gyro_body);
      EXPECT_EQ(a.imu->samples[i].accel_body, b.imu->samples[i].accel_body);
    }
  }
  ASSERT_EQ(a.gps.has_value(), b.gps.has_value());
  if (a.gps) {
    const io::GpsSensor& x = a.gps->sensor;
    const io::GpsSensor& y = b.gps->sensor;
    EXPECT_EQ(x.name, y.name);
    EXPECT_EQ(x.kind, y.kind);
    EXPECT_EQ(x.rate_hz, y.rate_hz);
    EXPECT_EQ(x.antenna_in_body, y.antenna_in_body);
    EXPECT_EQ(x.default_sigma_h, y.default_sigma_h);
    EXPECT_EQ(x.default_sigma_v, y.default_sigma_v);
    ASSERT_EQ(a.gps->fixes.size(), b.gps->fixes.size());
    for (std::size_t i = 0; i < a.gps->fixes.size(); ++i) {
      EXPECT_EQ(a.gps->fixes[i].t, b.gps->fixes[i].t);
      EXPECT_EQ(a.gps->fixes[i].position_world, b.gps->fixes[i].position_world);
      EXPECT_EQ(a.gps->fixes[i].sigma_h, b.gps->fixes[i].sigma_h);
      EXPECT_EQ(a.gps->fixes[i].sigma_v, b.gps->fixes[i].sigma_v);
      EXPECT_EQ(a.gps->fixes[i].fix, b.gps->fixes[i].fix);
    }
  }
}

class PassMeasurementsTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_pass_measurements_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
    path_ = (dir_ / "measurements.bin").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The error a damaged file gives (empty when it was accepted).
  std::string ErrorOf(const std::string& bytes) {
    WriteFileBytes(path_, bytes);
    try {
      ReadPassMeasurements(path_);
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  }

  fs::path dir_;
  std::string path_;
};

TEST_F(PassMeasurementsTest, RoundTripsBitForBit) {
  const PassMeasurements m = Example();
  WritePassMeasurements(path_, m);
  ExpectSame(ReadPassMeasurements(path_), m);
  // Writing what was read gives the same bytes.
  const std::string first = ReadFileBytes(path_);
  WritePassMeasurements(path_, ReadPassMeasurements(path_));
  EXPECT_EQ(ReadFileBytes(path_), first);
}

TEST_F(PassMeasurementsTest, RoundTripsEachPartAlone) {
  const PassMeasurements full = Example();
  for (int part = 0; part < 4; ++part) {
    PassMeasurements p;
    if (part == 1) {
      p.camera = full.camera;
      p.image_folder = full.image_folder;
    }
    if (part == 2) p.imu = full.imu;
    if (part == 3) p.gps = full.gps;
    WritePassMeasurements(path_, p);
    SCOPED_TRACE(part);
    ExpectSame(ReadPassMeasurements(path_), p);
  }
}

TEST_F(PassMeasurementsTest, ImagePathJoinsFieldFolderAndName) {
  EXPECT_EQ(Example().ImagePath("/data/field", 1),
            "/data/field/sessions/2017-05-01/cam0/data/img1.png");
}

TEST_F(PassMeasurementsTest, RejectsDamagedFiles) {
  EXPECT_NE(ErrorOf("").find("measurements"), std::string::npos);
  fs::remove(path_);
  try {
    ReadPassMeasurements(path_);
    FAIL() << "a missing file was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("crop4d slam"), std::string::npos) << e.what();
  }
  WritePassMeasurements(path_, Example());
  const std::string good = ReadFileBytes(path_);
  // Every truncation is an error naming the file.
  for (std::size_t size : {std::size_t{5}, std::size_t{13}, good.size() / 2, good.size() - 1}) {
    const std::string why = ErrorOf(good.substr(0, size));
    EXPECT_NE(why.find(path_), std::string::npos) << size << ": " << why;
  }
  // A flipped bit anywhere in the payload or footer.
  for (std::size_t at = 12; at < good.size(); at += 17) {
    std::string flipped = good;
    flipped[at] ^= 0x10;
    EXPECT_FALSE(ErrorOf(flipped).empty()) << "flipped byte " << at << " was accepted";
  }
  std::string foreign = good;
  foreign[1] = 'X';
  EXPECT_NE(ErrorOf(foreign).find("not a crop4d pass measurements"), std::string::npos);
  std::string version = good;
  version[8] = 2;
  EXPECT_NE(ErrorOf(version).find("version 2"), std::string::npos);
  EXPECT_TRUE(ErrorOf(good).empty());
}

TEST_F(PassMeasurementsTest, SessionImagesJoinTheSessionsPassesOnce) {
  const std::string workspace = (dir_ / "ws").string();
  const Layout layout(workspace);
  PassMeasurements a = Example();
  PassMeasurements b = Example();
  b.camera->images.erase(b.camera->images.begin());  // b starts at a's second image
  b.camera->images.push_back({2000 * kSecond, "late.png", 9});
  PassMeasurements imu_only;
  imu_only.imu = Example().imu;
  std::vector<slam::RowPass> passes(3);
  passes[0].id = "row00";
  passes[1].id = "row01";
  passes[2].id = "all";
  for (std::size_t p = 0; p < passes.size(); ++p) {
    fs::create_directories(layout.PassDir("s", passes[p].id));
    WritePassMeasurements(layout.PassMeasurements("s", passes[p].id).string(), p == 0   ? a
                                                                               : p == 1 ? b
                                                                                        : imu_only);
  }
  WritePassList(layout.PassList("s").string(), passes);

  const io::ImageSequence images = SessionImages(workspace, "s", "/f", "");
  ASSERT_EQ(images.size(), 4u);  // three of a, b's two again and one more
  EXPECT_EQ(images.entry(3).filename, "late.png");
  EXPECT_EQ(images.Path(0), "/f/sessions/2017-05-01/cam0/data/img0.png");
  EXPECT_EQ(images.camera().name, "cam0");
  EXPECT_EQ(SessionImages(workspace, "s", "/f", "cam0").size(), 4u);
  // Another camera than row SLAM's, or passes of two cameras, are errors that name them.
  try {
    SessionImages(workspace, "s", "/f", "cam1");
    FAIL() << "another camera was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("cam1"), std::string::npos) << e.what();
  }
  b.camera->sensor.name = "cam1";
  WritePassMeasurements(layout.PassMeasurements("s", "row01").string(), b);
  EXPECT_THROW(SessionImages(workspace, "s", "/f", ""), InputError);
  // A session without any camera pass.
  WritePassList(layout.PassList("s").string(), {passes[2]});
  EXPECT_THROW(SessionImages(workspace, "s", "/f", ""), InputError);
}

TEST(SelectPassMeasurements, KeepsThePassImagesImuMarginAndGpsWindow) {
  slam::SessionStreams streams;
  streams.camera.emplace();
  streams.imu.emplace();
  for (int i = 0; i < 100; ++i) {
    streams.camera->images.push_back({i * kSecond, std::to_string(i) + ".png", i + 2});
  }
  // IMU every 0.1 s from 0 to 99.9 s, then a gap of 10 s, then samples again.
  for (int i = 0; i < 1000; ++i) streams.imu->samples.push_back({i * kSecond / 10, {}, {}});
  for (int i = 0; i < 10; ++i)
    streams.imu->samples.push_back({110 * kSecond + i * kSecond, {}, {}});
  slam::GpsStream gps;
  gps.sensor.name = "gps0";
  for (int i = 0; i < 120; ++i) gps.fixes.push_back({i * kSecond, {}, 0.02, 0.04, {}});

  const PassMeasurements p = SelectPassMeasurements(
      &*streams.camera, &*streams.imu, &gps, {20 * kSecond, 21 * kSecond, 30 * kSecond},
      20 * kSecond, 30 * kSecond, "sessions/s/cam0/data");
  ASSERT_TRUE(p.camera && p.imu && p.gps);
  EXPECT_EQ(p.image_folder, "sessions/s/cam0/data");
  ASSERT_EQ(p.camera->images.size(), 3u);
  EXPECT_EQ(p.camera->images[2].filename, "30.png");
  // 19.0 s .. 31.0 s (the margin is one second either side; the sample at 31 s is past it).
  EXPECT_EQ(p.imu->samples.front().timestamp, 19 * kSecond);
  EXPECT_EQ(p.imu->samples.back().timestamp, 31 * kSecond - kSecond / 10);
  EXPECT_EQ(p.gps->fixes.size(), 11u);
  EXPECT_EQ(p.gps->fixes.front().t, 20 * kSecond);
  EXPECT_EQ(p.gps->sensor.name, "gps0");

  // States inside the IMU gap: the samples bracketing them are kept.
  const PassMeasurements gap =
      SelectPassMeasurements(nullptr, &*streams.imu, nullptr, {}, 102 * kSecond, 105 * kSecond, "");
  ASSERT_TRUE(gap.imu);
  EXPECT_FALSE(gap.gps);
  EXPECT_LE(gap.imu->samples.front().timestamp, 102 * kSecond);
  EXPECT_GE(gap.imu->samples.back().timestamp, 105 * kSecond);
  EXPECT_EQ(gap.imu->samples.size(), 2u);

  EXPECT_FALSE(gap.camera);
  // Without the IMU in the problem (row SLAM from camera and GPS only), none is kept.
  EXPECT_FALSE(SelectPassMeasurements(&*streams.camera, nullptr, nullptr, {}, 0, kSecond, "x").imu);
}

}  // namespace
}  // namespace crop4d::workspace
