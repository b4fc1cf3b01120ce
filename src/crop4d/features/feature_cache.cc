#include "crop4d/features/feature_cache.h"

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <unordered_map>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/features/hash.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::features {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the feature cache is written in the machine's byte order, assumed little-endian");

constexpr char kMagic[8] = {'C', '4', 'D', 'F', 'E', 'A', 'T', '\0'};
constexpr std::size_t kKeypointBytes = 6 * 4;
constexpr std::size_t kBytesPerFeature = kKeypointBytes + kDescriptorSize + 3;
// Limits that a well-formed file never exceeds; larger values mean corruption, and checking
// them before allocating keeps a corrupt count from asking for terabytes.
constexpr std::uint32_t kMaxKeyLength = 4096;
constexpr int kMaxImageSide = 1 << 16;

// Appends raw bytes to a buffer.
class Buffer {
 public:
  template <typename T>
  void Put(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    const auto* p = reinterpret_cast<const char*>(&value);
    bytes_.append(p, sizeof(T));
  }
  void PutBytes(const void* data, std::size_t size) {
    bytes_.append(static_cast<const char*>(data), size);
  }
  std::string& bytes() { return bytes_; }

 private:
  std::string bytes_;
};

// Writes buffers to the file while hashing them.
class HashingWriter {
 public:
  explicit HashingWriter(std::ostream& out) : out_(out) {}
  void Write(const std::string& bytes) {
    hasher_.AddBytes(bytes.data(), bytes.size());
    out_.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  }
  std::uint64_t hash() const { return hasher_.hash(); }

 private:
  std::ostream& out_;
  Fnv1aHasher hasher_;
};

// Reads from the file while hashing, never past the bytes before the checksum footer.
class HashingReader {
 public:
  // `prefix` holds the hash of the bytes already read.
  HashingReader(std::istream& in, std::uint64_t payload_size, Fnv1aHasher prefix)
      : in_(in), remaining_(payload_size), hasher_(prefix) {}

  // False when fewer than `size` payload bytes are left or the stream fails.
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
  Fnv1aHasher hasher_;
};

FeatureCacheStatus Fail(FeatureCacheStatus status, const std::string& what, std::string* detail,
                        FeatureCache* cache) {
  if (detail != nullptr) *detail = what;
  *cache = FeatureCache();
  return status;
}

}  // namespace

std::string_view ToString(FeatureCacheStatus status) {
  switch (status) {
    case FeatureCacheStatus::kOk:
      return "ok";
    case FeatureCacheStatus::kMissing:
      return "missing";
    case FeatureCacheStatus::kUnreadable:
      return "unreadable";
    case FeatureCacheStatus::kBadMagic:
      return "not a feature cache";
    case FeatureCacheStatus::kWrongVersion:
      return "wrong format version";
    case FeatureCacheStatus::kTruncated:
      return "truncated";
    case FeatureCacheStatus::kCorrupt:
      return "corrupt";
    case FeatureCacheStatus::kOptionsChanged:
      return "written with other extraction options";
  }
  return "unknown";
}

void WriteFeatureCache(const std::string& path, const FeatureCache& cache) {
  CROP4D_CHECK_MSG(cache.image_keys.size() == cache.features.size(),
                   "FeatureCache: one key per feature set");
  io::AtomicFile file(path);
  HashingWriter writer(file.stream());

  Buffer header;
  header.PutBytes(kMagic, sizeof(kMagic));
  header.Put<std::uint32_t>(kFeatureCacheVersion);
  header.Put<std::uint32_t>(kDescriptorSize);
  header.Put<std::uint64_t>(cache.options_hash);
  header.Put<std::uint64_t>(cache.features.size());
  writer.Write(header.bytes());

  for (std::size_t i = 0; i < cache.features.size(); ++i) {
    const FeatureSet& set = cache.features[i];
    const std::string& key = cache.image_keys[i];
    CROP4D_CHECK_MSG(set.IsConsistent(), "FeatureCache: inconsistent FeatureSet");
    CROP4D_CHECK_MSG(key.size() <= kMaxKeyLength, "FeatureCache: image key too long");
    Buffer block;
    block.Put<std::uint32_t>(static_cast<std::uint32_t>(key.size()));
    block.PutBytes(key.data(), key.size());
    block.Put<std::int32_t>(set.image_width);
    block.Put<std::int32_t>(set.image_height);
    block.Put<std::uint64_t>(set.size());
    block.bytes().reserve(block.bytes().size() + set.size() * kBytesPerFeature);
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
    writer.Write(block.bytes());
  }
  const std::uint64_t checksum = writer.hash();
  file.stream().write(reinterpret_cast<const char*>(&checksum), sizeof(checksum));
  file.Commit();
}

FeatureCacheStatus ReadFeatureCache(const std::string& path, FeatureCache* cache,
                                    std::string* detail) {
  CROP4D_CHECK(cache != nullptr);
  *cache = FeatureCache();
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) {
    return Fail(FeatureCacheStatus::kMissing, "no such file", detail, cache);
  }
  const std::uintmax_t file_size = std::filesystem::file_size(path, ec);
  if (ec) return Fail(FeatureCacheStatus::kUnreadable, ec.message(), detail, cache);
  std::ifstream in(path, std::ios::binary);
  if (!in) return Fail(FeatureCacheStatus::kUnreadable, "cannot open", detail, cache);

  char magic[sizeof(kMagic)] = {};
  in.read(magic, sizeof(magic));
  if (!in || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0) {
    return Fail(FeatureCacheStatus::kBadMagic, "the file does not start with the cache magic",
                detail, cache);
  }
  std::uint32_t version = 0;
  in.read(reinterpret_cast<char*>(&version), sizeof(version));
  if (!in) return Fail(FeatureCacheStatus::kTruncated, "ends inside the header", detail, cache);
  if (version != kFeatureCacheVersion) {
    return Fail(FeatureCacheStatus::kWrongVersion,
                "format version " + std::to_string(version) + ", expected " +
                    std::to_string(kFeatureCacheVersion),
                detail, cache);
  }
  // Everything after the magic and version, up to the checksum footer, is read through the
  // hashing reader, whose hash starts from that of the magic and version (as the writer's).
  constexpr std::uint64_t kFixedBytes = sizeof(kMagic) + 4 + 4 + 8 + 8 + 8;
  if (file_size < kFixedBytes) {
    return Fail(FeatureCacheStatus::kTruncated, "shorter than the header and footer", detail,
                cache);
  }
  Fnv1aHasher prefix;
  prefix.AddBytes(kMagic, sizeof(kMagic));
  prefix.Add(version);
  HashingReader reader(in, file_size - sizeof(kMagic) - 4 - 8, prefix);

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
        !reader.Get(&set.image_height) || !reader.Get(&n)) {
      return Fail(FeatureCacheStatus::kTruncated, "ends inside " + where, detail, cache);
    }
    if (set.image_width < 0 || set.image_height < 0 || set.image_width > kMaxImageSide ||
        set.image_height > kMaxImageSide) {
      return Fail(FeatureCacheStatus::kCorrupt, where + ": impossible image size", detail, cache);
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
  if (reader.remaining() != 0) {
    return Fail(FeatureCacheStatus::kCorrupt,
                std::to_string(reader.remaining()) + " unexpected bytes after the last image",
                detail, cache);
  }
  std::uint64_t stored_checksum = 0;
  in.read(reinterpret_cast<char*>(&stored_checksum), sizeof(stored_checksum));
  if (!in) return Fail(FeatureCacheStatus::kTruncated, "no checksum", detail, cache);
  if (stored_checksum != reader.hash()) {
    return Fail(FeatureCacheStatus::kCorrupt, "checksum mismatch", detail, cache);
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
