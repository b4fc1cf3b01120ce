#pragma once

// TUM RGB-D trajectory files (read by evo and most SLAM tools): one pose per line,
//   timestamp tx ty tz qx qy qz qw
// with the timestamp in seconds; lines starting with '#' are comments. crop4d writes the
// timestamp as "<seconds>.<9 digits>" so that it converts back to the exact int64 nanoseconds,
// and reads either that or any decimal number of seconds.

#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::io {

struct StampedPose {
  Timestamp t = 0;
  geometry::Rigid3 pose;  // e.g. world_from_camera
};

// One TUM line (with '\n'): translation to 1 µm, quaternion to 1e-9.
std::string FormatTumLine(Timestamp t, const geometry::Rigid3& pose);

// Writes `poses` atomically; `comment` (may hold several lines) is written first as '#' lines,
// followed by the column line "# t[s] tx ty tz qx qy qz qw".
void WriteTum(const std::string& path, const std::vector<StampedPose>& poses,
              const std::string& comment = "");

// Reads a TUM file. Throws InputError naming the file and line for a line that does not hold
// eight numbers, a zero quaternion, or timestamps that are not strictly increasing.
std::vector<StampedPose> ReadTum(const std::string& path);

// Parses a TUM timestamp ("1464177600.123456789", "1464177600.5", "12") into nanoseconds,
// exactly for up to 9 decimals. Returns false for anything else.
bool ParseTumTime(const std::string& text, Timestamp* t);

}  // namespace crop4d::io
