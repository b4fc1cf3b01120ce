#pragma once

// `crop4d import --images DIR` (docs/import.md, "Image folders with EXIF"): a folder of JPEGs
// from a phone or action camera on a pole, or a drone, whose EXIF tags hold the time and the
// GNSS position of each picture, becomes a session with cam0/ and gps0/ (no IMU). Tags are read
// with exiv2.
//
// Time of an image (UTC ns) = Exif.Photo.DateTimeOriginal + SubSecTimeOriginal (the camera's
// clock, to the digits written) − its UTC offset, the offset being, in this order:
//   1. Exif.Photo.OffsetTimeOriginal of the image (the camera knew its zone);
//   2. ExifImportOptions::utc_offset_s (`--time-zone`);
//   3. from the GPS date/time stamps (GPSDateStamp + GPSTimeStamp, UTC): the median over the
//      images of (camera clock − GPS time), rounded to the nearest 15 minutes (every time zone
//      is a multiple of 15 min). The GPS stamps are not used as the image times themselves:
//      they are the time of the last fix (often whole seconds, and on phones seconds older than
//      the picture), while the camera clock has sub-second resolution and is consistent from
//      image to image;
//   4. otherwise the import stops and asks for --time-zone.
// A missing DateTimeOriginal is an error; images are sorted by time and two images with the
// same time are an error. Kalibr's timeshift_cam_imu, when given, is added to every time.
//
// GPS: Exif.GPSInfo latitude/longitude/altitude with their refs become gps0/data.csv at the
// image's time. sigma_h = GPSHPositioningError when present, else the default; sigma_v =
// sigma_h · (default_v / default_h). Fix: 1 (single), 2 (DGPS) when GPSDifferential = 1, 4 (RTK
// fixed) with gps_kind rtk, 0 (not used) when GPSStatus = V (void); a 2-D fix
// (GPSMeasureMode 2) has no measured altitude: sigma_v = 1000 m. The altitude is written as
// the ellipsoidal height our format expects; EXIF calls it height above sea level, and a
// camera that writes that differs by the geoid undulation (a constant offset over a field).
// An image without GPS tags is imported without a GPS sample (a warning counts them).
//
// Camera: the intrinsics come from ExifImportOptions::camera (a Kalibr camera chain or our
// sensor.yaml) or else, as a starting value that the solve refines, from EXIF: fx = fy =
// FocalLength · FocalPlaneXResolution / unit (FocalPlaneResolutionUnit: inch, cm, mm, µm), or
// from FocalLengthIn35mmFilm (diagonal rule: f_px = f35 / 43.267 mm · image diagonal in px);
// principal point at the centre ((w − 1) / 2, (h − 1) / 2), no distortion. All images must have
// the same size. Images are hard-linked when possible, else copied, never re-encoded:
// cam0/data/<t_ns>.jpg.
//
// Everything is read and checked before anything is written; the session is written into a
// hidden folder and renamed into place, so a failed import leaves nothing behind.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"

namespace crop4d::io {

struct ExifImportOptions {
  // The folder of JPEG images (*.jpg, *.jpeg, any case; other files are ignored with a warning).
  std::string image_folder;
  // The field folder: created when it has no field.yaml.
  std::string field_folder;
  // Session folder name (default: the UTC date of the first image, YYYY-MM-DD).
  std::string session_id;
  // Name for a new field.yaml (default: the folder's name).
  std::string field_name;
  // Free text for session.yaml's notes (the importer adds where the data came from).
  std::string notes;
  // Origin of a new field (default: the first image with a GPS fix).
  std::optional<geometry::GeodeticPoint> origin;
  // Replace an existing session folder instead of refusing.
  bool overwrite = false;
  // UTC offset of the camera clock, seconds (east positive), for images without
  // OffsetTimeOriginal (`--time-zone +02:00`).
  std::optional<int> utc_offset_s;
  // The camera's calibration (intrinsics, distortion, resolution, T_BS), from Kalibr or a
  // sensor.yaml; unset: a starting value from EXIF. `camera_source` says where it came from.
  std::optional<CameraSensor> camera;
  std::string camera_source;
  // Added to every image time (Kalibr's timeshift_cam_imu: onto the IMU clock).
  Timestamp camera_time_shift_ns = 0;
  // Receiver kind for gps0/sensor.yaml: standard unless set (rtk: fix code 4 for every fix).
  std::optional<GpsKind> gps_kind;
  // Default 1-sigmas (m) for images without GPSHPositioningError. Unset: 5 / 10 m (standard,
  // a phone) or 0.02 / 0.04 m (rtk).
  std::optional<double> sigma_h, sigma_v;
  // GNSS antenna in the body frame, metres (the body frame is the camera's unless the
  // calibration says otherwise).
  Eigen::Vector3d antenna_in_body = Eigen::Vector3d::Zero();

  // Throws InputError (naming the option) when a value is unusable.
  void Check() const;
};

struct ExifImportSummary {
  std::string session_folder;
  bool field_created = false;
  bool field_sessions_updated = false;
  geometry::GeodeticPoint origin;
  std::int64_t images = 0;
  std::int64_t images_linked = 0;  // the rest were copied
  Timestamp first_t = 0, last_t = 0;
  double rate_hz = 0.0;
  int width = 0, height = 0;
  // How the UTC offset was found ("OffsetTimeOriginal +02:00", "--time-zone +02:00", "UTC
  // offset +02:00 from the GPS time stamps"), and the median over the images of the camera
  // clock (in UTC) minus the GPS stamp, s, when there are stamps (a warning above 2 s).
  std::string time_rule;
  std::optional<double> clock_minus_gps_s;
  Timestamp time_shift_ns = 0;
  // Intrinsics and where they came from; true when they are EXIF's starting value.
  geometry::PinholeRadTan camera;
  std::string camera_source;
  bool camera_from_exif = false;
  // gps0: samples written, images without GPS, samples with their own sigma.
  std::int64_t gps_samples = 0;
  std::int64_t images_without_gps = 0;
  std::int64_t gps_with_accuracy_tag = 0;
  GpsKind gps_kind = GpsKind::kStandard;
  double default_sigma_h = 0.0, default_sigma_v = 0.0;
  // Files in the folder that are not JPEG images by name (ignored).
  std::int64_t other_files = 0;
};

// Throws InputError (file, line 0, what) on bad input; nothing is written then.
ExifImportSummary ImportExifFolder(const ExifImportOptions& options);

std::string FormatExifImportSummary(const ExifImportSummary& summary);

// "+02:00", "-05:30", "+0200", "+2", "Z", "UTC" → seconds east of UTC. False when malformed.
bool ParseUtcOffset(const std::string& text, int* seconds);

}  // namespace crop4d::io
