#pragma once

// Streaming readers of the sensors' data.csv files (docs/format.md):
//   cam: #timestamp [ns],filename
//   imu: #timestamp [ns],w_x,w_y,w_z [rad s^-1],a_x,a_y,a_z [m s^-2]
//   mag: #timestamp [ns],m_x,m_y,m_z [uT]
//   gps: #timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix
//
// Each reader calls `callback(sample, line)` for every good line, in file order, holding one
// line in memory at a time. The samples delivered have strictly increasing timestamps and
// finite values. Problems are reported to `diag` (nullptr: logged) with the file and line:
//   errors (the line is skipped): wrong column count, a field that is not a number, NaN or
//     inf, a timestamp not after the previous sample's (duplicate or out of order),
//     impossible values (|lat| > 90, |lon| > 180, negative sigma, unknown fix code, an image
//     file name that leaves the folder), and a file without any sample;
//   warnings (the sample is kept): values beyond `DataCheckLimits`, a missing or odd header,
//     GPS fix codes crop4d does not use (3, 6, 7, 8; delivered as GpsFix::kNone).
// A file that cannot be opened (missing, a folder) throws InputError.

#include <cstdint>
#include <functional>
#include <istream>
#include <map>
#include <string>

#include "crop4d/io/dataset.h"
#include "crop4d/io/diagnostics.h"

namespace crop4d::io {

// Bounds of physically plausible sensor values; beyond them a sample is kept with a warning.
struct DataCheckLimits {
  // Largest angular rate per axis, rad/s (35 rad/s ≈ 2000 °/s, a common gyro full scale).
  double max_gyro_rad_s = 35.0;
  // Largest specific force per axis, m/s² (160 m/s² ≈ 16 g).
  double max_accel_m_s2 = 160.0;
  // Largest magnetic field norm, µT (the Earth's field is 25–65 µT).
  double max_mag_ut = 200.0;
  // Plausible ellipsoidal heights, metres.
  double min_alt_m = -500.0;
  double max_alt_m = 9000.0;
  // Largest plausible GPS sigma, metres.
  double max_gps_sigma_m = 1000.0;
};

struct DataFileStats {
  std::int64_t lines = 0;                  // lines read (header, comments and blank lines included)
  std::int64_t samples = 0;                // samples delivered to the callback
  std::int64_t bad_lines = 0;              // wrong column count or not a number (skipped)
  std::int64_t non_finite = 0;             // NaN or inf (skipped)
  std::int64_t duplicates = 0;             // same timestamp as the previous sample (skipped)
  std::int64_t out_of_order = 0;           // timestamp before the previous sample's (skipped)
  std::int64_t invalid = 0;                // impossible values (skipped)
  std::int64_t out_of_range = 0;           // beyond DataCheckLimits (kept)
  bool header = false;                     // the "#timestamp [ns],..." header line was found
  std::map<int, std::int64_t> fix_counts;  // GPS only: samples per NMEA fix code

  std::int64_t skipped() const {
    return bad_lines + non_finite + duplicates + out_of_order + invalid;
  }
};

template <typename Sample>
using SampleCallback = std::function<void(const Sample& sample, std::int64_t line)>;

DataFileStats ReadImageCsv(const std::string& path, const SampleCallback<ImageEntry>& callback,
                           Diagnostics* diag);
DataFileStats ReadImuCsv(const std::string& path, const SampleCallback<ImuSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits = DataCheckLimits());
DataFileStats ReadMagCsv(const std::string& path, const SampleCallback<MagSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits = DataCheckLimits());
DataFileStats ReadGpsCsv(const std::string& path, const SampleCallback<GpsSample>& callback,
                         Diagnostics* diag, const DataCheckLimits& limits = DataCheckLimits());

// The same from a stream (tests, fuzzing); `name` stands for the file in messages.
DataFileStats ReadImageCsv(std::istream& in, const std::string& name,
                           const SampleCallback<ImageEntry>& callback, Diagnostics* diag);
DataFileStats ReadImuCsv(std::istream& in, const std::string& name,
                         const SampleCallback<ImuSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits = DataCheckLimits());
DataFileStats ReadMagCsv(std::istream& in, const std::string& name,
                         const SampleCallback<MagSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits = DataCheckLimits());
DataFileStats ReadGpsCsv(std::istream& in, const std::string& name,
                         const SampleCallback<GpsSample>& callback, Diagnostics* diag,
                         const DataCheckLimits& limits = DataCheckLimits());

}  // namespace crop4d::io
