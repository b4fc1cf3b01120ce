#include "crop4d/features/feature_cache.h"

#include <string>
#include <unordered_map>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/io/checksummed_file.h"

namespace crop4d::features {
namespace {

constexpr char kMagic[8] = {'C', '4', 'D', 'F', 'E', 'A', 'T', '\0'};
constexpr std::size_t kKeypointBytes = 6 * 4;
constexpr std::size_t kBytesPerFeature = kKeypointBytes + kDescriptorSize + 3;
// Limits that a well-formed file never exceeds; larger values mean corruption, and checking
// them before allocating keeps a corrupt count from asking for terabytes.
constexpr std::uint32_t kMaxKeyLength = 4096;
constexpr int kMaxImageSide = 1 << 16;

FeatureCacheStatus Fail(FeatureCacheStatus status, const std::string& what, std::string* detail,
                        FeatureCache* cache) {
  if (detail != nullptr) *detail = what;
  *cache = FeatureCache();
  return status;
}

}  // namespace

std::string_view ToString(FeatureCacheStatus status) {
  switch (status) {
    case FeatureCacheStatus::kBadMagic:
      return "not a feature cache";
    case FeatureCacheStatus::kOptionsChanged:
      return "written with other extraction options";
    default:
      return io::ToString(io::ToChecksummedStatus(status));
  }
}

void WriteFeatureCache(const std::string& path, const FeatureCache& cache) {
  CROP4D_CHECK_MSG(cache.image_keys.size() == cache.features.size(),
                   "FeatureCache: one key per feature set");
  io::ChecksummedFileWriter writer(path, kMagic, kFeatureCacheVersion);
  io::ByteBuffer header;
  header.Put<std::uint32_t>(kDescriptorSize);
  header.Put<std::uint64_t>(cache.options_hash);
  header.Put<std::uint64_t>(cache.features.size());
  writer.Write(header);

  // One block per image, streamed: the whole cache (tens of MB) never sits in memory twice.
  for (std::size_t i = 0; i < cache.features.size(); ++i) {
    const FeatureSet& set = cache.features[i];
    const std::string& key = cache.image_keys[i];
    CROP4D_CHECK_MSG(set.IsConsistent(), "FeatureCache: inconsistent FeatureSet");
    io::ByteBuffer block;
    block.PutString(key, kMaxKeyLength, "FeatureCache: image key");
    block.Put<std::int32_t>(set.image_width);
    block.Put<std::int32_t>(set.image_height);
    block.Put<float>(set.sharpness);
    block.Put<std::uint64_t>(set.size());
    block.reserve(block.size() + set.size() * kBytesPerFeature);
    for (const Keypoint& k : set.keypoints) {
      block.Put(k.x);
      block.Put(k.y);
      block.Put(k.size);
      block.Put(k.angle);
      block.Put(k.response);
      block.Put(k.octave);
    }
    block.PutBytes(set.descriptors.data(), set.descriptors.size());
    for (const auto& rgb : set.colors) block.PutBytes(rgb.data(), 3);
    writer.Write(block);
  }
  writer.Commit();
}

FeatureCacheStatus ReadFeatureCache(const std::string& path, FeatureCache* cache,
                                    std::string* detail) {
  CROP4D_CHECK(cache != nullptr);
  *cache = FeatureCache();
  io::ChecksummedFileReader reader(path, kMagic, kFeatureCacheVersion, "cache");
  if (reader.status() != io::ChecksummedFileStatus::kOk) {
    return Fail(io::ToFormatStatus<FeatureCacheStatus>(reader.status()), reader.detail(), detail,
                cache);
  }
  // Descriptor size, options hash and image count: the smallest valid payload.
  if (reader.remaining() < 4 + 8 + 8) {
    return Fail(FeatureCacheStatus::kTruncated, "shorter than the header and footer", detail,
                cache);
  }

  FeatureCache result;
  std::uint32_t descriptor_size = 0;
  std::uint64_t num_images = 0;
  if (!reader.Get(&descriptor_size) || !reader.Get(&result.options_hash) ||
      !reader.Get(&num_images)) {
    return Fail(FeatureCacheStatus::kTruncated, "ends inside the header", detail, cache);
  }
  if (descriptor_size != static_cast<std::uint32_t>(kDescriptorSize)) {
    return Fail(FeatureCacheStatus::kCorrupt, "descriptor size " + std::to_string(descriptor_size),
                detail, cache);
  }
  // Each image takes at least 20 bytes.
  if (num_images > reader.remaining() / 20) {
    return Fail(FeatureCacheStatus::kTruncated,
                "holds fewer bytes than its " + std::to_string(num_images) + " images need", detail,
                cache);
  }
  result.image_keys.reserve(num_images);
  result.features.reserve(num_images);
  for (std::uint64_t i = 0; i < num_images; ++i) {
    const std::string where = "image " + std::to_string(i);
    std::uint32_t key_length = 0;
    if (!reader.Get(&key_length)) {
      return Fail(FeatureCacheStatus::kTruncated, "ends at " + where, detail, cache);
    }
    if (key_length > kMaxKeyLength) {
      return Fail(FeatureCacheStatus::kCorrupt,
                  where + ": key length " + std::to_string(key_length), detail, cache);
    }
    std::string key(key_length, '\0');
    FeatureSet set;
    std::uint64_t n = 0;
    if (!reader.Read(key.data(), key_length) || !reader.Get(&set.image_width) ||
        !reader.Get(&set.image_height) || !reader.Get(&set.sharpness) || !reader.Get(&n)) {
      return Fail(FeatureCacheStatus::kTruncated, "ends inside " + where, detail, cache);
    }
    if (set.image_width < 0 || set.image_height < 0 || set.image_width > kMaxImageSide ||
        set.image_height > kMaxImageSide) {
      return Fail(FeatureCacheStatus::kCorrupt, where + ": impossible image size", detail, cache);
    }
    if (!(set.sharpness >= 0.0f) || !std::isfinite(set.sharpness)) {
      return Fail(FeatureCacheStatus::kCorrupt, where + ": impossible sharpness", detail, cache);
    }
    if (n > reader.remaining() / kBytesPerFeature) {
      return Fail(FeatureCacheStatus::kTruncated,
                  "ends inside the " + std::to_string(n) + " features of " + where, detail, cache);
    }
    set.keypoints.resize(n);
    set.descriptors.resize(n * kDescriptorSize);
    set.colors.resize(n);
    for (Keypoint& k : set.keypoints) {
      if (!reader.Get(&k.x) || !reader.Get(&k.y) || !reader.Get(&k.size) || !reader.Get(&k.angle) ||
          !reader.Get(&k.response) || !reader.Get(&k.octave)) {
        return Fail(FeatureCacheStatus::kTruncated, "ends inside " + where, detail, cache);
      }
    }
    if (!reader.Read(set.descriptors.data(), set.descriptors.size())) {
      return Fail(FeatureCacheStatus::kTruncated, "ends inside " + where, detail, cache);
    }
    for (auto& rgb : set.colors) {
      if (!reader.Read(rgb.data(), 3)) {
        return Fail(FeatureCacheStatus::kTruncated, "ends inside " + where, detail, cache);
      }
    }
    result.image_keys.push_back(std::move(key));
    result.features.push_back(std::move(set));
  }
  const io::ChecksummedFileStatus end = reader.Finish("the last image");
  if (end != io::ChecksummedFileStatus::kOk) {
    return Fail(io::ToFormatStatus<FeatureCacheStatus>(end), reader.detail(), detail, cache);
  }
  *cache = std::move(result);
  if (detail != nullptr) detail->clear();
  return FeatureCacheStatus::kOk;
}

FeatureCacheStatus LoadFeatureCache(const std::string& path, std::uint64_t expected_options_hash,
                                    const std::vector<std::string>& image_keys,
                                    std::vector<FeatureSet>* features, std::vector<bool>* found,
                                    std::string* detail) {
  CROP4D_CHECK(features != nullptr && found != nullptr);
  features->assign(image_keys.size(), FeatureSet());
  found->assign(image_keys.size(), false);
  FeatureCache cache;
  const FeatureCacheStatus status = ReadFeatureCache(path, &cache, detail);
  if (status != FeatureCacheStatus::kOk) return status;
  if (cache.options_hash != expected_options_hash) {
    if (detail != nullptr) *detail = "the extraction options changed";
    return FeatureCacheStatus::kOptionsChanged;
  }
  std::unordered_map<std::string_view, std::size_t> index_of_key;
  index_of_key.reserve(cache.image_keys.size());
  for (std::size_t i = 0; i < cache.image_keys.size(); ++i) {
    index_of_key.emplace(cache.image_keys[i], i);
  }
  for (std::size_t i = 0; i < image_keys.size(); ++i) {
    const auto it = index_of_key.find(image_keys[i]);
    if (it == index_of_key.end()) continue;
    (*features)[i] = std::move(cache.features[it->second]);
    (*found)[i] = true;
  }
  return FeatureCacheStatus::kOk;
}

}  // namespace crop4d::features
