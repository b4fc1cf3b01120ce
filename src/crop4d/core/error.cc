#include "crop4d/core/error.h"

#include <cstdio>
#include <cstdlib>

namespace crop4d {

std::string FormatLocation(const std::string& file, std::int64_t line, const std::string& message) {
  std::string out;
  if (!file.empty()) {
    out += file;
    if (line > 0) {
      out += ':';
      out += std::to_string(line);
    }
    out += ": ";
  }
  out += message;
  return out;
}

InputError::InputError(std::string file, std::int64_t line, std::string message)
    : std::runtime_error(FormatLocation(file, line, message)),
      file_(std::move(file)),
      line_(line),
      message_(std::move(message)) {}

void CheckFailed(const char* expression, const char* file, int line, const std::string& detail) {
  std::fprintf(stderr, "crop4d: internal check failed at %s:%d: %s%s%s\n", file, line, expression,
               detail.empty() ? "" : ": ", detail.c_str());
  std::fflush(stderr);
  std::abort();
}

}  // namespace crop4d
