#include "crop4d/io/sensor_csv.h"

#include <fmt/format.h>

#include <cmath>
#include <memory>
#include <set>
#include <string_view>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_format.h"

namespace crop4d::io {
namespace {

// Column names from a header constant: "#timestamp [ns],w_x [rad s^-1]" -> timestamp, w_x.
std::vector<std::string> ColumnNames(const char* header) {
  std::vector<std::string> names;
  std::string_view text(header);
  if (!text.empty() && text.front() == '#') text.remove_prefix(1);
  std::vector<std::string_view> fields;
  SplitCsvLine(text, ',', &fields);
  for (std::string_view field : fields) {
    const std::size_t bracket = field.find(" [");
    names.emplace_back(field.substr(0, bracket));
  }
  return names;
}

// A time difference for messages: "500 ns", "12.5 us", "3 ms", "2.1 s".
std::string FormatNanos(std::int64_t ns) {
  if (ns < 1000) return fmt::format("{} ns", ns);
  if (ns < 1000000) return fmt::format("{:.3g} us", ns * 1e-3);
  if (ns < 1000000000) return fmt::format("{:.3g} ms", ns * 1e-6);
  return FormatDuration(ns * 1e-9);
}

std::string Shorten(std::string_view text) {
  constexpr std::size_t kMax = 32;
  if (text.size() <= kMax) return std::string(text);
  return std::string(text.substr(0, kMax)) + "...";
}

// The state of reading one file: the reader, the reporting, the counts, and the parsing of
// the fields of the current line.
class LineParser {
 public:
  // `long_header`: the header of a longer layout of the same file (optional trailing columns:
  // gps0's velocities); a file whose header or first record has its column count is read with
  // it, every line of the file then having that count.
  LineParser(CsvReader* reader, const char* header, Diagnostics* diag,
             const char* long_header = nullptr)
      : reader_(reader), header_(header), names_(ColumnNames(header)) {
    if (long_header != nullptr) {
      long_names_ = ColumnNames(long_header);
      long_header_text_ = long_header;
    }
    if (diag == nullptr) {
      Diagnostics::Options options;
      options.log = true;
      own_diag_ = std::make_unique<Diagnostics>(options);
      diag = own_diag_.get();
    }
    diag_ = diag;
  }

  void Error(std::int64_t line, const std::string& message) {
    diag_->Error(reader_->name(), line, message);
  }
  void Warning(std::int64_t line, const std::string& message) {
    diag_->Warning(reader_->name(), line, message);
  }

  // Reads the next record with the right column count; false at the end of the file.
  bool Next() {
    bad_ = non_finite_ = invalid_ = false;
    while (reader_->Next(&record_)) {
      if (first_record_) {
        first_record_ = false;
        if (!long_names_.empty()) {
          std::size_t count = record_.fields.size();
          if (reader_->header()) {
            std::vector<std::string_view> header_fields;
            SplitCsvLine(*reader_->header(), ',', &header_fields);
            count = header_fields.size();
          }
          if (count == long_names_.size()) {
            names_ = long_names_;
            header_ = long_header_text_;
          }
        }
        if (!reader_->header()) {
          std::int64_t t = 0;
          if (!record_.fields.empty() && !ParseInt64(record_.fields[0], &t) &&
              record_.fields.size() == names_.size()) {
            Warning(record_.line, "header line should start with '#' (expected \"" +
                                      std::string(header_) + "\")");
            stats_.header = true;
            continue;
          }
          Warning(record_.line, "missing header line \"" + std::string(header_) +
                                    "\"; reading this line as data");
        } else {
          stats_.header = true;
          std::vector<std::string_view> header_fields;
          SplitCsvLine(*reader_->header(), ',', &header_fields);
          if (header_fields.size() != names_.size()) {
            Warning(reader_->header_line(),
                    fmt::format("header has {} columns, expected {} (\"{}\")", header_fields.size(),
                                names_.size(), header_));
          }
        }
      }
      if (reader_->too_long()) {
        ++stats_.bad_lines;
        Error(record_.line, "line too long (not a text data file?)");
        continue;
      }
      if (record_.fields.size() != names_.size()) {
        ++stats_.bad_lines;
        Error(
            record_.line,
            fmt::format("expected {} columns, found {}{}", names_.size(), record_.fields.size(),
                        record_.unterminated ? " (the file ends in the middle of this line)" : ""));
        continue;
      }
      return true;
    }
    stats_.lines = reader_->lines_read();
    return false;
  }

  std::int64_t line() const { return record_.line; }
  std::string_view Field(int column) const { return record_.fields[column]; }

  // Parses the timestamp in column 0; a problem is reported and marks the line.
  void Time(Timestamp* t) {
    if (!ParseInt64(record_.fields[0], t)) {
      bad_ = true;
      Error(line(), "column 1 (timestamp): '" + Shorten(record_.fields[0]) +
                        "' is not an integer number of nanoseconds");
    } else if (*t < 0) {
      invalid_ = true;
      Error(line(), fmt::format("column 1 (timestamp): negative timestamp {}", *t));
    }
  }

  // Checks order against the last accepted sample; call last, once the line is otherwise good.
  bool Order(Timestamp t) {
    if (has_last_ && t == last_t_) {
      ++stats_.duplicates;
      Error(line(), fmt::format("duplicate timestamp {} (same as line {})", t, last_line_));
      return false;
    }
    if (has_last_ && t < last_t_) {
      ++stats_.out_of_order;
      Error(line(), fmt::format("timestamp {} is {} before the previous sample's (line {}); "
                                "timestamps must be strictly increasing",
                                t, FormatNanos(last_t_ - t), last_line_));
      return false;
    }
    return true;
  }

  // Parses numbers in columns [first, first + n); reports every bad one.
  void Numbers(int first, int n, double* out) {
    for (int i = 0; i < n; ++i) {
      const int column = first + i;
      if (!ParseDouble(record_.fields[column], &out[i])) {
        Error(line(), fmt::format("column {} ({}): '{}' is not a number", column + 1,
                                  names_[column], Shorten(record_.fields[column])));
        bad_ = true;
      } else if (!std::isfinite(out[i])) {
        Error(line(), fmt::format("column {} ({}): value is not finite ({})", column + 1,
                                  names_[column], Shorten(record_.fields[column])));
        non_finite_ = true;
      }
    }
  }

  // Marks the current line as unparseable / holding an impossible value (already reported).
  void MarkBad() { bad_ = true; }
  void MarkInvalid() { invalid_ = true; }

  // Number of columns of the file's layout.
  int columns() const { return static_cast<int>(names_.size()); }

  // Whether the current line has a problem; counts it once, under its worst kind.
  bool Skip() {
    if (bad_) {
      ++stats_.bad_lines;
    } else if (non_finite_) {
      ++stats_.non_finite;
    } else if (invalid_) {
      ++stats_.invalid;
    }
    return bad_ || non_finite_ || invalid_;
  }

  void Accept(Timestamp t) {
    has_last_ = true;
    last_t_ = t;
    last_line_ = line();
    ++stats_.samples;
  }

  DataFileStats& stats() { return stats_; }

  DataFileStats Finish() {
    stats_.lines = reader_->lines_read();
    if (stats_.samples == 0) {
      if (stats_.lines == 0) {
        Error(0, "empty file: no header and no samples");
      } else if (stats_.skipped() == 0) {
        Error(0, "no samples (the file has no data lines)");
      } else {
        Error(0, "no valid samples");
      }
    }
    return stats_;
  }

 private:
  CsvReader* reader_;
  const char* header_;
  std::vector<std::string> names_;
  std::vector<std::string> long_names_;
  const char* long_header_text_ = nullptr;
  Diagnostics* diag_;
  std::unique_ptr<Diagnostics> own_diag_;
  CsvRecord record_;
  DataFileStats stats_;
  bool first_record_ = true;
  bool bad_ = false, non_finite_ = false, invalid_ = false;  // problems of the current line
  bool has_last_ = false;
  Timestamp last_t_ = 0;
  std::int64_t last_line_ = 0;
};

DataFileStats ReadImages(CsvReader& reader, const SampleCallback<ImageEntry>& callback,
                         Diagnostics* diag) {
  LineParser p(&reader, kImageCsvHeader, diag);
  std::set<std::string> seen;
  while (p.Next()) {
    ImageEntry entry;
    p.Time(&entry.t);
    entry.filename = std::string(p.Field(1));
    const std::string& name = entry.filename;
    if (name.empty()) {
      p.MarkBad();
      p.Error(p.line(), "column 2 (filename): empty file name");
    }
    if (name.front() == '/' || name == ".." || name.rfind("../", 0) == 0 ||
        name.find("/../") != std::string::npos ||
        (name.size() >= 3 && name.compare(name.size() - 3, 3, "/..") == 0) ||
        name.find('\\') != std::string::npos || name.find('\0') != std::string::npos) {
      p.MarkInvalid();
      p.Error(p.line(), "column 2 (filename): '" + Shorten(name) +
                            "' must be a path inside the camera's data/ folder");
    }
    if (p.Skip() || !p.Order(entry.t)) continue;
    if (!seen.insert(name).second) {
      ++p.stats().duplicates;
      p.Error(p.line(), "file name '" + Shorten(name) + "' is listed twice");
      continue;
    }
    entry.line = p.line();
    p.Accept(entry.t);
    callback(entry, p.line());
  }
  return p.Finish();
}

DataFileStats ReadImu(CsvReader& reader, const SampleCallback<ImuSample>& callback,
                      Diagnostics* diag, const DataCheckLimits& limits) {
  LineParser p(&reader, kImuCsvHeader, diag);
  double v[6];
  while (p.Next()) {
    ImuSample s;
    p.Time(&s.t);
    p.Numbers(1, 6, v);
    if (p.Skip() || !p.Order(s.t)) continue;
    s.gyro = Eigen::Vector3d(v[0], v[1], v[2]);
    s.accel = Eigen::Vector3d(v[3], v[4], v[5]);
    if (s.gyro.cwiseAbs().maxCoeff() > limits.max_gyro_rad_s) {
      ++p.stats().out_of_range;
      p.Warning(p.line(), fmt::format("angular rate {:.4g} rad/s is beyond {} rad/s",
                                      s.gyro.cwiseAbs().maxCoeff(), limits.max_gyro_rad_s));
    } else if (s.accel.cwiseAbs().maxCoeff() > limits.max_accel_m_s2) {
      ++p.stats().out_of_range;
      p.Warning(p.line(), fmt::format("acceleration {:.4g} m/s^2 is beyond {} m/s^2",
                                      s.accel.cwiseAbs().maxCoeff(), limits.max_accel_m_s2));
    }
    p.Accept(s.t);
    callback(s, p.line());
  }
  return p.Finish();
}

DataFileStats ReadMag(CsvReader& reader, const SampleCallback<MagSample>& callback,
                      Diagnostics* diag, const DataCheckLimits& limits) {
  LineParser p(&reader, kMagCsvHeader, diag);
  double v[3];
  while (p.Next()) {
    MagSample s;
    p.Time(&s.t);
    p.Numbers(1, 3, v);
    if (p.Skip() || !p.Order(s.t)) continue;
    s.field_ut = Eigen::Vector3d(v[0], v[1], v[2]);
    if (s.field_ut.norm() > limits.max_mag_ut) {
      ++p.stats().out_of_range;
      p.Warning(p.line(), fmt::format("magnetic field {:.4g} uT is beyond {} uT", s.field_ut.norm(),
                                      limits.max_mag_ut));
    }
    p.Accept(s.t);
    callback(s, p.line());
  }
  return p.Finish();
}

DataFileStats ReadGps(CsvReader& reader, const SampleCallback<GpsSample>& callback,
                      Diagnostics* diag, const DataCheckLimits& limits) {
  LineParser p(&reader, kGpsCsvHeader, diag, kGpsCsvHeaderWithVelocity);
  double v[5];
  double velocity[4];
  while (p.Next()) {
    GpsSample s;
    p.Time(&s.t);
    p.Numbers(1, 3, v);
    // sigma_h and sigma_v may be left empty: 0 means "use the sensor's default".
    for (int i = 0; i < 2; ++i) {
      if (p.Field(4 + i).empty()) {
        v[3 + i] = 0.0;
      } else {
        p.Numbers(4 + i, 1, &v[3 + i]);
      }
    }
    std::int64_t fix = 0;
    if (!ParseInt64(p.Field(6), &fix)) {
      p.MarkBad();
      p.Error(p.line(),
              "column 7 (fix): '" + Shorten(p.Field(6)) + "' is not an NMEA fix code (0-8)");
    }
    // Optional velocity columns (ve, vn, vu, sigma_vel): empty fields mean no velocity.
    const bool has_velocity = p.columns() > 7 && !p.Field(7).empty();
    if (has_velocity) p.Numbers(7, 4, velocity);
    if (p.Skip()) continue;
    bool valid = true;
    if (has_velocity && velocity[3] < 0.0) {
      p.Error(p.line(), "negative velocity sigma");
      valid = false;
    }
    if (std::abs(v[0]) > 90.0) {
      p.Error(p.line(), fmt::format("column 2 (lat): latitude {} is outside [-90, 90]", v[0]));
      valid = false;
    }
    if (std::abs(v[1]) > 180.0) {
      p.Error(p.line(), fmt::format("column 3 (lon): longitude {} is outside [-180, 180]", v[1]));
      valid = false;
    }
    if (v[3] < 0.0 || v[4] < 0.0) {
      p.Error(p.line(), "negative sigma");
      valid = false;
    }
    if (fix < 0 || fix > 8) {
      p.Error(p.line(), fmt::format("column 7 (fix): {} is not an NMEA fix code (0-8)", fix));
      valid = false;
    }
    if (!valid) {
      p.MarkInvalid();
      p.Skip();
      continue;
    }
    if (!p.Order(s.t)) continue;
    s.position.lat_deg = v[0];
    s.position.lon_deg = v[1];
    s.position.alt_m = v[2];
    s.sigma_h = v[3];
    s.sigma_v = v[4];
    if (has_velocity) {
      s.velocity_enu = Eigen::Vector3d(velocity[0], velocity[1], velocity[2]);
      s.sigma_velocity = velocity[3];
    }
    if (IsGpsFixUsed(static_cast<int>(fix))) {
      s.fix = static_cast<GpsFix>(fix);
    } else {
      s.fix = GpsFix::kNone;
      p.Warning(p.line(), fmt::format("fix code {} ({}) is not a measured position; read as 0 "
                                      "(none)",
                                      fix, GpsFixName(static_cast<int>(fix))));
    }
    if (v[2] < limits.min_alt_m || v[2] > limits.max_alt_m) {
      ++p.stats().out_of_range;
      p.Warning(p.line(), fmt::format("altitude {} m is outside [{}, {}] m", v[2], limits.min_alt_m,
                                      limits.max_alt_m));
    } else if (v[3] > limits.max_gps_sigma_m || v[4] > limits.max_gps_sigma_m) {
      ++p.stats().out_of_range;
      p.Warning(p.line(), fmt::format("sigma {} m is beyond {} m", std::max(v[3], v[4]),
                                      limits.max_gps_sigma_m));
    }
    ++p.stats().fix_counts[static_cast<int>(fix)];
    p.Accept(s.t);
    callback(s, p.line());
  }
  return p.Finish();
}

}  // namespace

DataFileStats ReadImageCsv(const std::string& path, const SampleCallback<ImageEntry>& callback,
                           Diagnostics* diag) {
  CsvReader reader(path);
  return ReadImages(reader, callback, diag);
}
DataFileStats ReadImuCsv(const std::string& path, const SampleCallback<ImuSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits) {
  CsvReader reader(path);
  return ReadImu(reader, callback, diag, limits);
}
DataFileStats ReadMagCsv(const std::string& path, const SampleCallback<MagSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits) {
  CsvReader reader(path);
  return ReadMag(reader, callback, diag, limits);
}
DataFileStats ReadGpsCsv(const std::string& path, const SampleCallback<GpsSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits) {
  CsvReader reader(path);
  return ReadGps(reader, callback, diag, limits);
}

DataFileStats ReadImageCsv(std::istream& in, const std::string& name,
                           const SampleCallback<ImageEntry>& callback, Diagnostics* diag) {
  CsvReader reader(in, name);
  return ReadImages(reader, callback, diag);
}
DataFileStats ReadImuCsv(std::istream& in, const std::string& name,
                         const SampleCallback<ImuSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits) {
  CsvReader reader(in, name);
  return ReadImu(reader, callback, diag, limits);
}
DataFileStats ReadMagCsv(std::istream& in, const std::string& name,
                         const SampleCallback<MagSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits) {
  CsvReader reader(in, name);
  return ReadMag(reader, callback, diag, limits);
}
DataFileStats ReadGpsCsv(std::istream& in, const std::string& name,
                         const SampleCallback<GpsSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits) {
  CsvReader reader(in, name);
  return ReadGps(reader, callback, diag, limits);
}

}  // namespace crop4d::io
