#pragma once

// In-memory description of a field folder in the crop4d dataset format (DESIGN.md §4,
// docs/format.md): field.yaml, sessions/<id>/session.yaml and one folder per sensor in the
// ASL/EuRoC layout (<sensor>/sensor.yaml + <sensor>/data.csv [+ <sensor>/data/ for images]).
// Reading is in dataset_reader.h, writing in dataset_writer.h.

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::io {

// ---- field.yaml -------------------------------------------------------------------------

// A crop row declared by the user: a straight segment in the field's ENU frame.
struct RowDeclaration {
  int index = 0;
  Eigen::Vector2d start_enu = Eigen::Vector2d::Zero();
  Eigen::Vector2d end_enu = Eigen::Vector2d::Zero();
};

// A named measurement site: a disc on the ground.
struct Site {
  std::string id;
  Eigen::Vector2d center_enu = Eigen::Vector2d::Zero();  // given in ENU or as lat/lon
  double radius_m = 0.5;
};

struct FieldInfo {
  std::string name;
  geometry::GeodeticPoint origin;     // the ENU origin of the world frame
  std::vector<RowDeclaration> rows;   // optional
  std::vector<Site> sites;            // optional
  std::vector<std::string> sessions;  // optional order; default: folders of sessions/ sorted
};

// ---- session.yaml -----------------------------------------------------------------------

struct SessionInfo {
  std::string id;            // folder name under sessions/
  Timestamp date = 0;        // midnight UTC of the session date
  std::string notes;         // free text (weather, ...)
  bool rain_before = false;  // rain since the previous session (changes the soil)
};

// ---- sensor.yaml ------------------------------------------------------------------------

struct CameraSensor {
  std::string name = "cam0";
  geometry::PinholeRadTan camera;
  double rate_hz = 7.5;
  geometry::Rigid3 body_from_sensor;  // T_BS
  // The optical centre's height above the ground the vehicle stands on, m, when measured
  // (`height_above_ground_m`; slam/camera_height_scale.h).
  std::optional<double> height_above_ground_m;
};

struct ImuSensor {
  std::string name = "imu0";
  double rate_hz = 167.0;
  double gyroscope_noise_density = 0.0;      // rad / s / sqrt(Hz)
  double gyroscope_random_walk = 0.0;        // rad / s^2 / sqrt(Hz)
  double accelerometer_noise_density = 0.0;  // m / s^2 / sqrt(Hz)
  double accelerometer_random_walk = 0.0;    // m / s^3 / sqrt(Hz)
  geometry::Rigid3 body_from_sensor;         // T_BS
};

struct MagSensor {
  std::string name = "mag0";
  double rate_hz = 110.0;
  geometry::Rigid3 body_from_sensor;
};

enum class GpsKind { kRtk, kStandard };

struct GpsSensor {
  std::string name = "gps0";
  GpsKind kind = GpsKind::kRtk;
  double rate_hz = 5.0;
  Eigen::Vector3d antenna_in_body = Eigen::Vector3d::Zero();  // lever arm, metres, frame B
  double default_sigma_h = 0.02;  // used when a sample's sigma is missing or zero
  double default_sigma_v = 0.04;
};

// ---- data.csv rows ----------------------------------------------------------------------

struct ImageEntry {
  Timestamp t = 0;
  std::string filename;   // relative to <camera>/data/
  std::int64_t line = 0;  // line in data.csv, for messages
};

struct ImuSample {
  Timestamp t = 0;
  Eigen::Vector3d gyro = Eigen::Vector3d::Zero();   // rad/s, sensor frame
  Eigen::Vector3d accel = Eigen::Vector3d::Zero();  // m/s^2, sensor frame (specific force)
};

struct MagSample {
  Timestamp t = 0;
  Eigen::Vector3d field_ut = Eigen::Vector3d::Zero();  // microtesla, sensor frame
};

// GPS fix quality, NMEA GGA convention.
enum class GpsFix : int {
  kNone = 0,
  kSingle = 1,
  kDgps = 2,
  kRtkFixed = 4,
  kRtkFloat = 5,
};

struct GpsSample {
  Timestamp t = 0;
  geometry::GeodeticPoint position;
  double sigma_h = 0.0;  // 1-sigma horizontal, metres
  double sigma_v = 0.0;  // 1-sigma vertical, metres
  GpsFix fix = GpsFix::kNone;
  // The receiver's velocity (east, north, up), m/s, and its 1-sigma per axis, when it gives one
  // (RTKLIB's vn, ve, vu; docs/format.md).
  std::optional<Eigen::Vector3d> velocity_enu;
  double sigma_velocity = 0.0;
};

// ---- ground truth (written by the simulator, read by eval) ------------------------------

struct SiteMeasurement {
  std::string site_id;
  Timestamp date = 0;
  double height_m = 0.0;
};

}  // namespace crop4d::io
