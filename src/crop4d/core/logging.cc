#include "crop4d/core/logging.h"

#include <spdlog/details/file_helper.h>
#include <spdlog/sinks/base_sink.h>
#include <spdlog/sinks/stdout_color_sinks.h>

#include <algorithm>
#include <atomic>
#include <mutex>
#include <string>

namespace crop4d {

namespace {
std::atomic<bool> g_quiet{false};

spdlog::level::level_enum ToLevel(Verbosity v) {
  switch (v) {
    case Verbosity::kQuiet:
      return spdlog::level::warn;
    case Verbosity::kNormal:
      return spdlog::level::info;
    case Verbosity::kVerbose:
      return spdlog::level::debug;
    case Verbosity::kTrace:
      return spdlog::level::trace;
  }
  return spdlog::level::info;
}
// A log file flushed after every line: a run killed at any moment keeps all it had logged.
// (spdlog's basic_file_sink is final and flushes only on request.)
class LineFlushedFileSink final : public spdlog::sinks::base_sink<std::mutex> {
 public:
  explicit LineFlushedFileSink(const std::string& path) { file_.open(path, /*truncate=*/false); }

 protected:
  void sink_it_(const spdlog::details::log_msg& msg) override {
    spdlog::memory_buf_t line;
    formatter_->format(msg, line);
    file_.write(line);
    file_.flush();
  }
  void flush_() override { file_.flush(); }

 private:
  spdlog::details::file_helper file_;
};
}  // namespace

void InitLogging(Verbosity verbosity) {
  auto logger = spdlog::get("crop4d");
  if (!logger) {
    auto sink = std::make_shared<spdlog::sinks::stderr_color_sink_mt>();
    sink->set_pattern("%^[%l]%$ %v");
    logger = std::make_shared<spdlog::logger>("crop4d", sink);
    spdlog::register_logger(logger);
    spdlog::set_default_logger(logger);
  }
  logger->sinks().front()->set_level(ToLevel(verbosity));
  g_quiet = ToLevel(verbosity) > spdlog::level::info;
  logger->set_level(spdlog::level::trace);
  logger->flush_on(spdlog::level::warn);
}

spdlog::sink_ptr AddLogFile(const std::string& path) {
  try {
    auto sink = std::make_shared<LineFlushedFileSink>(path);
    sink->set_pattern("%Y-%m-%d %H:%M:%S.%e [%l] %v");
    sink->set_level(spdlog::level::debug);
    spdlog::default_logger()->sinks().push_back(sink);
    return sink;
  } catch (const spdlog::spdlog_ex& e) {
    spdlog::warn("cannot open log file {}: {}", path, e.what());
    return nullptr;
  }
}

void RemoveLogSink(const spdlog::sink_ptr& sink) {
  if (!sink) return;
  sink->flush();
  auto& sinks = spdlog::default_logger()->sinks();
  sinks.erase(std::remove(sinks.begin(), sinks.end(), sink), sinks.end());
}

bool IsQuiet() { return g_quiet; }

Verbosity VerbosityFromFlags(int verbose_count, bool quiet) {
  if (quiet) return Verbosity::kQuiet;
  if (verbose_count >= 2) return Verbosity::kTrace;
  if (verbose_count == 1) return Verbosity::kVerbose;
  return Verbosity::kNormal;
}

}  // namespace crop4d
