#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <mutex>
#include <string>

namespace crop4d {

// Progress of a long loop, for every stage. Thread-safe: worker threads call Add() as they
// finish items. On a terminal (stderr is a TTY) it draws one bar line with count, rate and
// ETA, redrawn at most 10 times a second; otherwise (CI, a log file) it logs a line every
// `Options::log_interval_s` seconds. Finish() (or the destructor) prints the final line with
// the total time and mean rate.
//
//   Progress progress("render", images.size(), "img");
//   tbb::parallel_for(..., [&](size_t i) { Render(i); progress.Add(); });
class Progress {
 public:
  struct Options {
    // Seconds between log lines when stderr is not a terminal.
    double log_interval_s = 5.0;
    // Draw nothing at all (tests, --quiet).
    bool silent = false;
    // Force the terminal bar on or off; by default it follows isatty(stderr).
    int force_tty = -1;
    // Where lines go; by default spdlog (no TTY) or stderr (TTY). For tests.
    std::function<void(const std::string&)> sink;
  };

  // `label` names the work ("slam 2016-05-25/row03"), `total` the item count (0 = unknown),
  // `unit` what an item is ("img", "pair").
  Progress(std::string label, std::uint64_t total, std::string unit = "it");
  Progress(std::string label, std::uint64_t total, std::string unit, Options options);
  ~Progress();
  Progress(const Progress&) = delete;
  Progress& operator=(const Progress&) = delete;

  void Add(std::uint64_t n = 1);
  void Finish();

  std::uint64_t done() const { return done_.load(); }
  double ElapsedSeconds() const;
  // Items per second so far (0 before any).
  double Rate() const;
  // Estimated seconds left, or a negative number when unknown.
  double EtaSeconds() const;

  // Silences every Progress created after this call (the CLI's --quiet).
  static void SetGloballySilent(bool silent);
  // Puts `prefix` before the label of every line ("[3/8 fuse] "), so that the bars of a
  // multi-stage run read as one display of the whole run (`crop4d run`); "" removes it.
  static void SetGlobalPrefix(const std::string& prefix);

 private:
  void Report(bool final_line);
  std::string Line(bool final_line) const;
  std::string LineWithoutPrefix(bool final_line) const;

  std::string label_, unit_;
  std::uint64_t total_;
  Options options_;
  bool tty_;
  std::atomic<std::uint64_t> done_{0};
  std::chrono::steady_clock::time_point start_;
  std::mutex mutex_;
  std::chrono::steady_clock::time_point last_report_;
  bool finished_ = false;
};

}  // namespace crop4d
