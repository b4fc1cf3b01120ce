#include "crop4d/io/tum.h"

#include <fmt/format.h>

#include <cctype>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::io {

std::string FormatTumLine(Timestamp t, const geometry::Rigid3& pose) {
  // Split into whole seconds and a non-negative nanosecond remainder (also before 1970).
  Timestamp seconds = t / kNanosPerSecond, nanos = t % kNanosPerSecond;
  if (nanos < 0) {
    nanos += kNanosPerSecond;
    --seconds;
  }
  const Eigen::Vector3d& p = pose.translation();
  const Eigen::Quaterniond& q = pose.rotation();
  return fmt::format("{}.{:09d} {:.6f} {:.6f} {:.6f} {:.9f} {:.9f} {:.9f} {:.9f}\n", seconds, nanos,
                     p.x(), p.y(), p.z(), q.x(), q.y(), q.z(), q.w());
}

void WriteTum(const std::string& path, const std::vector<StampedPose>& poses,
              const std::string& comment) {
  std::string text;
  std::istringstream lines(comment);
  for (std::string line; std::getline(lines, line);) text += "# " + line + "\n";
  text += "# t[s] tx ty tz qx qy qz qw\n";
  for (const StampedPose& p : poses) text += FormatTumLine(p.t, p.pose);
  WriteFileAtomic(path, text);
}

bool ParseTumTime(const std::string& text, Timestamp* t) {
  const size_t dot = text.find('.');
  const std::string whole = text.substr(0, dot);
  const std::string fraction = dot == std::string::npos ? "" : text.substr(dot + 1);
  const bool negative = !whole.empty() && whole[0] == '-';
  const std::string digits = negative ? whole.substr(1) : whole;
  if (digits.empty() || digits.size() > 11 || fraction.size() > 9) return false;
  for (char c : digits + fraction) {
    if (!std::isdigit(static_cast<unsigned char>(c))) return false;
  }
  const Timestamp seconds = std::stoll(digits);
  const Timestamp nanos =
      fraction.empty() ? 0 : std::stoll(fraction + std::string(9 - fraction.size(), '0'));
  *t = (negative ? -1 : 1) * (seconds * kNanosPerSecond + nanos);
  return true;
}

std::vector<StampedPose> ReadTum(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(path, 0, "cannot open the trajectory file");
  std::vector<StampedPose> poses;
  std::string line;
  for (std::int64_t number = 1; std::getline(in, line); ++number) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const size_t first = line.find_first_not_of(" \t");
    if (first == std::string::npos || line[first] == '#') continue;
    std::istringstream fields(line);
    std::vector<std::string> tokens;
    for (std::string token; fields >> token;) tokens.push_back(token);
    double v[7];
    bool numeric = tokens.size() == 8;
    for (int k = 0; numeric && k < 7; ++k) {
      // strtod (not operator>>) so that "nan" and "inf" parse and are reported as such.
      char* end = nullptr;
      v[k] = std::strtod(tokens[k + 1].c_str(), &end);
      numeric = end != tokens[k + 1].c_str() && *end == '\0';
    }
    if (!numeric) throw InputError(path, number, "expected 8 numbers: t tx ty tz qx qy qz qw");
    const std::string& time_text = tokens[0];
    StampedPose p;
    if (!ParseTumTime(time_text, &p.t)) {
      throw InputError(path, number, "'" + time_text + "' is not a timestamp in seconds");
    }
    for (double x : v) {
      if (!std::isfinite(x)) throw InputError(path, number, "NaN or infinite value");
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (q.norm() < 1e-6) throw InputError(path, number, "zero quaternion");
    if (!poses.empty() && p.t <= poses.back().t) {
      throw InputError(path, number, "timestamps are not strictly increasing");
    }
    p.pose = geometry::Rigid3(q, Eigen::Vector3d(v[0], v[1], v[2]));
    poses.push_back(p);
  }
  return poses;
}

}  // namespace crop4d::io
