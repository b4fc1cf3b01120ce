#pragma once

// Reader of RTKLIB solution files (.pos), the usual output of open-source RTK processing
// (rtkpost, rnx2rtkp, rtknavi, demo5), for `crop4d import` (docs/import.md).
//
// A .pos file has '%' header lines and one epoch per line:
//
//   % program   : RTKLIB ver.demo5 b34k
//   % (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,...)
//   %  GPST          latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m) ...
//   2025/08/28 17:30:39.749   40.0966916 -105.1471665  1601.4350   1  25   0.0099   0.0099 ...
//
// The column header line (the last '%' line whose first word is GPST, UTC or JST) gives
//   - the time system: GPST, UTC or JST (JST is converted to UTC, UTC+9 h);
//   - the time format, seen in the data: "YYYY/MM/DD HH:MM:SS.sss" or "WEEK TOW" (GPS week and
//     seconds of the week);
//   - the position format: latitude/longitude in decimal degrees ("latitude(deg)"), in
//     degrees-minutes-seconds ("latitude(d'\")", three fields each) and the ellipsoidal height,
//     or ECEF x/y/z ("x-ecef(m)"), converted to WGS84 with GeographicLib. ENU baselines
//     ("e-baseline(m)") and NMEA output are not supported.
// Fields are separated by blanks or by commas (RTKLIB's "field separator" option). Without a
// column header, the file is read as GPST with latitude/longitude in degrees (a warning).
//
// Time: the calendar date and time of the file (or its week/seconds) become nanoseconds since
// the Unix epoch as if they were UTC, so the time scale of the input is kept (GPST stays GPST)
// unless Options::leap_seconds converts GPST to UTC. Timestamps of a session need only be
// consistent between its sensors.
//
// Fix quality: RTKLIB's Q becomes the NMEA GGA code of our format (docs/format.md):
//   Q 1 fix → 4 RTK fixed, 2 float → 5 RTK float, 3 SBAS → 2 DGPS, 4 DGPS → 2 DGPS,
//   5 single → 1 single, 6 PPP → 2 DGPS (a corrected solution; NMEA has no PPP code),
//   0 none and 7 dead reckoning → 0 none (read, not used as a position).
// Sigmas: sigma_h = sqrt((sdn² + sde²) / 2), the RMS of the two horizontal 1-sigmas (the
// per-axis horizontal sigma that our GPS factor takes), sigma_v = sdu. For ECEF files the ECEF
// covariance (sdx..sdzx, RTKLIB writes sign(c)·sqrt(|c|) for the off-diagonal terms) is rotated
// into the local ENU frame first.
//
// Errors: strict by default: a malformed line (wrong field count, a field that is not a
// number, a bad date, an unknown Q, timestamps not strictly increasing) throws InputError with
// the file and the line. With Options::skip_bad_lines the line is skipped with a warning.

#include <cstdint>
#include <istream>
#include <map>
#include <string>
#include <string_view>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"

namespace crop4d::io {

enum class PosTimeSystem { kGpst, kUtc, kJst };
enum class PosCoordinates { kLlhDegrees, kLlhDms, kEcef };

const char* PosTimeSystemName(PosTimeSystem system);
const char* PosCoordinatesName(PosCoordinates coordinates);

struct RtklibPosFile {
  struct Options {
    // GPST − UTC in seconds (18 since 2017-01-01), subtracted from GPST times to give UTC;
    // 0 keeps the file's time scale. Ignored (with a warning) for UTC and JST files.
    int leap_seconds = 0;
    // Skip malformed lines with a logged warning instead of throwing InputError.
    bool skip_bad_lines = false;
  };

  PosTimeSystem time_system = PosTimeSystem::kGpst;          // from the column header
  PosCoordinates coordinates = PosCoordinates::kLlhDegrees;  // from the column header
  bool column_header = false;                                // a column header line was found
  bool geoid_heights = false;           // the header says height=geodetic (not ellipsoidal)
  std::vector<GpsSample> samples;       // every epoch, in file order (strictly increasing t)
  std::map<int, std::int64_t> quality;  // epochs per RTKLIB Q value
  std::int64_t lines = 0;               // lines read
  std::int64_t skipped_lines = 0;       // malformed lines skipped (skip_bad_lines only)
};

// Reads a .pos file. Throws InputError naming the file (and line) when it cannot be read, has
// no epoch, or (strict mode) has a malformed line.
RtklibPosFile ReadRtklibPos(const std::string& path, const RtklibPosFile::Options& options = {});
// The same from a stream; `name` stands for the file in messages.
RtklibPosFile ReadRtklibPos(std::istream& in, const std::string& name,
                            const RtklibPosFile::Options& options = {});

// RTKLIB solution quality Q (0..7) to the NMEA GGA fix code of our format (see above); -1 for
// a value RTKLIB does not write.
int RtklibQualityToFix(int q);

// ---- time text ----------------------------------------------------------------------------

// Parses a plain decimal number "[-+]digits[.digits]" exactly into an integer count of
// 1/`units_per_one` of its unit, rounded half away from zero, e.g. ("12.3456789015", 1e9) →
// 12345678902 (seconds to nanoseconds). Exponent notation ("1.5e3") is accepted and converted
// through double. False when the text is not a number or the result overflows int64.
bool ParseDecimalScaled(std::string_view text, std::int64_t units_per_one, std::int64_t* value);

// "YYYY/MM/DD" (also "YYYY-MM-DD") and "HH:MM:SS[.fraction]" read as a UTC calendar time, to
// nanoseconds since the Unix epoch, exact to the nanosecond. False when either is not valid.
bool ParseCalendarTime(std::string_view date, std::string_view time, Timestamp* t);

// GPS week and seconds of the week (ns) to nanoseconds since the Unix epoch, in the GPS time
// scale (the GPS epoch 1980-01-06 00:00:00 is Unix time 315964800 s; no leap seconds).
Timestamp GpsWeekToTimestamp(std::int64_t week, Timestamp seconds_of_week_ns);

}  // namespace crop4d::io
