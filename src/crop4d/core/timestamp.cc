#include "crop4d/core/timestamp.h"

#include <chrono>
#include <cmath>
#include <cstdio>

namespace crop4d {

Timestamp SecondsToTimestamp(double seconds) {
  return static_cast<Timestamp>(std::llround(seconds * 1e9));
}

double TimestampToSeconds(Timestamp t) {
  // Split into whole seconds and the remainder so that the remainder keeps full precision.
  const Timestamp whole = t / kNanosPerSecond;
  const Timestamp rest = t % kNanosPerSecond;
  return static_cast<double>(whole) + static_cast<double>(rest) * 1e-9;
}

double DurationSeconds(Timestamp from, Timestamp to) { return TimestampToSeconds(to - from); }

Timestamp FromDate(int year, int month, int day) {
  using namespace std::chrono;
  const sys_days days =
      year_month_day{std::chrono::year{year}, std::chrono::month{static_cast<unsigned>(month)},
                     std::chrono::day{static_cast<unsigned>(day)}};
  return static_cast<Timestamp>(days.time_since_epoch().count()) * 86400 * kNanosPerSecond;
}

bool ParseDate(const std::string& text, Timestamp* t) {
  int y = 0, m = 0, d = 0;
  char tail = 0;
  if (text.size() != 10 || std::sscanf(text.c_str(), "%4d-%2d-%2d%c", &y, &m, &d, &tail) != 3) {
    return false;
  }
  if (text[4] != '-' || text[7] != '-') return false;
  const std::chrono::year_month_day ymd{std::chrono::year{y},
                                        std::chrono::month{static_cast<unsigned>(m)},
                                        std::chrono::day{static_cast<unsigned>(d)}};
  if (!ymd.ok()) return false;
  *t = FromDate(y, m, d);
  return true;
}

namespace {
void SplitDays(Timestamp t, std::chrono::year_month_day* ymd, Timestamp* nanos_of_day) {
  constexpr Timestamp kNanosPerDay = 86400 * kNanosPerSecond;
  Timestamp days = t / kNanosPerDay;
  Timestamp rest = t % kNanosPerDay;
  if (rest < 0) {
    rest += kNanosPerDay;
    --days;
  }
  *ymd = std::chrono::year_month_day{std::chrono::sys_days{std::chrono::days{days}}};
  *nanos_of_day = rest;
}
}  // namespace

std::string FormatTimestamp(Timestamp t) {
  std::chrono::year_month_day ymd;
  Timestamp rest = 0;
  SplitDays(t, &ymd, &rest);
  const Timestamp secs = rest / kNanosPerSecond;
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%04d-%02u-%02uT%02lld:%02lld:%02lld.%09lldZ",
                static_cast<int>(ymd.year()), static_cast<unsigned>(ymd.month()),
                static_cast<unsigned>(ymd.day()), static_cast<long long>(secs / 3600),
                static_cast<long long>((secs / 60) % 60), static_cast<long long>(secs % 60),
                static_cast<long long>(rest % kNanosPerSecond));
  return buf;
}

std::string FormatDate(Timestamp t) { return FormatTimestamp(t).substr(0, 10); }

std::string FormatDuration(double seconds) {
  char buf[64];
  if (!std::isfinite(seconds) || seconds < 0) return "?";
  if (seconds < 1.0) {
    std::snprintf(buf, sizeof(buf), "%.0f ms", seconds * 1e3);
  } else if (seconds < 60.0) {
    std::snprintf(buf, sizeof(buf), "%.1f s", seconds);
  } else if (seconds < 3600.0) {
    const long s = std::lround(seconds);
    std::snprintf(buf, sizeof(buf), "%ld min %02ld s", s / 60, s % 60);
  } else {
    const long m = std::lround(seconds / 60.0);
    std::snprintf(buf, sizeof(buf), "%ld h %02ld min", m / 60, m % 60);
  }
  return buf;
}

}  // namespace crop4d
