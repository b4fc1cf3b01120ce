#pragma once

// Test support (library crop4d_exif_test_writer, built with the tests): writes a folder of JPEG
// images with EXIF time and GPS tags, as a phone or a drone would, for `crop4d import --images`
// (exif_import.h). Tests give the images, their true times and geodetic positions and sigmas;
// ExifImagesFromSession takes them from a (simulated) session folder.
//
// Precision of what is written:
//   - time: DateTimeOriginal (whole seconds of the camera clock = UTC + utc_offset_minutes) and
//     SubSecTimeOriginal with `subsec_digits` digits (the time is truncated to them; 9 digits
//     give the nanosecond exactly); OffsetTimeOriginal "+HH:MM" when write_offset_tag;
//     GPSDateStamp / GPSTimeStamp in UTC with microseconds when write_gps_time;
//   - latitude / longitude: degrees/1, minutes/1, seconds/10^6: 1e-6 arc second (≤ 31 µm);
//   - altitude: |alt| / 10^4 m with GPSAltitudeRef (0.1 mm); GPSHPositioningError: sigma_h /
//     10^4 m; GPSMeasureMode 3;
//   - focal length (when focal_length_px is set): FocalLength in mm / 10^6 and
//     FocalPlaneX/YResolution in pixels per cm / 10^3 (unit 3, cm) from pixel_pitch_um, giving
//     fx back within 1e-3 px; FocalLengthIn35mmFilm (an integer, diagonal rule) when
//     write_focal_35mm.

#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"

namespace crop4d::io::testing {

struct ExifTestImage {
  // The picture: a JPEG file is copied byte for byte before the tags are added; any other
  // image OpenCV reads (a simulated session's PNG) is encoded as JPEG first.
  std::string source;
  // True time of the picture, ns since the epoch (UTC).
  Timestamp t = 0;
  // True GNSS position; unset: no GPS tags in this image.
  std::optional<geometry::GeodeticPoint> position;
  // Written as GPSHPositioningError (metres) when > 0.
  double sigma_h = 0.0;
};

struct ExifTestWriterOptions {
  // The camera clock's zone: DateTimeOriginal = UTC + this many minutes.
  int utc_offset_minutes = 0;
  // Write OffsetTimeOriginal (the zone); without it the importer needs --time-zone or the GPS
  // stamps.
  bool write_offset_tag = true;
  // Write GPSDateStamp / GPSTimeStamp (UTC) in images with a position.
  bool write_gps_time = true;
  // Digits of SubSecTimeOriginal, 0 to 9 (0: the tag is not written).
  int subsec_digits = 9;
  // Quality of JPEGs encoded from other formats.
  int jpeg_quality = 95;
  // Focal length in pixels: FocalLength + FocalPlaneX/YResolution from pixel_pitch_um.
  std::optional<double> focal_length_px;
  double pixel_pitch_um = 2.0;
  // Also write FocalLengthIn35mmFilm (needs focal_length_px).
  bool write_focal_35mm = false;
  // File names: <prefix><4-digit index>.jpg, in the order given.
  std::string name_prefix = "IMG_";
};

// Writes the images into `folder` (created) and returns the paths written. Throws
// std::runtime_error when an image cannot be read or written.
std::vector<std::string> WriteExifImageFolder(const std::string& folder,
                                              const std::vector<ExifTestImage>& images,
                                              const ExifTestWriterOptions& options = {});

// The images of `camera` in a session folder (our format), each with the position of receiver
// `gps` interpolated linearly at its time (lat, lon, alt) and that sample's sigma_h; images
// outside the receiver's time span get no position.
std::vector<ExifTestImage> ExifImagesFromSession(const std::string& session_folder,
                                                 const std::string& camera = "cam0",
                                                 const std::string& gps = "gps0");

// WriteExifImageFolder(folder, ExifImagesFromSession(session_folder), options): a simulated
// session's camera images with its GPS track, as a phone would have tagged them.
std::vector<std::string> WriteSessionAsExifFolder(const std::string& session_folder,
                                                  const std::string& folder,
                                                  const ExifTestWriterOptions& options = {});

// The time that the importer reads back from an image written with `subsec_digits` digits:
// `t` truncated to them.
Timestamp TruncatedToDigits(Timestamp t, int subsec_digits);

}  // namespace crop4d::io::testing
