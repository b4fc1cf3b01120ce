#include "crop4d/io/exif_test_writer.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <exiv2/exiv2.hpp>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>

#include "crop4d/io/dataset_reader.h"

namespace crop4d::io::testing {
namespace {

namespace fs = std::filesystem;

constexpr Timestamp kNanosPerDay = 86400 * kNanosPerSecond;

Timestamp FloorDiv(Timestamp a, Timestamp b) {
  return a / b - ((a % b != 0) && ((a < 0) != (b < 0)));
}

// "YYYY:MM:DD" and the nanoseconds into that day of a timestamp.
std::string ExifDate(Timestamp t, Timestamp* ns_of_day) {
  const Timestamp days = FloorDiv(t, kNanosPerDay);
  *ns_of_day = t - days * kNanosPerDay;
  const std::chrono::year_month_day ymd{
      std::chrono::sys_days{std::chrono::days{static_cast<int>(days)}}};
  return fmt::format("{:04d}:{:02d}:{:02d}", static_cast<int>(ymd.year()),
                     static_cast<unsigned>(ymd.month()), static_cast<unsigned>(ymd.day()));
}

// Degrees as EXIF's three rationals: d/1 m/1 s/10^6.
std::string DegreesMinutesSeconds(double degrees) {
  degrees = std::abs(degrees);
  long long d = static_cast<long long>(std::floor(degrees));
  const double minutes = (degrees - d) * 60.0;
  long long m = static_cast<long long>(std::floor(minutes));
  long long micro = std::llround((minutes - m) * 60.0 * 1e6);
  if (micro >= 60'000'000) {
    micro -= 60'000'000;
    ++m;
  }
  if (m >= 60) {
    m -= 60;
    ++d;
  }
  return fmt::format("{}/1 {}/1 {}/1000000", d, m, micro);
}

bool IsJpegFile(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[3] = {0, 0, 0};
  in.read(head, 3);
  return in && static_cast<unsigned char>(head[0]) == 0xFF &&
         static_cast<unsigned char>(head[1]) == 0xD8 && static_cast<unsigned char>(head[2]) == 0xFF;
}

}  // namespace

Timestamp TruncatedToDigits(Timestamp t, int subsec_digits) {
  Timestamp unit = kNanosPerSecond;
  for (int k = 0; k < subsec_digits; ++k) unit /= 10;
  return FloorDiv(t, unit) * unit;
}

std::vector<std::string> WriteExifImageFolder(const std::string& folder,
                                              const std::vector<ExifTestImage>& images,
                                              const ExifTestWriterOptions& o) {
  if (o.subsec_digits < 0 || o.subsec_digits > 9) {
    throw std::runtime_error("subsec_digits must be 0..9");
  }
  fs::create_directories(folder);
  std::vector<std::string> written;
  for (std::size_t k = 0; k < images.size(); ++k) {
    const ExifTestImage& image = images[k];
    const std::string path =
        (fs::path(folder) / fmt::format("{}{:04d}.jpg", o.name_prefix, k)).string();
    int width = 0, height = 0;
    if (IsJpegFile(image.source)) {
      fs::copy_file(image.source, path, fs::copy_options::overwrite_existing);
    } else {
      const cv::Mat pixels = cv::imread(image.source, cv::IMREAD_COLOR);
      if (pixels.empty()) throw std::runtime_error("cannot read " + image.source);
      if (!cv::imwrite(path, pixels, {cv::IMWRITE_JPEG_QUALITY, o.jpeg_quality})) {
        throw std::runtime_error("cannot write " + path);
      }
    }
    auto file = Exiv2::ImageFactory::open(path);
    file->readMetadata();
    width = file->pixelWidth();
    height = file->pixelHeight();
    Exiv2::ExifData& exif = file->exifData();

    // Time: the camera clock in its zone.
    Timestamp ns_of_day = 0;
    const Timestamp clock =
        image.t + static_cast<Timestamp>(o.utc_offset_minutes) * 60 * kNanosPerSecond;
    const std::string date = ExifDate(clock, &ns_of_day);
    const Timestamp seconds = ns_of_day / kNanosPerSecond;
    exif["Exif.Photo.DateTimeOriginal"] = fmt::format(
        "{} {:02d}:{:02d}:{:02d}", date, seconds / 3600, seconds / 60 % 60, seconds % 60);
    if (o.subsec_digits > 0) {
      const std::string nine = fmt::format("{:09d}", ns_of_day % kNanosPerSecond);
      exif["Exif.Photo.SubSecTimeOriginal"] = nine.substr(0, o.subsec_digits);
    }
    if (o.write_offset_tag) {
      const int minutes = std::abs(o.utc_offset_minutes);
      exif["Exif.Photo.OffsetTimeOriginal"] = fmt::format(
          "{}{:02d}:{:02d}", o.utc_offset_minutes < 0 ? '-' : '+', minutes / 60, minutes % 60);
    }

    // GPS.
    if (image.position) {
      const geometry::GeodeticPoint& p = *image.position;
      exif["Exif.GPSInfo.GPSVersionID"] = "2 3 0 0";
      exif["Exif.GPSInfo.GPSLatitudeRef"] = p.lat_deg < 0 ? "S" : "N";
      exif["Exif.GPSInfo.GPSLatitude"] = DegreesMinutesSeconds(p.lat_deg);
      exif["Exif.GPSInfo.GPSLongitudeRef"] = p.lon_deg < 0 ? "W" : "E";
      exif["Exif.GPSInfo.GPSLongitude"] = DegreesMinutesSeconds(p.lon_deg);
      exif["Exif.GPSInfo.GPSAltitudeRef"] = p.alt_m < 0 ? "1" : "0";
      exif["Exif.GPSInfo.GPSAltitude"] =
          fmt::format("{}/10000", std::llround(std::abs(p.alt_m) * 1e4));
      exif["Exif.GPSInfo.GPSMeasureMode"] = "3";
      if (image.sigma_h > 0) {
        exif["Exif.GPSInfo.GPSHPositioningError"] =
            fmt::format("{}/10000", std::llround(image.sigma_h * 1e4));
      }
      if (o.write_gps_time) {
        Timestamp utc_ns_of_day = 0;
        exif["Exif.GPSInfo.GPSDateStamp"] = ExifDate(image.t, &utc_ns_of_day);
        const Timestamp s = utc_ns_of_day / kNanosPerSecond;
        exif["Exif.GPSInfo.GPSTimeStamp"] =
            fmt::format("{}/1 {}/1 {}/1000000", s / 3600, s / 60 % 60,
                        (s % 60) * 1'000'000 + (utc_ns_of_day % kNanosPerSecond) / 1000);
      }
    }

    // Focal length.
    if (o.focal_length_px) {
      const double pitch_mm = o.pixel_pitch_um * 1e-3;
      exif["Exif.Photo.FocalLength"] =
          fmt::format("{}/1000000", std::llround(*o.focal_length_px * pitch_mm * 1e6));
      const std::string per_cm = fmt::format("{}/1000", std::llround(10.0 / pitch_mm * 1e3));
      exif["Exif.Photo.FocalPlaneXResolution"] = per_cm;
      exif["Exif.Photo.FocalPlaneYResolution"] = per_cm;
      exif["Exif.Photo.FocalPlaneResolutionUnit"] = "3";
      if (o.write_focal_35mm) {
        const double f35 = *o.focal_length_px / std::hypot(width, height) * std::hypot(36.0, 24.0);
        exif["Exif.Photo.FocalLengthIn35mmFilm"] = std::to_string(std::lround(f35));
      }
    }
    file->writeMetadata();
    written.push_back(path);
  }
  return written;
}

std::vector<ExifTestImage> ExifImagesFromSession(const std::string& session_folder,
                                                 const std::string& camera,
                                                 const std::string& gps) {
  const Session session(session_folder);
  const std::vector<GpsSample> track = session.ReadGps(gps);
  std::vector<ExifTestImage> images;
  for (const ImageEntry& entry : session.ReadImageList(camera)) {
    ExifTestImage image;
    image.source = session.ImagePath(camera, entry.filename);
    image.t = entry.t;
    const auto after = std::lower_bound(track.begin(), track.end(), entry.t,
                                        [](const GpsSample& s, Timestamp t) { return s.t < t; });
    if (after != track.end() && (after->t == entry.t || after != track.begin())) {
      const GpsSample& b = *after;
      const GpsSample& a = after->t == entry.t ? b : *(after - 1);
      const double w = a.t == b.t ? 0.0 : DurationSeconds(a.t, entry.t) / DurationSeconds(a.t, b.t);
      geometry::GeodeticPoint p;
      p.lat_deg = a.position.lat_deg + w * (b.position.lat_deg - a.position.lat_deg);
      p.lon_deg = a.position.lon_deg + w * (b.position.lon_deg - a.position.lon_deg);
      p.alt_m = a.position.alt_m + w * (b.position.alt_m - a.position.alt_m);
      image.position = p;
      image.sigma_h = w < 0.5 ? a.sigma_h : b.sigma_h;
    }
    images.push_back(image);
  }
  return images;
}

std::vector<std::string> WriteSessionAsExifFolder(const std::string& session_folder,
                                                  const std::string& folder,
                                                  const ExifTestWriterOptions& options) {
  return WriteExifImageFolder(folder, ExifImagesFromSession(session_folder), options);
}

}  // namespace crop4d::io::testing
