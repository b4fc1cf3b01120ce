#include "crop4d/io/exif_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <exiv2/exiv2.hpp>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/exif_test_writer.h"
#include "crop4d/io/kalibr.h"
#include "crop4d/io/sample_field.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/io/validator.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::ExifImagesFromSession;
using testing::ExifTestImage;
using testing::ExifTestWriterOptions;
using testing::ReadText;
using testing::TempDir;
using testing::TruncatedToDigits;
using testing::WriteExifImageFolder;

// The sample field's camera (sample_field.cc): 32 × 24 px, fx = fy = 25.6 px.
constexpr double kSampleFocalPx = 25.6;

// Removes a tag from a JPEG file.
void RemoveTag(const std::string& path, const char* key) {
  auto image = Exiv2::ImageFactory::open(path);
  image->readMetadata();
  Exiv2::ExifData& exif = image->exifData();
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  ASSERT_NE(it, exif.end()) << key;
  exif.erase(it);
  image->writeMetadata();
}

// The InputError's message of an import, "" (and a failure) when it succeeded.
std::string ImportError(const ExifImportOptions& options) {
  try {
    ImportExifFolder(options);
  } catch (const InputError& e) {
    return e.what();
  }
  ADD_FAILURE() << "the import succeeded";
  return "";
}

class ExifImportTest : public ::testing::Test {
 protected:
  void SetUp() override {
    SampleFieldOptions sample;
    sample.with_mag = false;
    WriteSampleField(dir_ / "sample", sample);
    truth_ = ExifImagesFromSession(dir_ / "sample/sessions/2016-05-25");
  }
  // The simulated session's images and true GPS as a JPEG folder with EXIF.
  std::vector<std::string> WriteFolder(const ExifTestWriterOptions& options,
                                       const std::string& name = "jpegs") {
    return WriteExifImageFolder(dir_ / name, truth_, options);
  }
  ExifImportOptions Options(const std::string& folder = "jpegs") const {
    ExifImportOptions options;
    options.image_folder = dir_ / folder;
    options.field_folder = dir_ / "field";
    return options;
  }
  static ExifTestWriterOptions WithFocal() {
    ExifTestWriterOptions options;
    options.focal_length_px = kSampleFocalPx;
    return options;
  }

  TempDir dir_;
  std::vector<ExifTestImage> truth_;
};

TEST_F(ExifImportTest, ASimulatedSessionComesBackFromItsJpegFolder) {
  ASSERT_EQ(truth_.size(), 16u);  // 2 s at 7.5 Hz
  ASSERT_TRUE(truth_.front().position);
  ExifTestWriterOptions writer = WithFocal();
  writer.utc_offset_minutes = 120;  // a camera clock on UTC+2, with OffsetTimeOriginal
  const std::vector<std::string> files = WriteFolder(writer);
  ExifImportOptions options = Options();
  options.gps_kind = GpsKind::kRtk;
  const ExifImportSummary summary = ImportExifFolder(options);
  EXPECT_TRUE(summary.field_created);
  EXPECT_EQ(summary.images, 16);
  EXPECT_EQ(summary.gps_samples, 16);
  EXPECT_EQ(summary.images_without_gps, 0);
  EXPECT_TRUE(summary.camera_from_exif);
  EXPECT_NE(summary.time_rule.find("OffsetTimeOriginal +02:00"), std::string::npos);
  // The GPS stamps (microseconds) agree with the camera clock (nanoseconds) once in UTC.
  ASSERT_TRUE(summary.clock_minus_gps_s);
  EXPECT_NEAR(*summary.clock_minus_gps_s, 0.0, 1e-6);
  EXPECT_EQ(summary.session_folder, (dir_ / "field/sessions/2016-05-25"));

  const Field field(dir_ / "field");
  const Session session = field.OpenSession("2016-05-25");
  const std::vector<ImageEntry> images = session.ReadImageList("cam0");
  const std::vector<GpsSample> gps = session.ReadGps("gps0");
  ASSERT_EQ(images.size(), truth_.size());
  ASSERT_EQ(gps.size(), truth_.size());
  // 1e-6 arc second in degrees: the precision of the written latitude and longitude.
  const double arcsec_micro_deg = 1e-6 / 3600.0;
  for (std::size_t k = 0; k < truth_.size(); ++k) {
    // Times exact (9 sub-second digits), in UTC although the clock was on UTC+2.
    EXPECT_EQ(images[k].t, truth_[k].t) << k;
    EXPECT_EQ(gps[k].t, truth_[k].t) << k;
    EXPECT_NEAR(gps[k].position.lat_deg, truth_[k].position->lat_deg,
                0.5 * arcsec_micro_deg + 1e-13);
    EXPECT_NEAR(gps[k].position.lon_deg, truth_[k].position->lon_deg,
                0.5 * arcsec_micro_deg + 1e-13);
    EXPECT_NEAR(gps[k].position.alt_m, truth_[k].position->alt_m, 0.5e-4 + 1e-9);
    // GPSHPositioningError gives sigma_h; sigma_v = sigma_h · 0.04 / 0.02 (the rtk defaults).
    EXPECT_NEAR(gps[k].sigma_h, 0.02, 1e-12);
    EXPECT_NEAR(gps[k].sigma_v, 0.04, 1e-12);
    EXPECT_EQ(gps[k].fix, GpsFix::kRtkFixed);
    // The JPEG is the very file of the folder (linked or copied, not re-encoded).
    EXPECT_EQ(ReadText(session.ImagePath("cam0", images[k].filename)), ReadText(files[k])) << k;
  }
  // Intrinsics from the EXIF focal length and focal-plane resolution, centre principal point.
  const CameraSensor* cam0 = session.FindCamera("cam0");
  ASSERT_NE(cam0, nullptr);
  EXPECT_NEAR(cam0->camera.fx, kSampleFocalPx, 0.1);
  EXPECT_NEAR(cam0->camera.fy, kSampleFocalPx, 0.1);
  EXPECT_DOUBLE_EQ(cam0->camera.cx, 15.5);
  EXPECT_DOUBLE_EQ(cam0->camera.cy, 11.5);
  EXPECT_EQ(cam0->camera.k1, 0.0);
  EXPECT_EQ(cam0->camera.width, 32);
  EXPECT_EQ(session.FindGps("gps0")->kind, GpsKind::kRtk);
  EXPECT_TRUE(session.imus().empty());
  EXPECT_NE(session.info().notes.find("starting value"), std::string::npos);
  EXPECT_NE(FormatExifImportSummary(summary).find("starting value"), std::string::npos);
  // The origin is the first fix; the field validates (no IMU is a warning, not an error).
  EXPECT_NEAR(field.info().origin.lat_deg, gps.front().position.lat_deg, 1e-9);
  EXPECT_EQ(ValidateField(dir_ / "field").errors, 0u);
  // A second import of the same session is refused; nothing but the session is in sessions/.
  EXPECT_THROW(ImportExifFolder(options), InputError);
  EXPECT_EQ(std::distance(fs::directory_iterator(dir_ / "field/sessions"), {}), 1);
}

TEST_F(ExifImportTest, TheTimeZoneComesFromTheTagTheOptionOrTheGpsStamps) {
  // Three sub-second digits (a phone): times truncated to the millisecond.
  ExifTestWriterOptions writer = WithFocal();
  writer.subsec_digits = 3;
  writer.utc_offset_minutes = -300;  // UTC−5
  writer.write_offset_tag = false;
  WriteFolder(writer);
  // No offset tag: the GPS stamps give −05:00.
  ExifImportOptions options = Options();
  options.session_id = "stamps";
  ExifImportSummary summary = ImportExifFolder(options);
  EXPECT_NE(summary.time_rule.find("-05:00 from the GPS time stamps"), std::string::npos)
      << summary.time_rule;
  ASSERT_TRUE(summary.clock_minus_gps_s);
  EXPECT_NEAR(*summary.clock_minus_gps_s, 0.0, 1e-3);  // the clock's milliseconds
  std::vector<ImageEntry> images = Field(dir_ / "field").OpenSession("stamps").ReadImageList();
  ASSERT_EQ(images.size(), truth_.size());
  for (std::size_t k = 0; k < images.size(); ++k) {
    EXPECT_EQ(images[k].t, TruncatedToDigits(truth_[k].t, 3)) << k;
  }
  // --time-zone takes precedence over the GPS stamps; a wrong one shifts every time.
  options.session_id = "option";
  options.utc_offset_s = -4 * 3600;
  summary = ImportExifFolder(options);
  images = Field(dir_ / "field").OpenSession("option").ReadImageList();
  EXPECT_EQ(images.front().t, TruncatedToDigits(truth_.front().t, 3) - 3600 * kNanosPerSecond);
  // Without the GPS stamps and without the option, the import asks for --time-zone.
  writer.write_gps_time = false;
  WriteFolder(writer, "no_zone");
  ExifImportOptions no_zone = Options("no_zone");
  no_zone.session_id = "no_zone";
  EXPECT_NE(ImportError(no_zone).find("--time-zone"), std::string::npos);
  // A Kalibr time shift moves every image onto the IMU clock; Kalibr's intrinsics are used.
  const KalibrCamera kalibr = [&] {
    testing::WriteText(
        dir_ / "camchain.yaml",
        "cam0:\n  T_cam_imu:\n  - [1, 0, 0, 0]\n  - [0, 1, 0, 0]\n  - [0, 0, 1, 0]\n"
        "  - [0, 0, 0, 1]\n  camera_model: pinhole\n  distortion_model: radtan\n"
        "  distortion_coeffs: [-0.05, 0.01, 0, 0]\n  intrinsics: [25.5, 25.7, 16, 12]\n"
        "  resolution: [32, 24]\n  timeshift_cam_imu: -0.25\n");
    return ReadKalibrCamchain(dir_ / "camchain.yaml").front();
  }();
  no_zone.utc_offset_s = -5 * 3600;
  no_zone.camera = kalibr.sensor;
  no_zone.camera_source = dir_ / "camchain.yaml";
  no_zone.camera_time_shift_ns = kalibr.time_shift_ns;
  summary = ImportExifFolder(no_zone);
  EXPECT_FALSE(summary.camera_from_exif);
  const Session shifted = Field(dir_ / "field").OpenSession("no_zone");
  EXPECT_EQ(shifted.ReadImageList().front().t,
            TruncatedToDigits(truth_.front().t, 3) - 250'000'000);
  EXPECT_DOUBLE_EQ(shifted.FindCamera("cam0")->camera.fy, 25.7);
  EXPECT_DOUBLE_EQ(shifted.FindCamera("cam0")->camera.k1, -0.05);
}

TEST_F(ExifImportTest, IntrinsicsFromThe35mmEquivalentFocalLength) {
  ExifTestWriterOptions writer = WithFocal();
  writer.write_focal_35mm = true;
  const std::vector<std::string> files = testing::WriteSessionAsExifFolder(
      dir_ / "sample/sessions/2016-05-25", dir_ / "jpegs", writer);
  ASSERT_EQ(files.size(), 16u);
  for (const std::string& file : files) {
    RemoveTag(file, "Exif.Photo.FocalPlaneXResolution");
    RemoveTag(file, "Exif.Photo.FocalPlaneYResolution");
  }
  const ExifImportSummary summary = ImportExifFolder(Options());
  // The integer written: round(25.6 / 40 px · 43.267 mm) = 28 mm → 28 / 43.267 · 40 px.
  const double diagonal_mm = std::hypot(36.0, 24.0);
  const double f35 = std::round(kSampleFocalPx / std::hypot(32.0, 24.0) * diagonal_mm);
  EXPECT_NEAR(summary.camera.fx, f35 / diagonal_mm * std::hypot(32.0, 24.0), 0.1);
  EXPECT_NEAR(summary.camera.fx, kSampleFocalPx, 0.5);  // within the integer's rounding
  // With neither tag the intrinsics must be given.
  for (const std::string& file : files) RemoveTag(file, "Exif.Photo.FocalLengthIn35mmFilm");
  ExifImportOptions options = Options();
  options.overwrite = true;
  EXPECT_NE(ImportError(options).find("--camera-yaml"), std::string::npos);
}

TEST_F(ExifImportTest, GpsSigmasFixesAndImagesWithoutGps) {
  truth_[3].position.reset();  // no GPS tags in the fourth image
  truth_[5].sigma_h = 0.0;     // no GPSHPositioningError in the sixth
  const std::vector<std::string> files = WriteFolder(WithFocal());
  {
    auto image = Exiv2::ImageFactory::open(files[7]);
    image->readMetadata();
    image->exifData()["Exif.GPSInfo.GPSDifferential"] = "1";
    image->writeMetadata();
  }
  ExifImportOptions options = Options();
  options.sigma_h = 3.0;
  options.sigma_v = 4.5;
  const ExifImportSummary summary = ImportExifFolder(options);
  EXPECT_EQ(summary.images, 16);
  EXPECT_EQ(summary.gps_samples, 15);
  EXPECT_EQ(summary.images_without_gps, 1);
  EXPECT_EQ(summary.gps_with_accuracy_tag, 14);
  const Session session = Field(dir_ / "field").OpenSession("2016-05-25");
  EXPECT_EQ(session.ReadImageList().size(), 16u);  // the image without GPS is kept
  const std::vector<GpsSample> gps = session.ReadGps();
  ASSERT_EQ(gps.size(), 15u);
  EXPECT_EQ(session.FindGps("gps0")->kind, GpsKind::kStandard);
  // Sample 4 is image 5 (image 3 has none): the default sigmas; the others 0.02 · 4.5 / 3.
  EXPECT_DOUBLE_EQ(gps[4].sigma_h, 3.0);
  EXPECT_DOUBLE_EQ(gps[4].sigma_v, 4.5);
  EXPECT_NEAR(gps[0].sigma_h, 0.02, 1e-12);
  EXPECT_NEAR(gps[0].sigma_v, 0.03, 1e-12);
  EXPECT_EQ(gps[0].fix, GpsFix::kSingle);
  EXPECT_EQ(gps[6].fix, GpsFix::kDgps);  // image 7, GPSDifferential 1
}

TEST_F(ExifImportTest, MalformedFoldersAreRefusedAndNothingIsWritten) {
  const std::vector<std::string> files = WriteFolder(WithFocal());
  // No DateTimeOriginal in one image: the error names the file and the tag.
  RemoveTag(files[2], "Exif.Photo.DateTimeOriginal");
  std::string message = ImportError(Options());
  EXPECT_NE(message.find(fs::path(files[2]).filename().string()), std::string::npos) << message;
  EXPECT_NE(message.find("DateTimeOriginal"), std::string::npos) << message;
  EXPECT_FALSE(fs::exists(dir_ / "field"));

  // A file named .jpg that is a PNG.
  WriteFolder(WithFocal());
  const cv::Mat pixels(24, 32, CV_8UC3, cv::Scalar(10, 20, 30));
  ASSERT_TRUE(cv::imwrite(dir_ / "x.png", pixels));
  fs::copy_file(dir_ / "x.png", dir_ / "jpegs/IMG_9999.jpg");
  message = ImportError(Options());
  EXPECT_NE(message.find("IMG_9999.jpg"), std::string::npos) << message;
  EXPECT_NE(message.find("not a JPEG"), std::string::npos) << message;
  fs::remove(dir_ / "jpegs/IMG_9999.jpg");

  // An image of another size.
  std::vector<ExifTestImage> other(1, truth_.front());
  ASSERT_TRUE(cv::imwrite(dir_ / "big.png", cv::Mat(48, 64, CV_8UC3, cv::Scalar(1, 2, 3))));
  other[0].source = dir_ / "big.png";
  other[0].t += 10 * kNanosPerSecond;
  ExifTestWriterOptions big = WithFocal();
  big.name_prefix = "BIG_";
  WriteExifImageFolder(dir_ / "jpegs", other, big);
  message = ImportError(Options());
  EXPECT_NE(message.find("BIG_0000.jpg"), std::string::npos) << message;
  EXPECT_NE(message.find("same size"), std::string::npos) << message;
  fs::remove(dir_ / "jpegs/BIG_0000.jpg");

  // Two images with the same time.
  std::vector<ExifTestImage> twin(1, truth_[4]);
  ExifTestWriterOptions twin_options = WithFocal();
  twin_options.name_prefix = "TWIN_";
  WriteExifImageFolder(dir_ / "jpegs", twin, twin_options);
  message = ImportError(Options());
  EXPECT_NE(message.find("same time"), std::string::npos) << message;
  fs::remove(dir_ / "jpegs/TWIN_0000.jpg");

  // Other files are ignored; the folder imports now.
  testing::WriteText(dir_ / "jpegs/notes.txt", "pole height 2.1 m\n");
  const ExifImportSummary summary = ImportExifFolder(Options());
  EXPECT_EQ(summary.other_files, 1);
  EXPECT_EQ(summary.images, 16);
  // An empty folder and a missing one.
  fs::create_directories(dir_ / "empty");
  EXPECT_THROW(ImportExifFolder(Options("empty")), InputError);
  EXPECT_THROW(ImportExifFolder(Options("missing")), InputError);
}

TEST(ParseUtcOffsetTest, AcceptsTheUsualSpellings) {
  int s = 0;
  EXPECT_TRUE(ParseUtcOffset("+02:00", &s));
  EXPECT_EQ(s, 7200);
  EXPECT_TRUE(ParseUtcOffset("-05:30", &s));
  EXPECT_EQ(s, -19800);
  EXPECT_TRUE(ParseUtcOffset("+0545", &s));
  EXPECT_EQ(s, 20700);
  EXPECT_TRUE(ParseUtcOffset("+2", &s));
  EXPECT_EQ(s, 7200);
  EXPECT_TRUE(ParseUtcOffset("Z", &s));
  EXPECT_EQ(s, 0);
  EXPECT_FALSE(ParseUtcOffset("02:00", &s));
  EXPECT_FALSE(ParseUtcOffset("+02:0", &s));
  EXPECT_FALSE(ParseUtcOffset("+25:00", &s));
  EXPECT_FALSE(ParseUtcOffset("+02:00x", &s));
}

}  // namespace
}  // namespace crop4d::io
