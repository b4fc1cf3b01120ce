#pragma once

// Reader of IMU text files in other layouts than ours, for `crop4d import` (docs/import.md):
// a column mapping says which column holds what, and units say how to convert it to ours
// (timestamps in ns, angular rate in rad/s, specific force in m/s²). Samples stay in the IMU's
// own (sensor) frame; the mounting goes into imu0/sensor.yaml's T_BS.
//
//   ImuCsvFile::Options options;
//   options.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz,_,_,_,_");
//   options.accel_unit = ParseAccelUnit("g");
//   ImuCsvFile imu = ReadImuCsvMapped("imu.csv", options);
//
// Column names: `t` (also `time`, `timestamp`), `ax ay az` (also `a_x`..), `gx gy gz` (also
// `wx wy wz`, `w_x`..), each exactly once; `_` or `skip` ignores a column; a last entry `...`
// ignores any further columns. Without `...` every line must have exactly as many columns as
// the mapping names.
// Lines: the first Options::header_lines lines are skipped, then blank lines and lines starting
// with '#' or '%'. The delimiter is a comma, a semicolon, a tab or blanks; by default it is
// found from the first data line (comma, else semicolon, else tab, else blanks).
// Timestamps are parsed from their decimal text exactly (no rounding through double for plain
// decimals), so "1756402240.9610000" s is 1756402240961000000 ns.
// Errors are strict: a line with the wrong column count, a field that is not a finite number,
// a negative timestamp or one not after the previous line's throws InputError with the file
// and the line.

#include <cstdint>
#include <istream>
#include <string>
#include <string_view>
#include <vector>

#include "crop4d/io/dataset.h"

namespace crop4d::io {

enum class ImuTimeUnit { kSeconds, kMilliseconds, kMicroseconds, kNanoseconds };
enum class AccelUnit { kMetersPerSecond2, kStandardGravity };
enum class GyroUnit { kRadiansPerSecond, kDegreesPerSecond };

// What a column of the input holds.
enum class ImuColumn { kSkip, kTime, kAx, kAy, kAz, kGx, kGy, kGz, kRest };

// Parse the CLI's text forms; throw InputError naming the option and the accepted values.
// Time: s, ms, us, ns. Accelerometer: g, mps2 (also m/s2, m/s^2). Gyro: rads (also rad/s),
// degs (also deg/s, dps). Delimiter: auto, comma, semicolon, tab, space.
ImuTimeUnit ParseImuTimeUnit(std::string_view text);
AccelUnit ParseAccelUnit(std::string_view text);
GyroUnit ParseGyroUnit(std::string_view text);
char ParseDelimiter(std::string_view text);  // 0 = auto, ' ' = blanks
// "t,ax,ay,az,gx,gy,gz,_,_,_,_" (commas or blanks between names).
std::vector<ImuColumn> ParseImuColumns(std::string_view text);

// Nanoseconds per unit.
std::int64_t NanosPerUnit(ImuTimeUnit unit);

struct ImuCsvFile {
  struct Options {
    // What each column holds, in order (see above); the default is our own order with the
    // time first: t, gx, gy, gz, ax, ay, az.
    std::vector<ImuColumn> columns = {ImuColumn::kTime, ImuColumn::kGx, ImuColumn::kGy,
                                      ImuColumn::kGz,   ImuColumn::kAx, ImuColumn::kAy,
                                      ImuColumn::kAz};
    // Unit of the time column (a count of this unit since the Unix epoch).
    ImuTimeUnit time_unit = ImuTimeUnit::kSeconds;
    // Unit of the accelerometer columns (g = 9.80665 m/s²).
    AccelUnit accel_unit = AccelUnit::kMetersPerSecond2;
    // Unit of the gyro columns.
    GyroUnit gyro_unit = GyroUnit::kRadiansPerSecond;
    // Lines skipped at the start of the file (column titles, units).
    int header_lines = 0;
    // Field separator; 0 = found from the first data line, ' ' = runs of blanks.
    char delimiter = 0;
    // Added to every timestamp (e.g. to convert GPS time to UTC: −18 s since 2017), ns.
    std::int64_t time_offset_ns = 0;

    // Throws InputError when the mapping lacks a column or names one twice, or when
    // header_lines is negative.
    void Check() const;
  };

  std::vector<ImuSample> samples;  // in file order, strictly increasing t, SI units
  char delimiter = ',';            // the delimiter used
  std::int64_t lines = 0;          // lines read

  // (n − 1) / time span, or 0 with fewer than 2 samples.
  double MeanRateHz() const;
};

ImuCsvFile ReadImuCsvMapped(const std::string& path, const ImuCsvFile::Options& options = {});
// The same from a stream; `name` stands for the file in messages.
ImuCsvFile ReadImuCsvMapped(std::istream& in, const std::string& name,
                            const ImuCsvFile::Options& options = {});

}  // namespace crop4d::io
