#include "crop4d/io/workspace_lock.h"

#include <fcntl.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/file.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <filesystem>

#include "crop4d/core/error.h"

namespace crop4d::io {

namespace {

// Reads the holder line a lock holder wrote into its lock file ("" when empty or unreadable).
std::string ReadHolderLine(int fd) {
  char buffer[512];
  const ssize_t n = ::pread(fd, buffer, sizeof(buffer) - 1, 0);
  if (n <= 0) return "";
  std::string text(buffer, static_cast<std::size_t>(n));
  if (const auto end = text.find('\n'); end != std::string::npos) text.resize(end);
  return text;
}

std::string HolderLine(const std::string& command) {
  char host[256] = "?";
  ::gethostname(host, sizeof(host) - 1);
  host[sizeof(host) - 1] = '\0';
  const std::time_t now = std::time(nullptr);
  std::tm utc{};
  ::gmtime_r(&now, &utc);
  char since[32];
  std::strftime(since, sizeof(since), "%Y-%m-%dT%H:%M:%SZ", &utc);
  return fmt::format("{}, pid {} on {}, since {}", command, ::getpid(), host, since);
}

int OpenLockFile(const std::string& path) {
  const int fd = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    throw InputError(path, 0,
                     fmt::format("cannot open the workspace lock: {}", std::strerror(errno)));
  }
  return fd;
}

// flock, retried when a signal interrupts it. Returns false when the lock is held elsewhere
// (non-blocking only).
bool Flock(int fd, int operation, const std::string& path) {
  while (::flock(fd, operation) != 0) {
    if (errno == EINTR) continue;
    if (errno == EWOULDBLOCK) return false;
    throw InputError(path, 0, fmt::format("cannot lock the workspace: {}", std::strerror(errno)));
  }
  return true;
}

}  // namespace

WorkspaceLock::WorkspaceLock(const std::filesystem::path& lock_file, const std::string& command,
                             IfBusy if_busy, Sharing sharing)
    : exclusive_(sharing == Sharing::kExclusive) {
  const std::string path = lock_file.string();
  fd_ = OpenLockFile(path);
  const int mode = exclusive_ ? LOCK_EX : LOCK_SH;
  try {
    if (!Flock(fd_, mode | LOCK_NB, path)) {
      const std::string holder = ReadHolderLine(fd_);
      // Shared holders write no line: an empty file while the lock is held means them.
      const std::string who =
          holder.empty() ? "another crop4d process (or the tasks of a cluster run: crop4d status)"
                         : holder;
      if (if_busy == IfBusy::kFail) {
        throw InputError(path, 0,
                         fmt::format("the workspace is in use by {}; run this again when it has "
                                     "ended (crop4d run --wait waits for it)",
                                     who));
      }
      spdlog::warn("the workspace is in use by {}: waiting until it ends", who);
      Flock(fd_, mode, path);
    }
    if (!exclusive_) return;
    const std::string line = HolderLine(command) + "\n";
    if (::ftruncate(fd_, 0) != 0 ||
        ::pwrite(fd_, line.data(), line.size(), 0) != static_cast<ssize_t>(line.size())) {
      spdlog::debug("could not write the holder into {}: {}", path, std::strerror(errno));
    }
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

WorkspaceLock::~WorkspaceLock() {
  if (fd_ < 0) return;
  if (!exclusive_) {
    ::close(fd_);
    return;
  }
  // Emptied first: a holder line in an unlocked file would name a process that has ended.
  if (::ftruncate(fd_, 0) != 0) {
    spdlog::debug("could not empty the workspace lock file: {}", std::strerror(errno));
  }
  ::close(fd_);
}

}  // namespace crop4d::io
