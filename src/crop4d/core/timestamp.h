#pragma once

#include <cstdint>
#include <string>

namespace crop4d {

// Time everywhere in crop4d: nanoseconds since the Unix epoch (DESIGN.md §3).
using Timestamp = std::int64_t;

inline constexpr Timestamp kNanosPerSecond = 1'000'000'000;
inline constexpr Timestamp kNanosPerMillisecond = 1'000'000;

// Seconds (double) to nanoseconds, rounded to the nearest nanosecond.
Timestamp SecondsToTimestamp(double seconds);

// Nanoseconds to seconds. Exact to ~0.2 µs for present-day epochs (double has 53 bits).
double TimestampToSeconds(Timestamp t);

// Duration between two timestamps in seconds, computed in integers first so that it stays
// exact for the small differences the estimators use.
double DurationSeconds(Timestamp from, Timestamp to);

// Timestamp for midnight UTC of a calendar date, e.g. FromDate(2016, 5, 25).
Timestamp FromDate(int year, int month, int day);

// Parses "YYYY-MM-DD" into midnight UTC. Returns false when the text is not a valid date.
bool ParseDate(const std::string& text, Timestamp* t);

// ISO-8601 UTC with nanoseconds, e.g. "2016-05-25T14:03:07.123456789Z".
std::string FormatTimestamp(Timestamp t);

// "YYYY-MM-DD" of a timestamp (UTC).
std::string FormatDate(Timestamp t);

// A human duration: "850 ms", "12.3 s", "4 min 05 s", "1 h 02 min".
std::string FormatDuration(double seconds);

}  // namespace crop4d
