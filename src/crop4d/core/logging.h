#pragma once

#include <spdlog/spdlog.h>

#include <string>

namespace crop4d {

// How much the CLI prints: -q gives kQuiet (warnings and errors), -v kVerbose (debug), -vv
// kTrace.
enum class Verbosity { kQuiet, kNormal, kVerbose, kTrace };

// Sets up the default spdlog logger: messages to stderr ("[info] ..." style, colour on a
// terminal), at the level that `verbosity` names. Safe to call more than once.
void InitLogging(Verbosity verbosity);

// Also writes every message (at debug level and above) to `path`, e.g. the workspace log file.
// Returns false with a warning when the file cannot be opened.
bool AddLogFile(const std::string& path);

// Maps the count of -v flags and the -q flag to a verbosity.
Verbosity VerbosityFromFlags(int verbose_count, bool quiet);

}  // namespace crop4d
