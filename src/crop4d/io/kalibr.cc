#include "crop4d/io/kalibr.h"

#include <fmt/format.h>

#include <Eigen/Core>
#include <Eigen/LU>
#include <cmath>
#include <regex>

#include "crop4d/core/error.h"
#include "crop4d/io/yaml_util.h"

namespace crop4d::io {
namespace {

using Need = YamlMap::Need;

// Tolerances of a rigid transform: as for sensor.yaml's T_BS (docs/format.md).
constexpr double kOrthonormalTolerance = 1e-3;
constexpr double kLastRowTolerance = 1e-9;

// A 4x4 matrix in Kalibr's layout: a list of 4 rows, each a list of 4 numbers. Reports a
// problem (naming the key) and returns false when the value is not that.
bool GetMatrix4(YamlMap& map, const char* key, Need need, Eigen::Matrix4d* matrix) {
  const YAML::Node node = map.GetSequence(key, need);
  if (!node.IsDefined()) return false;
  YamlFile* file = map.file();
  const std::int64_t line = map.LineOf(key);
  const std::string name = "key '" + map.KeyName(key) + "'";
  if (node.size() != 4) {
    file->Error(line, fmt::format("{}: expected a 4x4 matrix (4 rows of 4 numbers), found {} rows",
                                  name, node.size()));
    return false;
  }
  for (std::size_t r = 0; r < 4; ++r) {
    const YAML::Node row = node[r];
    const std::int64_t row_line = YamlLine(row) != 0 ? YamlLine(row) : line;
    if (!row.IsSequence() || row.size() != 4) {
      file->Error(
          row_line,
          fmt::format(
              "{}: expected a 4x4 matrix (4 rows of 4 numbers), row {} has {}", name, r + 1,
              row.IsSequence() ? fmt::format("{} numbers", row.size()) : std::string("no list")));
      return false;
    }
    for (std::size_t c = 0; c < 4; ++c) {
      double value = 0;
      if (!row[c].IsScalar() || !ParseYamlDouble(row[c].Scalar(), &value) ||
          !std::isfinite(value)) {
        file->Error(row_line, fmt::format("{}: row {}, column {} is not a finite number", name,
                                          r + 1, c + 1));
        return false;
      }
      (*matrix)(static_cast<int>(r), static_cast<int>(c)) = value;
    }
  }
  return true;
}

// Checks that `m` is a rigid transform; reports the problem (naming the key) otherwise.
bool CheckRigid(YamlMap& map, const char* key, const Eigen::Matrix4d& m) {
  const std::int64_t line = map.LineOf(key);
  const std::string name = "key '" + map.KeyName(key) + "'";
  if ((m.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > kLastRowTolerance) {
    map.file()->Error(line, name + ": not a rigid transform: the last row must be [0, 0, 0, 1]");
    return false;
  }
  const Eigen::Matrix3d r = m.topLeftCorner<3, 3>();
  const double orthonormality =
      (r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff();
  const double det = r.determinant();
  if (orthonormality > kOrthonormalTolerance || std::abs(det - 1.0) > kOrthonormalTolerance) {
    map.file()->Error(line, fmt::format("{}: not a rigid transform: the rotation block is not a "
                                        "rotation (|R^T R - I| = {:.2g}, det = {:.4g})",
                                        name, orthonormality, det));
    return false;
  }
  return true;
}

// One camN entry.
KalibrCamera ReadCamera(YamlMap& map, const std::string& name, std::int64_t line) {
  YamlFile* file = map.file();
  KalibrCamera camera;
  camera.line = line;
  camera.sensor.name = name;
  geometry::PinholeRadTan& model = camera.sensor.camera;

  std::string camera_model;
  if (map.Get("camera_model", &camera_model, Need::kRequired) && camera_model != "pinhole") {
    file->Error(map.LineOf("camera_model"),
                "key '" + map.KeyName("camera_model") + "': camera model '" + camera_model +
                    "' is not supported: crop4d's camera is a pinhole with radial-tangential "
                    "distortion (calibrate with Kalibr's pinhole-radtan or pinhole-none)");
  }
  std::vector<double> resolution;
  if (map.Get("resolution", &resolution, 2, 2, Need::kRequired)) {
    if (resolution[0] < 1 || resolution[1] < 1 || resolution[0] != std::floor(resolution[0]) ||
        resolution[1] != std::floor(resolution[1]) || resolution[0] > 1e5 || resolution[1] > 1e5) {
      file->Error(map.LineOf("resolution"),
                  "key '" + map.KeyName("resolution") + "': expected two positive integers [w, h]");
    } else {
      model.width = static_cast<int>(resolution[0]);
      model.height = static_cast<int>(resolution[1]);
    }
  }
  std::vector<double> intrinsics;
  if (map.Get("intrinsics", &intrinsics, 4, 4, Need::kRequired)) {
    const std::string key = "key '" + map.KeyName("intrinsics") + "'";
    if (intrinsics[0] <= 0 || intrinsics[1] <= 0) {
      file->Error(map.LineOf("intrinsics"),
                  key + ": the focal lengths fu, fv must be positive [fu, fv, pu, pv]");
    } else if (intrinsics[2] <= 0 || intrinsics[3] <= 0 ||
               (model.width > 0 &&
                (intrinsics[2] >= model.width || intrinsics[3] >= model.height))) {
      file->Error(map.LineOf("intrinsics"),
                  key + ": the principal point pu, pv must be positive and inside the image");
    } else {
      model.fx = intrinsics[0];
      model.fy = intrinsics[1];
      model.cx = intrinsics[2];
      model.cy = intrinsics[3];
    }
  }
  std::string distortion;
  map.Get("distortion_model", &distortion, Need::kRequired);
  const bool radtan = distortion == "radtan" || distortion == "radial-tangential";
  if (distortion == "equidistant") {
    file->Error(map.LineOf("distortion_model"),
                "key '" + map.KeyName("distortion_model") +
                    "': 'equidistant' (Kannala-Brandt fisheye) is not supported: crop4d has no "
                    "fisheye model, only radial-tangential (recalibrate with pinhole-radtan)");
  } else if (!radtan && distortion != "none" && !distortion.empty()) {
    file->Error(map.LineOf("distortion_model"),
                "key '" + map.KeyName("distortion_model") + "': '" + distortion +
                    "' is not supported (crop4d reads radtan or none)");
  }
  std::vector<double> coefficients;
  if (map.Get("distortion_coeffs", &coefficients, radtan ? 4 : 0, radtan ? 5 : 8,
              radtan ? Need::kRequired : Need::kOptional) &&
      radtan) {
    model.k1 = coefficients[0];
    model.k2 = coefficients[1];
    model.p1 = coefficients[2];
    model.p2 = coefficients[3];
    if (coefficients.size() == 5) model.k3 = coefficients[4];
  }

  Eigen::Matrix4d camera_from_imu;
  if (GetMatrix4(map, "T_cam_imu", Need::kRequired, &camera_from_imu) &&
      CheckRigid(map, "T_cam_imu", camera_from_imu)) {
    camera.sensor.body_from_sensor = geometry::Rigid3::FromMatrix(camera_from_imu).Inverse();
  }
  // The chain between consecutive cameras is implied by their T_cam_imu; it is checked for
  // being a rigid transform and otherwise not used.
  Eigen::Matrix4d camera_from_previous;
  if (GetMatrix4(map, "T_cn_cnm1", Need::kOptional, &camera_from_previous)) {
    CheckRigid(map, "T_cn_cnm1", camera_from_previous);
  }
  if (map.Get("timeshift_cam_imu", &camera.time_shift_s, Need::kOptional)) {
    if (std::abs(camera.time_shift_s) > 3600) {
      file->Error(map.LineOf("timeshift_cam_imu"),
                  fmt::format("key '{}': {} s is not a plausible time shift (seconds expected)",
                              map.KeyName("timeshift_cam_imu"), camera.time_shift_s));
    } else {
      camera.time_shift_ns = SecondsToTimestamp(camera.time_shift_s);
    }
  }
  map.Get("rostopic", &camera.rostopic, Need::kOptional);
  const YAML::Node overlaps = map.GetSequence("cam_overlaps", Need::kOptional);
  if (overlaps.IsDefined()) {
    for (const YAML::Node& item : overlaps) {
      double index = -1;
      if (!item.IsScalar() || !ParseYamlDouble(item.Scalar(), &index) || index < 0 ||
          index != std::floor(index)) {
        file->Error(map.LineOf("cam_overlaps"),
                    "key '" + map.KeyName("cam_overlaps") + "': expected camera indices");
        break;
      }
      camera.overlaps.push_back(static_cast<int>(index));
    }
  }
  map.WarnUnknownKeys();
  return camera;
}

}  // namespace

const KalibrCamera* KalibrCalibration::FindCamera(const std::string& name) const {
  for (const KalibrCamera& camera : cameras) {
    if (camera.sensor.name == name) return &camera;
  }
  return nullptr;
}

std::vector<KalibrCamera> ReadKalibrCamchain(const std::string& path) {
  YamlFile file(path, nullptr);
  YamlMap root = file.Root();
  std::vector<KalibrCamera> cameras;
  // Kalibr numbers the cameras cam0, cam1, ... without gaps.
  for (int n = 0;; ++n) {
    const std::string name = "cam" + std::to_string(n);
    if (!root.Has(name.c_str())) break;
    std::optional<YamlMap> map = root.GetMap(name.c_str(), Need::kRequired);
    if (!map) break;
    cameras.push_back(ReadCamera(*map, name, root.LineOf(name.c_str())));
  }
  if (cameras.empty() && file.error_count() == 0) {
    file.Error(root.line(),
               "missing required key 'cam0' (expected Kalibr's camchain-imucam.yaml "
               "with cam0, cam1, ...)");
  }
  root.WarnUnknownKeys();
  file.Finish();
  return cameras;
}

KalibrImu ReadKalibrImu(const std::string& path) {
  YamlFile file(path, nullptr);
  YamlMap root = file.Root();
  // Kalibr's result files nest the values under imu0:, its input file has them at the top.
  std::optional<YamlMap> nested;
  if (root.Has("imu0")) nested = root.GetMap("imu0", Need::kRequired);
  YamlMap& map = nested ? *nested : root;
  KalibrImu imu;
  imu.sensor.name = "imu0";
  struct Noise {
    const char* key;
    double* value;
  };
  const Noise noise[] = {
      {"accelerometer_noise_density", &imu.sensor.accelerometer_noise_density},
      {"accelerometer_random_walk", &imu.sensor.accelerometer_random_walk},
      {"gyroscope_noise_density", &imu.sensor.gyroscope_noise_density},
      {"gyroscope_random_walk", &imu.sensor.gyroscope_random_walk},
  };
  for (const Noise& n : noise) {
    if (map.Get(n.key, n.value, Need::kRequired) && *n.value < 0) {
      file.Error(map.LineOf(n.key), "key '" + map.KeyName(n.key) + "' must not be negative");
    }
  }
  if (map.Get("update_rate", &imu.update_rate_hz, Need::kOptional)) {
    if (imu.update_rate_hz <= 0) {
      file.Error(map.LineOf("update_rate"),
                 "key '" + map.KeyName("update_rate") + "' must be positive (Hz)");
    } else {
      imu.sensor.rate_hz = imu.update_rate_hz;
    }
  }
  map.Get("rostopic", &imu.rostopic, Need::kOptional);
  Eigen::Matrix4d imu_from_body;
  if (GetMatrix4(map, "T_i_b", Need::kOptional, &imu_from_body) &&
      CheckRigid(map, "T_i_b", imu_from_body)) {
    imu.sensor.body_from_sensor = geometry::Rigid3::FromMatrix(imu_from_body).Inverse();
    imu.has_imu_from_body = true;
  }
  // Keys of Kalibr's files that crop4d does not need.
  for (const char* known : {"model", "time_offset"}) map.Has(known);
  map.WarnUnknownKeys();
  if (nested) root.WarnUnknownKeys();
  file.Finish();
  return imu;
}

KalibrCalibration ReadKalibr(const std::string& camchain_path, const std::string& imu_path) {
  if (camchain_path.empty() && imu_path.empty()) {
    throw InputError("--kalibr-camchain", 0, "no Kalibr file given");
  }
  KalibrCalibration calibration;
  calibration.camchain_path = camchain_path;
  calibration.imu_path = imu_path;
  if (!camchain_path.empty()) calibration.cameras = ReadKalibrCamchain(camchain_path);
  if (!imu_path.empty()) calibration.imu = ReadKalibrImu(imu_path);
  if (calibration.imu && calibration.imu->has_imu_from_body) {
    // body_from_camera = body_from_imu · imu_from_camera.
    for (KalibrCamera& camera : calibration.cameras) {
      camera.sensor.body_from_sensor =
          calibration.imu->sensor.body_from_sensor * camera.sensor.body_from_sensor;
    }
  }
  return calibration;
}

std::vector<std::string> ApplyKalibr(const KalibrCalibration& calibration,
                                     std::map<std::string, CameraSensor>* cameras,
                                     std::map<std::string, ImuSensor>* imus) {
  std::vector<std::string> lines;
  for (auto& [name, sensor] : *cameras) {
    const KalibrCamera* camera = calibration.FindCamera(name);
    if (camera == nullptr) {
      if (!calibration.camchain_path.empty()) {
        lines.push_back(name + ": not in the Kalibr camera chain; keeps its own calibration");
      }
      continue;
    }
    const geometry::PinholeRadTan& model = camera->sensor.camera;
    if (sensor.camera.width > 0 && sensor.camera.height > 0 &&
        (sensor.camera.width != model.width || sensor.camera.height != model.height)) {
      throw InputError(
          calibration.camchain_path, camera->line,
          fmt::format("{}.resolution [{}, {}] differs from the images' size {}x{}: "
                      "the calibration is of another camera or image size",
                      name, model.width, model.height, sensor.camera.width, sensor.camera.height));
    }
    sensor.camera = model;
    sensor.body_from_sensor = camera->sensor.body_from_sensor;
    lines.push_back(fmt::format(
        "{}: intrinsics, distortion and T_BS from Kalibr; image times + timeshift_cam_imu "
        "({:+.6f} s) onto the IMU clock",
        name, camera->time_shift_s));
  }
  for (const KalibrCamera& camera : calibration.cameras) {
    if (cameras->count(camera.sensor.name) == 0) {
      lines.push_back(camera.sensor.name + " of the Kalibr camera chain: no such camera imported");
    }
  }
  if (calibration.imu) {
    const auto it = imus->find("imu0");
    if (it == imus->end()) {
      lines.push_back("imu0 of the Kalibr IMU file: no IMU imported");
    } else {
      ImuSensor& sensor = it->second;
      const ImuSensor& kalibr = calibration.imu->sensor;
      sensor.gyroscope_noise_density = kalibr.gyroscope_noise_density;
      sensor.gyroscope_random_walk = kalibr.gyroscope_random_walk;
      sensor.accelerometer_noise_density = kalibr.accelerometer_noise_density;
      sensor.accelerometer_random_walk = kalibr.accelerometer_random_walk;
      sensor.body_from_sensor = kalibr.body_from_sensor;
      lines.push_back(fmt::format(
          "imu0: noise from Kalibr (gyro {:.4g} rad/s/√Hz, walk {:.4g}; accel {:.4g} m/s²/√Hz, "
          "walk {:.4g}){}",
          kalibr.gyroscope_noise_density, kalibr.gyroscope_random_walk,
          kalibr.accelerometer_noise_density, kalibr.accelerometer_random_walk,
          calibration.imu->has_imu_from_body ? ", T_BS = T_i_b^-1" : ""));
    }
  }
  return lines;
}

}  // namespace crop4d::io
