#include "crop4d/io/checksummed_file.h"

#include <cstring>
#include <filesystem>
#include <system_error>
#include <utility>

#include "crop4d/core/error.h"

namespace crop4d::io {

void ByteBuffer::PutString(std::string_view text, std::size_t max_length, std::string_view what) {
  CROP4D_CHECK_MSG(text.size() <= max_length, std::string(what) + " too long");
  Put<std::uint32_t>(static_cast<std::uint32_t>(text.size()));
  PutBytes(text.data(), text.size());
}

ChecksummedFileWriter::ChecksummedFileWriter(std::string path,
                                             const char (&magic)[kChecksummedMagicSize],
                                             std::uint32_t version)
    : file_(std::move(path)) {
  ByteBuffer header;
  header.PutBytes(magic, kChecksummedMagicSize);
  header.Put<std::uint32_t>(version);
  Write(header);
}

void ChecksummedFileWriter::Write(std::string_view bytes) {
  hasher_.AddBytes(bytes.data(), bytes.size());
  file_.stream().write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

void ChecksummedFileWriter::Commit() {
  const std::uint64_t checksum = hasher_.hash();
  file_.stream().write(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  file_.Commit();
}

std::string_view ToString(ChecksummedFileStatus status) {
  switch (status) {
    case ChecksummedFileStatus::kOk:
      return "ok";
    case ChecksummedFileStatus::kMissing:
      return "missing";
    case ChecksummedFileStatus::kUnreadable:
      return "unreadable";
    case ChecksummedFileStatus::kBadMagic:
      return "bad magic";
    case ChecksummedFileStatus::kWrongVersion:
      return "wrong format version";
    case ChecksummedFileStatus::kTruncated:
      return "truncated";
    case ChecksummedFileStatus::kCorrupt:
      return "corrupt";
  }
  return "unknown";
}

ChecksummedFileReader::ChecksummedFileReader(const std::string& path,
                                             const char (&magic)[kChecksummedMagicSize],
                                             std::uint32_t version, std::string_view name) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    Fail(ChecksummedFileStatus::kMissing, "no such file");
    return;
  }
  // file_size also fails on a folder, which would otherwise open as an empty stream.
  const std::uintmax_t file_size = std::filesystem::file_size(path, ec);
  if (ec) {
    Fail(ChecksummedFileStatus::kUnreadable, ec.message());
    return;
  }
  in_.open(path, std::ios::binary);
  if (!in_) {
    Fail(ChecksummedFileStatus::kUnreadable, "cannot open");
    return;
  }
  char found_magic[kChecksummedMagicSize] = {};
  in_.read(found_magic, sizeof(found_magic));
  if (!in_ || std::memcmp(found_magic, magic, kChecksummedMagicSize) != 0) {
    Fail(ChecksummedFileStatus::kBadMagic,
         "the file does not start with the " + std::string(name) + " magic");
    return;
  }
  in_.read(reinterpret_cast<char*>(&found_version_), sizeof(found_version_));
  if (!in_) {
    found_version_ = 0;
    Fail(ChecksummedFileStatus::kTruncated, "ends inside the header");
    return;
  }
  if (found_version_ != version) {
    Fail(ChecksummedFileStatus::kWrongVersion, "format version " + std::to_string(found_version_) +
                                                   ", expected " + std::to_string(version));
    return;
  }
  if (file_size < kChecksummedHeaderBytes + kChecksummedFooterBytes) {
    Fail(ChecksummedFileStatus::kTruncated, "shorter than the header and footer");
    return;
  }
  // The payload hash continues from that of the magic and version, as the writer's does.
  hasher_.AddBytes(magic, kChecksummedMagicSize);
  hasher_.Add(found_version_);
  remaining_ = file_size - kChecksummedHeaderBytes - kChecksummedFooterBytes;
}

bool ChecksummedFileReader::Read(void* data, std::size_t size) {
  if (status_ != ChecksummedFileStatus::kOk || failed_ || size > remaining_) return false;
  in_.read(static_cast<char*>(data), static_cast<std::streamsize>(size));
  if (!in_) {
    // The file shrank under us or an I/O error: nothing after this point can be trusted.
    failed_ = true;
    return false;
  }
  hasher_.AddBytes(data, size);
  remaining_ -= size;
  return true;
}

ChecksummedFileStatus ChecksummedFileReader::Finish(std::string_view what) {
  if (status_ != ChecksummedFileStatus::kOk) return status_;
  if (remaining_ != 0) {
    return Fail(ChecksummedFileStatus::kCorrupt,
                std::to_string(remaining_) + " unexpected bytes after " + std::string(what));
  }
  std::uint64_t stored_checksum = 0;
  if (failed_ || !in_.read(reinterpret_cast<char*>(&stored_checksum), sizeof(stored_checksum))) {
    return Fail(ChecksummedFileStatus::kTruncated, "no checksum");
  }
  if (stored_checksum != hasher_.hash()) {
    return Fail(ChecksummedFileStatus::kCorrupt, "checksum mismatch");
  }
  detail_.clear();
  return ChecksummedFileStatus::kOk;
}

ChecksummedFileStatus ChecksummedFileReader::Fail(ChecksummedFileStatus status,
                                                  std::string detail) {
  status_ = status;
  detail_ = std::move(detail);
  remaining_ = 0;
  return status;
}

}  // namespace crop4d::io
