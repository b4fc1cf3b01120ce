#include "crop4d/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

std::string TemporaryPath(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

}  // namespace

AtomicFile::AtomicFile(std::string path) : path_(std::move(path)) {
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  if (!parent.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(parent, ec);
    if (ec) {
      throw InputError(path_, 0, "cannot create folder " + parent.string() + ": " + ec.message());
    }
  }
  std::error_code ec;
  if (std::filesystem::is_directory(path_, ec)) {
    throw InputError(path_, 0, "cannot write: it is a folder");
  }
  tmp_path_ = TemporaryPath(path_);
  stream_.open(tmp_path_, std::ios::binary | std::ios::trunc);
  if (!stream_) {
    throw InputError(path_, 0, std::string("cannot create: ") + std::strerror(errno));
  }
}

AtomicFile::~AtomicFile() {
  if (committed_) return;
  stream_.close();
  std::error_code ec;
  std::filesystem::remove(tmp_path_, ec);
}

void AtomicFile::Commit() {
  if (committed_) throw InputError(path_, 0, "written twice (internal error)");
  stream_.flush();
  const bool written = static_cast<bool>(stream_);
  stream_.close();
  if (!written || stream_.fail()) {
    std::error_code ec;
    std::filesystem::remove(tmp_path_, ec);
    throw InputError(path_, 0, "write failed (disk full?)");
  }
  std::error_code ec;
  std::filesystem::rename(tmp_path_, path_, ec);
  if (ec) {
    std::error_code ignored;
    std::filesystem::remove(tmp_path_, ignored);
    throw InputError(path_, 0, "cannot rename the temporary file into place: " + ec.message());
  }
  committed_ = true;
}

void WriteFileAtomic(const std::string& path, const std::string& content) {
  AtomicFile file(path);
  file.stream().write(content.data(), static_cast<std::streamsize>(content.size()));
  file.Commit();
}

}  // namespace crop4d::io
