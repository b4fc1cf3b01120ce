#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>

namespace crop4d {

// Bad input: a file that cannot be read or parsed, a value out of range, a missing key.
// The CLI prints it as "error: <file>:<line>: <what is wrong>" and exits with code 2.
// Programmer mistakes are CHECKs that abort instead (DESIGN.md §7).
class InputError : public std::runtime_error {
 public:
  // line <= 0 means "the whole file" and is left out of the message.
  InputError(std::string file, std::int64_t line, std::string message);
  explicit InputError(std::string message) : InputError("", 0, std::move(message)) {}

  const std::string& file() const { return file_; }
  std::int64_t line() const { return line_; }
  // What is wrong, without the location.
  const std::string& message() const { return message_; }

 private:
  std::string file_;
  std::int64_t line_;
  std::string message_;
};

// Formats "<file>:<line>: <message>", leaving out empty parts.
std::string FormatLocation(const std::string& file, std::int64_t line, const std::string& message);

// Aborts with the expression, file and line when a programmer invariant does not hold.
[[noreturn]] void CheckFailed(const char* expression, const char* file, int line,
                              const std::string& detail);

}  // namespace crop4d

#define CROP4D_CHECK(cond)                                             \
  do {                                                                 \
    if (!(cond)) ::crop4d::CheckFailed(#cond, __FILE__, __LINE__, ""); \
  } while (0)

#define CROP4D_CHECK_MSG(cond, msg)                                       \
  do {                                                                    \
    if (!(cond)) ::crop4d::CheckFailed(#cond, __FILE__, __LINE__, (msg)); \
  } while (0)
