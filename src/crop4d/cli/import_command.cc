// crop4d import: makes a session of our dataset format from an RTKLIB solution file (.pos) and
// an IMU text file with a column and unit mapping, or from an EuRoC / ASL sequence as it is
// (--euroc; docs/import.md). Exit code 0 when the
// session was written, 2 on bad input (nothing is written then).

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/euroc_import.h"
#include "crop4d/io/exif_import.h"
#include "crop4d/io/importer.h"
#include "crop4d/io/kalibr.h"
#include "crop4d/io/rosbag/bag_import.h"

namespace crop4d::cli {
namespace {

struct ImportArgs {
  io::SessionImporter::Options options;
  std::string origin;  // "lat,lon[,alt]"
  std::string gps_kind = "auto";
  std::string antenna;  // "x,y,z"
  std::string imu_columns = "t,gx,gy,gz,ax,ay,az";
  std::string imu_time_unit = "s";
  std::string accel_unit = "mps2";
  std::string gyro_unit = "rads";
  std::string imu_delimiter = "auto";
  std::string imu_time_offset = "0";  // seconds, decimal text (parsed exactly)
  std::string imu_time_scale = "pos";
  std::string imu_rpy_deg;                // "roll,pitch,yaw"
  std::string imu_position;               // "x,y,z"
  std::string euroc;                      // an EuRoC / ASL sequence (its mav0/ or the folder above)
  std::string bag;                        // a ROS 1 bag (--bag)
  std::vector<std::string> bag_topics;    // --topic SENSOR=TOPIC, repeatable
  std::string bag_stamp = "header";       // --stamp header|receive
  std::vector<std::string> sensor_yamls;  // --sensor-yaml SENSOR=FILE, repeatable

  // --images and the Kalibr files.
  std::string images;           // a folder of JPEGs with EXIF time and GPS (--images)
  std::string kalibr_camchain;  // Kalibr camchain-imucam.yaml
  std::string kalibr_imu;       // Kalibr imu.yaml
  std::string camera_yaml;      // cam0 calibration in our sensor.yaml format (--images)
  std::string time_zone;        // the camera clock's UTC offset, "+02:00" (--images)
  std::string gps_sigma;        // "H[,V]" default GPS sigmas, metres (--images)
};

// "a,b,c" with exactly `min_count`..3 finite numbers; missing trailing ones are 0.
Eigen::Vector3d ParseNumbers(const std::string& text, const std::string& option, int min_count,
                             const char* expected) {
  std::vector<std::string_view> fields;
  io::SplitCsvLine(text, ',', &fields);
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  if (static_cast<int>(fields.size()) < min_count || fields.size() > 3) {
    throw InputError(option, 0, "expected " + std::string(expected) + ", got '" + text + "'");
  }
  for (std::size_t k = 0; k < fields.size(); ++k) {
    if (!io::ParseDouble(fields[k], &v[k]) || !std::isfinite(v[k])) {
      throw InputError(
          option, 0,
          "'" + std::string(fields[k]) + "' is not a number (expected " + expected + ")");
    }
  }
  return v;
}

// --origin "lat,lon[,alt]" (unset when empty).
std::optional<geometry::GeodeticPoint> ParseOrigin(const std::string& text) {
  if (text.empty()) return std::nullopt;
  const Eigen::Vector3d v = ParseNumbers(text, "--origin", 2, "lat,lon[,alt]");
  return geometry::GeodeticPoint{v.x(), v.y(), v.z()};
}

// --gps-kind auto|rtk|standard (unset for auto).
std::optional<io::GpsKind> ParseGpsKindOption(const std::string& text) {
  if (text == "auto") return std::nullopt;
  const std::optional<io::GpsKind> kind = io::ParseGpsKind(text);
  if (!kind) {
    throw InputError("--gps-kind", 0,
                     "unknown kind '" + text + "' (expected auto, rtk or standard)");
  }
  return kind;
}

// Prints an import's summary (unless quiet) and logs what was written; the exit code 0.
int Report(const std::string& text, const std::string& session_folder, bool sessions_updated) {
  if (!IsQuiet()) {
    std::fputs(text.c_str(), stdout);
    std::fflush(stdout);
  }
  spdlog::info("import: wrote {}{}", session_folder,
               sessions_updated ? " and added it to field.yaml's sessions" : "");
  return 0;
}

// --euroc: the sequence as it is; the .pos and IMU-file options do not apply.
int RunEurocImport(const ImportArgs& args) {
  if (!args.options.pos_path.empty() || !args.options.imu_path.empty()) {
    throw InputError("--euroc", 0,
                     "takes the sequence's own IMU and has no GNSS: leave out --pos and --imu");
  }
  io::EurocImportOptions options;
  options.sequence_folder = args.euroc;
  options.field_folder = args.options.field_folder;
  options.session_id = args.options.session_id;
  options.field_name = args.options.field_name;
  options.overwrite = args.options.overwrite;
  options.origin = ParseOrigin(args.origin);
  if (!args.kalibr_camchain.empty() || !args.kalibr_imu.empty()) {
    options.kalibr = io::ReadKalibr(args.kalibr_camchain, args.kalibr_imu);
  }
  const io::EurocImportSummary summary = io::ImportEuroc(options);
  return Report(io::FormatEurocImportSummary(summary), summary.session_folder,
                summary.field_sessions_updated);
}

// "NAME=VALUE" of a repeatable option such as --topic cam0=/camera/image_raw.
std::pair<std::string, std::string> SplitAssignment(const std::string& text, const char* option,
                                                    const char* expected) {
  const std::size_t at = text.find('=');
  if (at == std::string::npos || at == 0 || at + 1 == text.size()) {
    throw InputError(option, 0, "expected " + std::string(expected) + ", got '" + text + "'");
  }
  return {text.substr(0, at), text.substr(at + 1)};
}

// --bag: a ROS 1 bag; its own sensors, so the .pos, IMU-file and EuRoC options do not apply.
int RunBagImport(const ImportArgs& args) {
  if (!args.options.pos_path.empty() || !args.options.imu_path.empty() || !args.euroc.empty()) {
    throw InputError("--bag", 0, "imports the bag's own sensors: leave out --pos, --imu, --euroc");
  }
  io::BagImportOptions options;
  options.bag_path = args.bag;
  options.field_folder = args.options.field_folder;
  options.session_id = args.options.session_id;
  options.field_name = args.options.field_name;
  options.notes = args.options.notes;
  options.overwrite = args.options.overwrite;
  options.gyroscope_noise_density = args.options.gyroscope_noise_density;
  options.gyroscope_random_walk = args.options.gyroscope_random_walk;
  options.accelerometer_noise_density = args.options.accelerometer_noise_density;
  options.accelerometer_random_walk = args.options.accelerometer_random_walk;
  options.origin = ParseOrigin(args.origin);
  options.gps_kind = ParseGpsKindOption(args.gps_kind);
  if (!args.antenna.empty()) {
    options.antenna_in_body = ParseNumbers(args.antenna, "--antenna", 3, "x,y,z in metres");
  }
  for (const std::string& text : args.bag_topics) {
    const auto [sensor, topic] = SplitAssignment(text, "--topic", "SENSOR=TOPIC");
    if (!options.topics.emplace(sensor, topic).second) {
      throw InputError("--topic", 0, "'" + sensor + "' is given twice");
    }
  }
  if (args.bag_stamp == "header") {
    options.stamp = io::BagStamp::kHeader;
  } else if (args.bag_stamp == "receive") {
    options.stamp = io::BagStamp::kReceive;
  } else {
    throw InputError("--stamp", 0,
                     "unknown stamp '" + args.bag_stamp + "' (expected header or receive)");
  }
  // Calibration files in crop4d's sensor.yaml format, one per sensor folder name.
  for (const std::string& text : args.sensor_yamls) {
    const auto [sensor, path] = SplitAssignment(text, "--sensor-yaml", "SENSOR=FILE");
    const std::optional<io::SensorKind> kind = io::SensorKindFromFolder(sensor);
    if (!kind) {
      throw InputError("--sensor-yaml", 0,
                       "'" + sensor +
                           "' is not a sensor folder name (cam<N>, imu<N>, gps<N>, "
                           "mag<N>)");
    }
    switch (*kind) {
      case io::SensorKind::kCamera:
        options.cameras[sensor] = io::ReadCameraSensorYaml(path);
        break;
      case io::SensorKind::kImu:
        options.imus[sensor] = io::ReadImuSensorYaml(path);
        break;
      case io::SensorKind::kGps:
        options.gps[sensor] = io::ReadGpsSensorYaml(path);
        break;
      case io::SensorKind::kMag:
        options.mags[sensor] = io::ReadMagSensorYaml(path);
        break;
    }
    options.sensor_yaml_files[sensor] = path;  // copied into the session as it is
  }
  // Kalibr results: each camera of the chain (intrinsics, distortion, T_BS, image times moved
  // by timeshift_cam_imu onto the IMU clock) and imu0's noise; --sensor-yaml for the same
  // sensor is a conflict.
  if (!args.kalibr_camchain.empty() || !args.kalibr_imu.empty()) {
    const io::KalibrCalibration kalibr = io::ReadKalibr(args.kalibr_camchain, args.kalibr_imu);
    for (const io::KalibrCamera& camera : kalibr.cameras) {
      const std::string& name = camera.sensor.name;
      if (!options.cameras.emplace(name, camera.sensor).second) {
        throw InputError("--kalibr-camchain", 0, name + " is also given with --sensor-yaml");
      }
      options.camera_time_shift_ns[name] = camera.time_shift_ns;
    }
    if (kalibr.imu && !options.imus.emplace("imu0", kalibr.imu->sensor).second) {
      throw InputError("--kalibr-imu", 0, "imu0 is also given with --sensor-yaml");
    }
  }
  const io::BagImportSummary summary = io::ImportBag(options);
  return Report(io::FormatBagImportSummary(summary), summary.session_folder,
                summary.field_sessions_updated);
}

// --images: a folder of JPEGs with EXIF time and GPS (cam0/ + gps0/, no IMU).
int RunImagesImport(const ImportArgs& args) {
  if (!args.options.pos_path.empty() || !args.options.imu_path.empty() || !args.euroc.empty()) {
    throw InputError("--images", 0,
                     "takes time and GPS from the EXIF tags: leave out --pos, --imu and --euroc");
  }
  if (!args.camera_yaml.empty() && !args.kalibr_camchain.empty()) {
    throw InputError("--camera-yaml", 0, "give --camera-yaml or --kalibr-camchain, not both");
  }
  io::ExifImportOptions options;
  options.image_folder = args.images;
  options.field_folder = args.options.field_folder;
  options.session_id = args.options.session_id;
  options.field_name = args.options.field_name;
  options.notes = args.options.notes;
  options.overwrite = args.options.overwrite;
  options.origin = ParseOrigin(args.origin);
  if (!args.antenna.empty()) {
    options.antenna_in_body = ParseNumbers(args.antenna, "--antenna", 3, "x,y,z in metres");
  }
  options.gps_kind = ParseGpsKindOption(args.gps_kind);
  if (!args.gps_sigma.empty()) {
    const Eigen::Vector3d v = ParseNumbers(args.gps_sigma, "--gps-sigma", 1, "H[,V] in metres");
    options.sigma_h = v.x();
    if (v.y() != 0.0) options.sigma_v = v.y();
  }
  if (!args.time_zone.empty()) {
    int seconds = 0;
    if (!io::ParseUtcOffset(args.time_zone, &seconds)) {
      throw InputError("--time-zone", 0,
                       "'" + args.time_zone + "' is not a UTC offset (+HH:MM, -HH:MM or Z)");
    }
    options.utc_offset_s = seconds;
  }
  if (!args.camera_yaml.empty()) {
    options.camera = io::ReadCameraSensorYaml(args.camera_yaml);
    options.camera_source = args.camera_yaml;
  }
  if (!args.kalibr_camchain.empty() || !args.kalibr_imu.empty()) {
    const io::KalibrCalibration kalibr = io::ReadKalibr(args.kalibr_camchain, args.kalibr_imu);
    if (const io::KalibrCamera* cam0 = kalibr.FindCamera("cam0")) {
      options.camera = cam0->sensor;
      options.camera_source = args.kalibr_camchain + " (Kalibr cam0)";
      options.camera_time_shift_ns = cam0->time_shift_ns;
    }
  }
  const io::ExifImportSummary summary = io::ImportExifFolder(options);
  return Report(io::FormatExifImportSummary(summary), summary.session_folder,
                summary.field_sessions_updated);
}

int RunImport(const ImportArgs& args) {
  if (!args.images.empty()) return RunImagesImport(args);
  if (!args.euroc.empty()) return RunEurocImport(args);
  if (!args.bag.empty()) return RunBagImport(args);
  if (!args.kalibr_camchain.empty() || !args.kalibr_imu.empty() || !args.camera_yaml.empty() ||
      !args.time_zone.empty() || !args.gps_sigma.empty()) {
    throw InputError("--kalibr-camchain", 0,
                     "--kalibr-camchain, --kalibr-imu, --camera-yaml, --time-zone and --gps-sigma "
                     "apply to --images (and the Kalibr files to --euroc), not to --pos / --imu");
  }
  if (args.options.session_id.empty()) {
    throw InputError("--session", 0, "the session's folder name is required (a date is good)");
  }
  io::SessionImporter::Options options = args.options;
  options.origin = ParseOrigin(args.origin);
  options.gps_kind = ParseGpsKindOption(args.gps_kind);
  if (!args.antenna.empty()) {
    options.antenna_in_body = ParseNumbers(args.antenna, "--antenna", 3, "x,y,z in metres");
  }
  if (!args.imu_rpy_deg.empty()) {
    options.imu_rpy_deg =
        ParseNumbers(args.imu_rpy_deg, "--imu-rpy-deg", 3, "roll,pitch,yaw in degrees");
  }
  if (!args.imu_position.empty()) {
    options.imu_position_in_body =
        ParseNumbers(args.imu_position, "--imu-position", 3, "x,y,z in metres");
  }
  options.imu.columns = io::ParseImuColumns(args.imu_columns);
  options.imu.time_unit = io::ParseImuTimeUnit(args.imu_time_unit);
  options.imu.accel_unit = io::ParseAccelUnit(args.accel_unit);
  options.imu.gyro_unit = io::ParseGyroUnit(args.gyro_unit);
  options.imu.delimiter = io::ParseDelimiter(args.imu_delimiter);
  if (!io::ParseDecimalScaled(args.imu_time_offset, kNanosPerSecond, &options.imu.time_offset_ns)) {
    throw InputError("--imu-time-offset", 0,
                     "'" + args.imu_time_offset + "' is not a number of seconds");
  }
  if (args.imu_time_scale == "pos") {
    options.imu_time_scale = io::ImuTimeScale::kSameAsPos;
  } else if (args.imu_time_scale == "gpst") {
    options.imu_time_scale = io::ImuTimeScale::kGpst;
  } else if (args.imu_time_scale == "utc") {
    options.imu_time_scale = io::ImuTimeScale::kUtc;
  } else {
    throw InputError(
        "--imu-time-scale", 0,
        "unknown time scale '" + args.imu_time_scale + "' (expected pos, gpst or utc)");
  }

  const io::SessionImporter::Summary summary = io::SessionImporter(options).Run();
  return Report(io::FormatImportSummary(summary), summary.session_folder,
                summary.field_sessions_updated);
}

}  // namespace

RunFunction SetupImport(CLI::App& app) {
  auto args = std::make_shared<ImportArgs>();
  io::SessionImporter::Options& o = args->options;
  app.description(
      "Make a session of the crop4d dataset format (docs/format.md) from an RTKLIB solution "
      "file (.pos, → gps0/) and an IMU text file with a column and unit mapping (→ imu0/). "
      "Creates the field folder (field.yaml with the origin and no rows) or adds the session "
      "to an existing field. A session without rows is processed as one pass. Or, with --euroc, "
      "an EuRoC / ASL sequence (cam*/ and imu*/ verbatim, its ground truth for crop4d eval; no "
      "GPS).\n"
      "Timestamps keep the input's time scale (GPST stays GPST) unless --leap-seconds converts "
      "GPST to UTC. RTKLIB Q → NMEA fix: 1 fix→4, 2 float→5, 3 sbas→2, 4 dgps→2, 5 single→1, "
      "6 ppp→2. sigma_h = sqrt((sdn²+sde²)/2), sigma_v = sdu. See docs/import.md.\n"
      "Exit code: 0 when the session was written, 2 on bad input (nothing written).");
  app.add_option("--out", o.field_folder, "The field folder to create or add the session to")
      ->required()
      ->type_name("FIELD");
  app.add_option("--session", o.session_id,
                 "Session folder name under sessions/ (a date, YYYY-MM-DD..., is a good choice; "
                 "required except with --euroc, where the first IMU sample's date is the default)")
      ->type_name("ID");
  app.add_option("--euroc", args->euroc,
                 "Import an EuRoC / ASL sequence as it is: its mav0/ folder or the folder above "
                 "(camera and IMU folders verbatim, ground truth into ground_truth/; no GPS: a new "
                 "field's origin is 0,0,0 unless --origin)")
      ->type_name("PATH");
  const char* bag_group = "ROS 1 bag (--bag)";
  app.add_option("--bag", args->bag,
                 "Import a ROS 1 bag (plain, bz2 or lz4): sensor_msgs/Image and CompressedImage "
                 "-> cam<N>/, Imu -> imu<N>/, NavSatFix -> gps<N>/, MagneticField -> mag<N>/ "
                 "(session id default: the date of the first stamp)")
      ->type_name("FILE")
      ->group(bag_group);
  app.add_option("--topic", args->bag_topics,
                 "Which topic feeds which sensor folder, repeatable: cam0=/camera/image_raw, "
                 "imu0=/imu/data, gps0=/fix, mag0=/mag, cam0_info=/camera/camera_info (default: "
                 "the bag's only topic of a sensor's types)")
      ->type_name("SENSOR=TOPIC")
      ->group(bag_group);
  app.add_option("--stamp", args->bag_stamp,
                 "Sample times: header (header.stamp) or receive (the bag's record time)")
      ->capture_default_str()
      ->group(bag_group);
  app.add_option("--sensor-yaml", args->sensor_yamls,
                 "Calibration of a sensor as a crop4d sensor.yaml, repeatable: cam0=FILE; "
                 "a camera without one uses the bag's CameraInfo")
      ->type_name("SENSOR=FILE")
      ->group(bag_group);
  const char* images_group = "Image folder with EXIF time and GPS (--images)";
  app.add_option("--images", args->images,
                 "Import a folder of JPEGs (phone, action camera, drone) as cam0/ + gps0/ (no "
                 "IMU): time from DateTimeOriginal + SubSecTimeOriginal, GPS from EXIF GPSInfo; "
                 "session id default: the date of the first image (docs/import.md)")
      ->type_name("DIR")
      ->group(images_group);
  app.add_option("--camera-yaml", args->camera_yaml,
                 "cam0 calibration in crop4d's sensor.yaml format (default: a starting value "
                 "from the EXIF focal length)")
      ->type_name("FILE")
      ->group(images_group);
  app.add_option("--time-zone", args->time_zone,
                 "UTC offset of the camera clock for images without OffsetTimeOriginal, e.g. "
                 "+02:00 (default: from the GPS date/time stamps, else an error)")
      ->type_name("+HH:MM")
      ->group(images_group);
  app.add_option("--gps-sigma", args->gps_sigma,
                 "1-sigma of images without GPSHPositioningError, metres: H[,V] (default 5,10; "
                 "0.02,0.04 with --gps-kind rtk; V default 2 H)")
      ->type_name("H[,V]")
      ->group(images_group);
  const char* kalibr_group = "Kalibr calibration (with --euroc, --images or --bag)";
  app.add_option("--kalibr-camchain", args->kalibr_camchain,
                 "Kalibr camchain-imucam.yaml: intrinsics, radtan distortion, T_BS = T_cam_imu^-1; "
                 "image times + timeshift_cam_imu (onto the IMU clock)")
      ->type_name("FILE")
      ->group(kalibr_group);
  app.add_option("--kalibr-imu", args->kalibr_imu,
                 "Kalibr imu.yaml: IMU noise densities and random walks (and T_i_b)")
      ->type_name("FILE")
      ->group(kalibr_group);
  app.add_option("--name", o.field_name, "Field name for a new field.yaml (default: folder name)");
  app.add_option("--notes", o.notes, "Free text for session.yaml's notes");
  app.add_flag("--overwrite", o.overwrite,
               "Replace the imported files of an existing session instead of refusing");

  // GNSS.
  app.add_option("--pos", o.pos_path, "RTKLIB solution file (.pos) for gps0/")
      ->type_name("FILE")
      ->group("GNSS (RTKLIB .pos)");
  app.add_option("--leap-seconds", o.pos.leap_seconds,
                 "Convert GPS time to UTC: subtract N s (GPST−UTC, 18 since 2017) from the GPST "
                 ".pos times and from GPST IMU times (default 0: keep GPST)")
      ->capture_default_str()
      ->check(CLI::Range(-100, 100))
      ->type_name("N")
      ->group("GNSS (RTKLIB .pos)");
  app.add_flag("--skip-bad-lines", o.pos.skip_bad_lines,
               "Skip malformed .pos lines with a warning (default: stop with an error naming "
               "the line)")
      ->group("GNSS (RTKLIB .pos)");
  app.add_option("--gps-kind", args->gps_kind,
                 "Receiver kind written to gps0/sensor.yaml: auto (rtk when any epoch is RTK "
                 "fixed or float), rtk or standard")
      ->capture_default_str()
      ->group("GNSS (RTKLIB .pos)");
  app.add_option("--antenna", args->antenna,
                 "GNSS antenna phase centre in the body frame, metres (default 0,0,0)")
      ->type_name("X,Y,Z")
      ->group("GNSS (RTKLIB .pos)");
  app.add_option("--origin", args->origin,
                 "Origin of a new field's ENU frame, degrees and ellipsoidal metres (default: "
                 "the first GNSS epoch with a fix)")
      ->type_name("LAT,LON,ALT")
      ->group("GNSS (RTKLIB .pos)");

  // IMU.
  const char* imu_group = "IMU (text file with a column and unit mapping)";
  app.add_option("--imu", o.imu_path, "IMU text file for imu0/")
      ->type_name("FILE")
      ->group(imu_group);
  app.add_option("--imu-columns", args->imu_columns,
                 "What each column holds: t, ax, ay, az, gx, gy, gz; _ or skip ignores one; a "
                 "last ... ignores any further columns")
      ->capture_default_str()
      ->type_name("LIST")
      ->group(imu_group);
  app.add_option("--imu-time-unit", args->imu_time_unit,
                 "Unit of the time column, counted from the Unix epoch: s, ms, us or ns")
      ->capture_default_str()
      ->group(imu_group);
  app.add_option("--accel-unit", args->accel_unit, "Accelerometer unit: g or mps2 (m/s^2)")
      ->capture_default_str()
      ->group(imu_group);
  app.add_option("--gyro-unit", args->gyro_unit, "Gyro unit: rads (rad/s) or degs (deg/s)")
      ->capture_default_str()
      ->group(imu_group);
  app.add_option("--imu-header-lines", o.imu.header_lines,
                 "Lines to skip at the start of the IMU file ('#' and '%' lines are skipped "
                 "anyway)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber)
      ->group(imu_group);
  app.add_option("--imu-delimiter", args->imu_delimiter,
                 "Field separator: auto, comma, semicolon, tab or space")
      ->capture_default_str()
      ->group(imu_group);
  app.add_option("--imu-time-offset", args->imu_time_offset,
                 "Seconds added to every IMU timestamp (a known latency or clock offset)")
      ->capture_default_str()
      ->type_name("S")
      ->group(imu_group);
  app.add_option("--imu-time-scale", args->imu_time_scale,
                 "Time scale of the IMU timestamps, for --leap-seconds: pos (that of the .pos "
                 "file), gpst or utc")
      ->capture_default_str()
      ->group(imu_group);
  app.add_option("--imu-rpy-deg", args->imu_rpy_deg,
                 "IMU mounting in the body frame, degrees: T_BS rotation = Rz(yaw) Ry(pitch) "
                 "Rx(roll); samples stay in the IMU frame (default 0,0,0)")
      ->type_name("R,P,Y")
      ->group(imu_group);
  app.add_option("--imu-position", args->imu_position,
                 "IMU position in the body frame, metres (T_BS translation; default 0,0,0)")
      ->type_name("X,Y,Z")
      ->group(imu_group);
  app.add_option("--gyro-noise", o.gyroscope_noise_density,
                 "Gyro noise density, rad/s/sqrt(Hz) (default: generic consumer MEMS)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber)
      ->group(imu_group);
  app.add_option("--gyro-walk", o.gyroscope_random_walk, "Gyro bias random walk, rad/s^2/sqrt(Hz)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber)
      ->group(imu_group);
  app.add_option("--accel-noise", o.accelerometer_noise_density,
                 "Accelerometer noise density, m/s^2/sqrt(Hz)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber)
      ->group(imu_group);
  app.add_option("--accel-walk", o.accelerometer_random_walk,
                 "Accelerometer bias random walk, m/s^3/sqrt(Hz)")
      ->capture_default_str()
      ->check(CLI::NonNegativeNumber)
      ->group(imu_group);
  return [args] { return RunImport(*args); };
}

}  // namespace crop4d::cli
