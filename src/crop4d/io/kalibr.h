#pragma once

// Kalibr calibration results (docs/import.md, "Kalibr calibration"): the camera chain of a
// camera-IMU calibration (`camchain-imucam.yaml`, `kalibr_calibrate_imu_camera`'s output) and
// the IMU noise file (`imu.yaml`). They give our sensor.yaml values:
//
//   camchain-imucam.yaml                      our cam<N>/sensor.yaml
//   camN.camera_model: pinhole                camera_model: pinhole
//   camN.intrinsics: [fu, fv, pu, pv]         intrinsics: [fu, fv, cu, cv]
//   camN.distortion_model: radtan             distortion_model: radial-tangential
//   camN.distortion_coeffs: [k1, k2, r1, r2]  distortion_coefficients: [k1, k2, p1, p2]
//   camN.resolution: [w, h]                   resolution: [w, h]
//   camN.T_cam_imu (camera_from_imu)          T_BS = body_from_camera = T_cam_imu⁻¹
//   camN.timeshift_cam_imu (s)                image times moved onto the IMU clock:
//                                             t_imu = t_cam + timeshift_cam_imu (Kalibr's
//                                             convention), applied when the images are written
//
//   imu.yaml (imu0: or top level)             our imu0/sensor.yaml
//   accelerometer_noise_density, ..._random_walk, gyroscope_noise_density, ..._random_walk
//   T_i_b (optional, imu_from_body)           T_BS = body_from_imu = T_i_b⁻¹; the cameras'
//                                             T_BS become T_i_b⁻¹ · T_cam_imu⁻¹
//
// The body frame is imu0's frame unless imu.yaml gives T_i_b. Kalibr's other camera models
// (omni, ds, eucm) and the equidistant (fisheye) distortion have no counterpart in crop4d's
// camera model (pinhole + radial-tangential, geometry/camera.h) and are refused.
//
// Every problem throws InputError naming the file, the line and the key ("cam0.T_cam_imu").

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"

namespace crop4d::io {

// One camera of camchain-imucam.yaml.
struct KalibrCamera {
  // name "camN", intrinsics, distortion, resolution and body_from_sensor = T_cam_imu⁻¹ (or
  // T_i_b⁻¹ · T_cam_imu⁻¹). rate_hz is not in the file: whoever writes the sensor sets it from
  // the data.
  CameraSensor sensor;
  // timeshift_cam_imu in nanoseconds (rounded): t_imu = t_cam + time_shift_ns.
  Timestamp time_shift_ns = 0;
  double time_shift_s = 0.0;
  // The camera's ROS topic (rostopic), "" when absent.
  std::string rostopic;
  // cam_overlaps: the cameras whose fields of view overlap this one's.
  std::vector<int> overlaps;
  // Line of the camera's entry in the file, for messages.
  std::int64_t line = 0;

  // A camera-clock time on the IMU clock.
  Timestamp ToImuClock(Timestamp t_camera) const { return t_camera + time_shift_ns; }
};

// imu0 of imu.yaml.
struct KalibrImu {
  // name "imu0", the four noise values, body_from_sensor = T_i_b⁻¹ (identity without T_i_b);
  // rate_hz = update_rate when given.
  ImuSensor sensor;
  // update_rate (Hz), 0 when absent.
  double update_rate_hz = 0.0;
  std::string rostopic;
  // Whether the file gave T_i_b (then the body frame is not the IMU frame).
  bool has_imu_from_body = false;
};

struct KalibrCalibration {
  std::string camchain_path;  // "" when only imu.yaml was read
  std::string imu_path;       // "" when only the camera chain was read
  std::vector<KalibrCamera> cameras;
  std::optional<KalibrImu> imu;

  // The camera named `name` ("cam0"), or nullptr.
  const KalibrCamera* FindCamera(const std::string& name) const;
};

// Reads camchain-imucam.yaml: every top-level key camN (N = 0, 1, ...). body_from_sensor is
// T_cam_imu⁻¹ (body = the IMU frame). Throws InputError on a missing key, a value of the
// wrong type or size, a T_cam_imu that is not a rigid transform (rotation block orthonormal
// within 1e-3 with det +1, last row [0, 0, 0, 1]), non-positive focal lengths, a principal
// point outside the image, an unsupported camera or distortion model.
std::vector<KalibrCamera> ReadKalibrCamchain(const std::string& path);

// Reads imu.yaml: the map under `imu0:` (Kalibr's result files) or the top level (Kalibr's
// input file). Throws InputError as above (noise values must be finite and ≥ 0).
KalibrImu ReadKalibrImu(const std::string& path);

// Reads either file or both (an empty path skips it) and puts the cameras into the body frame
// that imu.yaml's T_i_b defines. Throws InputError when both paths are empty.
KalibrCalibration ReadKalibr(const std::string& camchain_path, const std::string& imu_path);

// Applies a calibration to sensors that an importer has assembled (name → sensor, e.g. from a
// ROS bag or an EuRoC sequence): a camera of the same name gets the intrinsics, distortion,
// resolution and T_BS of the calibration (its rate_hz and height_above_ground_m are kept);
// "imu0" gets the noise values and T_BS (its rate_hz is kept). A camera whose resolution is
// already set (width, height > 0) and differs from the calibration's is an InputError (the
// calibration is of another camera or another image size). The time shift is not applied here:
// the importer moves the image times with KalibrCamera::ToImuClock when it writes them.
// Returns one line per sensor saying what was applied or left alone (for the import summary).
std::vector<std::string> ApplyKalibr(const KalibrCalibration& calibration,
                                     std::map<std::string, CameraSensor>* cameras,
                                     std::map<std::string, ImuSensor>* imus);

}  // namespace crop4d::io
