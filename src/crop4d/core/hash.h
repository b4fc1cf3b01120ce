#pragma once

// FNV-1a 64-bit hashing (Fowler, Noll, Vo), used for option fingerprints and the feature
// cache checksum. Not cryptographic: it detects accidental change, not tampering.

#include <cstddef>
#include <cstdint>
#include <cstring>
#include <string_view>
#include <type_traits>

namespace crop4d {

class Fnv1aHasher {
 public:
  void AddBytes(const void* data, std::size_t size) {
    const auto* bytes = static_cast<const unsigned char*>(data);
    for (std::size_t i = 0; i < size; ++i) {
      hash_ ^= bytes[i];
      hash_ *= 0x100000001b3ULL;
    }
  }
  template <typename T>
  void Add(const T& value) {
    static_assert(std::is_trivially_copyable_v<T>);
    unsigned char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    AddBytes(bytes, sizeof(T));
  }
  void AddString(std::string_view text) {
    Add<std::uint64_t>(text.size());
    AddBytes(text.data(), text.size());
  }
  std::uint64_t hash() const { return hash_; }

 private:
  std::uint64_t hash_ = 0xcbf29ce484222325ULL;
};

}  // namespace crop4d
