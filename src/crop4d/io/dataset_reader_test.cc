#include "crop4d/io/dataset_reader.h"

#include <fmt/format.h>
#include <gtest/gtest.h>

#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/image_probe.h"
#include "crop4d/io/image_sequence.h"
#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

class DatasetReaderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SampleFieldOptions options;
    options.sessions = {"2016-05-25", "2016-06-01"};
    WriteSampleField(dir_.path(), options);
  }
  std::string Session1(const std::string& relative) const {
    return dir_ / ("sessions/2016-05-25/" + relative);
  }

  TempDir dir_;
};

TEST_F(DatasetReaderTest, ReadsTheSampleField) {
  Diagnostics diag;
  const Field field(dir_.path(), &diag);
  EXPECT_EQ(field.info().name, "sample field");
  EXPECT_EQ(field.info().origin.lat_deg, 33.7756);
  EXPECT_EQ(field.info().rows.size(), 2u);
  EXPECT_EQ(field.info().sites.size(), 2u);
  EXPECT_EQ(field.session_ids(), (std::vector<std::string>{"2016-05-25", "2016-06-01"}));

  const Session session = field.OpenSession("2016-06-01", &diag);
  EXPECT_EQ(session.id(), "2016-06-01");
  EXPECT_EQ(session.info().date, FromDate(2016, 6, 1));
  EXPECT_TRUE(session.info().rain_before);
  EXPECT_EQ(session.info().notes, "sunny, light wind");
  ASSERT_EQ(session.cameras().size(), 1u);
  EXPECT_EQ(session.cameras()[0].camera.width, 32);
  EXPECT_EQ(session.imus().size(), 1u);
  EXPECT_EQ(session.mags().size(), 1u);
  ASSERT_EQ(session.gps_receivers().size(), 1u);
  EXPECT_EQ(session.gps_receivers()[0].antenna_in_body, Eigen::Vector3d(0, 0, 0.8));
  EXPECT_EQ(session.FindImu("imu1"), nullptr);

  // 2 s of data: floor(2 * rate) + 1 samples, the first at 14:00 UTC.
  const std::vector<ImuSample> imu = session.ReadImu("imu0", &diag);
  ASSERT_EQ(imu.size(), 335u);
  EXPECT_EQ(imu.front().t, FromDate(2016, 6, 1) + 14 * 3600 * kNanosPerSecond);
  EXPECT_EQ(imu.front().accel, Eigen::Vector3d(0.05, 0.0, 9.80665));
  EXPECT_EQ(session.ReadMag("mag0", &diag).size(), 221u);
  EXPECT_EQ(session.ReadGps("gps0", &diag).size(), 11u);
  EXPECT_EQ(session.ReadImageList("cam0", &diag).size(), 16u);
  EXPECT_EQ(diag.error_count() + diag.warning_count(), 0u) << diag.items()[0].ToString();
  EXPECT_THROW(session.ReadImu("imu1"), InputError);
}

TEST_F(DatasetReaderTest, GpsSamplesWithoutSigmaGetTheReceiverDefault) {
  testing::WriteLines(Session1("gps0/data.csv"),
                      {"#timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix",
                       "1464184800000000000,33.7756,-84.3963,290,,,4",
                       "1464184800200000000,33.7756,-84.3963,290,0.5,0.7,1"});
  const Session session(dir_ / "sessions/2016-05-25");
  const std::vector<GpsSample> gps = session.ReadGps("gps0");
  ASSERT_EQ(gps.size(), 2u);
  EXPECT_EQ(gps[0].sigma_h, 0.02);
  EXPECT_EQ(gps[0].sigma_v, 0.04);
  EXPECT_EQ(gps[1].sigma_h, 0.5);
  EXPECT_EQ(gps[1].sigma_v, 0.7);
}

TEST_F(DatasetReaderTest, ImagesAreLoadedOneAtATimeAndBadOnesSkipped) {
  const Session session(dir_ / "sessions/2016-05-25");
  Diagnostics diag;
  const ImageSequence images(session, "cam0", &diag);
  ASSERT_EQ(images.size(), 16u);
  const cv::Mat first = images.LoadImage(0, cv::IMREAD_COLOR, &diag);
  EXPECT_EQ(first.cols, 32);
  EXPECT_EQ(first.rows, 24);
  EXPECT_EQ(first.type(), CV_8UC3);
  // Pixel (r=1, c=2) of image 0 as written: B = 14, G = 109, R = 3.
  EXPECT_EQ(first.at<cv::Vec3b>(1, 2), cv::Vec3b(14, 109, 3));

  fs::remove(images.Path(1));
  testing::WriteText(images.Path(2), "");
  EXPECT_TRUE(images.LoadImage(1, cv::IMREAD_COLOR, &diag).empty());
  EXPECT_TRUE(images.LoadImage(2, cv::IMREAD_COLOR, &diag).empty());
  const std::vector<Diagnostic> items = diag.items();
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[0].file, Session1("cam0/data.csv"));
  EXPECT_EQ(items[0].line, 3);
  EXPECT_EQ(items[0].message, "image '" + images.entry(1).filename + "' missing; skipped");
  EXPECT_EQ(items[1].line, 4);
  EXPECT_EQ(items[1].message,
            "image '" + images.entry(2).filename + "' empty file (0 bytes); skipped");
}

TEST_F(DatasetReaderTest, ProbeImageTellsWhatIsWrong) {
  const Session session(dir_ / "sessions/2016-05-25");
  const std::vector<ImageEntry> list = session.ReadImageList();
  const std::string good = session.ImagePath("cam0", list[0].filename);
  const ImageProbe probe = ProbeImage(good);
  EXPECT_TRUE(probe.ok);
  EXPECT_EQ(probe.format, "png");
  EXPECT_EQ(probe.width, 32);
  EXPECT_EQ(probe.height, 24);

  testing::WriteText(dir_ / "text.png", "hello, not an image");
  EXPECT_EQ(ProbeImage(dir_ / "text.png").problem, "not an image (unknown file signature)");
  fs::create_directories(dir_ / "folder.png");
  EXPECT_EQ(ProbeImage(dir_ / "folder.png").problem, "is a folder, not an image file");
  EXPECT_EQ(ProbeImage(dir_ / "none.png").problem, "missing");
  // A PNG cut short lacks its IEND chunk: found without decoding.
  const std::string bytes = testing::ReadText(good);
  testing::WriteText(dir_ / "cut.png", bytes.substr(0, bytes.size() - 20));
  EXPECT_EQ(ProbeImage(dir_ / "cut.png", false).problem,
            "truncated PNG (no IEND chunk at the end)");
  // A PNG damaged inside but whole passes the cheap check, not decoding.
  std::string damaged = bytes;
  for (std::size_t i = damaged.size() / 2; i < damaged.size() / 2 + 4; ++i) damaged[i] ^= 0x5A;
  testing::WriteText(dir_ / "damaged.png", damaged);
  EXPECT_TRUE(ProbeImage(dir_ / "damaged.png", false).ok);
  EXPECT_EQ(ProbeImage(dir_ / "damaged.png", true).problem,
            "cannot be decoded (truncated or corrupt png)");
  // The same for a JPEG: whole, then cut short.
  const std::string jpeg = dir_ / "image.jpg";
  ASSERT_TRUE(cv::imwrite(jpeg, cv::Mat(24, 32, CV_8UC3, cv::Scalar(10, 200, 30))));
  EXPECT_TRUE(ProbeImage(jpeg).ok);
  const std::string jpeg_bytes = testing::ReadText(jpeg);
  testing::WriteText(dir_ / "cut.jpg", jpeg_bytes.substr(0, jpeg_bytes.size() * 2 / 3));
  EXPECT_EQ(ProbeImage(dir_ / "cut.jpg").problem,
            "truncated JPEG (no end-of-image marker at the end)");
}

TEST_F(DatasetReaderTest, BrokenSensorYamlThrowsWithoutCollectorAndIsLeftOutWithOne) {
  testing::ReplaceInFile(Session1("cam0/sensor.yaml"), "intrinsics:", "intrinsic:");
  try {
    Session session(dir_ / "sessions/2016-05-25");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), Session1("cam0/sensor.yaml"));
    EXPECT_EQ(e.message(), "missing required key 'intrinsics'");
  }
  Diagnostics diag;
  const Session session(dir_ / "sessions/2016-05-25", &diag);
  EXPECT_TRUE(session.cameras().empty());
  EXPECT_EQ(session.imus().size(), 1u);
  const std::vector<Diagnostic> items = diag.items();
  ASSERT_EQ(items.size(), 2u);
  EXPECT_EQ(items[0].ToString(),
            "error: " + Session1("cam0/sensor.yaml") + ":2: missing required key 'intrinsics'");
  EXPECT_EQ(items[1].severity, Severity::kWarning);
  EXPECT_EQ(items[1].message, "unknown key 'intrinsic' (ignored)");
  EXPECT_EQ(items[1].line, 17);
}

TEST_F(DatasetReaderTest, SitesMayBeGivenAsLatLon) {
  const geometry::LocalEnu enu(geometry::GeodeticPoint{33.7756, -84.3963, 290.0});
  const geometry::GeodeticPoint site = enu.ToGeodetic(Eigen::Vector3d(3.0, 40.0, 0.0));
  testing::WriteText(dir_ / "field.yaml",
                     "name: f\norigin: {lat: 33.7756, lon: -84.3963, alt: 290}\n"
                     "sites:\n  - {id: a, lat: " +
                         fmt::format("{}", site.lat_deg) +
                         ", lon: " + fmt::format("{}", site.lon_deg) + "}\n");
  const FieldInfo field = ReadFieldYaml(dir_ / "field.yaml");
  ASSERT_EQ(field.sites.size(), 1u);
  EXPECT_NEAR(field.sites[0].center_enu.x(), 3.0, 1e-6);
  EXPECT_NEAR(field.sites[0].center_enu.y(), 40.0, 1e-6);
  EXPECT_EQ(field.sites[0].radius_m, 0.5);
}

TEST_F(DatasetReaderTest, FieldYamlProblemsNameKeyAndLine) {
  testing::WriteText(dir_ / "field.yaml",
                     "name: f\n"
                     "origin: {lat: 95, alt: 3}\n"
                     "rows:\n"
                     "  - {index: 1, start: [0, 0], end: [0, 10]}\n"
                     "  - {index: 1, start: [1, 0], end: [1, 10]}\n"
                     "colour: green\n");
  Diagnostics diag;
  EXPECT_THROW(ReadFieldYaml(dir_ / "field.yaml", &diag), InputError);
  std::vector<std::string> messages;
  for (const Diagnostic& d : diag.items()) {
    messages.push_back(std::to_string(d.line) + ": " + d.message);
  }
  EXPECT_EQ(messages,
            (std::vector<std::string>{
                "2: missing required key 'origin.lon'", "2: origin.lat must be within [-90, 90]",
                "5: row index 1 is declared twice", "6: unknown key 'colour' (ignored)"}));
}

TEST_F(DatasetReaderTest, SessionDateFromYamlOrFolderName) {
  EXPECT_EQ(DateFromSessionId("2016-05-25"), FromDate(2016, 5, 25));
  EXPECT_EQ(DateFromSessionId("2016-05-25_pm"), FromDate(2016, 5, 25));
  EXPECT_EQ(DateFromSessionId("2016-05-251"), std::nullopt);
  EXPECT_EQ(DateFromSessionId("day1"), std::nullopt);
  // No session.yaml: the name gives the date.
  fs::remove(Session1("session.yaml"));
  EXPECT_EQ(Session(dir_ / "sessions/2016-05-25").info().date, FromDate(2016, 5, 25));
  // A name that is not a date needs session.yaml.
  fs::rename(dir_ / "sessions/2016-05-25", dir_ / "sessions/day1");
  try {
    Session session(dir_ / "sessions/day1");
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir_ / "sessions/day1/session.yaml");
    EXPECT_EQ(e.message(), "file not found");
  }
}

TEST_F(DatasetReaderTest, SessionOrderFromFieldYamlAndUnlistedFoldersWarned) {
  testing::ReplaceInFile(dir_ / "field.yaml", "  - \"2016-06-01\"\n", "");
  Diagnostics diag(Diagnostics::Options{dir_.path()});
  const Field field(dir_.path(), &diag);
  EXPECT_EQ(field.session_ids(), std::vector<std::string>{"2016-05-25"});
  const std::vector<Diagnostic> items = diag.items();
  ASSERT_EQ(items.size(), 1u);
  EXPECT_EQ(items[0].ToString(),
            "warning: sessions/2016-06-01: session folder not listed in field.yaml 'sessions'; "
            "ignored");
}

}  // namespace
}  // namespace crop4d::io
