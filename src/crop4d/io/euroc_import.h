#pragma once

// `crop4d import --euroc PATH` (docs/import.md): an EuRoC / ASL sequence (Burri et al., IJRR
// 2016; the layout of Kalibr, maplab, OKVIS, Basalt) becomes a session as it is. Our dataset
// format is that layout (docs/format.md), so the camera and IMU folders (sensor.yaml, data.csv,
// images) are taken verbatim: checked with the dataset readers, then copied (images hard-linked
// when the field is on the same file system). The sequence's ground truth
// (`state_groundtruth_estimate0/data.csv`: body = imu0 pose, velocity and biases) becomes the
// field's ground truth for `crop4d eval`: `ground_truth/<session>/body_poses.tum`,
// `cam<N>_poses.tum` at the image times, `imu_biases.csv`.
//
// EuRoC has no GPS: a new field gets the conventional origin 0°, 0°, 0 m unless one is given (the
// positions of a session without GPS are in its own local level frame; docs/slam.md).
//
// Everything is read and checked before anything is written; the session is written into a
// hidden folder and renamed into place, so a failed import leaves nothing behind.

#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/kalibr.h"

namespace crop4d::io {

struct EurocImportOptions {
  // The sequence: its mav0/ folder, or the folder that holds mav0/.
  std::string sequence_folder;
  // The field folder: created when it has no field.yaml.
  std::string field_folder;
  // Session folder name (default: the date of the first IMU sample, YYYY-MM-DD).
  std::string session_id;
  // Name for a new field.yaml (default: the folder's name).
  std::string field_name;
  // Origin of a new field (default 0°, 0°, 0 m by convention: the sequence has no GPS).
  std::optional<geometry::GeodeticPoint> origin;
  // Replace an existing session folder instead of refusing.
  bool overwrite = false;
  // Kalibr results (--kalibr-camchain, --kalibr-imu) that replace the sequence's own camera and
  // IMU sensor.yaml values (kalibr.h: ApplyKalibr); each calibrated camera's image times are
  // moved onto the IMU clock by its timeshift_cam_imu (t_imu = t_cam + shift) in data.csv.
  std::optional<KalibrCalibration> kalibr;
};

struct EurocImportSummary {
  std::string session_folder;
  bool field_created = false;
  bool field_sessions_updated = false;
  // Per sensor folder imported: name, samples (images or IMU samples), first and last time.
  struct Sensor {
    std::string name;
    std::int64_t samples = 0;
    Timestamp first_t = 0, last_t = 0;
  };
  std::vector<Sensor> sensors;
  // Ground-truth states written (0: the sequence has none).
  std::int64_t truth_states = 0;
  // Images hard-linked (the rest were copied).
  std::int64_t images_linked = 0;
  // What the Kalibr calibration changed, one line per sensor (empty without one).
  std::vector<std::string> kalibr_lines;
};

// Throws InputError (file, line, what) on a missing or malformed part; nothing is written then.
EurocImportSummary ImportEuroc(const EurocImportOptions& options);

std::string FormatEurocImportSummary(const EurocImportSummary& summary);

}  // namespace crop4d::io
