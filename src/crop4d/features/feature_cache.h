#pragma once

// The features of a row pass, cached in the workspace so that a rerun skips extraction
// (DESIGN.md §5: sessions/<session>/rows/<row>/features/). One versioned binary file holds the
// features of every image, keyed by an image identifier (e.g. the image's timestamp), together
// with the fingerprint of the extraction options (FeatureExtractor::Options::Hash()).
//
// Layout (little-endian):
//   char[8]  magic "C4DFEAT\0"
//   u32      format version (kFeatureCacheVersion)
//   u32      descriptor size (128)
//   u64      extraction options hash
//   u64      image count
//   per image:
//     u32 key length, key bytes
//     i32 width, i32 height, f32 sharpness, u64 feature count n
//     n × {f32 x, f32 y, f32 size, f32 angle, f32 response, i32 octave}
//     n × 128 u8 descriptors
//     n × 3 u8 RGB colours
//   u64      FNV-1a 64 checksum of every byte above
//
// Writes are atomic (io::AtomicFile). Reading detects a missing, foreign (magic), old or
// future (version), truncated or corrupted (checksum) file and says which; the caller then
// re-extracts with a warning.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "crop4d/features/feature_extractor.h"

namespace crop4d::features {

inline constexpr std::uint32_t kFeatureCacheVersion = 2;

enum class FeatureCacheStatus {
  kOk,
  kMissing,         // no file at the path
  kUnreadable,      // exists but cannot be opened or read
  kBadMagic,        // not a crop4d feature cache
  kWrongVersion,    // written by another version of the format
  kTruncated,       // ends before its content does
  kCorrupt,         // checksum mismatch or impossible values
  kOptionsChanged,  // written with other extraction options
};

std::string_view ToString(FeatureCacheStatus status);

struct FeatureCache {
  // FeatureExtractor::Options::Hash() of the options that produced `features`.
  std::uint64_t options_hash = 0;
  // One identifier per image, unique, in the order of `features`.
  std::vector<std::string> image_keys;
  std::vector<FeatureSet> features;
};

// Writes `cache` atomically to `path` (parent folders are created). Throws InputError when
// the file cannot be written.
void WriteFeatureCache(const std::string& path, const FeatureCache& cache);

// Reads a cache file. On any status other than kOk, `cache` is left empty and `detail` (when
// given) says what is wrong in words. Never throws on bad content.
FeatureCacheStatus ReadFeatureCache(const std::string& path, FeatureCache* cache,
                                    std::string* detail = nullptr);

// Reads a cache file and checks that it was written with `expected_options_hash`
// (kOptionsChanged otherwise). The features of the images in `image_keys` that the file holds
// are moved into `features` (resized to image_keys.size()) and flagged in `found`; images the
// file lacks are left empty and unflagged, so that only those need extracting.
FeatureCacheStatus LoadFeatureCache(const std::string& path, std::uint64_t expected_options_hash,
                                    const std::vector<std::string>& image_keys,
                                    std::vector<FeatureSet>* features, std::vector<bool>* found,
                                    std::string* detail = nullptr);

}  // namespace crop4d::features
