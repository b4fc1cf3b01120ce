#include "crop4d/association/association_file.h"

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <type_traits>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/features/hash.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::association {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the association file is written in the machine's byte order, assumed little-endian");

constexpr char kMagic[8] = {'C', '4', 'D', 'A', 'S', 'S', 'O', '\0'};
// Bytes of one CrossMatch record: 4 i32, 2 i64, 5 f32, 1 i32.
constexpr std::uint64_t kMatchBytes = 4 * 4 + 2 * 8 + 5 * 4 + 4;
// Longest session, pass or method name a well-formed file holds; a larger length means a
// corrupt file, and checking it before allocating keeps a bad length from asking for gigabytes.
constexpr std::uint32_t kMaxNameLength = 4096;

// Appends the little-endian bytes of values to a string.
class Buffer {
 public:
  template <typename T>
  void Put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    bytes_.append(reinterpret_cast<const char*>(&value), sizeof(T));
  }
  void PutBytes(const void* data, std::size_t size) {
    bytes_.append(static_cast<const char*>(data), size);
  }
  void PutString(const std::string& text) {
    CROP4D_CHECK_MSG(text.size() <= kMaxNameLength, "association file: name too long");
    Put<std::uint32_t>(static_cast<std::uint32_t>(text.size()));
    PutBytes(text.data(), text.size());
  }
  const std::string& bytes() const { return bytes_; }

 private:
  std::string bytes_;
};

// Reads the bytes between the version and the checksum footer while hashing them; never reads
// past the footer.
class PayloadReader {
 public:
  PayloadReader(std::istream& in, std::uint64_t payload_size, features::Fnv1aHasher prefix)
      : in_(in), remaining_(payload_size), hasher_(prefix) {}

  bool Read(void* data, std::size_t size) {
    if (size > remaining_) return false;
    in_.read(static_cast<char*>(data), static_cast<std::streamsize>(size));
    if (!in_) return false;
    hasher_.AddBytes(data, size);
    remaining_ -= size;
    return true;
  }
  template <typename T>
  bool Get(T* value) {
    return Read(value, sizeof(T));
  }
  std::uint64_t remaining() const { return remaining_; }
  std::uint64_t hash() const { return hasher_.hash(); }

 private:
  std::istream& in_;
  std::uint64_t remaining_;
  features::Fnv1aHasher hasher_;
};

AssociationFileStatus Fail(AssociationFileStatus status, const std::string& what,
                           std::string* detail, PassAssociation* association) {
  if (detail != nullptr) *detail = what;
  *association = PassAssociation();
  return status;
}

}  // namespace

std::string_view ToString(AssociationFileStatus status) {
  switch (status) {
    case AssociationFileStatus::kOk:
      return "ok";
    case AssociationFileStatus::kMissing:
      return "missing";
    case AssociationFileStatus::kUnreadable:
      return "unreadable";
    case AssociationFileStatus::kBadMagic:
      return "not an association file";
    case AssociationFileStatus::kWrongVersion:
      return "wrong format version";
    case AssociationFileStatus::kTruncated:
      return "truncated";
    case AssociationFileStatus::kCorrupt:
      return "corrupt";
  }
  return "unknown";
}

void WriteAssociationFile(const std::string& path, const PassAssociation& association) {
  Buffer buffer;
  buffer.PutBytes(kMagic, sizeof(kMagic));
  buffer.Put<std::uint32_t>(kAssociationFileVersion);
  buffer.PutString(association.a.session);
  buffer.PutString(association.a.pass);
  buffer.PutString(association.b.session);
  buffer.PutString(association.b.pass);
  buffer.PutString(association.method);
  buffer.Put<std::uint64_t>(association.matches.size());
  for (const CrossMatch& m : association.matches) {
    buffer.Put(m.image_a);
    buffer.Put(m.feature_a);
    buffer.Put(m.image_b);
    buffer.Put(m.feature_b);
    buffer.Put(m.t_a);
    buffer.Put(m.t_b);
    buffer.Put(m.xa);
    buffer.Put(m.ya);
    buffer.Put(m.xb);
    buffer.Put(m.yb);
    buffer.Put(m.distance);
    buffer.Put(m.landmark_a);
  }
  features::Fnv1aHasher hasher;
  hasher.AddBytes(buffer.bytes().data(), buffer.bytes().size());
  buffer.Put<std::uint64_t>(hasher.hash());

  io::AtomicFile file(path);
  file.stream().write(buffer.bytes().data(), static_cast<std::streamsize>(buffer.bytes().size()));
  file.Commit();
}

AssociationFileStatus ReadAssociationFile(const std::string& path, PassAssociation* association,
                                          std::string* detail) {
  CROP4D_CHECK(association != nullptr);
  *association = PassAssociation();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return Fail(AssociationFileStatus::kMissing, "no such file", detail, association);
  }
  const std::uintmax_t file_size = std::filesystem::file_size(path, ec);
  if (ec) return Fail(AssociationFileStatus::kUnreadable, ec.message(), detail, association);
  std::ifstream in(path, std::ios::binary);
  if (!in) return Fail(AssociationFileStatus::kUnreadable, "cannot open", detail, association);

  char magic[sizeof(kMagic)] = {};
  in.read(magic, sizeof(magic));
  if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) {
    return Fail(AssociationFileStatus::kBadMagic,
                "the file does not start with the association file magic", detail, association);
  }
  std::uint32_t version = 0;
  in.read(reinterpret_cast<char*>(&version), sizeof(version));
  if (!in) {
    return Fail(AssociationFileStatus::kTruncated, "ends inside the header", detail, association);
  }
  if (version != kAssociationFileVersion) {
    return Fail(AssociationFileStatus::kWrongVersion,
                "format version " + std::to_string(version) + ", expected " +
                    std::to_string(kAssociationFileVersion),
                detail, association);
  }
  // Magic, version, five lengths, the match count and the checksum: the smallest valid file.
  constexpr std::uint64_t kFixedBytes = sizeof(kMagic) + 4 + 5 * 4 + 8 + 8;
  if (file_size < kFixedBytes) {
    return Fail(AssociationFileStatus::kTruncated, "shorter than the header and footer", detail,
                association);
  }
  features::Fnv1aHasher prefix;
  prefix.AddBytes(kMagic, sizeof(kMagic));
  prefix.Add(version);
  PayloadReader reader(in, file_size - sizeof(kMagic) - 4 - 8, prefix);

  PassAssociation result;
  const auto read_string = [&](const char* what, std::string* text,
                               AssociationFileStatus* status) -> bool {
    std::uint32_t length = 0;
    if (!reader.Get(&length)) {
      *status = Fail(AssociationFileStatus::kTruncated, std::string("ends before the ") + what,
                     detail, association);
      return false;
    }
    if (length > kMaxNameLength) {
      *status = Fail(AssociationFileStatus::kCorrupt,
                     std::string(what) + ": impossible length " + std::to_string(length), detail,
                     association);
      return false;
    }
    text->assign(length, '\0');
    if (!reader.Read(text->data(), length)) {
      *status = Fail(AssociationFileStatus::kTruncated, std::string("ends inside the ") + what,
                     detail, association);
      return false;
    }
    return true;
  };
  AssociationFileStatus status = AssociationFileStatus::kOk;
  if (!read_string("session a", &result.a.session, &status) ||
      !read_string("pass a", &result.a.pass, &status) ||
      !read_string("session b", &result.b.session, &status) ||
      !read_string("pass b", &result.b.pass, &status) ||
      !read_string("method", &result.method, &status)) {
    return status;
  }
  std::uint64_t count = 0;
  if (!reader.Get(&count)) {
    return Fail(AssociationFileStatus::kTruncated, "ends before the match count", detail,
                association);
  }
  if (count > reader.remaining() / kMatchBytes) {
    return Fail(AssociationFileStatus::kTruncated,
                "holds fewer bytes than its " + std::to_string(count) + " matches need", detail,
                association);
  }
  result.matches.resize(count);
  for (CrossMatch& m : result.matches) {
    if (!reader.Get(&m.image_a) || !reader.Get(&m.feature_a) || !reader.Get(&m.image_b) ||
        !reader.Get(&m.feature_b) || !reader.Get(&m.t_a) || !reader.Get(&m.t_b) ||
        !reader.Get(&m.xa) || !reader.Get(&m.ya) || !reader.Get(&m.xb) || !reader.Get(&m.yb) ||
        !reader.Get(&m.distance) || !reader.Get(&m.landmark_a)) {
      return Fail(AssociationFileStatus::kTruncated, "ends inside the matches", detail,
                  association);
    }
  }
  if (reader.remaining() != 0) {
    return Fail(AssociationFileStatus::kCorrupt,
                std::to_string(reader.remaining()) + " unexpected bytes after the last match",
                detail, association);
  }
  std::uint64_t stored_checksum = 0;
  in.read(reinterpret_cast<char*>(&stored_checksum), sizeof(stored_checksum));
  if (!in) return Fail(AssociationFileStatus::kTruncated, "no checksum", detail, association);
  if (stored_checksum != reader.hash()) {
    return Fail(AssociationFileStatus::kCorrupt, "checksum mismatch", detail, association);
  }
  *association = std::move(result);
  if (detail != nullptr) detail->clear();
  return AssociationFileStatus::kOk;
}

std::string AssociationFileName(const PassRef& a, const PassRef& b) {
  return a.session + "_" + a.pass + "__" + b.session + "_" + b.pass + ".bin";
}

}  // namespace crop4d::association
