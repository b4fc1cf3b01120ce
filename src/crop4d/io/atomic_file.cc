#include "crop4d/io/atomic_file.h"

#include <unistd.h>

#include <atomic>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <system_error>
#include <vector>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

constexpr const char* kTemporaryInfix = ".tmp.";

std::string TemporaryPath(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  return path + kTemporaryInfix + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

// Whether `name` ends in TemporaryPath's suffix: ".tmp.<digits>.<digits>".
bool IsTemporaryName(const std::string& name) {
  const std::size_t at = name.rfind(kTemporaryInfix);
  if (at == std::string::npos) return false;
  const std::string tail = name.substr(at + std::strlen(kTemporaryInfix));
  const std::size_t dot = tail.find('.');
  auto digits = [](const std::string& s) {
    return !s.empty() && s.find_first_not_of("0123456789") == std::string::npos;
  };
  return dot != std::string::npos && digits(tail.substr(0, dot)) && digits(tail.substr(dot + 1));
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

int RemoveStaleTemporaryFiles(const std::string& folder) {
  namespace fs = std::filesystem;
  std::vector<fs::path> stale;
  std::error_code ec;
  for (fs::recursive_directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
    if (it->is_regular_file(ec) && IsTemporaryName(it->path().filename().string())) {
      stale.push_back(it->path());
    }
  }
  int removed = 0;
  for (const fs::path& p : stale) removed += fs::remove(p, ec) ? 1 : 0;
  return removed;
}

void AppendFileTo(const std::string& from, const std::string& target, std::ostream& out) {
  std::ifstream in(from, std::ios::binary);
  if (!in) {
    throw InputError(target, 0,
                     "cannot read the temporary file " + from + ": " + std::strerror(errno));
  }
  std::vector<char> block(1 << 20);
  while (out) {
    in.read(block.data(), static_cast<std::streamsize>(block.size()));
    if (in.gcount() == 0) break;
    out.write(block.data(), in.gcount());
  }
  if (in.bad()) throw InputError(target, 0, "cannot read the temporary file " + from);
}

}  // namespace crop4d::io
