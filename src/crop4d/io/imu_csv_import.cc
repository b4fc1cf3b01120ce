#include "crop4d/io/imu_csv_import.h"

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>

#include "crop4d/core/error.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/rtklib_pos.h"

namespace crop4d::io {
namespace {

constexpr double kStandardGravity = 9.80665;  // m/s² per g
constexpr double kPi = 3.14159265358979323846;

std::string Lower(std::string_view text) {
  std::string out(text);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// Splits at runs of blanks.
void SplitBlanks(std::string_view line, std::vector<std::string_view>* fields) {
  fields->clear();
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && IsBlank(line[i])) ++i;
    const std::size_t start = i;
    while (i < line.size() && !IsBlank(line[i])) ++i;
    if (i > start) fields->push_back(line.substr(start, i - start));
  }
}

const char* ColumnName(ImuColumn column) {
  switch (column) {
    case ImuColumn::kTime:
      return "t";
    case ImuColumn::kAx:
      return "ax";
    case ImuColumn::kAy:
      return "ay";
    case ImuColumn::kAz:
      return "az";
    case ImuColumn::kGx:
      return "gx";
    case ImuColumn::kGy:
      return "gy";
    case ImuColumn::kGz:
      return "gz";
    case ImuColumn::kSkip:
      return "_";
    case ImuColumn::kRest:
      return "...";
  }
  return "?";
}

}  // namespace

ImuTimeUnit ParseImuTimeUnit(std::string_view text) {
  const std::string t = Lower(text);
  if (t == "s") return ImuTimeUnit::kSeconds;
  if (t == "ms") return ImuTimeUnit::kMilliseconds;
  if (t == "us") return ImuTimeUnit::kMicroseconds;
  if (t == "ns") return ImuTimeUnit::kNanoseconds;
  throw InputError("--imu-time-unit", 0,
                   "unknown time unit '" + std::string(text) + "' (expected s, ms, us or ns)");
}

AccelUnit ParseAccelUnit(std::string_view text) {
  const std::string t = Lower(text);
  if (t == "g") return AccelUnit::kStandardGravity;
  if (t == "mps2" || t == "m/s2" || t == "m/s^2") return AccelUnit::kMetersPerSecond2;
  throw InputError(
      "--accel-unit", 0,
      "unknown accelerometer unit '" + std::string(text) + "' (expected g or mps2, i.e. m/s^2)");
}

GyroUnit ParseGyroUnit(std::string_view text) {
  const std::string t = Lower(text);
  if (t == "rads" || t == "rad/s") return GyroUnit::kRadiansPerSecond;
  if (t == "degs" || t == "deg/s" || t == "dps") return GyroUnit::kDegreesPerSecond;
  throw InputError("--gyro-unit", 0,
                   "unknown gyro unit '" + std::string(text) +
                       "' (expected rads, i.e. rad/s, or degs, i.e. deg/s)");
}

char ParseDelimiter(std::string_view text) {
  const std::string t = Lower(text);
  if (t == "auto") return 0;
  if (t == "comma" || t == ",") return ',';
  if (t == "semicolon" || t == ";") return ';';
  if (t == "tab") return '\t';
  if (t == "space" || t == "blank" || t == "whitespace") return ' ';
  throw InputError("--imu-delimiter", 0,
                   "unknown delimiter '" + std::string(text) +
                       "' (expected auto, comma, semicolon, tab or space)");
}

std::vector<ImuColumn> ParseImuColumns(std::string_view text) {
  std::vector<ImuColumn> columns;
  std::size_t i = 0;
  while (i <= text.size()) {
    std::size_t end = i;
    while (end < text.size() && text[end] != ',' && !IsBlank(text[end])) ++end;
    const std::string name = Lower(text.substr(i, end - i));
    i = end + 1;
    if (name.empty()) {
      if (end >= text.size()) break;
      continue;
    }
    if (!columns.empty() && columns.back() == ImuColumn::kRest) {
      throw InputError("--imu-columns", 0, "'...' must be the last entry");
    }
    if (name == "t" || name == "time" || name == "timestamp") {
      columns.push_back(ImuColumn::kTime);
    } else if (name == "ax" || name == "a_x") {
      columns.push_back(ImuColumn::kAx);
    } else if (name == "ay" || name == "a_y") {
      columns.push_back(ImuColumn::kAy);
    } else if (name == "az" || name == "a_z") {
      columns.push_back(ImuColumn::kAz);
    } else if (name == "gx" || name == "wx" || name == "w_x") {
      columns.push_back(ImuColumn::kGx);
    } else if (name == "gy" || name == "wy" || name == "w_y") {
      columns.push_back(ImuColumn::kGy);
    } else if (name == "gz" || name == "wz" || name == "w_z") {
      columns.push_back(ImuColumn::kGz);
    } else if (name == "_" || name == "skip") {
      columns.push_back(ImuColumn::kSkip);
    } else if (name == "...") {
      columns.push_back(ImuColumn::kRest);
    } else {
      throw InputError("--imu-columns", 0,
                       "unknown column name '" + name +
                           "' (expected t, ax, ay, az, gx, gy, gz, _ or skip, and ... last)");
    }
  }
  return columns;
}

std::int64_t NanosPerUnit(ImuTimeUnit unit) {
  switch (unit) {
    case ImuTimeUnit::kSeconds:
      return kNanosPerSecond;
    case ImuTimeUnit::kMilliseconds:
      return 1'000'000;
    case ImuTimeUnit::kMicroseconds:
      return 1'000;
    case ImuTimeUnit::kNanoseconds:
      return 1;
  }
  return 1;
}

void ImuCsvFile::Options::Check() const {
  const ImuColumn required[] = {ImuColumn::kTime, ImuColumn::kAx, ImuColumn::kAy, ImuColumn::kAz,
                                ImuColumn::kGx,   ImuColumn::kGy, ImuColumn::kGz};
  for (ImuColumn column : required) {
    const auto count = std::count(columns.begin(), columns.end(), column);
    if (count == 0) {
      throw InputError("--imu-columns", 0,
                       std::string("the column mapping has no '") + ColumnName(column) +
                           "' column (it needs t, ax, ay, az, gx, gy, gz)");
    }
    if (count > 1) {
      throw InputError(
          "--imu-columns", 0,
          std::string("the column mapping names '") + ColumnName(column) + "' more than once");
    }
  }
  if (header_lines < 0) throw InputError("--imu-header-lines", 0, "must not be negative");
}

double ImuCsvFile::MeanRateHz() const {
  if (samples.size() < 2) return 0.0;
  return static_cast<double>(samples.size() - 1) /
         DurationSeconds(samples.front().t, samples.back().t);
}

ImuCsvFile ReadImuCsvMapped(const std::string& path, const ImuCsvFile::Options& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) {
    throw InputError(path, 0, "is a folder, not a file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the IMU file");
  return ReadImuCsvMapped(in, path, options);
}

ImuCsvFile ReadImuCsvMapped(std::istream& in, const std::string& name,
                            const ImuCsvFile::Options& options) {
  options.Check();
  const bool open_ended = options.columns.back() == ImuColumn::kRest;
  const std::size_t mapped = options.columns.size() - (open_ended ? 1 : 0);
  const std::int64_t nanos_per_unit = NanosPerUnit(options.time_unit);
  const double accel_scale =
      options.accel_unit == AccelUnit::kStandardGravity ? kStandardGravity : 1.0;
  const double gyro_scale = options.gyro_unit == GyroUnit::kDegreesPerSecond ? kPi / 180.0 : 1.0;

  ImuCsvFile result;
  char delimiter = options.delimiter;
  std::vector<std::string_view> fields;
  std::string line;
  std::int64_t line_number = 0;
  std::int64_t previous_line = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line_number <= options.header_lines) continue;
    if (line.size() > (1u << 16)) throw InputError(name, line_number, "line too long");
    std::size_t first = 0;
    while (first < line.size() && IsBlank(line[first])) ++first;
    if (first == line.size() || line[first] == '#' || line[first] == '%') continue;
    const std::string_view text(line);
    if (delimiter == 0) {
      delimiter = text.find(',') != std::string_view::npos    ? ','
                  : text.find(';') != std::string_view::npos  ? ';'
                  : text.find('\t') != std::string_view::npos ? '\t'
                                                              : ' ';
    }
    if (delimiter == ' ') {
      SplitBlanks(text, &fields);
    } else {
      SplitCsvLine(text, delimiter, &fields);
    }
    if (fields.size() < mapped || (!open_ended && fields.size() != mapped)) {
      throw InputError(
          name, line_number,
          "expected " + std::string(open_ended ? "at least " : "") + std::to_string(mapped) +
              " columns (as --imu-columns maps them), found " + std::to_string(fields.size()));
    }
    ImuSample sample;
    for (std::size_t k = 0; k < mapped; ++k) {
      const ImuColumn column = options.columns[k];
      if (column == ImuColumn::kSkip) continue;
      if (column == ImuColumn::kTime) {
        std::int64_t t = 0;
        if (!ParseDecimalScaled(fields[k], nanos_per_unit, &t)) {
          throw InputError(name, line_number,
                           "column " + std::to_string(k + 1) + " (time) is not a number: '" +
                               std::string(fields[k]) + "'");
        }
        sample.t = t + options.time_offset_ns;
        continue;
      }
      double value = 0.0;
      if (!ParseDouble(fields[k], &value) || !std::isfinite(value)) {
        throw InputError(name, line_number,
                         "column " + std::to_string(k + 1) + " (" + ColumnName(column) +
                             ") is not a finite number: '" + std::string(fields[k]) + "'");
      }
      switch (column) {
        case ImuColumn::kAx:
          sample.accel.x() = value * accel_scale;
          break;
        case ImuColumn::kAy:
          sample.accel.y() = value * accel_scale;
          break;
        case ImuColumn::kAz:
          sample.accel.z() = value * accel_scale;
          break;
        case ImuColumn::kGx:
          sample.gyro.x() = value * gyro_scale;
          break;
        case ImuColumn::kGy:
          sample.gyro.y() = value * gyro_scale;
          break;
        case ImuColumn::kGz:
          sample.gyro.z() = value * gyro_scale;
          break;
        default:
          break;
      }
    }
    if (sample.t < 0) {
      throw InputError(name, line_number,
                       "negative timestamp (times must count from the Unix epoch; check "
                       "--imu-time-unit)");
    }
    if (!result.samples.empty() && sample.t <= result.samples.back().t) {
      throw InputError(name, line_number,
                       "timestamp " + FormatTimestamp(sample.t) +
                           " is not after the previous line's (line " +
                           std::to_string(previous_line) + ")");
    }
    result.samples.push_back(sample);
    previous_line = line_number;
  }
  result.lines = line_number;
  result.delimiter = delimiter == 0 ? ',' : delimiter;
  if (in.bad()) throw InputError(name, 0, "read error");
  if (result.samples.empty()) throw InputError(name, 0, "no IMU samples in the file");
  return result;
}

}  // namespace crop4d::io
