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

// Also writes every message (at debug level and above) to `path`, appending and flushed line by
// line, e.g. the workspace log file. Returns the sink (for RemoveLogSink), or null with a warning
// when the file cannot be opened.
spdlog::sink_ptr AddLogFile(const std::string& path);

// Takes a sink added by AddLogFile off the default logger (flushing it first); null is ignored.
void RemoveLogSink(const spdlog::sink_ptr& sink);

// True when the terminal shows only warnings and errors (-q): commands leave out their result
// tables then. (The default logger itself stays at trace level so that the log file of a run
// gets debug messages; its level says nothing about the terminal.)
bool IsQuiet();

// Maps the count of -v flags and the -q flag to a verbosity.
Verbosity VerbosityFromFlags(int verbose_count, bool quiet);

}  // namespace crop4d
