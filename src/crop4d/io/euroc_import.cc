#include "crop4d/io/euroc_import.h"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <map>
#include <regex>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/diagnostics.h"
#include "crop4d/io/importer.h"
#include "crop4d/io/sensor_csv.h"
#include "crop4d/io/tum.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

constexpr const char* kTruthFolder = "state_groundtruth_estimate0";

// The folder with cam0/ and imu0/: PATH/mav0, or PATH itself.
fs::path FindMav0(const std::string& path) {
  std::error_code ec;
  if (!fs::is_directory(path, ec)) {
    throw InputError(path, 0, "no such folder (expected an EuRoC sequence: its mav0/ folder)");
  }
  if (fs::is_directory(fs::path(path) / "mav0", ec)) return fs::path(path) / "mav0";
  if (fs::is_directory(fs::path(path) / "imu0", ec)) return fs::path(path);
  throw InputError(path, 0, "not an EuRoC / ASL sequence: no mav0/ folder and no imu0/ in it");
}

// The first error of a reader's diagnostics as an InputError.
void ThrowOnErrors(const Diagnostics& diag) {
  for (const Diagnostic& d : diag.items()) {
    if (d.severity == Severity::kError) throw InputError(d.file, d.line, d.message);
  }
}

// One sensor folder of the sequence, read and checked.
struct SequenceSensor {
  std::string name;
  fs::path folder;
  std::vector<ImageEntry> images;  // cameras
  std::int64_t samples = 0;
  Timestamp first_t = 0, last_t = 0;
  std::optional<geometry::Rigid3> body_from_camera;
  // The sensor.yaml values, and whether they (and a camera's data.csv) are written anew
  // instead of copied: a Kalibr calibration replaced them.
  std::optional<CameraSensor> camera;
  std::optional<ImuSensor> imu;
  bool rewrite = false;
};

SequenceSensor ReadCameraFolder(const fs::path& folder) {
  SequenceSensor s;
  s.name = folder.filename().string();
  s.folder = folder;
  Diagnostics diag;
  const CameraSensor sensor = ReadCameraSensorYaml((folder / kSensorYaml).string(), &diag);
  ThrowOnErrors(diag);
  s.body_from_camera = sensor.body_from_sensor;
  s.camera = sensor;
  const std::string csv = (folder / kDataCsv).string();
  ReadImageCsv(
      csv, [&](const ImageEntry& e, std::int64_t) { s.images.push_back(e); }, &diag);
  ThrowOnErrors(diag);
  if (s.images.empty()) throw InputError(csv, 0, "lists no image");
  for (const ImageEntry& e : s.images) {
    std::error_code ec;
    const fs::path image = folder / "data" / e.filename;
    if (!fs::is_regular_file(image, ec)) {
      throw InputError(csv, 0, "the image " + image.string() + " it lists does not exist");
    }
  }
  s.samples = static_cast<std::int64_t>(s.images.size());
  s.first_t = s.images.front().t;
  s.last_t = s.images.back().t;
  return s;
}

SequenceSensor ReadImuFolder(const fs::path& folder) {
  SequenceSensor s;
  s.name = folder.filename().string();
  s.folder = folder;
  Diagnostics diag;
  s.imu = ReadImuSensorYaml((folder / kSensorYaml).string(), &diag);
  ThrowOnErrors(diag);
  const std::string csv = (folder / kDataCsv).string();
  ReadImuCsv(
      csv,
      [&](const ImuSample& sample, std::int64_t) {
        if (s.samples++ == 0) s.first_t = sample.t;
        s.last_t = sample.t;
      },
      &diag);
  ThrowOnErrors(diag);
  if (s.samples < 2) throw InputError(csv, 0, "fewer than 2 IMU samples");
  return s;
}

// One state of state_groundtruth_estimate0/data.csv.
struct TruthState {
  Timestamp t = 0;
  geometry::Rigid3 world_from_body;
  double biases[6] = {0, 0, 0, 0, 0, 0};  // bw x y z, ba x y z
};

// #timestamp, p_RS_R x y z [m], q_RS w x y z, v_RS_R x y z [m/s], b_w x y z [rad/s],
// b_a x y z [m/s²]: 17 columns.
std::vector<TruthState> ReadTruth(const fs::path& path) {
  std::vector<TruthState> states;
  CsvReader reader(path.string());
  CsvRecord record;
  while (reader.Next(&record)) {
    if (record.fields.size() != 17) {
      throw InputError(
          path.string(), record.line,
          fmt::format("expected 17 columns (EuRoC ground truth), found {}", record.fields.size()));
    }
    TruthState s;
    double v[16];
    if (!ParseInt64(record.fields[0], &s.t)) {
      throw InputError(path.string(), record.line, "the timestamp is not an integer (ns)");
    }
    for (int k = 0; k < 16; ++k) {
      if (!ParseDouble(record.fields[k + 1], &v[k]) || !std::isfinite(v[k])) {
        throw InputError(path.string(), record.line,
                         fmt::format("column {} is not a finite number", k + 2));
      }
    }
    const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
    if (std::abs(q.norm() - 1.0) > 1e-3) {
      throw InputError(path.string(), record.line, "the quaternion is not of unit length");
    }
    if (!states.empty() && s.t <= states.back().t) {
      throw InputError(path.string(), record.line, "timestamps are not increasing");
    }
    s.world_from_body = geometry::Rigid3(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2]));
    std::copy(v + 10, v + 16, s.biases);
    states.push_back(s);
  }
  return states;
}

// The truth at t (linear between states), unset outside their span.
std::optional<geometry::Rigid3> TruthAt(const std::vector<TruthState>& truth, Timestamp t) {
  if (truth.empty() || t < truth.front().t || t > truth.back().t) return std::nullopt;
  auto it = std::lower_bound(truth.begin(), truth.end(), t,
                             [](const TruthState& s, Timestamp x) { return s.t < x; });
  if (it->t == t) return it->world_from_body;
  const TruthState& b = *it;
  const TruthState& a = *(it - 1);
  return geometry::InterpolateSeparately(a.world_from_body, b.world_from_body,
                                         DurationSeconds(a.t, t) / DurationSeconds(a.t, b.t));
}

// Hard-links `from` to `to`, copying when the file systems differ; true when linked.
bool LinkOrCopy(const fs::path& from, const fs::path& to) {
  std::error_code ec;
  fs::create_hard_link(from, to, ec);
  if (!ec) return true;
  fs::copy_file(from, to, fs::copy_options::overwrite_existing);
  return false;
}

void WriteTruth(const fs::path& folder, const std::vector<TruthState>& truth,
                const std::vector<SequenceSensor>& cameras, const std::string& source) {
  std::vector<StampedPose> body;
  std::string biases =
      "#timestamp [ns],bg_x [rad s^-1],bg_y [rad s^-1],bg_z [rad s^-1],ba_x [m s^-2],ba_y [m "
      "s^-2],ba_z [m s^-2]\n";
  for (const TruthState& s : truth) {
    body.push_back({s.t, s.world_from_body});
    biases += fmt::format("{},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g},{:.9g}\n", s.t, s.biases[0],
                          s.biases[1], s.biases[2], s.biases[3], s.biases[4], s.biases[5]);
  }
  WriteTum((folder / "body_poses.tum").string(), body,
           "world_from_body (body = imu0) in the sequence's ground-truth frame, from " + source);
  WriteFileAtomic((folder / "imu_biases.csv").string(), biases);
  for (const SequenceSensor& camera : cameras) {
    std::vector<StampedPose> poses;
    for (const ImageEntry& e : camera.images) {
      if (const auto pose = TruthAt(truth, e.t)) {
        poses.push_back({e.t, *pose * *camera.body_from_camera});
      }
    }
    WriteTum((folder / (camera.name + "_poses.tum")).string(), poses,
             "world_from_camera of " + camera.name +
                 " at its image times, interpolated from the ground truth of " + source);
  }
}

// Applies Kalibr results to the sequence's cameras and IMUs (kalibr.h: ApplyKalibr): the
// calibrated sensors are written anew, and a calibrated camera's image times move onto the IMU
// clock by its timeshift_cam_imu. Returns the lines for the summary.
std::vector<std::string> ApplyKalibrToSequence(const KalibrCalibration& kalibr,
                                               std::vector<SequenceSensor>* cameras,
                                               std::vector<SequenceSensor>* imus) {
  std::map<std::string, CameraSensor> camera_map;
  std::map<std::string, ImuSensor> imu_map;
  for (const SequenceSensor& s : *cameras) camera_map[s.name] = *s.camera;
  for (const SequenceSensor& s : *imus) imu_map[s.name] = *s.imu;
  std::vector<std::string> lines = ApplyKalibr(kalibr, &camera_map, &imu_map);
  for (SequenceSensor& s : *cameras) {
    const KalibrCamera* calibrated = kalibr.FindCamera(s.name);
    if (calibrated == nullptr) continue;
    s.camera = camera_map[s.name];
    s.body_from_camera = s.camera->body_from_sensor;
    s.rewrite = true;
    for (ImageEntry& e : s.images) e.t = calibrated->ToImuClock(e.t);
    s.first_t = s.images.front().t;
    s.last_t = s.images.back().t;
  }
  for (SequenceSensor& s : *imus) {
    if (kalibr.imu && s.name == "imu0") {
      s.imu = imu_map[s.name];
      s.rewrite = true;
    }
  }
  return lines;
}

}  // namespace

EurocImportSummary ImportEuroc(const EurocImportOptions& o) {
  if (o.field_folder.empty()) throw InputError("--out", 0, "the field folder is required");
  if (o.origin && (std::abs(o.origin->lat_deg) > 90 || std::abs(o.origin->lon_deg) > 180)) {
    throw InputError("--origin", 0, "latitude beyond ±90° or longitude beyond ±180°");
  }
  const fs::path mav0 = FindMav0(o.sequence_folder);

  // ---- read and check everything ----
  std::vector<SequenceSensor> cameras, imus;
  const std::regex camera_name("cam[0-9]+"), imu_name("imu[0-9]+");
  std::vector<fs::path> folders;
  for (const fs::directory_entry& entry : fs::directory_iterator(mav0)) {
    if (entry.is_directory()) folders.push_back(entry.path());
  }
  std::sort(folders.begin(), folders.end());
  for (const fs::path& folder : folders) {
    const std::string name = folder.filename().string();
    if (std::regex_match(name, camera_name)) {
      cameras.push_back(ReadCameraFolder(folder));
    } else if (std::regex_match(name, imu_name)) {
      imus.push_back(ReadImuFolder(folder));
    } else if (name != kTruthFolder) {
      spdlog::info("import: {}/ is not a camera or an IMU; not imported", name);
    }
  }
  if (imus.empty()) throw InputError(mav0.string(), 0, "no imu0/ folder: crop4d needs an IMU");
  std::vector<std::string> kalibr_lines;
  if (o.kalibr) kalibr_lines = ApplyKalibrToSequence(*o.kalibr, &cameras, &imus);
  std::vector<TruthState> truth;
  const fs::path truth_csv = mav0 / kTruthFolder / kDataCsv;
  std::error_code ec;
  if (fs::exists(truth_csv, ec)) truth = ReadTruth(truth_csv);

  EurocImportSummary summary;
  summary.kalibr_lines = std::move(kalibr_lines);
  const Timestamp first_t = imus.front().first_t;
  const Timestamp date = DayOf(first_t);
  const std::string id = o.session_id.empty() ? FormatDate(date) : o.session_id;
  const fs::path field_folder(o.field_folder);
  const fs::path session_folder = NewSessionFolder(o.field_folder, id, o.overwrite);
  summary.session_folder = session_folder.string();
  std::optional<FieldInfo> field = ExistingField(o.field_folder);

  // ---- write the session into a hidden folder, then move it into place ----
  const fs::path staging =
      field_folder / kSessionsFolder / fmt::format(".{}.importing-{}", id, ::getpid());
  fs::remove_all(staging);
  try {
    for (const std::vector<SequenceSensor>* group : {&cameras, &imus}) {
      for (const SequenceSensor& sensor : *group) {
        const fs::path to = staging / sensor.name;
        fs::create_directories(to);
        if (!sensor.rewrite) {
          fs::copy_file(sensor.folder / kSensorYaml, to / kSensorYaml);
          fs::copy_file(sensor.folder / kDataCsv, to / kDataCsv);
        } else if (sensor.camera) {
          WriteCameraSensorYaml((to / kSensorYaml).string(), *sensor.camera);
          WriteImageCsv((to / kDataCsv).string(), sensor.images);
        } else {
          WriteImuSensorYaml((to / kSensorYaml).string(), *sensor.imu);
          fs::copy_file(sensor.folder / kDataCsv, to / kDataCsv);
        }
        for (const ImageEntry& e : sensor.images) {
          const fs::path image = to / "data" / e.filename;
          fs::create_directories(image.parent_path());
          if (LinkOrCopy(sensor.folder / "data" / e.filename, image)) ++summary.images_linked;
        }
        summary.sensors.push_back({sensor.name, sensor.samples, sensor.first_t, sensor.last_t});
      }
    }
    SessionInfo session;
    session.id = id;
    session.date = date;
    session.notes = fmt::format(
        "Imported by crop4d import --euroc from {} (EuRoC / ASL layout, sensor files verbatim{}); "
        "no GPS.",
        fs::absolute(mav0).lexically_normal().string(),
        o.kalibr ? fmt::format(" except the Kalibr calibration: {}",
                               fmt::join(summary.kalibr_lines, "; "))
                 : std::string());
    WriteSessionYaml((staging / kSessionYaml).string(), session);
    MoveIntoPlace(staging.string(), session_folder.string());
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }
  if (!truth.empty()) {
    const fs::path truth_folder = field_folder / "ground_truth" / id;
    fs::create_directories(truth_folder);
    WriteTruth(truth_folder, truth, cameras, (fs::path("mav0") / kTruthFolder).string());
    summary.truth_states = static_cast<std::int64_t>(truth.size());
  }
  AddSessionToField(o.field_folder, std::move(field), o.field_name,
                    o.origin.value_or(geometry::GeodeticPoint{0, 0, 0}), id, &summary.field_created,
                    &summary.field_sessions_updated);
  return summary;
}

std::string FormatEurocImportSummary(const EurocImportSummary& s) {
  std::string out = fmt::format("session {} (EuRoC / ASL sequence, no GPS)\n", s.session_folder);
  for (const EurocImportSummary::Sensor& sensor : s.sensors) {
    out += fmt::format("  {:<6} {:>8} {}  {} .. {}\n", sensor.name, sensor.samples,
                       sensor.name.rfind("cam", 0) == 0 ? "images " : "samples",
                       FormatTimestamp(sensor.first_t), FormatTimestamp(sensor.last_t));
  }
  out += s.truth_states > 0
             ? fmt::format("  ground truth: {} states → ground_truth/<session>/\n", s.truth_states)
             : "  ground truth: none in the sequence\n";
  for (const std::string& line : s.kalibr_lines) out += "  kalibr: " + line + "\n";
  if (s.field_created) out += "  field.yaml written (origin 0°, 0°, 0 m unless --origin)\n";
  return out;
}

}  // namespace crop4d::io
