#include "crop4d/io/dataset_reader.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <set>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/io/yaml_util.h"

namespace crop4d::io {
namespace fs = std::filesystem;
namespace {

using Need = YamlMap::Need;

std::string JoinPath(const std::string& a, const std::string& b) {
  return (fs::path(a) / b).string();
}

std::string FolderName(const std::string& file_path) {
  return fs::path(file_path).parent_path().filename().string();
}

// With a collector, an InputError is recorded (duplicates are dropped) and reading goes on;
// without one, it propagates.
void ReportOrRethrow(const InputError& e, Diagnostics* diag) {
  if (diag == nullptr) throw e;
  diag->Error(e.file(), e.line(), e.message());
}

// T_BS: {cols: 4, rows: 4, data: [16 numbers, row-major]}, a rigid transform.
void ReadTbs(YamlMap& map, geometry::Rigid3* body_from_sensor, Need need) {
  std::optional<YamlMap> tbs = map.GetMap("T_BS", need);
  if (!tbs) return;
  YamlFile* file = tbs->file();
  int rows = 4, cols = 4;
  tbs->Get("rows", &rows, Need::kOptional);
  tbs->Get("cols", &cols, Need::kOptional);
  if (rows != 4 || cols != 4) {
    file->Error(tbs->line(),
                fmt::format("T_BS: expected a 4x4 matrix, found rows: {}, cols: {}", rows, cols));
  }
  std::vector<double> data;
  if (tbs->Get("data", &data, 16, 16, Need::kRequired) && rows == 4 && cols == 4) {
    const Eigen::Matrix4d m =
        Eigen::Map<const Eigen::Matrix<double, 4, 4, Eigen::RowMajor>>(data.data());
    const std::int64_t line = tbs->LineOf("data");
    if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
      file->Error(line, "T_BS: the last row must be [0, 0, 0, 1]");
    } else {
      const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
      const double orthogonality =
          (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
      if (orthogonality > 1e-3 || r.determinant() <= 0) {
        file->Error(line, fmt::format("T_BS: the rotation block is not a rotation matrix "
                                      "(|R^T R - I| = {:.2g}, det = {:.3g})",
                                      orthogonality, r.determinant()));
      } else {
        *body_from_sensor = geometry::Rigid3::FromMatrix(m);
      }
    }
  }
  tbs->WarnUnknownKeys();
}

// sensor_type and comment, common to every sensor.yaml.
void ReadCommonKeys(YamlMap& map, SensorKind kind) {
  std::string type;
  if (map.Get("sensor_type", &type, Need::kOptional)) {
    const std::optional<SensorKind> named = SensorKindFromType(type);
    if (!named || *named != kind) {
      map.file()->Warning(map.LineOf("sensor_type"),
                          fmt::format("sensor_type '{}' does not match the folder, a {} sensor",
                                      type, SensorKindName(kind)));
    }
  }
  std::string comment;
  map.Get("comment", &comment, Need::kOptional);
}

void ReadRate(YamlMap& map, double* rate_hz, Need need) {
  double rate = *rate_hz;
  if (!map.Get("rate_hz", &rate, need)) return;
  if (rate <= 0) {
    map.file()->Error(map.LineOf("rate_hz"),
                      fmt::format("rate_hz must be positive, found {}", rate));
    return;
  }
  *rate_hz = rate;
}

void ReadNonNegative(YamlMap& map, const char* key, double* value) {
  double x = 0;
  if (!map.Get(key, &x, Need::kRequired)) return;
  if (x < 0) {
    map.file()->Error(map.LineOf(key), fmt::format("{} must not be negative, found {}", key, x));
    return;
  }
  if (x == 0) {
    map.file()->Warning(map.LineOf(key),
                        fmt::format("{} is 0: the sensor would be trusted without limit", key));
  }
  *value = x;
}

}  // namespace

std::optional<Timestamp> DateFromSessionId(const std::string& id) {
  if (id.size() < 10) return std::nullopt;
  if (id.size() > 10 && std::isdigit(static_cast<unsigned char>(id[10]))) return std::nullopt;
  Timestamp t = 0;
  if (!ParseDate(id.substr(0, 10), &t)) return std::nullopt;
  return t;
}

// ---- field.yaml ------------------------------------------------------------------------------

FieldInfo ReadFieldYaml(const std::string& path, Diagnostics* diag) {
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  FieldInfo field;
  field.name = FolderName(path);
  root.Get("name", &field.name, Need::kOptional);

  bool origin_ok = false;
  if (std::optional<YamlMap> origin = root.GetMap("origin", Need::kRequired)) {
    const bool lat_ok = origin->Get("lat", &field.origin.lat_deg, Need::kRequired);
    const bool lon_ok = origin->Get("lon", &field.origin.lon_deg, Need::kRequired);
    origin->Get("alt", &field.origin.alt_m, Need::kOptional);
    origin_ok = lat_ok && lon_ok;
    if (lat_ok && std::abs(field.origin.lat_deg) > 90.0) {
      file.Error(origin->LineOf("lat"), "origin.lat must be within [-90, 90]");
      origin_ok = false;
    }
    if (lon_ok && std::abs(field.origin.lon_deg) > 180.0) {
      file.Error(origin->LineOf("lon"), "origin.lon must be within [-180, 180]");
      origin_ok = false;
    }
    origin->WarnUnknownKeys();
  }

  const YAML::Node rows = root.GetSequence("rows", Need::kOptional);
  std::set<int> row_indices;
  for (std::size_t i = 0; rows.IsDefined() && i < rows.size(); ++i) {
    YamlMap row(&file, rows[i], fmt::format("rows[{}]", i), root.LineOf("rows"));
    RowDeclaration declaration;
    std::vector<double> start, end;
    const bool index_ok = row.Get("index", &declaration.index, Need::kRequired);
    const bool start_ok = row.Get("start", &start, 2, 2, Need::kRequired);
    const bool end_ok = row.Get("end", &end, 2, 2, Need::kRequired);
    const bool ok = index_ok && start_ok && end_ok;
    row.WarnUnknownKeys();
    if (!ok) continue;
    declaration.start_enu = Eigen::Vector2d(start[0], start[1]);
    declaration.end_enu = Eigen::Vector2d(end[0], end[1]);
    if (!row_indices.insert(declaration.index).second) {
      file.Error(row.line(), fmt::format("row index {} is declared twice", declaration.index));
      continue;
    }
    if ((declaration.end_enu - declaration.start_enu).norm() < 1e-6) {
      file.Error(row.line(),
                 fmt::format("row {}: start and end are the same point", declaration.index));
      continue;
    }
    field.rows.push_back(declaration);
  }

  const YAML::Node sites = root.GetSequence("sites", Need::kOptional);
  std::set<std::string> site_ids;
  for (std::size_t i = 0; sites.IsDefined() && i < sites.size(); ++i) {
    YamlMap map(&file, sites[i], fmt::format("sites[{}]", i), root.LineOf("sites"));
    Site site;
    bool ok = map.Get("id", &site.id, Need::kRequired);
    if (map.Get("radius", &site.radius_m, Need::kOptional) && site.radius_m <= 0) {
      file.Error(map.LineOf("radius"), "site radius must be positive");
      ok = false;
    }
    const bool has_enu = map.Has("x") || map.Has("y");
    const bool has_geo = map.Has("lat") || map.Has("lon");
    if (has_enu && has_geo) {
      file.Error(map.line(), "site '" + site.id + "': give either x, y or lat, lon, not both");
      ok = false;
    } else if (has_geo) {
      geometry::GeodeticPoint point;
      point.alt_m = field.origin.alt_m;
      const bool lat_ok = map.Get("lat", &point.lat_deg, Need::kRequired);
      const bool lon_ok = map.Get("lon", &point.lon_deg, Need::kRequired);
      ok = ok && lat_ok && lon_ok;
      if (ok && (std::abs(point.lat_deg) > 90.0 || std::abs(point.lon_deg) > 180.0)) {
        file.Error(map.line(), "site '" + site.id + "': lat/lon out of range");
        ok = false;
      }
      if (ok && origin_ok) {
        site.center_enu = geometry::LocalEnu(field.origin).ToEnu(point).head<2>();
      }
    } else {
      double x = 0, y = 0;
      const bool x_ok = map.Get("x", &x, Need::kRequired);
      const bool y_ok = map.Get("y", &y, Need::kRequired);
      ok = ok && x_ok && y_ok;
      site.center_enu = Eigen::Vector2d(x, y);
    }
    map.WarnUnknownKeys();
    if (!ok) continue;
    if (!site_ids.insert(site.id).second) {
      file.Error(map.line(), "site id '" + site.id + "' is declared twice");
      continue;
    }
    field.sites.push_back(site);
  }

  const YAML::Node sessions = root.GetSequence("sessions", Need::kOptional);
  std::set<std::string> session_ids;
  for (std::size_t i = 0; sessions.IsDefined() && i < sessions.size(); ++i) {
    const YAML::Node item = sessions[i];
    if (!item.IsScalar() || item.Scalar().empty()) {
      file.Error(YamlLine(item) ? YamlLine(item) : root.LineOf("sessions"),
                 fmt::format("sessions[{}]: expected a session folder name", i));
      continue;
    }
    const std::string& id = item.Scalar();
    if (id.find('/') != std::string::npos || id == "." || id == "..") {
      file.Error(YamlLine(item), "sessions: '" + id + "' is not a folder name");
      continue;
    }
    if (!session_ids.insert(id).second) {
      file.Error(YamlLine(item), "session '" + id + "' is listed twice");
      continue;
    }
    field.sessions.push_back(id);
  }
  root.WarnUnknownKeys();
  file.Finish();
  return field;
}

// ---- session.yaml ----------------------------------------------------------------------------

SessionInfo ReadSessionYaml(const std::string& path, const std::string& id, Diagnostics* diag) {
  SessionInfo info;
  info.id = id;
  const std::optional<Timestamp> id_date = DateFromSessionId(id);
  std::error_code ec;
  if (!fs::exists(path, ec) && id_date) {
    info.date = *id_date;  // session.yaml is optional when the folder name is the date
    return info;
  }
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  std::string date_text;
  if (root.Get("date", &date_text, Need::kOptional)) {
    Timestamp date = 0;
    if (!ParseDate(date_text, &date)) {
      file.Error(root.LineOf("date"), "date '" + date_text + "' is not a date (YYYY-MM-DD)");
    } else {
      info.date = date;
      if (id_date && *id_date != date) {
        file.Warning(root.LineOf("date"),
                     "date " + date_text + " differs from the session folder name '" + id + "'");
      }
    }
  } else if (id_date) {
    info.date = *id_date;
  } else {
    file.Error(root.line(),
               "missing required key 'date' (the session folder name '" + id + "' is not a date)");
  }
  root.Get("notes", &info.notes, Need::kOptional);
  root.Get("rain_before", &info.rain_before, Need::kOptional);
  root.WarnUnknownKeys();
  file.Finish();
  return info;
}

// ---- sensor.yaml -----------------------------------------------------------------------------

CameraSensor ReadCameraSensorYaml(const std::string& path, Diagnostics* diag) {
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  CameraSensor sensor;
  sensor.name = FolderName(path);
  ReadCommonKeys(root, SensorKind::kCamera);
  ReadTbs(root, &sensor.body_from_sensor, Need::kRequired);
  ReadRate(root, &sensor.rate_hz, Need::kRequired);
  double height = 0;
  if (root.Get("height_above_ground_m", &height, Need::kOptional)) {
    if (height > 0 && height < 100) {
      sensor.height_above_ground_m = height;
    } else {
      file.Error(root.LineOf("height_above_ground_m"),
                 fmt::format("height_above_ground_m must be in (0, 100) m, found {}", height));
    }
  }
  geometry::PinholeRadTan& camera = sensor.camera;

  std::vector<double> resolution;
  if (root.Get("resolution", &resolution, 2, 2, Need::kRequired)) {
    if (resolution[0] < 1 || resolution[1] < 1 || resolution[0] != std::floor(resolution[0]) ||
        resolution[1] != std::floor(resolution[1]) || resolution[0] > 1e5 || resolution[1] > 1e5) {
      file.Error(root.LineOf("resolution"), "resolution must be two positive integers [w, h]");
    } else {
      camera.width = static_cast<int>(resolution[0]);
      camera.height = static_cast<int>(resolution[1]);
    }
  }
  std::string model = "pinhole";
  root.Get("camera_model", &model, Need::kOptional);
  if (model != "pinhole") {
    file.Error(root.LineOf("camera_model"),
               "camera_model '" + model + "' is not supported (crop4d reads 'pinhole')");
  }
  std::vector<double> intrinsics;
  if (root.Get("intrinsics", &intrinsics, 4, 4, Need::kRequired)) {
    if (intrinsics[0] <= 0 || intrinsics[1] <= 0) {
      file.Error(root.LineOf("intrinsics"), "intrinsics: focal lengths fu, fv must be positive");
    } else {
      camera.fx = intrinsics[0];
      camera.fy = intrinsics[1];
      camera.cx = intrinsics[2];
      camera.cy = intrinsics[3];
    }
  }
  std::string distortion = "radial-tangential";
  root.Get("distortion_model", &distortion, Need::kOptional);
  const bool radtan =
      distortion == "radial-tangential" || distortion == "radtan" || distortion == "plumb_bob";
  if (!radtan && distortion != "none") {
    file.Error(root.LineOf("distortion_model"),
               "distortion_model '" + distortion +
                   "' is not supported (crop4d reads 'radial-tangential' or 'none')");
  }
  std::vector<double> coefficients;
  if (root.Get("distortion_coefficients", &coefficients, 4, 5,
               radtan ? Need::kRequired : Need::kOptional)) {
    camera.k1 = coefficients[0];
    camera.k2 = coefficients[1];
    camera.p1 = coefficients[2];
    camera.p2 = coefficients[3];
    camera.k3 = coefficients.size() > 4 ? coefficients[4] : 0.0;
  }
  root.WarnUnknownKeys();
  file.Finish();
  return sensor;
}

ImuSensor ReadImuSensorYaml(const std::string& path, Diagnostics* diag) {
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  ImuSensor sensor;
  sensor.name = FolderName(path);
  ReadCommonKeys(root, SensorKind::kImu);
  ReadTbs(root, &sensor.body_from_sensor, Need::kRequired);
  ReadRate(root, &sensor.rate_hz, Need::kRequired);
  ReadNonNegative(root, "gyroscope_noise_density", &sensor.gyroscope_noise_density);
  ReadNonNegative(root, "gyroscope_random_walk", &sensor.gyroscope_random_walk);
  ReadNonNegative(root, "accelerometer_noise_density", &sensor.accelerometer_noise_density);
  ReadNonNegative(root, "accelerometer_random_walk", &sensor.accelerometer_random_walk);
  root.WarnUnknownKeys();
  file.Finish();
  return sensor;
}

MagSensor ReadMagSensorYaml(const std::string& path, Diagnostics* diag) {
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  MagSensor sensor;
  sensor.name = FolderName(path);
  ReadCommonKeys(root, SensorKind::kMag);
  ReadTbs(root, &sensor.body_from_sensor, Need::kOptional);
  ReadRate(root, &sensor.rate_hz, Need::kOptional);
  root.WarnUnknownKeys();
  file.Finish();
  return sensor;
}

GpsSensor ReadGpsSensorYaml(const std::string& path, Diagnostics* diag) {
  YamlFile file(path, diag);
  YamlMap root = file.Root();
  GpsSensor sensor;
  sensor.name = FolderName(path);
  ReadCommonKeys(root, SensorKind::kGps);
  std::string kind;
  if (root.Get("kind", &kind, Need::kRequired)) {
    if (const std::optional<GpsKind> parsed = ParseGpsKind(kind)) {
      sensor.kind = *parsed;
    } else {
      file.Error(root.LineOf("kind"), "kind '" + kind + "' is not 'rtk' or 'standard'");
    }
  }
  if (sensor.kind == GpsKind::kStandard) {
    // Typical of a single-frequency receiver without corrections.
    sensor.default_sigma_h = 2.5;
    sensor.default_sigma_v = 5.0;
  }
  ReadRate(root, &sensor.rate_hz, Need::kOptional);
  std::vector<double> antenna;
  if (root.Get("p_B_antenna", &antenna, 3, 3, Need::kRequired)) {
    sensor.antenna_in_body = Eigen::Vector3d(antenna[0], antenna[1], antenna[2]);
  }
  for (auto [key, value] : {std::pair{"sigma_h", &sensor.default_sigma_h},
                            std::pair{"sigma_v", &sensor.default_sigma_v}}) {
    double sigma = 0;
    if (root.Get(key, &sigma, Need::kOptional)) {
      if (sigma <= 0) {
        file.Error(root.LineOf(key), fmt::format("{} must be positive, found {}", key, sigma));
      } else {
        *value = sigma;
      }
    }
  }
  root.WarnUnknownKeys();
  file.Finish();
  return sensor;
}

std::vector<SensorFolder> ListSensorFolders(const std::string& session_folder, Diagnostics* diag) {
  std::vector<SensorFolder> sensors;
  std::error_code ec;
  fs::directory_iterator it(session_folder, ec);
  if (ec) throw InputError(session_folder, 0, "cannot list the session folder: " + ec.message());
  for (const fs::directory_entry& entry : it) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory(ec) || name.empty() || name.front() == '.') continue;
    if (const std::optional<SensorKind> kind = SensorKindFromFolder(name)) {
      sensors.push_back({name, *kind});
    } else if (diag != nullptr) {
      diag->Warning(entry.path().string(), 0,
                    "not a sensor folder (cam*, imu*, mag*, gps*); ignored");
    } else {
      spdlog::debug("{}: not a sensor folder; ignored", entry.path().string());
    }
  }
  std::sort(sensors.begin(), sensors.end(),
            [](const SensorFolder& a, const SensorFolder& b) { return a.name < b.name; });
  return sensors;
}

// ---- Session ---------------------------------------------------------------------------------

Session::Session(std::string folder, Diagnostics* diag) : folder_(std::move(folder)) {
  while (folder_.size() > 1 && folder_.back() == '/') folder_.pop_back();
  const std::string id = fs::path(folder_).filename().string();
  std::error_code ec;
  if (!fs::is_directory(folder_, ec)) throw InputError(folder_, 0, "session folder not found");
  info_.id = id;
  try {
    info_ = ReadSessionYaml(JoinPath(folder_, kSessionYaml), id, diag);
  } catch (const InputError& e) {
    ReportOrRethrow(e, diag);
  }
  for (const SensorFolder& sensor : ListSensorFolders(folder_, diag)) {
    const std::string yaml = JoinPath(JoinPath(folder_, sensor.name), kSensorYaml);
    try {
      switch (sensor.kind) {
        case SensorKind::kCamera:
          cameras_.push_back(ReadCameraSensorYaml(yaml, diag));
          break;
        case SensorKind::kImu:
          imus_.push_back(ReadImuSensorYaml(yaml, diag));
          break;
        case SensorKind::kMag:
          if (fs::exists(yaml, ec)) {
            mags_.push_back(ReadMagSensorYaml(yaml, diag));
          } else {
            MagSensor mag;  // sensor.yaml is optional for a magnetometer
            mag.name = sensor.name;
            mags_.push_back(mag);
          }
          break;
        case SensorKind::kGps:
          gps_.push_back(ReadGpsSensorYaml(yaml, diag));
          break;
      }
    } catch (const InputError& e) {
      ReportOrRethrow(e, diag);
    }
  }
}

namespace {
template <typename T>
const T* FindByName(const std::vector<T>& sensors, const std::string& name) {
  for (const T& sensor : sensors) {
    if (sensor.name == name) return &sensor;
  }
  return nullptr;
}

template <typename T>
const T& Require(const T* sensor, const std::string& folder, const std::string& name,
                 const char* kind) {
  if (sensor == nullptr) {
    throw InputError(folder, 0, fmt::format("session has no {} '{}'", kind, name));
  }
  return *sensor;
}
}  // namespace

const CameraSensor* Session::FindCamera(const std::string& name) const {
  return FindByName(cameras_, name);
}
const ImuSensor* Session::FindImu(const std::string& name) const { return FindByName(imus_, name); }
const MagSensor* Session::FindMag(const std::string& name) const { return FindByName(mags_, name); }
const GpsSensor* Session::FindGps(const std::string& name) const { return FindByName(gps_, name); }

std::string Session::DataCsvPath(const std::string& sensor) const {
  return JoinPath(JoinPath(folder_, sensor), kDataCsv);
}

std::string Session::ImagePath(const std::string& camera, const std::string& filename) const {
  return JoinPath(JoinPath(JoinPath(folder_, camera), kImageFolder), filename);
}

DataFileStats Session::ForEachImageEntry(const std::string& camera,
                                         const std::function<void(const ImageEntry&)>& callback,
                                         Diagnostics* diag) const {
  Require(FindCamera(camera), folder_, camera, "camera");
  return ReadImageCsv(
      DataCsvPath(camera), [&](const ImageEntry& e, std::int64_t) { callback(e); }, diag);
}

DataFileStats Session::ForEachImuSample(const std::string& imu,
                                        const std::function<void(const ImuSample&)>& callback,
                                        Diagnostics* diag) const {
  Require(FindImu(imu), folder_, imu, "IMU");
  return ReadImuCsv(
      DataCsvPath(imu), [&](const ImuSample& s, std::int64_t) { callback(s); }, diag);
}

DataFileStats Session::ForEachMagSample(const std::string& mag,
                                        const std::function<void(const MagSample&)>& callback,
                                        Diagnostics* diag) const {
  Require(FindMag(mag), folder_, mag, "magnetometer");
  return ReadMagCsv(
      DataCsvPath(mag), [&](const MagSample& s, std::int64_t) { callback(s); }, diag);
}

DataFileStats Session::ForEachGpsSample(const std::string& gps,
                                        const std::function<void(const GpsSample&)>& callback,
                                        Diagnostics* diag) const {
  const GpsSensor& sensor = Require(FindGps(gps), folder_, gps, "GPS receiver");
  return ReadGpsCsv(
      DataCsvPath(gps),
      [&](const GpsSample& s, std::int64_t) {
        GpsSample sample = s;
        if (sample.sigma_h <= 0) sample.sigma_h = sensor.default_sigma_h;
        if (sample.sigma_v <= 0) sample.sigma_v = sensor.default_sigma_v;
        callback(sample);
      },
      diag);
}

std::vector<ImageEntry> Session::ReadImageList(const std::string& camera, Diagnostics* diag) const {
  std::vector<ImageEntry> out;
  ForEachImageEntry(
      camera, [&](const ImageEntry& e) { out.push_back(e); }, diag);
  return out;
}

std::vector<ImuSample> Session::ReadImu(const std::string& imu, Diagnostics* diag) const {
  std::vector<ImuSample> out;
  ForEachImuSample(
      imu, [&](const ImuSample& s) { out.push_back(s); }, diag);
  return out;
}

std::vector<MagSample> Session::ReadMag(const std::string& mag, Diagnostics* diag) const {
  std::vector<MagSample> out;
  ForEachMagSample(
      mag, [&](const MagSample& s) { out.push_back(s); }, diag);
  return out;
}

std::vector<GpsSample> Session::ReadGps(const std::string& gps, Diagnostics* diag) const {
  std::vector<GpsSample> out;
  ForEachGpsSample(
      gps, [&](const GpsSample& s) { out.push_back(s); }, diag);
  return out;
}

// ---- Field -----------------------------------------------------------------------------------

Field::Field(std::string folder, Diagnostics* diag) : folder_(std::move(folder)) {
  while (folder_.size() > 1 && folder_.back() == '/') folder_.pop_back();
  std::error_code ec;
  if (!fs::is_directory(folder_, ec)) {
    throw InputError(
        folder_, 0,
        fs::exists(folder_, ec) ? "is a file, expected a field folder" : "field folder not found");
  }
  info_.name = fs::path(folder_).filename().string();
  const std::string field_yaml = JoinPath(folder_, kFieldYaml);
  try {
    info_ = ReadFieldYaml(field_yaml, diag);
  } catch (const InputError& e) {
    ReportOrRethrow(e, diag);
  }

  const std::string sessions_folder = JoinPath(folder_, kSessionsFolder);
  std::vector<std::string> folders;
  fs::directory_iterator it(sessions_folder, ec);
  if (ec) {
    const InputError error(sessions_folder, 0,
                           fs::exists(sessions_folder) ? "cannot list: " + ec.message()
                                                       : "missing folder: a field keeps its "
                                                         "sessions in sessions/<id>/");
    ReportOrRethrow(error, diag);
    return;
  }
  for (const fs::directory_entry& entry : it) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory(ec) && !name.empty() && name.front() != '.') folders.push_back(name);
  }
  std::sort(folders.begin(), folders.end());
  if (info_.sessions.empty()) {
    session_ids_ = folders;
    return;
  }
  const std::set<std::string> present(folders.begin(), folders.end());
  const std::set<std::string> listed(info_.sessions.begin(), info_.sessions.end());
  for (const std::string& id : info_.sessions) {
    if (present.count(id) != 0) {
      session_ids_.push_back(id);
    } else {
      ReportOrRethrow(
          InputError(field_yaml, 0,
                     "session '" + id + "' is listed but sessions/" + id + "/ does not exist"),
          diag);
    }
  }
  for (const std::string& id : folders) {
    if (listed.count(id) != 0) continue;
    const std::string message = "session folder not listed in field.yaml 'sessions'; ignored";
    if (diag != nullptr) {
      diag->Warning(JoinPath(sessions_folder, id), 0, message);
    } else {
      spdlog::warn("{}", FormatLocation(JoinPath(sessions_folder, id), 0, message));
    }
  }
}

std::string Field::SessionFolder(const std::string& id) const {
  return JoinPath(JoinPath(folder_, kSessionsFolder), id);
}

Session Field::OpenSession(const std::string& id, Diagnostics* diag) const {
  return Session(SessionFolder(id), diag);
}

}  // namespace crop4d::io
