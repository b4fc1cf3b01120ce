#pragma once

// `crop4d import` (docs/import.md): makes a session of our dataset format (docs/format.md)
// from other recordings: an RTKLIB solution file (.pos) becomes gps0/, an IMU text file with a
// column and unit mapping becomes imu0/. The session is created in a new field folder (then
// field.yaml is written, with the origin and no rows) or added to an existing one.
//
//   SessionImporter::Options options;
//   options.field_folder = "walk_field";
//   options.session_id = "2025-08-28";
//   options.pos_path = "gnss_1730_sf.pos";
//   options.imu_path = "imu_1730_sf.csv";
//   options.imu.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz,...");
//   options.imu.accel_unit = AccelUnit::kStandardGravity;
//   SessionImporter::Summary summary = SessionImporter(options).Run();
//
// Everything is read and checked before anything is written; every file is written atomically.
// A session without rows (like a walk) is a legitimate input: the pipeline processes it as one
// pass.

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <string>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/imu_csv_import.h"
#include "crop4d/io/rtklib_pos.h"

namespace crop4d::io {

// The time scale of the IMU file's timestamps, for Options::leap_seconds.
enum class ImuTimeScale {
  kSameAsPos,  // that of the .pos file (GPST when there is none)
  kGpst,       // GPS time
  kUtc,        // UTC
};

class SessionImporter {
 public:
  struct Options {
    // The field folder: created when it does not exist (or has no field.yaml).
    std::string field_folder;
    // The session's folder name under sessions/; a date (YYYY-MM-DD...) is a good choice.
    std::string session_id;
    // Name written to a new field.yaml (default: the folder's name).
    std::string field_name;
    // RTKLIB solution file for gps0/ ("" = none).
    std::string pos_path;
    // IMU text file for imu0/ ("" = none).
    std::string imu_path;
    // How the .pos file is read (leap seconds, strictness).
    RtklibPosFile::Options pos;
    // How the IMU file is read (column mapping, units, delimiter, header lines, offset).
    ImuCsvFile::Options imu;
    // Time scale of the IMU timestamps: pos.leap_seconds is subtracted from them too when they
    // are GPST.
    ImuTimeScale imu_time_scale = ImuTimeScale::kSameAsPos;
    // Origin of a new field's ENU frame (default: the first GNSS epoch with a fix).
    std::optional<geometry::GeodeticPoint> origin;
    // GNSS receiver kind (default: rtk when any epoch is RTK fixed or float, else standard).
    std::optional<GpsKind> gps_kind;
    // GNSS antenna phase centre in the body frame, metres (gps0 p_B_antenna).
    Eigen::Vector3d antenna_in_body = Eigen::Vector3d::Zero();
    // IMU mounting, degrees: body_from_sensor rotation R = Rz(yaw) Ry(pitch) Rx(roll) (the
    // aerospace z-y'-x'' sequence), so x_in_body = R x_in_sensor. Samples stay in the sensor
    // frame; this becomes imu0's T_BS.
    Eigen::Vector3d imu_rpy_deg = Eigen::Vector3d::Zero();
    // IMU position in the body frame, metres (translation of imu0's T_BS).
    Eigen::Vector3d imu_position_in_body = Eigen::Vector3d::Zero();
    // Continuous-time IMU noise for imu0/sensor.yaml. Defaults: a generic consumer MEMS IMU
    // (the EuRoC/Kalibr ADIS16448 values); pass the datasheet's values.
    double gyroscope_noise_density = 1.6968e-4;   // rad / s / sqrt(Hz)
    double gyroscope_random_walk = 1.9393e-5;     // rad / s^2 / sqrt(Hz)
    double accelerometer_noise_density = 2.0e-3;  // m / s^2 / sqrt(Hz)
    double accelerometer_random_walk = 3.0e-3;    // m / s^3 / sqrt(Hz)
    // Free text for session.yaml's notes (the importer adds where the data came from).
    std::string notes;
    // Replace the files of an existing session folder instead of refusing.
    bool overwrite = false;

    // Throws InputError (naming the option) when a value is unusable.
    void Check() const;
  };

  struct Summary {
    std::string session_folder;
    bool field_created = false;           // field.yaml was written
    bool field_sessions_updated = false;  // the session was added to field.yaml's list
    geometry::GeodeticPoint origin;       // the field's origin
    Timestamp date = 0;                   // the session's date (midnight UTC)
    std::string time_scale;               // "GPST" or "UTC": the scale of the timestamps
    // gps0
    std::int64_t gps_samples = 0;
    double gps_rate_hz = 0.0;
    GpsKind gps_kind = GpsKind::kRtk;
    std::map<int, std::int64_t> pos_quality;  // epochs per RTKLIB Q
    std::map<int, std::int64_t> fix_counts;   // samples per NMEA fix code written
    std::int64_t gps_velocities = 0;          // samples with the receiver's velocity
    PosTimeSystem pos_time_system = PosTimeSystem::kGpst;
    PosCoordinates pos_coordinates = PosCoordinates::kLlhDegrees;
    Timestamp gps_first_t = 0, gps_last_t = 0;
    // imu0
    std::int64_t imu_samples = 0;
    double imu_rate_hz = 0.0;
    Timestamp imu_first_t = 0, imu_last_t = 0;
  };

  explicit SessionImporter(Options options) : options_(std::move(options)) {}

  // Reads the inputs, checks them and writes the session. Throws InputError (file, line, what)
  // on bad input; nothing is written then.
  Summary Run() const;

 private:
  Options options_;
};

// Registers session `session_id` in the field at `field_folder`: writes a new field.yaml (named
// `name`, or after the folder; with `origin`) when `field` is unset, else appends the id to
// field.yaml's session list when the field has one. Sets *created and *sessions_updated.
void AddSessionToField(const std::string& field_folder, std::optional<FieldInfo> field,
                       const std::string& name, const geometry::GeodeticPoint& origin,
                       const std::string& session_id, bool* created, bool* sessions_updated);

// Midnight (UTC) of the day that holds t: a session's date.
Timestamp DayOf(Timestamp t);

// The folder of a new session `id` in `field_folder`, checked for an import that writes it
// whole: the id is a name every output can hold (NameProblem), the field folder is a folder or
// absent, and the session is absent unless `overwrite`. Throws InputError.
std::string NewSessionFolder(const std::string& field_folder, const std::string& id,
                             bool overwrite);

// The field.yaml of `field_folder` when it has one (throws InputError on a broken file).
std::optional<FieldInfo> ExistingField(const std::string& field_folder);

// An import's session, written into the hidden `staging` folder, replaces `session_folder`.
void MoveIntoPlace(const std::string& staging, const std::string& session_folder);

// The body_from_sensor rotation of SessionImporter::Options::imu_rpy_deg.
Eigen::Matrix3d RotationFromRollPitchYawDeg(const Eigen::Vector3d& rpy_deg);

// A human summary of an import: one line per sensor, the time scale and the origin.
std::string FormatImportSummary(const SessionImporter::Summary& summary);

}  // namespace crop4d::io
