// ROS 1 bag import: the tests write their own bags (BagWriter, the same library) from the sample
// session (sample_field.h, through session_bag_writer.h) and from hand-made messages, import
// them and compare.

#include "crop4d/io/rosbag/bag_import.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/rosbag/ros_bag.h"
#include "crop4d/io/rosbag/session_bag_writer.h"
#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::ImageMessage;
using testing::ImageMode;
using testing::ReadLines;
using testing::ReadText;
using testing::SessionBagOptions;
using testing::TempDir;
using testing::UseSessionCalibration;
using testing::WriteSessionBag;
using testing::WriteText;

constexpr const char* kSessionId = "2016-05-25";
constexpr Timestamp kT0 = 1464184800000000000;  // 2016-05-25 14:00 UTC

std::vector<std::uint8_t> ReadBytes(const std::string& path) {
  const std::string text = ReadText(path);
  return std::vector<std::uint8_t>(text.begin(), text.end());
}

CameraSensor Camera(int width, int height) {
  CameraSensor c;
  c.camera.width = width;
  c.camera.height = height;
  c.camera.fx = c.camera.fy = 10;
  c.camera.cx = width / 2.0;
  c.camera.cy = height / 2.0;
  return c;
}

// The InputError's text (file and message) of running `f`, or "" when nothing is thrown.
template <typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

class BagImportTest : public ::testing::Test {
 protected:
  void SetUp() override { WriteSampleField(original_field()); }
  std::string original_field() const { return dir_ / "original"; }
  std::string original_session() const {
    return dir_ / ("original/sessions/" + std::string(kSessionId));
  }
  std::string imported_session() const {
    return dir_ / ("imported/sessions/" + std::string(kSessionId));
  }
  BagImportOptions Options(const std::string& bag) const {
    BagImportOptions o;
    o.bag_path = bag;
    o.field_folder = dir_ / "imported";
    return o;
  }
  // The entries of the imported field's sessions/ folder (hidden ones included).
  std::vector<std::string> SessionsFolderEntries() const {
    std::vector<std::string> names;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir_ / "imported/sessions", ec)) {
      names.push_back(e.path().filename().string());
    }
    return names;
  }
  TempDir dir_;
};

// ---- the whole session, byte for byte ----

class BagRoundTripTest : public BagImportTest,
                         public ::testing::WithParamInterface<BagCompression> {};

TEST_P(BagRoundTripTest, SessionComesBackByteForByte) {
  const std::string bag = dir_ / "session.bag";
  SessionBagOptions bag_options;
  bag_options.compression = GetParam();
  const std::map<std::string, std::string> topics =
      WriteSessionBag(original_session(), bag, bag_options);
  EXPECT_EQ(topics, (std::map<std::string, std::string>{{"cam0", "/cam0/image_raw"},
                                                        {"gps0", "/gps0/fix"},
                                                        {"imu0", "/imu0/data"},
                                                        {"mag0", "/mag0/mag"}}));
  // The topics are not named: the importer picks the bag's only topic of each kind.
  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  EXPECT_EQ(o.sensor_yaml_files.size(), 4u);
  // The original field's origin (--origin): the same ENU frame, so `crop4d run` sees the same
  // input (the default, the first GPS fix, is tested below).
  const FieldInfo original_field_info = ReadFieldYaml(original_field() + "/field.yaml");
  o.origin = original_field_info.origin;
  const BagImportSummary summary = ImportBag(o);

  EXPECT_EQ(summary.session_folder, imported_session());
  EXPECT_TRUE(summary.field_created);
  ASSERT_EQ(summary.sensors.size(), 4u);
  const fs::path a(original_session()), b(imported_session());
  // --sensor-yaml files are copied as they are.
  for (const char* sensor : {"cam0", "imu0", "mag0", "gps0"}) {
    EXPECT_EQ(ReadText((b / sensor / kSensorYaml).string()),
              ReadText((a / sensor / kSensorYaml).string()))
        << sensor;
  }
  for (const char* sensor : {"cam0", "imu0", "mag0"}) {
    EXPECT_EQ(ReadText((b / sensor / kDataCsv).string()),
              ReadText((a / sensor / kDataCsv).string()))
        << sensor;
  }
  // GPS: NavSatFix has no RTK-float status (drivers send GBAS_FIX for fixed and float alike),
  // so fix 5 comes back as 4; every other column is the same text.
  std::vector<std::string> expected = ReadLines((a / "gps0" / kDataCsv).string());
  int floats = 0;
  for (std::string& line : expected) {
    if (line.ends_with(",5")) {
      line.back() = '4';
      ++floats;
    }
  }
  EXPECT_GT(floats, 0);
  EXPECT_EQ(ReadLines((b / "gps0" / kDataCsv).string()), expected);
  // Images: the same PNG files (re-encoded by the same OpenCV) and the same pixels.
  const std::vector<ImageEntry> images = Session(original_session()).ReadImageList("cam0");
  ASSERT_GT(images.size(), 10u);
  for (const ImageEntry& e : images) {
    const std::string from = (a / "cam0/data" / e.filename).string();
    const std::string to = (b / "cam0/data" / e.filename).string();
    ASSERT_TRUE(fs::exists(to)) << to;
    EXPECT_EQ(ReadText(to), ReadText(from)) << e.filename;
    const cv::Mat pa = cv::imread(from, cv::IMREAD_UNCHANGED);
    const cv::Mat pb = cv::imread(to, cv::IMREAD_UNCHANGED);
    EXPECT_EQ(cv::norm(pa, pb, cv::NORM_INF), 0.0);
  }
  // field.yaml has the given origin; the session is listed.
  const FieldInfo field = ReadFieldYaml(dir_ / "imported/field.yaml");
  EXPECT_EQ(field.origin.lat_deg, original_field_info.origin.lat_deg);
  EXPECT_EQ(field.origin.lon_deg, original_field_info.origin.lon_deg);
  EXPECT_EQ(field.origin.alt_m, original_field_info.origin.alt_m);
  EXPECT_EQ(Field(dir_ / "imported").session_ids(), std::vector<std::string>{kSessionId});
  // Nothing else is left in sessions/ (the staging folder is gone).
  EXPECT_EQ(SessionsFolderEntries(), std::vector<std::string>{kSessionId});
}

INSTANTIATE_TEST_SUITE_P(Compression, BagRoundTripTest,
                         ::testing::Values(BagCompression::kNone, BagCompression::kBz2,
                                           BagCompression::kLz4),
                         [](const ::testing::TestParamInfo<BagCompression>& info) {
                           return info.param == BagCompression::kNone  ? std::string("plain")
                                  : info.param == BagCompression::kBz2 ? std::string("bz2")
                                                                       : std::string("lz4");
                         });

TEST_F(BagImportTest, CompressedPngIsWrittenAsItIs) {
  const std::string bag = dir_ / "png.bag";
  SessionBagOptions bag_options;
  bag_options.images = ImageMode::kCompressed;
  bag_options.compression = BagCompression::kLz4;
  WriteSessionBag(original_session(), bag, bag_options);
  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  ImportBag(o);
  const fs::path a(original_session()), b(imported_session());
  EXPECT_EQ(ReadText((b / "cam0" / kDataCsv).string()), ReadText((a / "cam0" / kDataCsv).string()));
  for (const ImageEntry& e : Session(original_session()).ReadImageList("cam0")) {
    EXPECT_EQ(ReadText((b / "cam0/data" / e.filename).string()),
              ReadText((a / "cam0/data" / e.filename).string()));
  }
}

TEST_F(BagImportTest, CompressedJpegIsWrittenAsItIsWithItsExtension) {
  const std::string bag = dir_ / "jpeg.bag";
  std::vector<std::vector<std::uint8_t>> jpegs;
  std::vector<Timestamp> stamps;
  {
    BagWriter writer(bag, BagCompression::kBz2);
    for (int i = 0; i < 3; ++i) {
      cv::Mat image(24, 32, CV_8UC3, cv::Scalar(10 + 40 * i, 100, 200 - 30 * i));
      cv::circle(image, {16, 12}, 5, cv::Scalar(255, 255, 255), -1);
      std::vector<std::uint8_t> bytes;
      ASSERT_TRUE(cv::imencode(".jpg", image, bytes));
      RosCompressedImage m;
      m.stamp = kT0 + i * 133333333;
      m.format = "bgr8; jpeg compressed bgr8";
      m.data = bytes;
      writer.Write("/camera/image/compressed", m.stamp + 1000, m);
      jpegs.push_back(bytes);
      stamps.push_back(m.stamp);
    }
  }
  BagImportOptions o = Options(bag);
  o.cameras["cam0"] = Camera(32, 24);
  const BagImportSummary summary = ImportBag(o);
  ASSERT_EQ(summary.sensors.size(), 1u);
  EXPECT_EQ(summary.sensors[0].topic, "/camera/image/compressed");
  const std::vector<ImageEntry> images = Session(imported_session()).ReadImageList("cam0");
  ASSERT_EQ(images.size(), 3u);
  for (int i = 0; i < 3; ++i) {
    EXPECT_EQ(images[i].t, stamps[i]);
    EXPECT_EQ(images[i].filename, std::to_string(stamps[i]) + ".jpg");
    EXPECT_EQ(ReadBytes(imported_session() + "/cam0/data/" + images[i].filename), jpegs[i]);
  }
}

// ---- raw image encodings ----

class BagEncodingTest : public BagImportTest {
 protected:
  // Imports one image message on /cam and returns the written file decoded as it is.
  cv::Mat ImportOne(const RosImage& m) {
    const std::string bag = dir_ / ("enc" + std::to_string(count_++) + ".bag");
    {
      BagWriter writer(bag, BagCompression::kNone);
      writer.Write("/cam", m.stamp, m);
    }
    BagImportOptions o = Options(bag);
    o.field_folder = dir_ / ("field" + std::to_string(count_));
    o.cameras["cam0"] = Camera(static_cast<int>(m.width), static_cast<int>(m.height));
    const BagImportSummary summary = ImportBag(o);
    const std::string path =
        summary.session_folder + "/cam0/data/" + std::to_string(m.stamp) + ".png";
    return cv::imread(path, cv::IMREAD_UNCHANGED);
  }
  int count_ = 0;
};

cv::Mat Pattern(int type) {
  cv::Mat image(5, 7, type);
  cv::randu(image, 0, type == CV_16UC1 ? 65536 : 256);
  return image;
}

bool Same(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0.0;
}

TEST_F(BagEncodingTest, Mono8Bgr8Rgb8AreExact) {
  const cv::Mat mono = Pattern(CV_8UC1);
  EXPECT_TRUE(Same(ImportOne(ImageMessage(mono, kT0, "mono8")), mono));
  const cv::Mat bgr = Pattern(CV_8UC3);
  // A row stride with padding (step > width * 3) as some drivers write.
  EXPECT_TRUE(Same(ImportOne(ImageMessage(bgr, kT0, "bgr8", 5)), bgr));
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  EXPECT_TRUE(Same(ImportOne(ImageMessage(rgb, kT0, "rgb8")), bgr));
}

TEST_F(BagEncodingTest, Mono16IsExactInBothByteOrders) {
  const cv::Mat mono16 = Pattern(CV_16UC1);
  RosImage little = ImageMessage(mono16, kT0, "mono16");  // this host is little-endian
  EXPECT_TRUE(Same(ImportOne(little), mono16));
  RosImage big = little;
  big.is_bigendian = 1;
  for (std::size_t i = 0; i + 1 < big.data.size(); i += 2) std::swap(big.data[i], big.data[i + 1]);
  EXPECT_TRUE(Same(ImportOne(big), mono16));
}

TEST_F(BagEncodingTest, BayerPatternsDemosaicToTheirColour) {
  // A uniform colour mosaiced in each pattern must demosaic to that colour: a wrong pattern
  // mapping swaps red and blue or puts green where red is.
  const cv::Vec3b bgr(30, 120, 200);
  const std::map<std::string, std::array<char, 4>> patterns = {
      {"bayer_rggb8", {'R', 'G', 'G', 'B'}},
      {"bayer_bggr8", {'B', 'G', 'G', 'R'}},
      {"bayer_gbrg8", {'G', 'B', 'R', 'G'}},
      {"bayer_grbg8", {'G', 'R', 'B', 'G'}}};
  for (const auto& [encoding, layout] : patterns) {
    cv::Mat mosaic(8, 10, CV_8UC1);
    for (int r = 0; r < mosaic.rows; ++r) {
      for (int c = 0; c < mosaic.cols; ++c) {
        const char channel = layout[(r % 2) * 2 + (c % 2)];
        mosaic.at<std::uint8_t>(r, c) = channel == 'B' ? bgr[0] : channel == 'G' ? bgr[1] : bgr[2];
      }
    }
    const cv::Mat image = ImportOne(ImageMessage(mosaic, kT0, encoding));
    ASSERT_EQ(image.type(), CV_8UC3) << encoding;
    for (int r = 2; r < image.rows - 2; ++r) {
      for (int c = 2; c < image.cols - 2; ++c) {
        EXPECT_EQ(image.at<cv::Vec3b>(r, c), bgr) << encoding << " at " << r << "," << c;
      }
    }
  }
}

TEST_F(BagEncodingTest, UnsupportedEncodingAndShortDataAreErrors) {
  RosImage m = ImageMessage(Pattern(CV_8UC1), kT0, "yuv422");
  EXPECT_NE(ErrorOf([&] { ImportOne(m); }).find("yuv422"), std::string::npos);
  m = ImageMessage(Pattern(CV_8UC1), kT0, "mono8");
  m.data.resize(m.data.size() - 1);
  EXPECT_NE(ErrorOf([&] { ImportOne(m); }).find("do not fit"), std::string::npos);
}

TEST_F(BagEncodingTest, CameraTimeShiftMovesTheImageStamps) {
  const std::string bag = dir_ / "shift.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    for (int i = 0; i < 3; ++i) {
      const Timestamp t = kT0 + i * 100000000;
      writer.Write("/cam", t, ImageMessage(Pattern(CV_8UC1), t, "mono8"));
    }
  }
  BagImportOptions o = Options(bag);
  o.cameras["cam0"] = Camera(7, 5);
  o.camera_time_shift_ns["cam0"] = -2500000;  // Kalibr: t_imu = t_cam + timeshift_cam_imu
  const BagImportSummary summary = ImportBag(o);
  const std::vector<ImageEntry> images = Session(summary.session_folder).ReadImageList("cam0");
  ASSERT_EQ(images.size(), 3u);
  EXPECT_EQ(images[0].t, kT0 - 2500000);
  EXPECT_EQ(images[2].t, kT0 + 200000000 - 2500000);
  EXPECT_EQ(images[2].filename, std::to_string(kT0 + 200000000 - 2500000) + ".png");
  EXPECT_TRUE(fs::exists(summary.session_folder + "/cam0/data/" + images[2].filename));
  EXPECT_EQ(summary.sensors[0].calibration, "given by the caller (Kalibr)");
  // A camera given as a struct (not a file) gets the data's rate.
  EXPECT_EQ(ReadCameraSensorYaml(summary.session_folder + "/cam0/" + kSensorYaml).rate_hz, 10.0);
}

// ---- calibration ----

TEST_F(BagImportTest, CameraInfoGivesTheCalibrationWhenNoneIsPassed) {
  const std::string bag = dir_ / "info.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    RosCameraInfo info;
    info.stamp = kT0;
    info.width = 7;
    info.height = 5;
    info.distortion_model = "plumb_bob";
    info.D = {-0.1, 0.02, 0.001, -0.002, 0.0005};
    info.K = {6.5, 0, 3.4, 0, 6.25, 2.4, 0, 0, 1};
    writer.Write("/cam/camera_info", kT0, info);
    for (int i = 0; i < 5; ++i) {
      writer.Write("/cam/image_raw", kT0 + i * 100000000,
                   ImageMessage(Pattern(CV_8UC1), kT0 + i * 100000000, "mono8"));
    }
  }
  const BagImportSummary summary = ImportBag(Options(bag));
  const CameraSensor camera = ReadCameraSensorYaml(summary.session_folder + "/cam0/" + kSensorYaml);
  EXPECT_EQ(camera.camera.width, 7);
  EXPECT_EQ(camera.camera.height, 5);
  EXPECT_EQ(camera.camera.fx, 6.5);
  EXPECT_EQ(camera.camera.fy, 6.25);
  EXPECT_EQ(camera.camera.cx, 3.4);
  EXPECT_EQ(camera.camera.cy, 2.4);
  EXPECT_EQ(camera.camera.k1, -0.1);
  EXPECT_EQ(camera.camera.p2, -0.002);
  EXPECT_EQ(camera.camera.k3, 0.0005);
  EXPECT_EQ(camera.rate_hz, 10.0);  // from the image stamps
  EXPECT_NE(summary.sensors[0].calibration.find("/cam/camera_info"), std::string::npos);
}

TEST_F(BagImportTest, CameraWithoutCalibrationIsAnErrorNamingTheOption) {
  const std::string bag = dir_ / "nocal.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    writer.Write("/cam/image_raw", kT0, ImageMessage(Pattern(CV_8UC1), kT0, "mono8"));
  }
  const std::string error = ErrorOf([&] { ImportBag(Options(bag)); });
  EXPECT_NE(error.find("--sensor-yaml cam0=FILE"), std::string::npos) << error;
  EXPECT_NE(error.find("/cam/image_raw (sensor_msgs/Image, 1 message)"), std::string::npos)
      << error;
}

TEST_F(BagImportTest, ImuWithoutCalibrationGetsTheDefaults) {
  const std::string bag = dir_ / "imu.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    for (int i = 0; i < 201; ++i) {
      RosImu m;
      m.stamp = kT0 + i * 5000000;  // 200 Hz
      m.linear_acceleration = {0, 0, 9.81};
      writer.Write("/imu", m.stamp, m);
    }
  }
  BagImportOptions o = Options(bag);
  o.gyroscope_noise_density = 3e-4;
  const BagImportSummary summary = ImportBag(o);
  const ImuSensor imu = ReadImuSensorYaml(summary.session_folder + "/imu0/" + kSensorYaml);
  EXPECT_EQ(imu.rate_hz, 200.0);
  EXPECT_EQ(imu.gyroscope_noise_density, 3e-4);
  EXPECT_EQ(imu.accelerometer_noise_density, BagImportOptions().accelerometer_noise_density);
  EXPECT_TRUE(imu.body_from_sensor.rotation().isApprox(Eigen::Quaterniond::Identity()));
  // No GPS: the conventional origin 0°, 0°, 0 m, as for EuRoC.
  EXPECT_TRUE(summary.origin_by_convention);
  EXPECT_EQ(ReadFieldYaml(dir_ / "imported/field.yaml").origin.lat_deg, 0.0);
}

// ---- stamps ----

TEST_F(BagImportTest, HeaderStampsByDefaultRecordTimesOnRequest) {
  const std::string bag = dir_ / "session.bag";
  SessionBagOptions bag_options;
  bag_options.receive_delay_ns = 3000001;
  WriteSessionBag(original_session(), bag, bag_options);
  const std::vector<ImuSample> original = Session(original_session()).ReadImu("imu0");

  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  o.topics = {{"imu0", "/imu0/data"}};  // cam0 is still picked automatically
  ImportBag(o);
  std::vector<ImuSample> imported = Session(imported_session()).ReadImu("imu0");
  ASSERT_EQ(imported.size(), original.size());
  EXPECT_EQ(imported.front().t, original.front().t);
  EXPECT_EQ(imported.back().t, original.back().t);

  o.stamp = BagStamp::kReceive;
  o.overwrite = true;
  const BagImportSummary summary = ImportBag(o);
  EXPECT_EQ(summary.stamp, BagStamp::kReceive);
  imported = Session(imported_session()).ReadImu("imu0");
  ASSERT_EQ(imported.size(), original.size());
  for (std::size_t i = 0; i < original.size(); ++i) {
    ASSERT_EQ(imported[i].t, original[i].t + 3000001);
  }
}

TEST_F(BagImportTest, OutOfOrderStampsAreSortedAndARepeatedStampKeepsTheFirst) {
  const std::string bag = dir_ / "order.bag";
  const Timestamp ms = 1000000;
  {
    BagWriter writer(bag, BagCompression::kNone);
    // Header stamps (ms): 0, 20, 10, 30, 30 ; record times increasing.
    const int stamps[] = {0, 20, 10, 30, 30};
    for (int i = 0; i < 5; ++i) {
      RosImu m;
      m.stamp = kT0 + stamps[i] * ms;
      m.angular_velocity = {static_cast<double>(i), 0, 0};
      writer.Write("/imu", kT0 + 100 * ms + i * ms, m);
    }
  }
  const BagImportSummary summary = ImportBag(Options(bag));
  const std::vector<ImuSample> imu = Session(summary.session_folder).ReadImu("imu0");
  ASSERT_EQ(imu.size(), 4u);
  EXPECT_EQ(imu[0].t, kT0);
  EXPECT_EQ(imu[1].t, kT0 + 10 * ms);
  EXPECT_EQ(imu[1].gyro.x(), 2.0);
  EXPECT_EQ(imu[2].t, kT0 + 20 * ms);
  EXPECT_EQ(imu[3].t, kT0 + 30 * ms);
  EXPECT_EQ(imu[3].gyro.x(), 3.0);  // the first of the two messages stamped 30 ms
  ASSERT_EQ(summary.sensors.size(), 1u);
  EXPECT_EQ(summary.sensors[0].reordered, 1);
  EXPECT_EQ(summary.sensors[0].duplicates, 1);
}

TEST_F(BagImportTest, ZeroHeaderStampAsksForReceiveTimes) {
  const std::string bag = dir_ / "zero.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    RosImu m;
    m.stamp = 0;
    writer.Write("/imu", kT0, m);
  }
  EXPECT_NE(ErrorOf([&] { ImportBag(Options(bag)); }).find("--stamp receive"), std::string::npos);
  BagImportOptions o = Options(bag);
  o.stamp = BagStamp::kReceive;
  const BagImportSummary summary = ImportBag(o);
  EXPECT_EQ(summary.sensors[0].first_t, kT0);
}

// ---- GPS and magnetometer values ----

TEST_F(BagImportTest, NavSatStatusAndCovarianceMapToFixAndSigmas) {
  const std::string bag = dir_ / "gps.bag";
  const Timestamp dt = 200000000;
  {
    BagWriter writer(bag, BagCompression::kNone);
    const std::int8_t statuses[] = {RosNavSatFix::kStatusNoFix, RosNavSatFix::kStatusFix,
                                    RosNavSatFix::kStatusSbasFix, RosNavSatFix::kStatusGbasFix,
                                    RosNavSatFix::kStatusNoFix};
    for (int i = 0; i < 5; ++i) {
      RosNavSatFix m;
      m.stamp = kT0 + i * dt;
      m.status = statuses[i];
      m.latitude = 47.5 + i * 1e-6;
      m.longitude = 8.25;
      m.altitude = 400.5;
      if (i == 4) m.latitude = std::nan("");  // no fix, no position: left out
      if (i == 1) {
        m.position_covariance = {4e-4, 0, 0, 0, 1e-4, 0, 0, 0, 9e-4};
        m.position_covariance_type = RosNavSatFix::kCovarianceApproximated;
      }
      writer.Write("/fix", m.stamp, m);
    }
  }
  BagImportSummary summary = ImportBag(Options(bag));
  EXPECT_EQ(summary.gps_kind, GpsKind::kRtk);  // a GBAS fix: an RTK receiver
  std::vector<std::string> lines = ReadLines(summary.session_folder + "/gps0/" + kDataCsv);
  ASSERT_EQ(lines.size(), 5u);  // header + 4
  EXPECT_EQ(lines[1], fmt::format("{},47.5,8.25,400.5,0.02,0.04,0", kT0));
  EXPECT_EQ(lines[2], fmt::format("{},47.500001,8.25,400.5,{},0.03,1", kT0 + dt,
                                  std::sqrt((4e-4 + 1e-4) / 2)));
  EXPECT_TRUE(lines[3].ends_with(",2"));
  EXPECT_TRUE(lines[4].ends_with(",0.02,0.04,4"));
  EXPECT_EQ(summary.sensors[0].dropped, 1);
  // Field origin: the first sample with a fix.
  EXPECT_EQ(summary.origin.lat_deg, 47.500001);

  // A standard receiver: GBAS is DGPS, default sigmas are metres.
  BagImportOptions o = Options(bag);
  o.gps_kind = GpsKind::kStandard;
  o.overwrite = true;
  summary = ImportBag(o);
  lines = ReadLines(summary.session_folder + "/gps0/" + kDataCsv);
  EXPECT_TRUE(lines[4].ends_with(",2.5,5,2")) << lines[4];
}

TEST_F(BagImportTest, MagneticFieldTeslaBecomesMicrotesla) {
  const std::string bag = dir_ / "mag.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    RosMagneticField m;
    m.stamp = kT0;
    m.magnetic_field = {22.5e-6, 1.1e-6, -42e-6};
    writer.Write("/mag", kT0, m);
  }
  const BagImportSummary summary = ImportBag(Options(bag));
  const std::vector<std::string> lines = ReadLines(summary.session_folder + "/mag0/" + kDataCsv);
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[1], fmt::format("{},22.5,1.1,-42", kT0));
}

// ---- topics and errors ----

TEST_F(BagImportTest, SeveralTopicsOfAKindNeedANameAndErrorsListTheTopics) {
  const std::string bag = dir_ / "two.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    for (const char* topic : {"/imu_a", "/imu_b"}) {
      RosImu m;
      m.stamp = kT0;
      m.angular_velocity = {topic[5] == 'a' ? 1.0 : 2.0, 0, 0};
      writer.Write(topic, kT0, m);
    }
    writer.WriteString("/status", kT0, "recording");
  }
  std::string error = ErrorOf([&] { ImportBag(Options(bag)); });
  EXPECT_NE(error.find("--topic imu0=TOPIC"), std::string::npos) << error;
  EXPECT_NE(error.find("/imu_a (sensor_msgs/Imu)"), std::string::npos) << error;

  BagImportOptions o = Options(bag);
  o.topics = {{"imu0", "/nope"}};
  error = ErrorOf([&] { ImportBag(o); });
  EXPECT_NE(error.find("/nope"), std::string::npos) << error;
  for (const char* listed :
       {"/imu_a (sensor_msgs/Imu, 1 message)", "/imu_b (sensor_msgs/Imu, 1 message)",
        "/status (std_msgs/String, 1 message)"}) {
    EXPECT_NE(error.find(listed), std::string::npos) << error;
  }

  o.topics = {{"imu0", "/status"}};
  error = ErrorOf([&] { ImportBag(o); });
  EXPECT_NE(error.find("std_msgs/String is unknown to crop4d"), std::string::npos) << error;
  EXPECT_NE(error.find("/imu_a (sensor_msgs/Imu, 1 message)"), std::string::npos) << error;

  o.topics = {{"imu0", "/imu_b"}};
  const BagImportSummary summary = ImportBag(o);
  EXPECT_EQ(Session(summary.session_folder).ReadImu("imu0").front().gyro.x(), 2.0);
  EXPECT_TRUE(fs::exists(dir_ / "imported/field.yaml"));
}

TEST_F(BagImportTest, TopicWithoutUsableMessagesIsAnError) {
  const std::string bag = dir_ / "nan.bag";
  {
    BagWriter writer(bag, BagCompression::kNone);
    RosNavSatFix m;
    m.stamp = kT0;
    m.latitude = std::nan("");
    writer.Write("/fix", kT0, m);
  }
  const std::string error = ErrorOf([&] { ImportBag(Options(bag)); });
  EXPECT_NE(error.find("no usable message"), std::string::npos) << error;
  EXPECT_TRUE(SessionsFolderEntries().empty());
}

TEST_F(BagImportTest, TruncatedBagIsAnInputError) {
  const std::string bag = dir_ / "session.bag";
  WriteSessionBag(original_session(), bag, SessionBagOptions());
  const std::string bytes = ReadText(bag);
  WriteText(bag, bytes.substr(0, bytes.size() / 2));
  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  const std::string error = ErrorOf([&] { ImportBag(o); });
  EXPECT_NE(error.find("not a readable ROS 1 bag"), std::string::npos) << error;
  EXPECT_NE(error.find("cut short"), std::string::npos) << error;
  // The index is gone with the second half; the connection records written before the first
  // message of each topic (in the first chunks) still name the topics.
  EXPECT_NE(error.find("topics that could be read: /cam0/image_raw (sensor_msgs/Image)"),
            std::string::npos)
      << error;
  EXPECT_FALSE(fs::exists(dir_ / "imported/field.yaml"));
}

TEST_F(BagImportTest, CorruptChunkIsAnInputErrorThatListsTheTopics) {
  // The index is intact (topics known), a bz2 chunk in the middle is not.
  const std::string bag = dir_ / "session.bag";
  SessionBagOptions bag_options;
  bag_options.compression = BagCompression::kBz2;
  WriteSessionBag(original_session(), bag, bag_options);
  std::string bytes = ReadText(bag);
  const std::size_t from = bytes.size() / 4;
  for (std::size_t i = from; i < from + 64; ++i) bytes[i] = static_cast<char>(i * 37);
  WriteText(bag, bytes);
  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  const std::string error = ErrorOf([&] { ImportBag(o); });
  EXPECT_NE(error.find("not a readable ROS 1 bag"), std::string::npos) << error;
  EXPECT_NE(error.find("bz2 chunk does not decompress"), std::string::npos) << error;
  // The index at the end is intact: the message names the topics.
  EXPECT_NE(error.find("topics that could be read: /cam0/image_raw (sensor_msgs/Image), "
                       "/gps0/fix (sensor_msgs/NavSatFix), /imu0/data (sensor_msgs/Imu), "
                       "/mag0/mag (sensor_msgs/MagneticField)"),
            std::string::npos)
      << error;
  // Images already written went with the staging folder.
  EXPECT_TRUE(SessionsFolderEntries().empty());
}

TEST_F(BagImportTest, ImageOfTheWrongSizeStopsTheImportAndLeavesNothing) {
  const std::string bag = dir_ / "session.bag";
  WriteSessionBag(original_session(), bag, SessionBagOptions());
  BagImportOptions o = Options(bag);
  UseSessionCalibration(original_session(), &o);
  o.cameras["cam0"].camera.width = 64;
  const std::string error = ErrorOf([&] { ImportBag(o); });
  EXPECT_NE(error.find("the image is 32x24, the calibration of cam0 is for 64x24"),
            std::string::npos)
      << error;
  EXPECT_TRUE(SessionsFolderEntries().empty());
  EXPECT_FALSE(fs::exists(dir_ / "imported/field.yaml"));
}

TEST_F(BagImportTest, BadOptionsAreErrors) {
  BagImportOptions o = Options(dir_ / "any.bag");
  o.topics = {{"camera", "/x"}};
  EXPECT_NE(ErrorOf([&] { ImportBag(o); }).find("cam<N>"), std::string::npos);
  o.topics = {{"imu0_info", "/x"}};
  EXPECT_NE(ErrorOf([&] { ImportBag(o); }).find("cam<N>_info"), std::string::npos);
  o.topics.clear();
  EXPECT_NE(ErrorOf([&] { ImportBag(o); }).find("not a readable ROS 1 bag"), std::string::npos);
}

}  // namespace
}  // namespace crop4d::io
