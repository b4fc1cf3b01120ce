#pragma once

// Names and constants of the dataset format (docs/format.md), shared by the reader, the
// writer and the validator.

#include <optional>
#include <string>
#include <string_view>

#include "crop4d/io/dataset.h"

namespace crop4d::io {

inline constexpr const char* kFieldYaml = "field.yaml";
inline constexpr const char* kSessionsFolder = "sessions";
inline constexpr const char* kSessionYaml = "session.yaml";
inline constexpr const char* kSensorYaml = "sensor.yaml";
inline constexpr const char* kDataCsv = "data.csv";
inline constexpr const char* kImageFolder = "data";  // <camera>/data/<file>

inline constexpr const char* kImageCsvHeader = "#timestamp [ns],filename";
inline constexpr const char* kImuCsvHeader =
    "#timestamp [ns],w_x [rad s^-1],w_y [rad s^-1],w_z [rad s^-1],a_x [m s^-2],a_y [m s^-2],"
    "a_z [m s^-2]";
inline constexpr const char* kMagCsvHeader = "#timestamp [ns],m_x [uT],m_y [uT],m_z [uT]";
inline constexpr const char* kGpsCsvHeader =
    "#timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix";
// gps0/data.csv with the receiver's velocity (optional columns: east, north, up and a per-axis
// 1-sigma; empty on a line without one).
inline constexpr const char* kGpsCsvHeaderWithVelocity =
    "#timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix,ve [m/s],vn [m/s],"
    "vu [m/s],sigma_vel [m/s]";

// Columns of each data.csv.
inline constexpr int kImageCsvColumns = 2;
inline constexpr int kImuCsvColumns = 7;
inline constexpr int kMagCsvColumns = 4;
inline constexpr int kGpsCsvColumns = 7;

// The sensor kinds; a sensor folder's name is the kind's prefix and a number ("cam0", "gps1").
enum class SensorKind { kCamera, kImu, kMag, kGps };

const char* SensorKindName(SensorKind kind);      // "camera", "imu", "magnetometer", "gps"
const char* SensorFolderPrefix(SensorKind kind);  // "cam", "imu", "mag", "gps"
// The kind of a sensor folder name ("imu0" -> kImu), or nullopt for other names.
std::optional<SensorKind> SensorKindFromFolder(std::string_view folder);
// The kind named by sensor.yaml's sensor_type ("camera", "imu", "magnetometer" or "mag",
// "gps"), or nullopt.
std::optional<SensorKind> SensorKindFromType(std::string_view sensor_type);

const char* GpsKindName(GpsKind kind);  // "rtk", "standard"
std::optional<GpsKind> ParseGpsKind(std::string_view text);

// NMEA GGA fix quality names: 0 "none", 1 "single", 2 "dgps", 3 "pps", 4 "rtk-fixed",
// 5 "rtk-float", 6 "dead-reckoning", 7 "manual", 8 "simulation"; "unknown" otherwise.
const char* GpsFixName(int code);
// Whether a GGA code is one crop4d uses as a position (0, 1, 2, 4, 5 = the GpsFix values).
bool IsGpsFixUsed(int code);

}  // namespace crop4d::io
