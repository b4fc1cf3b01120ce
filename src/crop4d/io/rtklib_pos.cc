#include "crop4d/io/rtklib_pos.h"

#include <spdlog/spdlog.h>

#include <Eigen/Core>
#include <GeographicLib/Geocentric.hpp>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <optional>

#include "crop4d/core/error.h"
#include "crop4d/io/csv.h"

namespace crop4d::io {
namespace {

constexpr Timestamp kGpsEpochUnixSeconds = 315964800;  // 1980-01-06T00:00:00Z
constexpr Timestamp kSecondsPerWeek = 604800;
constexpr Timestamp kJstOffsetNs = 9 * 3600 * kNanosPerSecond;

bool IsBlank(char c) { return c == ' ' || c == '\t' || c == '\r' || c == '\n'; }

// Splits at blanks and commas (RTKLIB's default separator is blanks; its "field separator"
// option can make it a comma).
std::vector<std::string_view> Tokenize(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (IsBlank(line[i]) || line[i] == ',')) ++i;
    const std::size_t start = i;
    while (i < line.size() && !IsBlank(line[i]) && line[i] != ',') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

bool StartsWith(std::string_view text, std::string_view prefix) {
  return text.substr(0, prefix.size()) == prefix;
}

// Where each quantity sits in a data line (field indices; -1 = absent).
struct Layout {
  PosCoordinates coordinates = PosCoordinates::kLlhDegrees;
  int expected_fields = 0;  // 0 = unknown (no column header): at least min_fields
  int min_fields = 10;
  int pos[3] = {2, 3, 4};  // lat, lon, height or x, y, z (first field of a dms triple)
  int q = 5;
  int sd[3] = {7, 8, 9};           // sdn, sde, sdu or sdx, sdy, sdz
  int sd_cross[3] = {-1, -1, -1};  // sdxy, sdyz, sdzx (ECEF only)
  // Velocity (RTKLIB's "output velocity" option): vn, ve, vu or vx, vy, vz (ECEF), and their
  // standard deviations; -1 when absent.
  int vel[3] = {-1, -1, -1};
  int sd_vel[3] = {-1, -1, -1};
  std::int64_t header_line = 0;
};

Layout LayoutFromHeader(const std::vector<std::string_view>& tokens, const std::string& name,
                        std::int64_t line) {
  Layout layout;
  layout.header_line = line;
  layout.q = -1;
  for (int k = 0; k < 3; ++k) layout.pos[k] = layout.sd[k] = -1;
  bool dms = false;
  for (std::string_view token : tokens)
    dms = dms || (StartsWith(token, "latitude(d") && token != "latitude(deg)");
  bool ecef = false;
  int field = 2;  // the time (one header word) takes two data fields in both time formats
  for (std::size_t k = 1; k < tokens.size(); ++k) {
    const std::string_view token = tokens[k];
    int width = 1;
    if (StartsWith(token, "latitude")) {
      layout.pos[0] = field;
      width = dms ? 3 : 1;
    } else if (StartsWith(token, "longitude")) {
      layout.pos[1] = field;
      width = dms ? 3 : 1;
    } else if (StartsWith(token, "height")) {
      layout.pos[2] = field;
    } else if (StartsWith(token, "x-ecef")) {
      layout.pos[0] = field;
      ecef = true;
    } else if (StartsWith(token, "y-ecef")) {
      layout.pos[1] = field;
    } else if (StartsWith(token, "z-ecef")) {
      layout.pos[2] = field;
    } else if (StartsWith(token, "e-baseline") || StartsWith(token, "n-baseline") ||
               StartsWith(token, "u-baseline")) {
      throw InputError(name, line,
                       "ENU baseline solutions are not supported; output lat/lon/height or "
                       "ECEF x/y/z from RTKLIB (solution format 'llh' or 'xyz')");
    } else if (token == "Q") {
      layout.q = field;
    } else if (token == "sdn(m)" || token == "sdx(m)") {
      layout.sd[0] = field;
    } else if (token == "sde(m)" || token == "sdy(m)") {
      layout.sd[1] = field;
    } else if (token == "sdu(m)" || token == "sdz(m)") {
      layout.sd[2] = field;
    } else if (token == "vn(m/s)" || token == "vx-ecef(m/s)") {
      layout.vel[0] = field;
    } else if (token == "ve(m/s)" || token == "vy-ecef(m/s)") {
      layout.vel[1] = field;
    } else if (token == "vu(m/s)" || token == "vz-ecef(m/s)") {
      layout.vel[2] = field;
    } else if (token == "sdvn" || token == "sdvx") {
      layout.sd_vel[0] = field;
    } else if (token == "sdve" || token == "sdvy") {
      layout.sd_vel[1] = field;
    } else if (token == "sdvu" || token == "sdvz") {
      layout.sd_vel[2] = field;
    } else if (token == "sdxy(m)") {
      layout.sd_cross[0] = field;
    } else if (token == "sdyz(m)") {
      layout.sd_cross[1] = field;
    } else if (token == "sdzx(m)") {
      layout.sd_cross[2] = field;
    }
    field += width;
  }
  layout.expected_fields = field;
  layout.coordinates =
      ecef ? PosCoordinates::kEcef : (dms ? PosCoordinates::kLlhDms : PosCoordinates::kLlhDegrees);
  if (layout.pos[0] < 0 || layout.pos[1] < 0 || layout.pos[2] < 0 || layout.q < 0) {
    throw InputError(name, line,
                     "column header without latitude/longitude/height (or x/y/z-ecef) and Q "
                     "columns");
  }
  return layout;
}

double Number(const std::vector<std::string_view>& tokens, int index, const char* what) {
  double value = 0.0;
  if (!ParseDouble(tokens[index], &value) || !std::isfinite(value)) {
    throw InputError(
        "", 0, std::string(what) + " is not a finite number: '" + std::string(tokens[index]) + "'");
  }
  return value;
}

double Degrees(const std::vector<std::string_view>& tokens, int index, bool dms, const char* what) {
  if (!dms) return Number(tokens, index, what);
  const double d = Number(tokens, index, what);
  const double m = Number(tokens, index + 1, what);
  const double s = Number(tokens, index + 2, what);
  if (m < 0 || m >= 60 || s < 0 || s >= 60) {
    throw InputError("", 0, std::string(what) + " minutes or seconds out of [0, 60)");
  }
  const bool negative = !tokens[index].empty() && tokens[index][0] == '-';
  const double magnitude = std::abs(d) + m / 60.0 + s / 3600.0;
  return negative ? -magnitude : magnitude;
}

// One data line to a sample; throws InputError without a location (the caller adds it).
GpsSample ParseEpoch(const std::vector<std::string_view>& tokens, const Layout& layout,
                     int* quality) {
  const int n = static_cast<int>(tokens.size());
  if (layout.expected_fields > 0 && n != layout.expected_fields) {
    throw InputError("", 0,
                     "expected " + std::to_string(layout.expected_fields) +
                         " fields (as the column header on line " +
                         std::to_string(layout.header_line) + " says), found " + std::to_string(n));
  }
  if (n < layout.min_fields) {
    throw InputError("", 0,
                     "expected at least " + std::to_string(layout.min_fields) +
                         " fields (time, position, Q, ns, sigmas), found " + std::to_string(n));
  }
  GpsSample sample;
  // Time: "YYYY/MM/DD HH:MM:SS.sss" or "WEEK TOW".
  const std::string_view t0 = tokens[0];
  if (t0.find('/') != std::string_view::npos || (t0.size() == 10 && t0[4] == '-' && t0[7] == '-')) {
    if (!ParseCalendarTime(t0, tokens[1], &sample.t)) {
      throw InputError(
          "", 0,
          "not a valid date and time: '" + std::string(t0) + " " + std::string(tokens[1]) + "'");
    }
  } else {
    std::int64_t week = 0;
    Timestamp tow = 0;
    if (!ParseInt64(t0, &week) || week < 0 || week > 100000 ||
        !ParseDecimalScaled(tokens[1], kNanosPerSecond, &tow) || tow < 0 ||
        tow >= (kSecondsPerWeek + 1) * kNanosPerSecond) {
      throw InputError("", 0,
                       "not a valid date and time or GPS week and seconds of week: '" +
                           std::string(t0) + " " + std::string(tokens[1]) + "'");
    }
    sample.t = GpsWeekToTimestamp(week, tow);
  }

  // Quality.
  const double q = Number(tokens, layout.q, "Q");
  const int q_int = static_cast<int>(std::lround(q));
  if (q != q_int || RtklibQualityToFix(q_int) < 0) {
    throw InputError("", 0,
                     "unknown solution quality Q=" + std::string(tokens[layout.q]) +
                         " (RTKLIB: 1 fix, 2 float, 3 sbas, 4 dgps, 5 single, 6 ppp)");
  }
  *quality = q_int;
  sample.fix = static_cast<GpsFix>(RtklibQualityToFix(q_int));

  // Sigmas (optional columns).
  double sd[3] = {0, 0, 0};
  for (int k = 0; k < 3; ++k) {
    if (layout.sd[k] < 0) continue;
    sd[k] = Number(tokens, layout.sd[k], k == 0 ? "sdn" : (k == 1 ? "sde" : "sdu"));
    if (sd[k] < 0) throw InputError("", 0, "negative standard deviation");
  }

  // Velocity (optional columns): as written, north/east/up or ECEF x/y/z.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero(), sd_velocity = Eigen::Vector3d::Zero();
  const bool has_velocity = layout.vel[0] >= 0 && layout.vel[1] >= 0 && layout.vel[2] >= 0;
  if (has_velocity) {
    for (int k = 0; k < 3; ++k) {
      velocity[k] = Number(tokens, layout.vel[k], "velocity");
      if (layout.sd_vel[k] >= 0) sd_velocity[k] = Number(tokens, layout.sd_vel[k], "sdv");
    }
    if ((sd_velocity.array() < 0).any()) {
      throw InputError("", 0, "negative velocity standard deviation");
    }
  }

  if (layout.coordinates == PosCoordinates::kEcef) {
    const double x = Number(tokens, layout.pos[0], "x-ecef");
    const double y = Number(tokens, layout.pos[1], "y-ecef");
    const double z = Number(tokens, layout.pos[2], "z-ecef");
    if (std::sqrt(x * x + y * y + z * z) < 1e6) {
      throw InputError("", 0, "ECEF position is not near the Earth's surface (|x| < 1000 km)");
    }
    std::vector<double> enu_to_ecef(9);
    GeographicLib::Geocentric::WGS84().Reverse(x, y, z, sample.position.lat_deg,
                                               sample.position.lon_deg, sample.position.alt_m,
                                               enu_to_ecef);
    // RTKLIB writes the covariance as sign(c) sqrt(|c|).
    auto variance = [](double s) { return s * std::abs(s); };
    Eigen::Matrix3d cov_ecef = Eigen::Matrix3d::Zero();
    for (int k = 0; k < 3; ++k) cov_ecef(k, k) = sd[k] * sd[k];
    const int pairs[3][2] = {{0, 1}, {1, 2}, {2, 0}};
    for (int k = 0; k < 3; ++k) {
      if (layout.sd_cross[k] < 0) continue;
      const double c = variance(Number(tokens, layout.sd_cross[k], "covariance"));
      cov_ecef(pairs[k][0], pairs[k][1]) = cov_ecef(pairs[k][1], pairs[k][0]) = c;
    }
    // GeographicLib's M is row-major with v_ecef = M v_enu.
    const Eigen::Matrix3d m =
        Eigen::Map<const Eigen::Matrix<double, 3, 3, Eigen::RowMajor>>(enu_to_ecef.data());
    const Eigen::Matrix3d cov_enu = m.transpose() * cov_ecef * m;
    sample.sigma_h = std::sqrt(std::max(0.0, (cov_enu(0, 0) + cov_enu(1, 1)) / 2.0));
    sample.sigma_v = std::sqrt(std::max(0.0, cov_enu(2, 2)));
    if (has_velocity) {
      sample.velocity_enu = m.transpose() * velocity;
      sample.sigma_velocity = std::sqrt(sd_velocity.squaredNorm() / 3.0);
    }
  } else {
    const bool dms = layout.coordinates == PosCoordinates::kLlhDms;
    sample.position.lat_deg = Degrees(tokens, layout.pos[0], dms, "latitude");
    sample.position.lon_deg = Degrees(tokens, layout.pos[1], dms, "longitude");
    sample.position.alt_m = Number(tokens, layout.pos[2], "height");
    if (std::abs(sample.position.lat_deg) > 90 || std::abs(sample.position.lon_deg) > 180) {
      throw InputError("", 0, "latitude beyond ±90° or longitude beyond ±180°");
    }
    sample.sigma_h = std::sqrt((sd[0] * sd[0] + sd[1] * sd[1]) / 2.0);
    sample.sigma_v = sd[2];
    if (has_velocity) {
      sample.velocity_enu = Eigen::Vector3d(velocity[1], velocity[0], velocity[2]);
      sample.sigma_velocity = std::sqrt(sd_velocity.squaredNorm() / 3.0);
    }
  }
  return sample;
}

}  // namespace

const char* PosTimeSystemName(PosTimeSystem system) {
  switch (system) {
    case PosTimeSystem::kGpst:
      return "GPST";
    case PosTimeSystem::kUtc:
      return "UTC";
    case PosTimeSystem::kJst:
      return "JST";
  }
  return "?";
}

const char* PosCoordinatesName(PosCoordinates coordinates) {
  switch (coordinates) {
    case PosCoordinates::kLlhDegrees:
      return "lat/lon/height (degrees)";
    case PosCoordinates::kLlhDms:
      return "lat/lon/height (degrees, minutes, seconds)";
    case PosCoordinates::kEcef:
      return "ECEF x/y/z";
  }
  return "?";
}

int RtklibQualityToFix(int q) {
  switch (q) {
    case 0:  // none
      return static_cast<int>(GpsFix::kNone);
    case 1:  // fix
      return static_cast<int>(GpsFix::kRtkFixed);
    case 2:  // float
      return static_cast<int>(GpsFix::kRtkFloat);
    case 3:  // SBAS
    case 4:  // DGPS
    case 6:  // PPP
      return static_cast<int>(GpsFix::kDgps);
    case 5:  // single
      return static_cast<int>(GpsFix::kSingle);
    case 7:  // dead reckoning
      return static_cast<int>(GpsFix::kNone);
    default:
      return -1;
  }
}

bool ParseDecimalScaled(std::string_view text, std::int64_t units_per_one, std::int64_t* value) {
  CROP4D_CHECK(units_per_one >= 1);
  constexpr std::int64_t kMax = std::numeric_limits<std::int64_t>::max();
  if (text.empty()) return false;
  if (text.find_first_of("eE") != std::string_view::npos) {
    double d = 0.0;
    if (!ParseDouble(text, &d) || !std::isfinite(d)) return false;
    const long double scaled = static_cast<long double>(d) * units_per_one;
    if (std::fabs(scaled) >= 9.2e18L) return false;
    *value = std::llround(scaled);
    return true;
  }
  std::size_t i = 0;
  bool negative = false;
  if (text[0] == '+' || text[0] == '-') {
    negative = text[0] == '-';
    i = 1;
  }
  auto is_digit = [](char c) { return c >= '0' && c <= '9'; };
  bool any_digit = false;
  std::int64_t whole = 0;
  for (; i < text.size() && is_digit(text[i]); ++i) {
    if (whole > (kMax - 9) / 10) return false;
    whole = whole * 10 + (text[i] - '0');
    any_digit = true;
  }
  std::int64_t fraction = 0;
  if (i < text.size() && text[i] == '.') {
    ++i;
    std::int64_t place = units_per_one;
    bool rounding_digit_seen = false;
    for (; i < text.size() && is_digit(text[i]); ++i) {
      any_digit = true;
      const int digit = text[i] - '0';
      if (place >= 10) {
        place /= 10;
        fraction += digit * place;
      } else if (!rounding_digit_seen) {
        rounding_digit_seen = true;
        if (digit >= 5) ++fraction;
      }
    }
  }
  if (i != text.size() || !any_digit) return false;
  if (whole > (kMax - fraction) / units_per_one) return false;
  const std::int64_t result = whole * units_per_one + fraction;
  *value = negative ? -result : result;
  return true;
}

bool ParseCalendarTime(std::string_view date, std::string_view time, Timestamp* t) {
  auto split = [](std::string_view text, std::string_view separators) {
    std::vector<std::string_view> parts;
    std::size_t start = 0;
    for (std::size_t i = 0; i <= text.size(); ++i) {
      if (i == text.size() || separators.find(text[i]) != std::string_view::npos) {
        parts.push_back(text.substr(start, i - start));
        start = i + 1;
      }
    }
    return parts;
  };
  const std::vector<std::string_view> ymd = split(date, "/-");
  const std::vector<std::string_view> hms = split(time, ":");
  if (ymd.size() != 3 || hms.size() != 3) return false;
  std::int64_t y = 0, mo = 0, d = 0, h = 0, mi = 0;
  Timestamp s_ns = 0;
  if (!ParseInt64(ymd[0], &y) || !ParseInt64(ymd[1], &mo) || !ParseInt64(ymd[2], &d) ||
      !ParseInt64(hms[0], &h) || !ParseInt64(hms[1], &mi) ||
      !ParseDecimalScaled(hms[2], kNanosPerSecond, &s_ns)) {
    return false;
  }
  if (ymd[0].size() != 4 || y < 1900 || y > 2999 || mo < 1 || mo > 12 || d < 1 || d > 31) {
    return false;
  }
  const std::chrono::year_month_day calendar{std::chrono::year(static_cast<int>(y)),
                                             std::chrono::month(static_cast<unsigned>(mo)),
                                             std::chrono::day(static_cast<unsigned>(d))};
  if (!calendar.ok() || h < 0 || h > 23 || mi < 0 || mi > 59 || s_ns < 0 ||
      s_ns >= 60 * kNanosPerSecond || hms[2].empty() || hms[2][0] == '-' || hms[2][0] == '+') {
    return false;
  }
  *t = FromDate(static_cast<int>(y), static_cast<int>(mo), static_cast<int>(d)) +
       (h * 3600 + mi * 60) * kNanosPerSecond + s_ns;
  return true;
}

Timestamp GpsWeekToTimestamp(std::int64_t week, Timestamp seconds_of_week_ns) {
  return (kGpsEpochUnixSeconds + week * kSecondsPerWeek) * kNanosPerSecond + seconds_of_week_ns;
}

RtklibPosFile ReadRtklibPos(const std::string& path, const RtklibPosFile::Options& options) {
  std::error_code ec;
  if (std::filesystem::is_directory(path, ec)) throw InputError(path, 0, "is a folder, not a file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the RTKLIB solution file");
  return ReadRtklibPos(in, path, options);
}

RtklibPosFile ReadRtklibPos(std::istream& in, const std::string& name,
                            const RtklibPosFile::Options& options) {
  RtklibPosFile result;
  Layout layout;
  bool warned_no_header = false;
  std::optional<std::int64_t> previous_line;
  std::string line;
  std::int64_t line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    if (line.size() > (1u << 16)) {
      throw InputError(name, line_number, "line too long: not an RTKLIB solution file?");
    }
    std::string_view text(line);
    std::size_t first = 0;
    while (first < text.size() && IsBlank(text[first])) ++first;
    if (first == text.size()) continue;  // blank line
    if (text[first] == '%' || text[first] == '#') {
      const std::vector<std::string_view> tokens = Tokenize(text.substr(first + 1));
      if (text.find("height=geodetic") != std::string_view::npos) result.geoid_heights = true;
      if (!tokens.empty() && (tokens[0] == "GPST" || tokens[0] == "UTC" || tokens[0] == "JST")) {
        if (!result.samples.empty()) {
          throw InputError(name, line_number, "a second column header after solution epochs");
        }
        layout = LayoutFromHeader(tokens, name, line_number);
        result.column_header = true;
        result.coordinates = layout.coordinates;
        result.time_system = tokens[0] == "GPST"  ? PosTimeSystem::kGpst
                             : tokens[0] == "UTC" ? PosTimeSystem::kUtc
                                                  : PosTimeSystem::kJst;
      }
      continue;
    }
    if (!result.column_header && !warned_no_header) {
      warned_no_header = true;
      spdlog::warn(
          "{}: no RTKLIB column header ('%  GPST  latitude(deg) ...'): reading GPST "
          "time and latitude/longitude/height in degrees",
          name);
    }
    try {
      int quality = 0;
      GpsSample sample = ParseEpoch(Tokenize(text), layout, &quality);
      if (result.time_system == PosTimeSystem::kJst) sample.t -= kJstOffsetNs;
      if (result.time_system == PosTimeSystem::kGpst) {
        sample.t -= static_cast<Timestamp>(options.leap_seconds) * kNanosPerSecond;
      }
      if (!result.samples.empty() && sample.t <= result.samples.back().t) {
        throw InputError("", 0,
                         "time " + FormatTimestamp(sample.t) +
                             " is not after the previous epoch's (line " +
                             std::to_string(*previous_line) + ")");
      }
      result.samples.push_back(sample);
      ++result.quality[quality];
      previous_line = line_number;
    } catch (const InputError& e) {
      if (!options.skip_bad_lines) throw InputError(name, line_number, e.message());
      ++result.skipped_lines;
      spdlog::warn("{} (line skipped)", FormatLocation(name, line_number, e.message()));
    }
  }
  result.lines = line_number;
  if (in.bad()) throw InputError(name, 0, "read error");
  if (result.samples.empty()) throw InputError(name, 0, "no solution epochs in the file");
  if (options.leap_seconds != 0 && result.time_system != PosTimeSystem::kGpst) {
    spdlog::warn("{}: times are already {}; --leap-seconds {} is not applied", name,
                 PosTimeSystemName(result.time_system), options.leap_seconds);
  }
  if (result.geoid_heights) {
    spdlog::warn(
        "{}: heights are geodetic (above the geoid), not ellipsoidal as crop4d "
        "expects; set RTKLIB's height option to 'ellipsoidal'",
        name);
  }
  return result;
}

}  // namespace crop4d::io
