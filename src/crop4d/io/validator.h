#pragma once

// `crop4d validate`: checks a field folder file by file and line by line, and summarises every
// sensor of every session (sample count, mean rate, time span, gaps, GPS fixes, images).
//
// Errors (the field cannot be used as it is): an unparseable line (wrong column count, a
// field that is not a number), NaN/inf in sensor data, timestamps not strictly increasing, an
// empty sensor file, malformed YAML or a missing/invalid required key, an image listed but
// missing or unreadable (or of the wrong size), a session without a camera.
// Warnings: gaps longer than Options::gap_periods sample periods, a mean rate off the nominal
// rate_hz, unknown YAML keys, images present but not listed, values out of physical range,
// timestamps that do not look like nanoseconds on the session's date, a missing IMU or GPS.
//
//   ValidationReport report = ValidateField("my_field");
//   for (const Diagnostic& d : report.diagnostics) std::cerr << d.ToString() << "\n";
//   return report.ok() ? 0 : 2;

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/diagnostics.h"
#include "crop4d/io/sensor_csv.h"

namespace crop4d::io {

struct ValidateOptions {
  // Decode every image completely (finds truncated files; slower) instead of checking the
  // file header and size only.
  bool decode_images = false;
  // A time between consecutive samples longer than this many nominal periods is a gap.
  double gap_periods = 3.0;
  // A mean rate further than this fraction from the nominal rate_hz is reported.
  double rate_tolerance = 0.05;
  // At most this many gaps (and unlisted images) are reported one by one per sensor; the
  // counts in the summary are always complete.
  int max_listed = 10;
  // Bounds of physically plausible sensor values.
  DataCheckLimits limits;
  // Only these sessions (empty: every session of the field).
  std::vector<std::string> sessions;
  // Show progress of the image checks (core/progress.h).
  bool progress = true;

  OptionCheck Check() const {
    OptionChecker c;
    c.Greater("gap_periods", gap_periods, 1.0)
        .Greater("rate_tolerance", rate_tolerance, 0.0)
        .AtLeast("max_listed", max_listed, 0);
    return c.Result();
  }
};

struct SensorReport {
  std::string name;  // "imu0"
  SensorKind kind = SensorKind::kImu;
  bool metadata_ok = false;           // sensor.yaml read without errors
  double nominal_rate_hz = 0.0;       // rate_hz from sensor.yaml (or the default)
  std::int64_t samples = 0;           // good samples in data.csv
  double mean_rate_hz = 0.0;          // (samples - 1) / span
  Timestamp first_t = 0, last_t = 0;  // time span of the good samples
  std::int64_t gaps = 0;              // gaps longer than gap_periods periods
  double longest_gap_s = 0.0;
  DataFileStats stats;  // line counts by problem; GPS fix counts
  // Cameras only.
  std::int64_t images_listed = 0;
  std::int64_t images_missing = 0;
  std::int64_t images_unreadable = 0;  // present but empty, not an image, or wrong size
  std::int64_t images_unlisted = 0;    // files in data/ not listed in data.csv

  double span_s() const { return samples > 1 ? DurationSeconds(first_t, last_t) : 0.0; }
};

struct SessionReport {
  std::string id;
  Timestamp date = 0;
  std::vector<SensorReport> sensors;
  // Why the session is below what its data promise or what the field's other sessions have (a
  // GPS receiver without a single fix, a sensor the other sessions have): each is also a
  // warning. `crop4d run` lists the session as degraded with these reasons.
  std::vector<std::string> degradations;
  // Why the session's name cannot be written into every output (NameProblem); empty when it
  // can. `crop4d run` skips such a session.
  std::string name_problem;
};

// Why `name` (a session folder or a site id) cannot be written into every output of crop4d:
// the CSV files (site_heights.csv, growth.csv, ...) hold it unquoted, so a comma, a double quote
// or a control character (a line break) would break their rows; a slash or backslash would
// make a file name of it a path. Empty when it can (spaces and any other Unicode can: the
// COLMAP export, which cannot hold a space, maps it to '_').
std::string NameProblem(const std::string& name);

struct ValidationReport {
  std::string folder;
  std::string field_name;
  std::vector<SessionReport> sessions;
  // Every problem found, sorted by file and line; paths are relative to the field folder.
  std::vector<Diagnostic> diagnostics;
  // Totals, including problems beyond the per-file limit of the collector.
  std::size_t errors = 0;
  std::size_t warnings = 0;
  std::map<std::string, std::size_t> suppressed;  // per file: problems counted, not listed

  bool ok() const { return errors == 0; }
};

// Validates the field folder `folder`. Never throws for bad input: every problem is in the
// report (a folder that does not exist is one error).
ValidationReport ValidateField(const std::string& folder,
                               const ValidateOptions& options = ValidateOptions());

// A plain-text summary table: one block per session, one line per sensor.
std::string FormatValidationSummary(const ValidationReport& report);

// The whole report (summary and diagnostics) as JSON.
std::string ValidationReportJson(const ValidationReport& report);

}  // namespace crop4d::io
