#include "crop4d/io/validator.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/image_probe.h"

namespace crop4d::io {
namespace fs = std::filesystem;
namespace {

constexpr Timestamp kNanosPerDay = 86400 * kNanosPerSecond;

struct ImageToCheck {
  std::string filename;
  std::int64_t line = 0;
};

// Tracks the timestamps of a sensor's samples: span, gaps, and reports gaps one by one up to
// the limit.
class TimeTracker {
 public:
  TimeTracker(const std::string& data_csv, double nominal_rate_hz, const ValidateOptions& options,
              Diagnostics* diag)
      : data_csv_(data_csv), rate_(nominal_rate_hz), options_(options), diag_(diag) {}

  void Add(Timestamp t, std::int64_t line, SensorReport* report) {
    if (has_prev_) {
      const double dt = DurationSeconds(prev_t_, t);
      const double periods = dt * rate_;
      if (periods > options_.gap_periods) {
        ++report->gaps;
        report->longest_gap_s = std::max(report->longest_gap_s, dt);
        if (report->gaps <= options_.max_listed) {
          diag_->Warning(data_csv_, line,
                         fmt::format("gap of {} ({:.1f} sample periods at {} Hz) after line {}",
                                     FormatDuration(dt), periods, rate_, prev_line_));
        }
      }
    } else {
      report->first_t = t;
    }
    report->last_t = t;
    has_prev_ = true;
    prev_t_ = t;
    prev_line_ = line;
  }

 private:
  std::string data_csv_;
  double rate_;
  const ValidateOptions& options_;
  Diagnostics* diag_;
  bool has_prev_ = false;
  Timestamp prev_t_ = 0;
  std::int64_t prev_line_ = 0;
};

// Reads sensor.yaml with the collector; returns whether it was read without errors.
template <typename Sensor, typename Read>
bool ReadMetadata(const std::string& path, Read read, Sensor* sensor, Diagnostics* diag) {
  try {
    *sensor = read(path, diag);
    return true;
  } catch (const InputError& e) {
    diag->Error(e.file(), e.line(), e.message());
    return false;
  }
}

void CheckImages(const std::string& session_id, const std::string& camera_folder,
                 const std::string& data_csv, const CameraSensor& camera, bool metadata_ok,
                 const std::vector<ImageToCheck>& images, const ValidateOptions& options,
                 SensorReport* report, Diagnostics* diag) {
  const fs::path data_folder = fs::path(camera_folder) / kImageFolder;
  report->images_listed = static_cast<std::int64_t>(images.size());
  std::vector<ImageProbe> probes(images.size());
  {
    Progress::Options progress_options;
    progress_options.silent = !options.progress;
    Progress progress("validate " + session_id + "/" + report->name + " images", images.size(),
                      "img", progress_options);
    tbb::parallel_for(std::size_t{0}, images.size(), [&](std::size_t i) {
      probes[i] = ProbeImage((data_folder / images[i].filename).string(), options.decode_images);
      progress.Add();
    });
  }
  std::set<std::string> listed;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const ImageToCheck& image = images[i];
    const ImageProbe& probe = probes[i];
    listed.insert(fs::path(image.filename).lexically_normal().generic_string());
    const std::string shown = std::string(kImageFolder) + "/" + image.filename;
    if (!probe.ok) {
      if (probe.problem == "missing") {
        ++report->images_missing;
        diag->Error(data_csv, image.line, "listed image " + shown + " is missing");
      } else {
        ++report->images_unreadable;
        diag->Error(data_csv, image.line,
                    "listed image " + shown + " is not readable: " + probe.problem);
      }
      continue;
    }
    if (metadata_ok && probe.width > 0 &&
        (probe.width != camera.camera.width || probe.height != camera.camera.height)) {
      ++report->images_unreadable;
      diag->Error(
          data_csv, image.line,
          fmt::format("listed image {} is {}x{}, but the camera's resolution is {}x{}", shown,
                      probe.width, probe.height, camera.camera.width, camera.camera.height));
    }
  }
  std::error_code ec;
  if (!fs::is_directory(data_folder, ec)) return;
  std::vector<std::string> unlisted;
  for (fs::recursive_directory_iterator it(data_folder, ec), end; !ec && it != end;
       it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const std::string relative = it->path().lexically_relative(data_folder).generic_string();
    if (!relative.empty() && relative.front() == '.') continue;  // hidden files
    if (listed.count(relative) == 0) unlisted.push_back(it->path().string());
  }
  std::sort(unlisted.begin(), unlisted.end());
  report->images_unlisted = static_cast<std::int64_t>(unlisted.size());
  for (std::size_t i = 0; i < unlisted.size(); ++i) {
    if (static_cast<int>(i) >= options.max_listed) {
      diag->Warning(data_folder.string(), 0,
                    fmt::format("{} more files not listed in {}", unlisted.size() - i,
                                diag->DisplayPath(data_csv)));
      break;
    }
    diag->Warning(unlisted[i], 0, "image present but not listed in " + diag->DisplayPath(data_csv));
  }
}

SensorReport ValidateSensor(const std::string& session_folder, const SessionReport& session,
                            const SensorFolder& folder, const ValidateOptions& options,
                            Diagnostics* diag) {
  SensorReport report;
  report.name = folder.name;
  report.kind = folder.kind;
  const std::string sensor_folder = (fs::path(session_folder) / folder.name).string();
  const std::string yaml = (fs::path(sensor_folder) / kSensorYaml).string();
  const std::string data_csv = (fs::path(sensor_folder) / kDataCsv).string();
  std::error_code ec;

  CameraSensor camera;
  ImuSensor imu;
  MagSensor mag;
  GpsSensor gps;
  switch (folder.kind) {
    case SensorKind::kCamera:
      report.metadata_ok = ReadMetadata(yaml, ReadCameraSensorYaml, &camera, diag);
      report.nominal_rate_hz = camera.rate_hz;
      break;
    case SensorKind::kImu:
      report.metadata_ok = ReadMetadata(yaml, ReadImuSensorYaml, &imu, diag);
      report.nominal_rate_hz = imu.rate_hz;
      break;
    case SensorKind::kMag:
      report.metadata_ok =
          !fs::exists(yaml, ec) || ReadMetadata(yaml, ReadMagSensorYaml, &mag, diag);
      report.nominal_rate_hz = mag.rate_hz;
      break;
    case SensorKind::kGps:
      report.metadata_ok = ReadMetadata(yaml, ReadGpsSensorYaml, &gps, diag);
      report.nominal_rate_hz = gps.rate_hz;
      break;
  }

  TimeTracker tracker(data_csv, report.nominal_rate_hz, options, diag);
  std::vector<ImageToCheck> images;
  try {
    switch (folder.kind) {
      case SensorKind::kCamera:
        report.stats = ReadImageCsv(
            data_csv,
            [&](const ImageEntry& e, std::int64_t line) {
              tracker.Add(e.t, line, &report);
              images.push_back({e.filename, line});
            },
            diag);
        break;
      case SensorKind::kImu:
        report.stats = ReadImuCsv(
            data_csv,
            [&](const ImuSample& s, std::int64_t line) { tracker.Add(s.t, line, &report); }, diag,
            options.limits);
        break;
      case SensorKind::kMag:
        report.stats = ReadMagCsv(
            data_csv,
            [&](const MagSample& s, std::int64_t line) { tracker.Add(s.t, line, &report); }, diag,
            options.limits);
        break;
      case SensorKind::kGps:
        report.stats = ReadGpsCsv(
            data_csv,
            [&](const GpsSample& s, std::int64_t line) { tracker.Add(s.t, line, &report); }, diag,
            options.limits);
        break;
    }
  } catch (const InputError& e) {
    diag->Error(e.file(), e.line(), e.message());
  }
  report.samples = report.stats.samples;

  if (report.gaps > options.max_listed) {
    diag->Warning(data_csv, 0,
                  fmt::format("{} gaps longer than {} sample periods in all (the first {} are "
                              "listed); longest {}",
                              report.gaps, options.gap_periods, options.max_listed,
                              FormatDuration(report.longest_gap_s)));
  }
  if (report.samples >= 2 && report.span_s() > 0) {
    report.mean_rate_hz = (report.samples - 1) / report.span_s();
    const double off = report.mean_rate_hz / report.nominal_rate_hz - 1.0;
    if (std::abs(off) > options.rate_tolerance) {
      diag->Warning(data_csv, 0,
                    fmt::format("mean rate {:.4g} Hz is {:+.0f}% off the nominal rate_hz {} "
                                "of {}",
                                report.mean_rate_hz, 100.0 * off, report.nominal_rate_hz,
                                diag->DisplayPath(yaml)));
    }
  }
  if (report.samples > 0 && session.date != 0 &&
      (report.first_t < session.date - kNanosPerDay ||
       report.first_t > session.date + 2 * kNanosPerDay)) {
    diag->Warning(data_csv, 0,
                  fmt::format("the first timestamp, {}, is not on the session date {}: "
                              "timestamps must be nanoseconds since the Unix epoch",
                              FormatTimestamp(report.first_t), FormatDate(session.date)));
  }
  if (folder.kind == SensorKind::kCamera) {
    CheckImages(session.id, sensor_folder, data_csv, camera, report.metadata_ok, images, options,
                &report, diag);
  }
  return report;
}

SessionReport ValidateSession(const std::string& folder, const std::string& id,
                              const ValidateOptions& options, Diagnostics* diag) {
  SessionReport report;
  report.id = id;
  report.name_problem = NameProblem(id);
  if (!report.name_problem.empty()) {
    diag->Error(folder, 0,
                "session '" + id + "': " + report.name_problem +
                    " (rename the folder and its line in field.yaml)");
  }
  try {
    report.date = ReadSessionYaml((fs::path(folder) / kSessionYaml).string(), id, diag).date;
  } catch (const InputError& e) {
    diag->Error(e.file(), e.line(), e.message());
  }
  std::vector<SensorFolder> sensors;
  try {
    sensors = ListSensorFolders(folder, diag);
  } catch (const InputError& e) {
    diag->Error(e.file(), e.line(), e.message());
    return report;
  }
  bool has_camera = false, has_imu = false, has_gps = false;
  for (const SensorFolder& sensor : sensors) {
    has_camera = has_camera || sensor.kind == SensorKind::kCamera;
    has_imu = has_imu || sensor.kind == SensorKind::kImu;
    has_gps = has_gps || sensor.kind == SensorKind::kGps;
    report.sensors.push_back(ValidateSensor(folder, report, sensor, options, diag));
  }
  // An IMU + GNSS session (e.g. from `crop4d import`) is legitimate: the method degrades.
  if (!has_camera) {
    diag->Warning(folder, 0, "session has no camera (cam0/): no images to reconstruct from");
  }
  if (!has_imu) diag->Warning(folder, 0, "session has no IMU (imu0/): the method degrades");
  if (!has_gps) diag->Warning(folder, 0, "session has no GPS (gps0/): the method degrades");
  for (const SensorReport& sensor : report.sensors) {
    if (sensor.kind != SensorKind::kGps || sensor.samples == 0) continue;
    const auto& fixes = sensor.stats.fix_counts;
    const auto none = fixes.find(static_cast<int>(GpsFix::kNone));
    if (none != fixes.end() && none->second == sensor.samples) {
      const std::string reason =
          fmt::format("{} has no fix in any of its {} samples (fix column 0): it gives no position",
                      sensor.name, sensor.samples);
      diag->Warning((fs::path(folder) / sensor.name / kDataCsv).string(), 0, reason);
      report.degradations.push_back(reason);
    }
  }

  // Every sensor should overlap the camera in time (a unit mistake shows up here).
  const SensorReport* camera = nullptr;
  for (const SensorReport& sensor : report.sensors) {
    if (sensor.kind == SensorKind::kCamera && sensor.samples > 0 && camera == nullptr) {
      camera = &sensor;
    }
  }
  for (const SensorReport& sensor : report.sensors) {
    if (camera == nullptr || &sensor == camera || sensor.samples == 0) continue;
    if (sensor.last_t < camera->first_t || sensor.first_t > camera->last_t) {
      diag->Warning((fs::path(folder) / sensor.name / kDataCsv).string(), 0,
                    "samples do not overlap " + camera->name + "'s images in time");
    }
  }
  return report;
}

// A session without a sensor folder that most of the field's other sessions have (a receiver
// left at home, a folder lost in the copy) is processed without it: warned about and recorded.
// A sensor that only a minority of the sessions have is an extra, not a loss.
void WarnAboutMissingSensors(const Field& field, std::vector<SessionReport>* sessions,
                             Diagnostics* diag) {
  if (sessions->size() < 2) return;
  std::map<std::string, std::pair<SensorKind, int>> have;  // folder name -> kind, sessions
  for (const SessionReport& s : *sessions) {
    for (const SensorReport& sensor : s.sensors) {
      auto [it, inserted] = have.try_emplace(sensor.name, sensor.kind, 0);
      ++it->second.second;
    }
  }
  for (SessionReport& s : *sessions) {
    for (const auto& [name, kind_count] : have) {
      const std::string& folder = name;  // (clang 14 cannot capture a structured binding)
      const bool present = std::any_of(s.sensors.begin(), s.sensors.end(),
                                       [&](const SensorReport& r) { return r.name == folder; });
      const auto others = sessions->size() - 1;
      if (present || 2 * static_cast<std::size_t>(kind_count.second) <= others) continue;
      const std::string reason =
          fmt::format("no {}/ ({}), which {} of the other {} sessions have: processed without it",
                      name, SensorKindName(kind_count.first), kind_count.second, others);
      diag->Warning(field.SessionFolder(s.id), 0, reason);
      s.degradations.push_back(reason);
    }
  }
}

std::string FormatFixCounts(const std::map<int, std::int64_t>& fix_counts, std::int64_t total) {
  std::string out;
  for (const auto& [code, count] : fix_counts) {
    if (!out.empty()) out += ", ";
    out += fmt::format("{} {} ({:.0f}%)", GpsFixName(code), count,
                       total > 0 ? 100.0 * count / total : 0.0);
  }
  return out.empty() ? "no fixes" : "fix: " + out;
}

}  // namespace

std::string NameProblem(const std::string& name) {
  if (name.empty()) return "the name is empty";
  for (const char c : name) {
    const auto u = static_cast<unsigned char>(c);
    if (c == ',' || c == '"') {
      return fmt::format("the name contains '{}', which the CSV outputs cannot hold", c);
    }
    if (c == '/' || c == '\\') {
      return fmt::format("the name contains '{}', which would make its output files a path", c);
    }
    if (u < 0x20 || u == 0x7f) {
      return fmt::format("the name contains the control character 0x{:02x}", u);
    }
  }
  return "";
}

ValidationReport ValidateField(const std::string& folder, const ValidateOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "ValidateField");
  ValidationReport report;
  report.folder = folder;
  Diagnostics::Options diag_options;
  diag_options.root = folder;
  Diagnostics diag(diag_options);
  try {
    Field field(folder, &diag);
    report.field_name = field.info().name;
    std::vector<std::string> ids = field.session_ids();
    if (!options.sessions.empty()) {
      std::vector<std::string> chosen;
      for (const std::string& id : options.sessions) {
        if (std::find(ids.begin(), ids.end(), id) != ids.end()) {
          chosen.push_back(id);
        } else {
          diag.Error(field.SessionFolder(id), 0, "no such session");
        }
      }
      ids = chosen;
    } else if (ids.empty() && fs::is_directory(fs::path(folder) / kSessionsFolder)) {
      diag.Error((fs::path(folder) / kSessionsFolder).string(), 0, "the field has no sessions");
    }
    for (const std::string& id : ids) {
      report.sessions.push_back(ValidateSession(field.SessionFolder(id), id, options, &diag));
    }
    WarnAboutMissingSensors(field, &report.sessions, &diag);
    for (const Site& site : field.info().sites) {
      const std::string problem = NameProblem(site.id);
      if (!problem.empty()) {
        diag.Error((fs::path(folder) / "field.yaml").string(), 0,
                   "site '" + site.id + "': " + problem);
      }
    }
  } catch (const InputError& e) {
    diag.Error(e.file(), e.line(), e.message());
  }
  report.diagnostics = diag.items();
  std::stable_sort(report.diagnostics.begin(), report.diagnostics.end(),
                   [](const Diagnostic& a, const Diagnostic& b) {
                     return std::tie(a.file, a.line) < std::tie(b.file, b.line);
                   });
  report.errors = diag.error_count();
  report.warnings = diag.warning_count();
  report.suppressed = diag.suppressed();
  return report;
}

std::string FormatValidationSummary(const ValidationReport& report) {
  std::string out = fmt::format("field '{}' ({}): {} session{}\n", report.field_name, report.folder,
                                report.sessions.size(), report.sessions.size() == 1 ? "" : "s");
  for (const SessionReport& session : report.sessions) {
    out += fmt::format("\nsession {} (date {})\n", session.id,
                       session.date != 0 ? FormatDate(session.date) : std::string("unknown"));
    out += fmt::format("  {:<8} {:>9} {:>20} {:>12} {:>6} {:>8}  {}\n", "sensor", "samples",
                       "rate Hz (nominal)", "span", "gaps", "skipped", "notes");
    for (const SensorReport& s : session.sensors) {
      std::string notes;
      if (s.kind == SensorKind::kCamera) {
        notes =
            fmt::format("images: {} listed, {} missing, {} unreadable, {} not listed",
                        s.images_listed, s.images_missing, s.images_unreadable, s.images_unlisted);
      } else if (s.kind == SensorKind::kGps) {
        notes = FormatFixCounts(s.stats.fix_counts, s.samples);
      }
      if (s.stats.out_of_range > 0) {
        notes += fmt::format("{}{} out of range", notes.empty() ? "" : "; ", s.stats.out_of_range);
      }
      if (s.gaps > 0) {
        notes += fmt::format("{}longest gap {}", notes.empty() ? "" : "; ",
                             FormatDuration(s.longest_gap_s));
      }
      const std::string rate = fmt::format("{:.2f} ({:g})", s.mean_rate_hz, s.nominal_rate_hz);
      out += fmt::format("  {:<8} {:>9} {:>20} {:>12} {:>6} {:>8}  {}\n", s.name, s.samples, rate,
                         FormatDuration(s.span_s()), s.gaps, s.stats.skipped(), notes);
    }
    for (const std::string& reason : session.degradations) out += "  degraded: " + reason + "\n";
  }
  out += fmt::format("\n{} error{}, {} warning{}\n", report.errors, report.errors == 1 ? "" : "s",
                     report.warnings, report.warnings == 1 ? "" : "s");
  return out;
}

std::string ValidationReportJson(const ValidationReport& report) {
  using nlohmann::json;
  json root;
  root["folder"] = report.folder;
  root["field"] = report.field_name;
  root["ok"] = report.ok();
  root["errors"] = report.errors;
  root["warnings"] = report.warnings;
  json sessions = json::array();
  for (const SessionReport& session : report.sessions) {
    json s;
    s["id"] = session.id;
    s["date"] = session.date != 0 ? FormatDate(session.date) : std::string();
    json sensors = json::array();
    for (const SensorReport& sensor : session.sensors) {
      json j;
      j["name"] = sensor.name;
      j["kind"] = SensorKindName(sensor.kind);
      j["metadata_ok"] = sensor.metadata_ok;
      j["samples"] = sensor.samples;
      j["nominal_rate_hz"] = sensor.nominal_rate_hz;
      j["mean_rate_hz"] = sensor.mean_rate_hz;
      j["first_t_ns"] = sensor.first_t;
      j["last_t_ns"] = sensor.last_t;
      j["span_s"] = sensor.span_s();
      j["gaps"] = sensor.gaps;
      j["longest_gap_s"] = sensor.longest_gap_s;
      j["lines"] = sensor.stats.lines;
      j["bad_lines"] = sensor.stats.bad_lines;
      j["non_finite"] = sensor.stats.non_finite;
      j["duplicates"] = sensor.stats.duplicates;
      j["out_of_order"] = sensor.stats.out_of_order;
      j["invalid"] = sensor.stats.invalid;
      j["out_of_range"] = sensor.stats.out_of_range;
      if (sensor.kind == SensorKind::kGps) {
        json fixes = json::object();
        for (const auto& [code, count] : sensor.stats.fix_counts) fixes[GpsFixName(code)] = count;
        j["fix_counts"] = fixes;
      }
      if (sensor.kind == SensorKind::kCamera) {
        j["images_listed"] = sensor.images_listed;
        j["images_missing"] = sensor.images_missing;
        j["images_unreadable"] = sensor.images_unreadable;
        j["images_unlisted"] = sensor.images_unlisted;
      }
      sensors.push_back(j);
    }
    s["sensors"] = sensors;
    s["degradations"] = session.degradations;
    sessions.push_back(s);
  }
  root["sessions"] = sessions;
  json diagnostics = json::array();
  for (const Diagnostic& d : report.diagnostics) {
    diagnostics.push_back({{"severity", SeverityName(d.severity)},
                           {"file", d.file},
                           {"line", d.line},
                           {"message", d.message}});
  }
  root["diagnostics"] = diagnostics;
  json suppressed = json::object();
  for (const auto& [file, count] : report.suppressed) suppressed[file] = count;
  root["suppressed"] = suppressed;
  return root.dump(2, ' ', false, json::error_handler_t::replace) + "\n";
}

}  // namespace crop4d::io
