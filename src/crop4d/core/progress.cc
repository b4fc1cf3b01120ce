#include "crop4d/core/progress.h"

#include <spdlog/spdlog.h>
#include <unistd.h>

#include <cstdio>

#include "crop4d/core/timestamp.h"

namespace crop4d {

namespace {
std::atomic<bool> g_silent{false};
std::mutex g_prefix_mutex;
std::string g_prefix;
}  // namespace

void Progress::SetGloballySilent(bool silent) { g_silent = silent; }

void Progress::SetGlobalPrefix(const std::string& prefix) {
  std::lock_guard lock(g_prefix_mutex);
  g_prefix = prefix;
}

Progress::Progress(std::string label, std::uint64_t total, std::string unit)
    : Progress(std::move(label), total, std::move(unit), Options()) {}

Progress::Progress(std::string label, std::uint64_t total, std::string unit, Options options)
    : label_(std::move(label)),
      unit_(std::move(unit)),
      total_(total),
      options_(std::move(options)),
      start_(std::chrono::steady_clock::now()),
      last_report_(start_) {
  if (g_silent) options_.silent = true;
  tty_ = options_.force_tty >= 0 ? options_.force_tty == 1 : ::isatty(STDERR_FILENO) == 1;
}

Progress::~Progress() { Finish(); }

double Progress::ElapsedSeconds() const {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
}

double Progress::Rate() const {
  const double t = ElapsedSeconds();
  return t > 0 ? static_cast<double>(done_.load()) / t : 0.0;
}

double Progress::EtaSeconds() const {
  const std::uint64_t done = done_.load();
  if (total_ == 0 || done == 0) return -1.0;
  if (done >= total_) return 0.0;
  return static_cast<double>(total_ - done) / Rate();
}

void Progress::Add(std::uint64_t n) {
  done_ += n;
  if (options_.silent) return;
  const auto now = std::chrono::steady_clock::now();
  const double interval = tty_ ? 0.1 : options_.log_interval_s;
  // Cheap check without the lock; the lock keeps reports from interleaving.
  if (std::chrono::duration<double>(now - last_report_).count() < interval) return;
  std::unique_lock lock(mutex_, std::try_to_lock);
  if (!lock.owns_lock() || finished_) return;
  if (std::chrono::duration<double>(now - last_report_).count() < interval) return;
  last_report_ = now;
  Report(false);
}

void Progress::Finish() {
  std::lock_guard lock(mutex_);
  if (finished_) return;
  finished_ = true;
  if (!options_.silent) Report(true);
}

std::string Progress::Line(bool final_line) const {
  std::string prefix;
  {
    std::lock_guard lock(g_prefix_mutex);
    prefix = g_prefix;
  }
  return prefix + LineWithoutPrefix(final_line);
}

std::string Progress::LineWithoutPrefix(bool final_line) const {
  const std::uint64_t done = done_.load();
  const double rate = Rate();
  char buf[256];
  if (final_line) {
    std::snprintf(buf, sizeof(buf), "%s: %llu %s in %s (%.2f %s/s)", label_.c_str(),
                  static_cast<unsigned long long>(done), unit_.c_str(),
                  FormatDuration(ElapsedSeconds()).c_str(), rate, unit_.c_str());
    return buf;
  }
  if (total_ == 0) {
    std::snprintf(buf, sizeof(buf), "%s: %llu %s, %.2f %s/s", label_.c_str(),
                  static_cast<unsigned long long>(done), unit_.c_str(), rate, unit_.c_str());
    return buf;
  }
  const double fraction = std::min(1.0, static_cast<double>(done) / static_cast<double>(total_));
  const double eta = EtaSeconds();
  std::string bar;
  if (tty_) {
    constexpr int kWidth = 30;
    const int filled = static_cast<int>(fraction * kWidth);
    bar.reserve(kWidth + 3);
    bar.push_back('[');
    bar.append(filled, '#');
    bar.append(kWidth - filled, '.');
    bar.append("] ");
  }
  std::snprintf(buf, sizeof(buf), "%s: %s%3.0f%% %llu/%llu %s, %.2f %s/s, ETA %s", label_.c_str(),
                bar.c_str(), 100.0 * fraction, static_cast<unsigned long long>(done),
                static_cast<unsigned long long>(total_), unit_.c_str(), rate, unit_.c_str(),
                eta < 0 ? "?" : FormatDuration(eta).c_str());
  return buf;
}

void Progress::Report(bool final_line) {
  const std::string line = Line(final_line);
  if (options_.sink) {
    options_.sink(line);
  } else if (tty_) {
    std::fprintf(stderr, "\r\033[K%s%s", line.c_str(), final_line ? "\n" : "");
    std::fflush(stderr);
  } else {
    spdlog::info("{}", line);
  }
}

}  // namespace crop4d
