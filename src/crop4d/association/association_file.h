#pragma once

// The cross matches between two row passes (`crop4d associate`, DESIGN.md §5:
// WS/associations/<a>__<b>.bin). Pass a is the one whose landmarks were projected (image I1),
// pass b the one searched (image I2). Every match carries the image timestamps and pixels of both
// sides, so that readers (fusion, evaluation) need no other file to place it.
//
// Layout (little-endian):
//   char[8]  magic "C4DASSO\0"
//   u32      format version (kAssociationFileVersion)
//   4 × (u32 length, bytes)   session a, pass a, session b, pass b
//   u32 length, bytes         method ("robust" or "naive")
//   u64      match count n
//   n × {i32 image_a, i32 feature_a, i32 image_b, i32 feature_b, i64 t_a, i64 t_b,
//        f32 xa, f32 ya, f32 xb, f32 yb, f32 distance, i32 landmark_a}
//   u64      FNV-1a 64 checksum of every byte above
//
// Writes are atomic (io::AtomicFile). Reading detects a missing, foreign, old or future,
// truncated or corrupt file and says which in words; it never throws on bad content.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "crop4d/core/timestamp.h"

namespace crop4d::association {

inline constexpr std::uint32_t kAssociationFileVersion = 1;

// One row pass of one session: the session folder name and the pass id ("row03", "row01_2").
struct PassRef {
  std::string session;
  std::string pass;

  bool operator==(const PassRef&) const = default;
  auto operator<=>(const PassRef&) const = default;
};

// One verified match between a feature of pass a and a feature of pass b.
struct CrossMatch {
  // Image index within each pass (the order of the pass's poses.tum and feature cache) and the
  // feature index within that image's feature set.
  std::int32_t image_a = -1;
  std::int32_t feature_a = -1;
  std::int32_t image_b = -1;
  std::int32_t feature_b = -1;
  // The two images' timestamps (ns) and the two keypoints (distorted pixels).
  Timestamp t_a = 0;
  Timestamp t_b = 0;
  float xa = 0, ya = 0, xb = 0, yb = 0;
  // Descriptor distance (L2 of the 8-bit SIFT descriptors) of the accepted pair.
  float distance = 0;
  // The landmark of pass a the match came from (index into that pass's tracks.bin), −1 for the
  // naive method.
  std::int32_t landmark_a = -1;

  bool operator==(const CrossMatch&) const = default;
};

struct PassAssociation {
  PassRef a;
  PassRef b;
  std::string method;  // "robust" or "naive"
  std::vector<CrossMatch> matches;

  bool operator==(const PassAssociation&) const = default;
};

enum class AssociationFileStatus {
  kOk,
  kMissing,
  kUnreadable,
  kBadMagic,
  kWrongVersion,
  kTruncated,
  kCorrupt,
};

std::string_view ToString(AssociationFileStatus status);

// Writes atomically (parent folders created). Throws InputError when it cannot be written.
void WriteAssociationFile(const std::string& path, const PassAssociation& association);

// Reads a file; on any status other than kOk `association` is left empty and `detail` (when given)
// says what is wrong.
AssociationFileStatus ReadAssociationFile(const std::string& path, PassAssociation* association,
                                          std::string* detail = nullptr);

// The file name of a pair: "<session a>_<pass a>__<session b>_<pass b>.bin".
std::string AssociationFileName(const PassRef& a, const PassRef& b);

}  // namespace crop4d::association
