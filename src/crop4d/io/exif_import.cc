#include "crop4d/io/exif_import.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <chrono>
#include <cmath>
#include <exiv2/exiv2.hpp>
#include <filesystem>
#include <map>
#include <mutex>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/image_probe.h"
#include "crop4d/io/importer.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

// Diagonal of the 36 × 24 mm frame that FocalLengthIn35mmFilm refers to.
const double kFullFrameDiagonalMm = std::hypot(36.0, 24.0);
// sigma_v of a 2-D fix, whose altitude is not measured.
constexpr double kTwoDimensionalSigmaV = 1000.0;
// A camera clock this far (s) from the GPS stamps is worth a warning.
constexpr double kClockWarningS = 2.0;
// Time zones are whole multiples of 15 minutes.
constexpr Timestamp kTimeZoneStep = 15 * 60 * kNanosPerSecond;

// exiv2 prints its own warnings to stderr; only errors are of interest (they also throw).
void QuietExiv2() {
  static std::once_flag once;
  std::call_once(once, [] { Exiv2::LogMsg::setLevel(Exiv2::LogMsg::error); });
}

// What one image's EXIF says.
struct ExifImage {
  fs::path path;
  int width = 0, height = 0;
  Timestamp clock_ns = 0;            // DateTimeOriginal + SubSecTimeOriginal, read as if UTC
  std::optional<int> offset_s;       // OffsetTimeOriginal
  std::optional<Timestamp> gps_utc;  // GPSDateStamp + GPSTimeStamp
  std::optional<geometry::GeodeticPoint> position;
  bool has_altitude = false;
  std::optional<double> horizontal_error_m;  // GPSHPositioningError
  bool two_dimensional = false;              // GPSMeasureMode 2
  bool differential = false;                 // GPSDifferential 1
  bool gps_void = false;                     // GPSStatus V
  std::optional<double> focal_length_mm;
  std::optional<double> focal_plane_x_per_mm;  // FocalPlaneXResolution in pixels per mm
  std::optional<double> focal_plane_y_per_mm;
  std::optional<double> focal_35mm;
  Timestamp t = 0;  // the final time (UTC ns, + shift)
};

bool IsJpegName(const fs::path& path) {
  std::string ext = path.extension().string();
  std::transform(ext.begin(), ext.end(), ext.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return ext == ".jpg" || ext == ".jpeg";
}

// Midnight UTC of a calendar date, or nullopt when the date does not exist.
std::optional<Timestamp> CivilDate(int year, int month, int day) {
  const std::chrono::year_month_day ymd{std::chrono::year{year},
                                        std::chrono::month{static_cast<unsigned>(month)},
                                        std::chrono::day{static_cast<unsigned>(day)}};
  if (!ymd.ok()) return std::nullopt;
  return FromDate(year, month, day);
}

// Parses a run of `count` digits at text[*at]; advances *at.
bool Digits(const std::string& text, std::size_t* at, int count, int* value) {
  *value = 0;
  for (int k = 0; k < count; ++k, ++*at) {
    if (*at >= text.size() || !std::isdigit(static_cast<unsigned char>(text[*at]))) return false;
    *value = *value * 10 + (text[*at] - '0');
  }
  return true;
}

// "YYYY:MM:DD HH:MM:SS" (EXIF's DateTimeOriginal) → ns since the epoch, the clock read as UTC.
std::optional<Timestamp> ParseExifDateTime(const std::string& text) {
  std::size_t at = 0;
  int year, month, day, hour, minute, second;
  const auto sep = [&](char c) { return at < text.size() && text[at++] == c; };
  if (!Digits(text, &at, 4, &year) || !sep(':') || !Digits(text, &at, 2, &month) || !sep(':') ||
      !Digits(text, &at, 2, &day) || !sep(' ') || !Digits(text, &at, 2, &hour) || !sep(':') ||
      !Digits(text, &at, 2, &minute) || !sep(':') || !Digits(text, &at, 2, &second)) {
    return std::nullopt;
  }
  if (month < 1 || month > 12 || hour > 23 || minute > 59 || second > 59) return std::nullopt;
  const std::optional<Timestamp> date = CivilDate(year, month, day);
  if (!date) return std::nullopt;
  return *date + ((hour * 60 + minute) * 60 + second) * kNanosPerSecond;
}

// SubSecTimeOriginal: the decimal digits of the fraction of a second ("123" = 0.123 s). Digits
// beyond the 9th (below 1 ns) are dropped; blanks around them are allowed.
std::optional<Timestamp> ParseSubSeconds(const std::string& text) {
  std::size_t begin = text.find_first_not_of(' ');
  std::size_t end = text.find_last_not_of(' ');
  if (begin == std::string::npos) return std::nullopt;
  Timestamp ns = 0, scale = kNanosPerSecond;
  for (std::size_t k = begin; k <= end; ++k) {
    if (!std::isdigit(static_cast<unsigned char>(text[k]))) return std::nullopt;
    scale /= 10;
    ns += (text[k] - '0') * scale;
  }
  return ns;
}

// The tag's value, or nullptr when absent.
const Exiv2::Exifdatum* Find(const Exiv2::ExifData& exif, const char* key) {
  const auto it = exif.findKey(Exiv2::ExifKey(key));
  return it == exif.end() ? nullptr : &*it;
}

// The i-th rational of a tag as a double; nullopt when it has a zero denominator.
std::optional<double> Rational(const Exiv2::Exifdatum& datum, long i) {
  if (datum.count() <= i) return std::nullopt;
  const Exiv2::Rational r = datum.toRational(i);
  if (r.second == 0) return std::nullopt;
  return static_cast<double>(r.first) / static_cast<double>(r.second);
}

std::string Text(const Exiv2::Exifdatum* datum) {
  if (datum == nullptr) return "";
  std::string text = datum->toString();
  while (!text.empty() && (text.back() == '\0' || text.back() == ' ')) text.pop_back();
  return text;
}

// Degrees from a GPSLatitude / GPSLongitude triple (degrees, minutes, seconds) and its ref.
double Angle(const fs::path& path, const Exiv2::Exifdatum& value, const std::string& ref,
             const char* negative_ref, const char* positive_ref, const char* name) {
  const std::optional<double> d = Rational(value, 0), m = Rational(value, 1),
                              s = Rational(value, 2);
  if (value.count() != 3 || !d || !m || !s) {
    throw InputError(path.string(), 0,
                     fmt::format("Exif.GPSInfo.{} must be 3 rationals (degrees, minutes, "
                                 "seconds), found '{}'",
                                 name, value.toString()));
  }
  if (ref != negative_ref && ref != positive_ref) {
    throw InputError(path.string(), 0,
                     fmt::format("Exif.GPSInfo.{}Ref is '{}' (expected {} or {})", name, ref,
                                 positive_ref, negative_ref));
  }
  const double degrees = *d + *m / 60.0 + *s / 3600.0;
  return ref == negative_ref ? -degrees : degrees;
}

ExifImage ReadExifImage(const fs::path& path) {
  ExifImage image;
  image.path = path;
  const ImageProbe probe = ProbeImage(path.string());
  if (!probe.ok || probe.format != "jpeg") {
    throw InputError(path.string(), 0,
                     probe.ok ? "not a JPEG file (a " + probe.format + " image)"
                              : "not a readable JPEG: " + probe.problem);
  }
  image.width = probe.width;
  image.height = probe.height;

  Exiv2::ExifData exif;
  try {
    // exiv2 0.27 returns a std::auto_ptr (Image::AutoPtr, deprecated): `auto` holds it without
    // naming the deprecated type.
    auto file = Exiv2::ImageFactory::open(path.string());
    file->readMetadata();
    exif = file->exifData();
  } catch (const Exiv2::AnyError& e) {
    throw InputError(path.string(), 0, std::string("cannot read the EXIF tags: ") + e.what());
  }

  // ---- time ----
  const std::string original = Text(Find(exif, "Exif.Photo.DateTimeOriginal"));
  if (original.empty()) {
    throw InputError(path.string(), 0,
                     "no Exif.Photo.DateTimeOriginal tag: the time the picture was taken is "
                     "unknown");
  }
  const std::optional<Timestamp> clock = ParseExifDateTime(original);
  if (!clock) {
    throw InputError(path.string(), 0,
                     "Exif.Photo.DateTimeOriginal '" + original +
                         "' is not a date and time (YYYY:MM:DD HH:MM:SS)");
  }
  image.clock_ns = *clock;
  const std::string subsec = Text(Find(exif, "Exif.Photo.SubSecTimeOriginal"));
  if (!subsec.empty()) {
    const std::optional<Timestamp> fraction = ParseSubSeconds(subsec);
    if (!fraction) {
      throw InputError(path.string(), 0,
                       "Exif.Photo.SubSecTimeOriginal '" + subsec + "' is not a run of digits");
    }
    image.clock_ns += *fraction;
  }
  const std::string offset = Text(Find(exif, "Exif.Photo.OffsetTimeOriginal"));
  // "   :  " (blanks) means unknown in the EXIF standard.
  if (offset.find_first_not_of(" :") != std::string::npos) {
    int seconds = 0;
    if (!ParseUtcOffset(offset, &seconds)) {
      throw InputError(path.string(), 0,
                       "Exif.Photo.OffsetTimeOriginal '" + offset + "' is not ±HH:MM");
    }
    image.offset_s = seconds;
  }
  const std::string gps_date = Text(Find(exif, "Exif.GPSInfo.GPSDateStamp"));
  const Exiv2::Exifdatum* gps_time = Find(exif, "Exif.GPSInfo.GPSTimeStamp");
  if (!gps_date.empty() && gps_time != nullptr && gps_time->count() == 3) {
    const std::optional<Timestamp> date = ParseExifDateTime(gps_date + " 00:00:00");
    const std::optional<double> h = Rational(*gps_time, 0), m = Rational(*gps_time, 1),
                                s = Rational(*gps_time, 2);
    if (date && h && m && s) {
      image.gps_utc = *date + SecondsToTimestamp((*h * 60.0 + *m) * 60.0 + *s);
    }
  }

  // ---- position ----
  const Exiv2::Exifdatum* lat = Find(exif, "Exif.GPSInfo.GPSLatitude");
  const Exiv2::Exifdatum* lon = Find(exif, "Exif.GPSInfo.GPSLongitude");
  if (lat != nullptr && lon != nullptr) {
    geometry::GeodeticPoint p;
    p.lat_deg =
        Angle(path, *lat, Text(Find(exif, "Exif.GPSInfo.GPSLatitudeRef")), "S", "N", "GPSLatitude");
    p.lon_deg = Angle(path, *lon, Text(Find(exif, "Exif.GPSInfo.GPSLongitudeRef")), "W", "E",
                      "GPSLongitude");
    if (std::abs(p.lat_deg) > 90 || std::abs(p.lon_deg) > 180) {
      throw InputError(path.string(), 0,
                       fmt::format("GPS position {}, {} is out of range", p.lat_deg, p.lon_deg));
    }
    if (const Exiv2::Exifdatum* alt = Find(exif, "Exif.GPSInfo.GPSAltitude")) {
      const std::optional<double> a = Rational(*alt, 0);
      if (!a) throw InputError(path.string(), 0, "Exif.GPSInfo.GPSAltitude is not a rational");
      const Exiv2::Exifdatum* ref = Find(exif, "Exif.GPSInfo.GPSAltitudeRef");
      const bool below = ref != nullptr && ref->count() > 0 && ref->toLong(0) == 1;
      p.alt_m = below ? -*a : *a;
      image.has_altitude = true;
    }
    image.position = p;
    if (const Exiv2::Exifdatum* error = Find(exif, "Exif.GPSInfo.GPSHPositioningError")) {
      const std::optional<double> e = Rational(*error, 0);
      if (e && *e > 0 && std::isfinite(*e)) image.horizontal_error_m = *e;
    }
    image.two_dimensional = Text(Find(exif, "Exif.GPSInfo.GPSMeasureMode")) == "2";
    const Exiv2::Exifdatum* differential = Find(exif, "Exif.GPSInfo.GPSDifferential");
    image.differential =
        differential != nullptr && differential->count() > 0 && differential->toLong(0) == 1;
    image.gps_void = Text(Find(exif, "Exif.GPSInfo.GPSStatus")) == "V";
  }

  // ---- focal length ----
  if (const Exiv2::Exifdatum* f = Find(exif, "Exif.Photo.FocalLength")) {
    if (const std::optional<double> v = Rational(*f, 0); v && *v > 0) image.focal_length_mm = v;
  }
  const Exiv2::Exifdatum* unit = Find(exif, "Exif.Photo.FocalPlaneResolutionUnit");
  // 2 inch (the default), 3 cm; 4 mm and 5 µm are written by some cameras.
  const long unit_code = unit != nullptr && unit->count() > 0 ? unit->toLong(0) : 2;
  const double unit_mm = unit_code == 3   ? 10.0
                         : unit_code == 4 ? 1.0
                         : unit_code == 5 ? 1e-3
                                          : 25.4;
  if (const Exiv2::Exifdatum* x = Find(exif, "Exif.Photo.FocalPlaneXResolution")) {
    if (const std::optional<double> v = Rational(*x, 0); v && *v > 0) {
      image.focal_plane_x_per_mm = *v / unit_mm;
    }
  }
  if (const Exiv2::Exifdatum* y = Find(exif, "Exif.Photo.FocalPlaneYResolution")) {
    if (const std::optional<double> v = Rational(*y, 0); v && *v > 0) {
      image.focal_plane_y_per_mm = *v / unit_mm;
    }
  }
  if (const Exiv2::Exifdatum* f35 = Find(exif, "Exif.Photo.FocalLengthIn35mmFilm")) {
    if (f35->count() > 0 && f35->toLong(0) > 0) {
      image.focal_35mm = static_cast<double>(f35->toLong(0));
    }
  }
  return image;
}

// A rate for sensor.yaml: 4 significant digits (as the other importers write it).
double RoundRate(double rate_hz) {
  if (rate_hz <= 0) return rate_hz;
  const double scale = std::pow(10.0, 3 - std::floor(std::log10(rate_hz)));
  return std::round(rate_hz * scale) / scale;
}

bool LinkOrCopy(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::create_hard_link(from, to, ec);
  if (!ec) return true;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  return false;
}

std::string FormatOffset(int seconds) {
  const int minutes = std::abs(seconds) / 60;
  return fmt::format("{}{:02d}:{:02d}", seconds < 0 ? '-' : '+', minutes / 60, minutes % 60);
}

// Sets every image's time (UTC ns) by the rule of exif_import.h; fills the summary's rule.
void AssignTimes(std::vector<ExifImage>* images, const ExifImportOptions& o,
                 ExifImportSummary* summary) {
  // The camera clock's offset from the GPS stamps, for images without an offset of their own.
  std::vector<Timestamp> clock_minus_gps;
  for (const ExifImage& image : *images) {
    if (image.gps_utc) clock_minus_gps.push_back(image.clock_ns - *image.gps_utc);
  }
  std::optional<Timestamp> median;
  if (!clock_minus_gps.empty()) {
    std::nth_element(clock_minus_gps.begin(), clock_minus_gps.begin() + clock_minus_gps.size() / 2,
                     clock_minus_gps.end());
    median = clock_minus_gps[clock_minus_gps.size() / 2];
  }
  std::map<std::string, int> rules;
  std::vector<Timestamp> residuals;
  for (ExifImage& image : *images) {
    Timestamp offset_ns = 0;
    if (image.offset_s) {
      offset_ns = *image.offset_s * kNanosPerSecond;
      ++rules["OffsetTimeOriginal " + FormatOffset(*image.offset_s)];
    } else if (o.utc_offset_s) {
      offset_ns = *o.utc_offset_s * kNanosPerSecond;
      ++rules["--time-zone " + FormatOffset(*o.utc_offset_s)];
    } else if (median) {
      const double steps = std::round(static_cast<double>(*median) / kTimeZoneStep);
      offset_ns = static_cast<Timestamp>(steps) * kTimeZoneStep;
      ++rules["UTC offset " + FormatOffset(static_cast<int>(offset_ns / kNanosPerSecond)) +
              " from the GPS time stamps"];
    } else {
      throw InputError(image.path.string(), 0,
                       "the camera clock's time zone is unknown (no OffsetTimeOriginal, no GPS "
                       "date/time stamps): give --time-zone ±HH:MM");
    }
    image.t = image.clock_ns - offset_ns + o.camera_time_shift_ns;
    // What is left between the camera clock (in UTC) and the GPS stamps: the clock's own error
    // plus the age of the fix.
    if (image.gps_utc) residuals.push_back(image.clock_ns - offset_ns - *image.gps_utc);
  }
  if (!residuals.empty()) {
    std::nth_element(residuals.begin(), residuals.begin() + residuals.size() / 2, residuals.end());
    summary->clock_minus_gps_s = DurationSeconds(0, residuals[residuals.size() / 2]);
    if (std::abs(*summary->clock_minus_gps_s) > kClockWarningS) {
      spdlog::warn(
          "{}: the camera clock (in UTC) differs from the GPS time stamps by {:+.1f} s "
          "(median): a wrong clock or time zone? The image times are the camera's",
          o.image_folder, *summary->clock_minus_gps_s);
    }
  }
  for (const auto& [rule, count] : rules) {
    if (!summary->time_rule.empty()) summary->time_rule += "; ";
    summary->time_rule += rules.size() == 1 ? rule : fmt::format("{} ({} images)", rule, count);
  }
  summary->time_shift_ns = o.camera_time_shift_ns;
}

// The camera: the given calibration, else EXIF's starting value.
CameraSensor CameraFor(const std::vector<ExifImage>& images, const ExifImportOptions& o,
                       ExifImportSummary* summary) {
  const ExifImage& first = images.front();
  CameraSensor sensor;
  sensor.name = "cam0";
  if (o.camera) {
    sensor = *o.camera;
    sensor.name = "cam0";
    if (sensor.camera.width != first.width || sensor.camera.height != first.height) {
      throw InputError(
          o.camera_source, 0,
          fmt::format("the calibration's resolution {}x{} differs from the images' "
                      "size {}x{}",
                      sensor.camera.width, sensor.camera.height, first.width, first.height));
    }
    summary->camera_source = o.camera_source;
    summary->camera = sensor.camera;
    return sensor;
  }
  // Without a calibration the mounting is the usual one of a pole or drone camera: looking
  // straight down, the image's top forward. Body x forward, y left, z up (row SLAM without an
  // IMU takes body z as up): camera x (right) = body −y, y (down in the image) = body −x, z (the
  // optical axis) = body −z.
  Eigen::Matrix3d body_from_camera;
  body_from_camera << 0, -1, 0, -1, 0, 0, 0, 0, -1;
  sensor.body_from_sensor =
      geometry::Rigid3(Eigen::Quaterniond(body_from_camera), Eigen::Vector3d::Zero());
  geometry::PinholeRadTan& camera = sensor.camera;
  camera.width = first.width;
  camera.height = first.height;
  camera.cx = 0.5 * (first.width - 1);
  camera.cy = 0.5 * (first.height - 1);
  if (first.focal_length_mm && first.focal_plane_x_per_mm) {
    camera.fx = *first.focal_length_mm * *first.focal_plane_x_per_mm;
    camera.fy =
        *first.focal_length_mm * first.focal_plane_y_per_mm.value_or(*first.focal_plane_x_per_mm);
    summary->camera_source = fmt::format(
        "EXIF FocalLength {:.4g} mm × FocalPlaneXResolution {:.6g} px/mm (a starting value)",
        *first.focal_length_mm, *first.focal_plane_x_per_mm);
  } else if (first.focal_35mm) {
    camera.fx = camera.fy =
        *first.focal_35mm / kFullFrameDiagonalMm * std::hypot(first.width, first.height);
    summary->camera_source =
        fmt::format("EXIF FocalLengthIn35mmFilm {:.0f} mm, diagonal rule (a starting value)",
                    *first.focal_35mm);
  } else {
    throw InputError(first.path.string(), 0,
                     "no camera calibration: give --camera-yaml or --kalibr-camchain (the EXIF "
                     "has neither FocalLength with FocalPlaneXResolution nor "
                     "FocalLengthIn35mmFilm)");
  }
  for (const ExifImage& image : images) {
    if (image.focal_length_mm != first.focal_length_mm || image.focal_35mm != first.focal_35mm) {
      spdlog::warn(
          "{}: another focal length than {} (a zoom lens?): the intrinsics are those of "
          "the first image",
          image.path.string(), first.path.filename().string());
      break;
    }
  }
  summary->camera_from_exif = true;
  summary->camera = camera;
  return sensor;
}

}  // namespace

bool ParseUtcOffset(const std::string& text, int* seconds) {
  if (text == "Z" || text == "UTC" || text == "utc") {
    *seconds = 0;
    return true;
  }
  if (text.size() < 2 || (text[0] != '+' && text[0] != '-')) return false;
  std::size_t at = 1;
  int hours = 0, minutes = 0;
  const std::size_t digits = text.find_first_not_of("0123456789", 1);
  const std::size_t hour_digits = (digits == std::string::npos ? text.size() : digits) - 1;
  if (hour_digits == 4 && digits == std::string::npos) {  // "+0200"
    if (!Digits(text, &at, 2, &hours) || !Digits(text, &at, 2, &minutes)) return false;
  } else if (hour_digits == 1 || hour_digits == 2) {
    if (!Digits(text, &at, static_cast<int>(hour_digits), &hours)) return false;
    if (at < text.size()) {
      if (text[at++] != ':' || !Digits(text, &at, 2, &minutes) || at != text.size()) return false;
    }
  } else {
    return false;
  }
  if (hours > 14 || minutes > 59) return false;
  *seconds = (text[0] == '-' ? -1 : 1) * (hours * 3600 + minutes * 60);
  return true;
}

void ExifImportOptions::Check() const {
  if (field_folder.empty()) throw InputError("--out", 0, "the field folder is required");
  if (origin && (std::abs(origin->lat_deg) > 90 || std::abs(origin->lon_deg) > 180)) {
    throw InputError("--origin", 0, "latitude beyond ±90° or longitude beyond ±180°");
  }
  if ((sigma_h && !(*sigma_h > 0 && std::isfinite(*sigma_h))) ||
      (sigma_v && !(*sigma_v > 0 && std::isfinite(*sigma_v)))) {
    throw InputError("--gps-sigma", 0, "sigmas must be positive metres");
  }
  if (utc_offset_s && std::abs(*utc_offset_s) > 14 * 3600) {
    throw InputError("--time-zone", 0, "UTC offsets lie within ±14:00");
  }
  if (camera) {
    if (const std::string why = camera->camera.Check(); !why.empty()) {
      throw InputError(camera_source, 0, "the camera calibration is not valid: " + why);
    }
  }
  if (!antenna_in_body.allFinite()) throw InputError("--antenna", 0, "must be finite");
}

ExifImportSummary ImportExifFolder(const ExifImportOptions& o) {
  o.Check();
  QuietExiv2();
  std::error_code ec;
  if (!fs::is_directory(o.image_folder, ec)) {
    throw InputError(o.image_folder, 0, "no such folder (expected a folder of JPEG images)");
  }
  ExifImportSummary summary;

  // ---- read and check every image ----
  std::vector<fs::path> files;
  for (const fs::directory_entry& entry : fs::directory_iterator(o.image_folder)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.') continue;
    if (entry.is_regular_file() && IsJpegName(entry.path())) {
      files.push_back(entry.path());
    } else {
      ++summary.other_files;
      spdlog::warn("{}: not a .jpg / .jpeg file; ignored", entry.path().string());
    }
  }
  if (files.empty()) throw InputError(o.image_folder, 0, "no .jpg or .jpeg file in the folder");
  std::sort(files.begin(), files.end());
  std::vector<ExifImage> images;
  images.reserve(files.size());
  for (const fs::path& file : files) images.push_back(ReadExifImage(file));
  for (const ExifImage& image : images) {
    if (image.width != images.front().width || image.height != images.front().height) {
      throw InputError(
          image.path.string(), 0,
          fmt::format("the image is {}x{}, {} is {}x{}: every image of a camera "
                      "must have the same size",
                      image.width, image.height, images.front().path.filename().string(),
                      images.front().width, images.front().height));
    }
  }
  AssignTimes(&images, o, &summary);
  std::sort(images.begin(), images.end(),
            [](const ExifImage& a, const ExifImage& b) { return a.t < b.t; });
  for (std::size_t k = 1; k < images.size(); ++k) {
    if (images[k].t == images[k - 1].t) {
      throw InputError(images[k].path.string(), 0,
                       "has the same time as " + images[k - 1].path.filename().string() + " (" +
                           FormatTimestamp(images[k].t) +
                           "): two pictures cannot be taken at once by one camera");
    }
  }
  CameraSensor camera = CameraFor(images, o, &summary);
  summary.width = camera.camera.width;
  summary.height = camera.camera.height;

  // ---- GPS ----
  const bool rtk = o.gps_kind == GpsKind::kRtk;
  summary.gps_kind = rtk ? GpsKind::kRtk : GpsKind::kStandard;
  summary.default_sigma_h = o.sigma_h.value_or(rtk ? 0.02 : 5.0);
  summary.default_sigma_v = o.sigma_v.value_or(o.sigma_h ? 2.0 * *o.sigma_h : (rtk ? 0.04 : 10.0));
  std::vector<GpsSample> gps;
  for (const ExifImage& image : images) {
    if (!image.position) {
      ++summary.images_without_gps;
      continue;
    }
    GpsSample sample;
    sample.t = image.t;
    sample.position = *image.position;
    sample.sigma_h = image.horizontal_error_m.value_or(summary.default_sigma_h);
    sample.sigma_v = sample.sigma_h * (summary.default_sigma_v / summary.default_sigma_h);
    if (image.horizontal_error_m) ++summary.gps_with_accuracy_tag;
    if (image.two_dimensional || !image.has_altitude) sample.sigma_v = kTwoDimensionalSigmaV;
    sample.fix = image.gps_void       ? GpsFix::kNone
                 : rtk                ? GpsFix::kRtkFixed
                 : image.differential ? GpsFix::kDgps
                                      : GpsFix::kSingle;
    gps.push_back(sample);
  }
  if (summary.images_without_gps > 0) {
    spdlog::warn(
        "{}: {} of {} images have no GPS position; they are imported without a GPS "
        "sample",
        o.image_folder, summary.images_without_gps, images.size());
  }
  summary.gps_samples = static_cast<std::int64_t>(gps.size());

  // ---- session, origin ----
  summary.images = static_cast<std::int64_t>(images.size());
  summary.first_t = images.front().t;
  summary.last_t = images.back().t;
  summary.rate_hz = images.size() > 1 ? static_cast<double>(images.size() - 1) /
                                            DurationSeconds(summary.first_t, summary.last_t)
                                      : 0.0;
  const Timestamp first_t = summary.first_t;
  const Timestamp date = DayOf(first_t);
  const std::string id = o.session_id.empty() ? FormatDate(date) : o.session_id;
  const fs::path field_folder(o.field_folder);
  const fs::path session_folder = NewSessionFolder(o.field_folder, id, o.overwrite);
  summary.session_folder = session_folder.string();
  std::optional<FieldInfo> field = ExistingField(o.field_folder);
  if (field) {
    summary.origin = field->origin;
  } else if (o.origin) {
    summary.origin = *o.origin;
  } else {
    const auto fix = std::find_if(gps.begin(), gps.end(),
                                  [](const GpsSample& s) { return s.fix != GpsFix::kNone; });
    if (fix == gps.end()) {
      throw InputError("--origin", 0,
                       "a new field needs an origin and no image has a GPS fix: give --origin "
                       "lat,lon,alt");
    }
    summary.origin = fix->position;
  }

  // ---- write the session into a hidden folder, then move it into place ----
  camera.rate_hz = summary.rate_hz > 0 ? RoundRate(summary.rate_hz) : 1.0;
  const fs::path staging =
      field_folder / kSessionsFolder / fmt::format(".{}.importing-{}", id, ::getpid());
  fs::remove_all(staging, ec);
  try {
    const fs::path cam0 = staging / "cam0";
    fs::create_directories(cam0 / kImageFolder);
    WriteCameraSensorYaml((cam0 / kSensorYaml).string(), camera);
    std::vector<ImageEntry> entries;
    for (const ExifImage& image : images) {
      ImageEntry entry;
      entry.t = image.t;
      entry.filename = std::to_string(image.t) + ".jpg";
      if (LinkOrCopy(image.path, cam0 / kImageFolder / entry.filename)) ++summary.images_linked;
      entries.push_back(entry);
    }
    WriteImageCsv((cam0 / kDataCsv).string(), entries);
    if (!gps.empty()) {
      GpsSensor sensor;
      sensor.name = "gps0";
      sensor.kind = summary.gps_kind;
      sensor.antenna_in_body = o.antenna_in_body;
      sensor.default_sigma_h = summary.default_sigma_h;
      sensor.default_sigma_v = summary.default_sigma_v;
      sensor.rate_hz = gps.size() > 1 ? RoundRate(static_cast<double>(gps.size() - 1) /
                                                  DurationSeconds(gps.front().t, gps.back().t))
                                      : 1.0;
      WriteGpsSensorYaml((staging / "gps0" / kSensorYaml).string(), sensor);
      WriteGpsCsv((staging / "gps0" / kDataCsv).string(), gps);
    }
    SessionInfo session;
    session.id = id;
    session.date = date;
    session.notes = o.notes;
    if (!session.notes.empty()) session.notes += ". ";
    session.notes += fmt::format(
        "Imported by crop4d import --images from {} ({} JPEG images, EXIF). Times: "
        "DateTimeOriginal + SubSecTimeOriginal, {}{}. Camera intrinsics: {}{}. GPS: EXIF "
        "GPSInfo of {} images, sigmas from GPSHPositioningError or {} / {} m.",
        fs::absolute(o.image_folder).lexically_normal().string(), images.size(), summary.time_rule,
        o.camera_time_shift_ns != 0
            ? fmt::format(", + {:.9f} s timeshift_cam_imu (onto the IMU clock)",
                          DurationSeconds(0, o.camera_time_shift_ns))
            : "",
        summary.camera_source,
        summary.camera_from_exif ? ", refined by the solve: not a calibration" : "", gps.size(),
        summary.default_sigma_h, summary.default_sigma_v);
    WriteSessionYaml((staging / kSessionYaml).string(), session);
    MoveIntoPlace(staging.string(), session_folder.string());
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }
  AddSessionToField(o.field_folder, std::move(field), o.field_name, summary.origin, id,
                    &summary.field_created, &summary.field_sessions_updated);
  return summary;
}

std::string FormatExifImportSummary(const ExifImportSummary& s) {
  std::string out =
      fmt::format("session {} (JPEG images with EXIF time and GPS, no IMU)\n", s.session_folder);
  out += fmt::format("  cam0  {:>6} images  {}x{}, {:.4g} Hz, {} .. {} ({} hard-linked)\n",
                     s.images, s.width, s.height, s.rate_hz, FormatTimestamp(s.first_t),
                     FormatTimestamp(s.last_t), s.images_linked);
  out += fmt::format("        times: DateTimeOriginal + SubSecTimeOriginal, {}\n", s.time_rule);
  if (s.clock_minus_gps_s) {
    out += fmt::format("        camera clock − GPS time stamp: {:+.3f} s (median)\n",
                       *s.clock_minus_gps_s);
  }
  if (s.time_shift_ns != 0) {
    out += fmt::format("        + timeshift_cam_imu {:+.9f} s: image times on the IMU clock\n",
                       DurationSeconds(0, s.time_shift_ns));
  }
  out += fmt::format("        intrinsics fx {:.2f}, fy {:.2f}, cx {:.2f}, cy {:.2f} px: {}\n",
                     s.camera.fx, s.camera.fy, s.camera.cx, s.camera.cy, s.camera_source);
  if (s.camera_from_exif) {
    out += "        (a starting value from EXIF, not a calibration: the solve refines it)\n";
  }
  if (s.gps_samples > 0) {
    out += fmt::format(
        "  gps0  {:>6} samples kind {}, {} with GPSHPositioningError, others sigma {} / {} m\n",
        s.gps_samples, GpsKindName(s.gps_kind), s.gps_with_accuracy_tag, s.default_sigma_h,
        s.default_sigma_v);
  } else {
    out += "  gps0  none (no image has a GPS position)\n";
  }
  if (s.images_without_gps > 0) {
    out += fmt::format("  {} images without a GPS position (imported without a GPS sample)\n",
                       s.images_without_gps);
  }
  if (s.other_files > 0) out += fmt::format("  {} other files ignored\n", s.other_files);
  out +=
      fmt::format("  field origin {:.9f}, {:.9f}, {:.3f} m{}\n", s.origin.lat_deg, s.origin.lon_deg,
                  s.origin.alt_m, s.field_created ? " (new field.yaml, no rows)" : "");
  return out;
}

}  // namespace crop4d::io
