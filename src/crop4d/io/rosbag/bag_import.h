#pragma once

// `crop4d import --bag FILE.bag` (docs/import.md, "ROS 1 bags"): a ROS 1 bag becomes a session
// of our dataset format (docs/format.md).
//
//   sensor_msgs/Image, CompressedImage -> cam<N>/ (raw images as PNG, compressed ones verbatim)
//   sensor_msgs/Imu                    -> imu<N>/ (angular_velocity, linear_acceleration)
//   sensor_msgs/NavSatFix              -> gps<N>/ (status -> fix, covariance -> sigmas)
//   sensor_msgs/MagneticField          -> mag<N>/ (tesla -> microtesla)
//
// Which topic feeds which sensor folder comes from Options::topics, or, for a sensor kind with
// no topic named, from the bag itself when it has exactly one topic of that kind's types.
// A bag holds no calibration: cameras take theirs from Options::cameras or from the bag's
// sensor_msgs/CameraInfo; the other sensors from the Options maps or documented defaults.
//
// Images are written as they are read (never all in memory), into a hidden folder that is
// renamed into place at the end, so a failed import leaves nothing behind. Samples whose header
// stamps are out of order are sorted (a repeated stamp keeps the first message).
//
//   BagImportOptions options;
//   options.bag_path = "drive.bag";
//   options.field_folder = "my_field";
//   options.topics = {{"cam0", "/camera/image_raw"}, {"imu0", "/imu/data"}};
//   options.cameras["cam0"] = ReadCameraSensorYaml("cam0.yaml");
//   BagImportSummary summary = ImportBag(options);

#include <Eigen/Core>
#include <cstdint>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"

namespace crop4d::io {

// Which time a sample gets.
enum class BagStamp {
  kHeader,   // header.stamp: when the sensor measured (the driver's clock)
  kReceive,  // the bag's record time: when the recorder received the message
};

struct BagImportOptions {
  // The .bag file.
  std::string bag_path;
  // The field folder: created when it has no field.yaml.
  std::string field_folder;
  // Session folder name (default: the date of the first stamp, YYYY-MM-DD, UTC).
  std::string session_id;
  // Name for a new field.yaml (default: the folder's name).
  std::string field_name;
  // Origin of a new field (default: the first GPS sample with a fix; without GPS the
  // conventional origin 0°, 0°, 0 m, docs/import.md).
  std::optional<geometry::GeodeticPoint> origin;
  // Replace an existing session folder instead of refusing.
  bool overwrite = false;
  // Sensor folder -> topic: "cam0" -> "/camera/image_raw", "imu0" -> "/imu/data", "gps0",
  // "mag0", and "cam0_info" -> a sensor_msgs/CameraInfo topic for cam0.
  std::map<std::string, std::string> topics;
  // Header stamps (default) or record times.
  BagStamp stamp = BagStamp::kHeader;
  // Calibration per sensor folder name (from --sensor-yaml or Kalibr files). A sensor without
  // an entry: cameras use the bag's CameraInfo (else an error), the others the defaults below.
  std::map<std::string, CameraSensor> cameras;
  std::map<std::string, ImuSensor> imus;
  std::map<std::string, GpsSensor> gps;
  std::map<std::string, MagSensor> mags;
  // The sensor.yaml file each of those structs was read from, when there is one (--sensor-yaml):
  // copied verbatim into the session, so that it is byte-identical to the original (a T_BS read
  // into a quaternion and written again can move by an ulp).
  std::map<std::string, std::string> sensor_yaml_files;
  // Nanoseconds added to the stamps of a camera's images (Kalibr's timeshift_cam_imu: camera
  // clock onto the IMU clock, t_imu = t_cam + shift).
  std::map<std::string, Timestamp> camera_time_shift_ns;
  // Defaults for an IMU without calibration (those of SessionImporter::Options: a generic
  // consumer MEMS IMU, the EuRoC/Kalibr ADIS16448 values; identity T_BS, rate from the data).
  double gyroscope_noise_density = 1.6968e-4;   // rad / s / sqrt(Hz)
  double gyroscope_random_walk = 1.9393e-5;     // rad / s^2 / sqrt(Hz)
  double accelerometer_noise_density = 2.0e-3;  // m / s^2 / sqrt(Hz)
  double accelerometer_random_walk = 3.0e-3;    // m / s^3 / sqrt(Hz)
  // GNSS receiver kind for a receiver without calibration (default: rtk when any message has
  // STATUS_GBAS_FIX, else standard). It also decides what GBAS_FIX means: RTK fixed (rtk) or
  // DGPS (standard).
  std::optional<GpsKind> gps_kind;
  // Antenna phase centre in the body frame for a receiver without calibration, metres.
  Eigen::Vector3d antenna_in_body = Eigen::Vector3d::Zero();
  // Free text for session.yaml's notes (the importer adds where the data came from).
  std::string notes;

  // Throws InputError (naming the option) when a value is unusable.
  void Check() const;
};

struct BagImportSummary {
  std::string session_folder;
  std::string bag_path;
  bool field_created = false;
  bool field_sessions_updated = false;
  geometry::GeodeticPoint origin;     // the field's origin
  bool origin_by_convention = false;  // 0°, 0°, 0 m written: no GPS and no --origin
  Timestamp date = 0;                 // the session's date (midnight UTC)
  BagStamp stamp = BagStamp::kHeader;
  struct Sensor {
    std::string name;         // "cam0"
    std::string topic;        // "/camera/image_raw"
    std::string datatype;     // "sensor_msgs/Image"
    std::string calibration;  // where sensor.yaml came from
    std::int64_t samples = 0;
    Timestamp first_t = 0, last_t = 0;
    std::int64_t reordered = 0;   // messages whose stamp was earlier than the one before
    std::int64_t duplicates = 0;  // messages dropped because their stamp was already taken
    std::int64_t dropped = 0;     // messages without a usable value (NaN, no position)
  };
  std::vector<Sensor> sensors;
  GpsKind gps_kind = GpsKind::kStandard;   // of gps0, when there is one
  std::map<int, std::int64_t> fix_counts;  // gps samples per NMEA fix code written (all receivers)
};

// Imports the bag. Throws InputError (the bag, the option or the topic, and what is wrong;
// messages about topics list the bag's topics and their types) on bad input; nothing is left
// behind then.
BagImportSummary ImportBag(const BagImportOptions& options);

std::string FormatBagImportSummary(const BagImportSummary& summary);

}  // namespace crop4d::io
