#pragma once

// The checksummed binary container shared by crop4d's own binary files: the feature cache
// (features/feature_cache.h), the association files (association/association_file.h) and a
// pass's tracks.bin (workspace/pass_files.h). Each format only defines its payload; this file
// owns the framing, so that all three detect damage the same way.
//
// Layout (machine byte order, which must be little-endian):
//   char[8]  magic, naming the format
//   u32      format version
//   ...      payload, defined by the format
//   u64      FNV-1a 64 checksum (Fnv1aHasher) of every byte above, magic and version included
//
// Writes are atomic (io::AtomicFile): the payload is streamed into the temporary file while it
// is hashed, so a large file (the feature cache: tens of MB) never needs to sit in memory whole.
// Reading checks the magic, the version and the size up front, then hands out the payload in
// bounded reads that never reach into the footer, and checks the checksum at the end. The
// checksum is therefore only known after the whole payload has been read: a reader must check
// every count against remaining() before allocating for it.
//
// Changing these bytes changes every format above; a format that needs another layout bumps its
// own version instead.

#include <bit>
#include <cstddef>
#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <type_traits>

#include "crop4d/core/hash.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::io {

static_assert(std::endian::native == std::endian::little,
              "checksummed files are written in the machine's byte order, assumed little-endian");

inline constexpr std::size_t kChecksummedMagicSize = 8;
// Magic and version before the payload, checksum after it.
inline constexpr std::size_t kChecksummedHeaderBytes = kChecksummedMagicSize + 4;
inline constexpr std::size_t kChecksummedFooterBytes = 8;

// Appends the (little-endian) bytes of values to a string, to be handed to
// ChecksummedFileWriter::Write.
class ByteBuffer {
 public:
  template <typename T>
  void Put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void PutBytes(const void* data, std::size_t size) {
    bytes_.append(static_cast<const char*>(data), size);
  }
  // A u32 length, then the bytes. Readers refuse lengths above their own limit before
  // allocating, so a writer must never exceed it: checked here (`what` names the string).
  void PutString(std::string_view text, std::size_t max_length, std::string_view what);
  const std::string& bytes() const { return bytes_; }
  std::size_t size() const { return bytes_.size(); }
  void reserve(std::size_t size) { bytes_.reserve(size); }
  void clear() { bytes_.clear(); }

 private:
  std::string bytes_;
};

// Writes one checksummed file atomically. Nothing appears at `path` unless Commit() is called.
class ChecksummedFileWriter {
 public:
  // Opens the temporary file and writes the magic and version. Throws InputError naming `path`
  // when it cannot be created.
  ChecksummedFileWriter(std::string path, const char (&magic)[kChecksummedMagicSize],
                        std::uint32_t version);

  // Appends payload bytes.
  void Write(std::string_view bytes);
  void Write(const ByteBuffer& buffer) { Write(std::string_view(buffer.bytes())); }

  // Writes the checksum footer and renames the file into place. Throws InputError on any I/O
  // failure.
  void Commit();

 private:
  AtomicFile file_;
  Fnv1aHasher hasher_;
};

enum class ChecksummedFileStatus {
  kOk,
  kMissing,       // no file at the path
  kUnreadable,    // exists but cannot be opened or read
  kBadMagic,      // not a file of this format
  kWrongVersion,  // written by another version of the format
  kTruncated,     // ends before its content does
  kCorrupt,       // checksum mismatch or unexpected bytes
};

std::string_view ToString(ChecksummedFileStatus status);

// The status enum of a format built on the container begins with the container's statuses, by
// name and in this order (it may add its own after them): conversions are casts, and the layout
// is checked at compile time.
template <typename Status>
constexpr bool kBeginsWithChecksummedStatuses = [] {
  using C = ChecksummedFileStatus;
  constexpr auto same = [](Status s, C c) { return static_cast<int>(s) == static_cast<int>(c); };
  return same(Status::kOk, C::kOk) && same(Status::kMissing, C::kMissing) &&
         same(Status::kUnreadable, C::kUnreadable) && same(Status::kBadMagic, C::kBadMagic) &&
         same(Status::kWrongVersion, C::kWrongVersion) && same(Status::kTruncated, C::kTruncated) &&
         same(Status::kCorrupt, C::kCorrupt);
}();

// The format's status for a container status.
template <typename Status>
Status ToFormatStatus(ChecksummedFileStatus status) {
  static_assert(kBeginsWithChecksummedStatuses<Status>,
                "the format's status enum must begin with ChecksummedFileStatus's enumerators");
  return static_cast<Status>(static_cast<int>(status));
}

// The container status of a format's status that is one of the container's (the format's own
// later statuses have none: the caller handles them first).
template <typename Status>
ChecksummedFileStatus ToChecksummedStatus(Status status) {
  static_assert(kBeginsWithChecksummedStatuses<Status>,
                "the format's status enum must begin with ChecksummedFileStatus's enumerators");
  return static_cast<ChecksummedFileStatus>(static_cast<int>(status));
}

// Reads one checksummed file. The constructor opens it and checks its header; when status() is
// kOk the payload can be read with Read/Get, and Finish() then checks the end and the checksum.
// Never throws on bad content.
class ChecksummedFileReader {
 public:
  // `name` names the format in the bad-magic detail ("the file does not start with the <name>
  // magic").
  ChecksummedFileReader(const std::string& path, const char (&magic)[kChecksummedMagicSize],
                        std::uint32_t version, std::string_view name);

  // The header's verdict, and what is wrong in words (empty when kOk).
  ChecksummedFileStatus status() const { return status_; }
  const std::string& detail() const { return detail_; }
  // The version the file holds (0 when it could not be read): for callers that phrase the
  // wrong-version message themselves.
  std::uint32_t found_version() const { return found_version_; }

  // Reads the next `size` payload bytes. False, consuming nothing, when fewer than `size` are
  // left before the footer, or when the file cannot be read (then every later read fails too).
  bool Read(void* data, std::size_t size);
  template <typename T>
  bool Get(T* value) {
    static_assert(std::is_trivially_copyable_v<T>);
    return Read(value, sizeof(T));
  }
  // Payload bytes not read yet.
  std::uint64_t remaining() const { return remaining_; }

  // After the last payload value: kCorrupt "<n> unexpected bytes after <what>" when payload is
  // left unread, kTruncated "no checksum" when the footer cannot be read, kCorrupt "checksum
  // mismatch", else kOk. Also sets status() and detail().
  ChecksummedFileStatus Finish(std::string_view what);

 private:
  ChecksummedFileStatus Fail(ChecksummedFileStatus status, std::string detail);

  std::ifstream in_;
  ChecksummedFileStatus status_ = ChecksummedFileStatus::kOk;
  std::string detail_;
  std::uint32_t found_version_ = 0;
  std::uint64_t remaining_ = 0;
  bool failed_ = false;
  Fnv1aHasher hasher_;
};

}  // namespace crop4d::io
