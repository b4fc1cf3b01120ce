#include "crop4d/association/association_file.h"

#include <string>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/io/checksummed_file.h"

namespace crop4d::association {
namespace {

constexpr char kMagic[8] = {'C', '4', 'D', 'A', 'S', 'S', 'O', '\0'};
// Bytes of one CrossMatch record: 4 i32, 2 i64, 5 f32, 1 i32.
constexpr std::uint64_t kMatchBytes = 4 * 4 + 2 * 8 + 5 * 4 + 4;
// Longest session, pass or method name a well-formed file holds; a larger length means a
// corrupt file, and checking it before allocating keeps a bad length from asking for gigabytes.
constexpr std::uint32_t kMaxNameLength = 4096;

AssociationFileStatus Fail(AssociationFileStatus status, const std::string& what,
                           std::string* detail, PassAssociation* association) {
  if (detail != nullptr) *detail = what;
  *association = PassAssociation();
  return status;
}

}  // namespace

std::string_view ToString(AssociationFileStatus status) {
  if (status == AssociationFileStatus::kBadMagic) return "not an association file";
  return io::ToString(io::ToChecksummedStatus(status));
}

void WriteAssociationFile(const std::string& path, const PassAssociation& association) {
  io::ByteBuffer buffer;
  const auto put_name = [&](const std::string& name) {
    buffer.PutString(name, kMaxNameLength, "association file: name");
  };
  put_name(association.a.session);
  put_name(association.a.pass);
  put_name(association.b.session);
  put_name(association.b.pass);
  put_name(association.method);
  buffer.Put<std::uint64_t>(association.matches.size());
  buffer.reserve(buffer.size() + association.matches.size() * kMatchBytes);
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
  io::ChecksummedFileWriter writer(path, kMagic, kAssociationFileVersion);
  writer.Write(buffer);
  writer.Commit();
}

AssociationFileStatus ReadAssociationFile(const std::string& path, PassAssociation* association,
                                          std::string* detail) {
  CROP4D_CHECK(association != nullptr);
  *association = PassAssociation();
  io::ChecksummedFileReader reader(path, kMagic, kAssociationFileVersion, "association file");
  if (reader.status() != io::ChecksummedFileStatus::kOk) {
    return Fail(io::ToFormatStatus<AssociationFileStatus>(reader.status()), reader.detail(), detail,
                association);
  }
  // Five lengths and the match count: the smallest valid payload.
  if (reader.remaining() < 5 * 4 + 8) {
    return Fail(AssociationFileStatus::kTruncated, "shorter than the header and footer", detail,
                association);
  }

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
  const io::ChecksummedFileStatus end = reader.Finish("the last match");
  if (end != io::ChecksummedFileStatus::kOk) {
    return Fail(io::ToFormatStatus<AssociationFileStatus>(end), reader.detail(), detail,
                association);
  }
  *association = std::move(result);
  if (detail != nullptr) detail->clear();
  return AssociationFileStatus::kOk;
}

std::string AssociationFileName(const PassRef& a, const PassRef& b) {
  return a.session + "_" + a.pass + "__" + b.session + "_" + b.pass + ".bin";
}

}  // namespace crop4d::association
