#include "crop4d/io/importer.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/validator.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

constexpr Timestamp kNanosPerDay = 86400 * kNanosPerSecond;

double MeanRateHz(std::size_t n, Timestamp first, Timestamp last) {
  if (n < 2 || last <= first) return 0.0;
  return static_cast<double>(n - 1) / DurationSeconds(first, last);
}

// A rate for sensor.yaml: 4 significant digits (the validator compares the mean rate with it).
double RoundRate(double rate_hz) {
  if (rate_hz <= 0) return rate_hz;
  const double scale = std::pow(10.0, 3 - std::floor(std::log10(rate_hz)));
  return std::round(rate_hz * scale) / scale;
}

bool IsValidSessionId(const std::string& id) {
  if (id.empty() || id == "." || id == ".." || id[0] == '.') return false;
  return id.find('/') == std::string::npos && id.find('\\') == std::string::npos;
}

}  // namespace

Eigen::Matrix3d RotationFromRollPitchYawDeg(const Eigen::Vector3d& rpy_deg) {
  const Eigen::Vector3d rpy = rpy_deg * (M_PI / 180.0);
  Eigen::Matrix3d r = (Eigen::AngleAxisd(rpy.z(), Eigen::Vector3d::UnitZ()) *
                       Eigen::AngleAxisd(rpy.y(), Eigen::Vector3d::UnitY()) *
                       Eigen::AngleAxisd(rpy.x(), Eigen::Vector3d::UnitX()))
                          .toRotationMatrix();
  // Multiples of 90° give exact 0 and ±1 in sensor.yaml instead of 1e-16 rounding residue.
  for (int i = 0; i < 9; ++i) {
    double& v = r.data()[i];
    if (std::abs(v) < 1e-12) v = 0.0;
    if (std::abs(std::abs(v) - 1.0) < 1e-12) v = v > 0 ? 1.0 : -1.0;
  }
  return r;
}

void SessionImporter::Options::Check() const {
  if (field_folder.empty()) throw InputError("--out", 0, "the field folder is required");
  if (!IsValidSessionId(session_id)) {
    throw InputError("--session", 0,
                     "'" + session_id +
                         "' is not a usable folder name (non-empty, no '/', not starting with "
                         "'.')");
  }
  if (pos_path.empty() && imu_path.empty()) {
    throw InputError("crop4d import: nothing to import: give --pos and/or --imu");
  }
  if (origin && (std::abs(origin->lat_deg) > 90 || std::abs(origin->lon_deg) > 180)) {
    throw InputError("--origin", 0, "latitude beyond ±90° or longitude beyond ±180°");
  }
  const double noise[] = {gyroscope_noise_density, gyroscope_random_walk,
                          accelerometer_noise_density, accelerometer_random_walk};
  for (double value : noise) {
    if (!(value >= 0) || !std::isfinite(value)) {
      throw InputError("crop4d import: IMU noise values must be finite and not negative");
    }
  }
  if (!antenna_in_body.allFinite() || !imu_rpy_deg.allFinite() ||
      !imu_position_in_body.allFinite()) {
    throw InputError("crop4d import: --antenna, --imu-rpy-deg and --imu-position must be finite");
  }
  if (!imu_path.empty()) imu.Check();
}

SessionImporter::Summary SessionImporter::Run() const {
  const Options& o = options_;
  o.Check();
  Summary summary;
  const fs::path field_folder(o.field_folder);
  const fs::path session_folder = field_folder / kSessionsFolder / o.session_id;
  summary.session_folder = session_folder.string();
  const fs::path field_yaml = field_folder / kFieldYaml;
  std::error_code ec;
  if (fs::exists(field_folder, ec) && !fs::is_directory(field_folder, ec)) {
    throw InputError(o.field_folder, 0, "exists and is not a folder");
  }
  if (fs::exists(session_folder, ec) && !o.overwrite) {
    throw InputError(summary.session_folder, 0,
                     "the session already exists (--overwrite replaces its imported files)");
  }
  const bool field_exists = fs::exists(field_yaml, ec);
  std::optional<FieldInfo> field;
  if (field_exists) field = ReadFieldYaml(field_yaml.string());  // throws on a broken file

  // ---- read everything first ----
  std::optional<RtklibPosFile> pos;
  if (!o.pos_path.empty()) {
    pos = ReadRtklibPos(o.pos_path, o.pos);
    summary.pos_quality = pos->quality;
    summary.pos_time_system = pos->time_system;
    summary.pos_coordinates = pos->coordinates;
  }
  const bool pos_gpst = !pos || pos->time_system == PosTimeSystem::kGpst;
  const bool times_utc = pos ? !pos_gpst || o.pos.leap_seconds != 0 : o.pos.leap_seconds != 0;

  std::optional<ImuCsvFile> imu;
  if (!o.imu_path.empty()) {
    ImuCsvFile::Options imu_options = o.imu;
    const bool imu_gpst = o.imu_time_scale == ImuTimeScale::kGpst ||
                          (o.imu_time_scale == ImuTimeScale::kSameAsPos && pos_gpst);
    if (imu_gpst) {
      imu_options.time_offset_ns -= static_cast<Timestamp>(o.pos.leap_seconds) * kNanosPerSecond;
    }
    imu = ReadImuCsvMapped(o.imu_path, imu_options);
  }
  summary.time_scale = times_utc ? "UTC" : "GPST";

  if (pos && imu) {
    const Timestamp g0 = pos->samples.front().t, g1 = pos->samples.back().t;
    const Timestamp i0 = imu->samples.front().t, i1 = imu->samples.back().t;
    if (i1 < g0 || i0 > g1) {
      throw InputError(o.imu_path, 0,
                       fmt::format("the IMU samples ({} .. {}) do not overlap the GNSS epochs "
                                   "({} .. {}) in time: check --imu-time-unit, "
                                   "--imu-time-offset, --leap-seconds and --imu-time-scale",
                                   FormatTimestamp(i0), FormatTimestamp(i1), FormatTimestamp(g0),
                                   FormatTimestamp(g1)));
    }
  }

  // ---- the origin and the date ----
  if (field) {
    summary.origin = field->origin;
    if (o.origin && (std::abs(o.origin->lat_deg - field->origin.lat_deg) > 1e-9 ||
                     std::abs(o.origin->lon_deg - field->origin.lon_deg) > 1e-9 ||
                     std::abs(o.origin->alt_m - field->origin.alt_m) > 1e-6)) {
      spdlog::warn("{}: the field exists; its origin is kept and --origin is ignored",
                   field_yaml.string());
    }
  } else if (o.origin) {
    summary.origin = *o.origin;
  } else if (pos) {
    const auto with_fix = std::find_if(pos->samples.begin(), pos->samples.end(),
                                       [](const GpsSample& s) { return s.fix != GpsFix::kNone; });
    summary.origin = (with_fix != pos->samples.end() ? *with_fix : pos->samples.front()).position;
  } else {
    throw InputError("--origin", 0,
                     "a new field needs an origin: give --origin lat,lon,alt (or --pos)");
  }
  const Timestamp first_t = pos ? pos->samples.front().t : imu->samples.front().t;
  summary.date = DayOf(first_t);

  // ---- write: sensors, then session.yaml, then field.yaml ----
  std::string sources;
  if (pos) {
    std::vector<GpsSample>& samples = pos->samples;
    summary.gps_samples = static_cast<std::int64_t>(samples.size());
    summary.gps_first_t = samples.front().t;
    summary.gps_last_t = samples.back().t;
    summary.gps_rate_hz = MeanRateHz(samples.size(), summary.gps_first_t, summary.gps_last_t);
    for (const GpsSample& s : samples) {
      ++summary.fix_counts[static_cast<int>(s.fix)];
      if (s.velocity_enu) ++summary.gps_velocities;
    }
    bool any_rtk = false;
    for (const GpsSample& s : samples) {
      any_rtk = any_rtk || s.fix == GpsFix::kRtkFixed || s.fix == GpsFix::kRtkFloat;
    }
    GpsSensor sensor;
    sensor.name = "gps0";
    sensor.kind = o.gps_kind ? *o.gps_kind : (any_rtk ? GpsKind::kRtk : GpsKind::kStandard);
    summary.gps_kind = sensor.kind;
    sensor.rate_hz = summary.gps_rate_hz > 0 ? RoundRate(summary.gps_rate_hz) : 5.0;
    sensor.antenna_in_body = o.antenna_in_body;
    sensor.default_sigma_h = sensor.kind == GpsKind::kRtk ? 0.02 : 2.5;
    sensor.default_sigma_v = sensor.kind == GpsKind::kRtk ? 0.04 : 5.0;
    const fs::path folder = session_folder / "gps0";
    WriteGpsSensorYaml((folder / kSensorYaml).string(), sensor);
    WriteGpsCsv((folder / kDataCsv).string(), samples);
    sources +=
        fmt::format("gps0 from {} (RTKLIB, {}, {})", fs::path(o.pos_path).filename().string(),
                    PosTimeSystemName(pos->time_system), PosCoordinatesName(pos->coordinates));
  }
  if (imu) {
    summary.imu_samples = static_cast<std::int64_t>(imu->samples.size());
    summary.imu_first_t = imu->samples.front().t;
    summary.imu_last_t = imu->samples.back().t;
    summary.imu_rate_hz = imu->MeanRateHz();
    ImuSensor sensor;
    sensor.name = "imu0";
    sensor.rate_hz = summary.imu_rate_hz > 0 ? RoundRate(summary.imu_rate_hz) : 100.0;
    sensor.gyroscope_noise_density = o.gyroscope_noise_density;
    sensor.gyroscope_random_walk = o.gyroscope_random_walk;
    sensor.accelerometer_noise_density = o.accelerometer_noise_density;
    sensor.accelerometer_random_walk = o.accelerometer_random_walk;
    sensor.body_from_sensor =
        geometry::Rigid3(RotationFromRollPitchYawDeg(o.imu_rpy_deg), o.imu_position_in_body);
    const fs::path folder = session_folder / "imu0";
    WriteImuSensorYaml((folder / kSensorYaml).string(), sensor);
    WriteImuCsv((folder / kDataCsv).string(), imu->samples);
    if (!sources.empty()) sources += "; ";
    sources += fmt::format("imu0 from {}", fs::path(o.imu_path).filename().string());
  }

  SessionInfo session;
  session.id = o.session_id;
  session.date = summary.date;
  session.notes = o.notes;
  if (!session.notes.empty()) session.notes += ". ";
  session.notes += fmt::format("Imported by crop4d import: {}. Timestamps in {}.", sources,
                               summary.time_scale == "UTC" ? "UTC" : "GPS time (GPST, not UTC)");
  WriteSessionYaml((session_folder / kSessionYaml).string(), session);

  AddSessionToField(o.field_folder, std::move(field), o.field_name, summary.origin, o.session_id,
                    &summary.field_created, &summary.field_sessions_updated);
  return summary;
}

Timestamp DayOf(Timestamp t) { return t - ((t % kNanosPerDay) + kNanosPerDay) % kNanosPerDay; }

std::string NewSessionFolder(const std::string& field_folder, const std::string& id,
                             bool overwrite) {
  if (const std::string problem = NameProblem(id); !problem.empty()) {
    throw InputError("--session", 0, "'" + id + "': " + problem);
  }
  std::error_code ec;
  if (fs::exists(field_folder, ec) && !fs::is_directory(field_folder, ec)) {
    throw InputError(field_folder, 0, "exists and is not a folder");
  }
  const fs::path folder = fs::path(field_folder) / kSessionsFolder / id;
  if (fs::exists(folder, ec) && !overwrite) {
    throw InputError(folder.string(), 0, "the session already exists (--overwrite replaces it)");
  }
  return folder.string();
}

std::optional<FieldInfo> ExistingField(const std::string& field_folder) {
  std::error_code ec;
  const fs::path yaml = fs::path(field_folder) / kFieldYaml;
  if (!fs::exists(yaml, ec)) return std::nullopt;
  return ReadFieldYaml(yaml.string());
}

void MoveIntoPlace(const std::string& staging, const std::string& session_folder) {
  std::error_code ec;
  if (fs::exists(session_folder, ec)) fs::remove_all(session_folder);
  fs::rename(staging, session_folder);
}

void AddSessionToField(const std::string& field_folder, std::optional<FieldInfo> field,
                       const std::string& name, const geometry::GeodeticPoint& origin,
                       const std::string& session_id, bool* created, bool* sessions_updated) {
  *created = *sessions_updated = false;
  const fs::path folder(field_folder);
  const std::string yaml = (folder / kFieldYaml).string();
  if (!field) {
    FieldInfo info;
    info.name = name.empty() ? fs::absolute(folder).lexically_normal().filename().string() : name;
    if (info.name.empty()) info.name = fs::absolute(folder).parent_path().filename().string();
    info.origin = origin;
    WriteFieldYaml(yaml, info);
    *created = true;
  } else if (!field->sessions.empty() && std::find(field->sessions.begin(), field->sessions.end(),
                                                   session_id) == field->sessions.end()) {
    field->sessions.push_back(session_id);
    WriteFieldYaml(yaml, *field);
    *sessions_updated = true;
  }
}

// A timestamp in the session's time scale: ISO 8601 with `Z` for UTC, with " GPST" for GPS time
// (which is not UTC: it runs ahead by the leap seconds).
std::string FormatStamp(Timestamp t, const std::string& scale) {
  std::string text = FormatTimestamp(t);
  if (scale != "UTC" && !text.empty() && text.back() == 'Z') {
    text.back() = ' ';
    text += scale;
  }
  return text;
}

std::string FormatImportSummary(const SessionImporter::Summary& s) {
  std::string out = fmt::format("session {} ({}), timestamps in {}\n", s.session_folder,
                                FormatDate(s.date), s.time_scale);
  if (s.gps_samples > 0) {
    std::string fixes;
    for (const auto& [code, count] : s.fix_counts) {
      if (!fixes.empty()) fixes += ", ";
      fixes += fmt::format("{} {}", count, GpsFixName(code));
    }
    out += fmt::format("  gps0  {} epochs, {:.4g} Hz, {} .. {}, kind {}: {}\n", s.gps_samples,
                       s.gps_rate_hz, FormatStamp(s.gps_first_t, s.time_scale),
                       FormatStamp(s.gps_last_t, s.time_scale), GpsKindName(s.gps_kind), fixes);
    if (s.gps_velocities > 0) {
      out += fmt::format("        {} with the receiver's velocity (kept in gps0/data.csv)\n",
                         s.gps_velocities);
    }
  }
  if (s.imu_samples > 0) {
    out += fmt::format("  imu0  {} samples, {:.4g} Hz, {} .. {}\n", s.imu_samples, s.imu_rate_hz,
                       FormatStamp(s.imu_first_t, s.time_scale),
                       FormatStamp(s.imu_last_t, s.time_scale));
  }
  out += fmt::format("  field origin {:.9f}, {:.9f}, {:.3f} m{}\n", s.origin.lat_deg,
                     s.origin.lon_deg, s.origin.alt_m,
                     s.field_created ? " (new field.yaml without rows: row passes only where the "
                                       "GPS track shows rows, else one trajectory)"
                                     : "");
  return out;
}

}  // namespace crop4d::io
