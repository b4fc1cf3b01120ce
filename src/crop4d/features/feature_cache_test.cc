#include "crop4d/features/feature_cache.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "crop4d/core/file_bytes_test_util.h"

namespace crop4d::features {
namespace {

namespace fs = std::filesystem;

FeatureSet RandomFeatureSet(int n, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<float> real(0, 600);
  std::uniform_int_distribution<int> byte(0, 255);
  FeatureSet set;
  set.image_width = 640;
  set.image_height = 480;
  set.sharpness = real(rng);
  for (int i = 0; i < n; ++i) {
    set.keypoints.push_back(
        {real(rng), real(rng), real(rng) / 50, real(rng) * 0.6f, real(rng) / 1e4f, byte(rng) << 8});
    for (int d = 0; d < kDescriptorSize; ++d) set.descriptors.push_back(byte(rng));
    set.colors.push_back({static_cast<std::uint8_t>(byte(rng)),
                          static_cast<std::uint8_t>(byte(rng)),
                          static_cast<std::uint8_t>(byte(rng))});
  }
  return set;
}

class FeatureCacheTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_feature_cache_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    path_ = (dir_ / "features" / "features.bin").string();
    cache_.options_hash = 0x1234567890abcdefULL;
    cache_.image_keys = {"1464184987000000000", "1464184987133333333", "empty"};
    cache_.features = {RandomFeatureSet(50, 1), RandomFeatureSet(7, 2), FeatureSet()};
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string ReadBytes() const { return crop4d::testing::ReadFileBytes(path_); }
  void WriteBytes(const std::string& bytes) const { crop4d::testing::WriteFileBytes(path_, bytes); }

  fs::path dir_;
  std::string path_;
  FeatureCache cache_;
};

TEST_F(FeatureCacheTest, RoundTripIsExact) {
  WriteFeatureCache(path_, cache_);
  FeatureCache read;
  std::string detail;
  ASSERT_EQ(ReadFeatureCache(path_, &read, &detail), FeatureCacheStatus::kOk) << detail;
  EXPECT_EQ(read.options_hash, cache_.options_hash);
  EXPECT_EQ(read.image_keys, cache_.image_keys);
  ASSERT_EQ(read.features.size(), 3u);
  for (int i = 0; i < 3; ++i) EXPECT_EQ(read.features[i], cache_.features[i]) << i;
  // No temporary file is left behind.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "features")) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST_F(FeatureCacheTest, MissingFile) {
  FeatureCache read;
  EXPECT_EQ(ReadFeatureCache(path_, &read), FeatureCacheStatus::kMissing);
}

TEST(FeatureCacheStatusTest, NamesEveryStatus) {
  EXPECT_EQ(ToString(FeatureCacheStatus::kOk), "ok");
  EXPECT_EQ(ToString(FeatureCacheStatus::kBadMagic), "not a feature cache");
  EXPECT_EQ(ToString(FeatureCacheStatus::kWrongVersion), "wrong format version");
  EXPECT_EQ(ToString(FeatureCacheStatus::kOptionsChanged), "written with other extraction options");
}

TEST_F(FeatureCacheTest, DetectsForeignFile) {
  fs::create_directories(fs::path(path_).parent_path());
  WriteBytes("this is not a feature cache at all, it is text");
  FeatureCache read;
  EXPECT_EQ(ReadFeatureCache(path_, &read), FeatureCacheStatus::kBadMagic);
  WriteBytes("");
  EXPECT_EQ(ReadFeatureCache(path_, &read), FeatureCacheStatus::kBadMagic);
}

TEST_F(FeatureCacheTest, DetectsOtherVersion) {
  WriteFeatureCache(path_, cache_);
  std::string bytes = ReadBytes();
  const std::uint32_t old_version = kFeatureCacheVersion + 1;
  std::memcpy(bytes.data() + 8, &old_version, sizeof(old_version));
  WriteBytes(bytes);
  FeatureCache read;
  std::string detail;
  EXPECT_EQ(ReadFeatureCache(path_, &read, &detail), FeatureCacheStatus::kWrongVersion);
  EXPECT_NE(detail.find("version"), std::string::npos);
  EXPECT_TRUE(read.features.empty());
}

TEST_F(FeatureCacheTest, DetectsTruncation) {
  WriteFeatureCache(path_, cache_);
  const std::string bytes = ReadBytes();
  // Cut everywhere from inside the header to just before the last byte.
  for (std::size_t size :
       {std::size_t{10}, std::size_t{20}, std::size_t{30}, bytes.size() / 3, bytes.size() / 2,
        bytes.size() - 9, bytes.size() - 8, bytes.size() - 1}) {
    WriteBytes(bytes.substr(0, size));
    FeatureCache read;
    const FeatureCacheStatus status = ReadFeatureCache(path_, &read);
    EXPECT_TRUE(status == FeatureCacheStatus::kTruncated || status == FeatureCacheStatus::kCorrupt)
        << "size " << size << ": " << ToString(status);
    EXPECT_TRUE(read.features.empty());
  }
  WriteBytes(bytes.substr(0, bytes.size() / 2));
  FeatureCache read;
  EXPECT_EQ(ReadFeatureCache(path_, &read), FeatureCacheStatus::kTruncated);
}

TEST_F(FeatureCacheTest, DetectsCorruption) {
  WriteFeatureCache(path_, cache_);
  const std::string bytes = ReadBytes();
  // A flipped bit in a descriptor, a keypoint, a colour or the checksum itself.
  for (std::size_t at : {bytes.size() / 2, std::size_t{60}, bytes.size() - 20, bytes.size() - 3}) {
    std::string corrupted = bytes;
    corrupted[at] = static_cast<char>(corrupted[at] ^ 0x10);
    WriteBytes(corrupted);
    FeatureCache read;
    EXPECT_EQ(ReadFeatureCache(path_, &read), FeatureCacheStatus::kCorrupt) << "byte " << at;
  }
  // Extra bytes appended.
  WriteBytes(bytes + "junk");
  FeatureCache read;
  EXPECT_NE(ReadFeatureCache(path_, &read), FeatureCacheStatus::kOk);
}

TEST_F(FeatureCacheTest, LoadChecksOptionsAndPicksImagesByKey) {
  WriteFeatureCache(path_, cache_);
  std::vector<FeatureSet> features;
  std::vector<bool> found;
  EXPECT_EQ(LoadFeatureCache(path_, cache_.options_hash + 1, cache_.image_keys, &features, &found),
            FeatureCacheStatus::kOptionsChanged);
  EXPECT_EQ(found, std::vector<bool>(3, false));

  const std::vector<std::string> keys = {"new", "1464184987133333333", "1464184987000000000"};
  ASSERT_EQ(LoadFeatureCache(path_, cache_.options_hash, keys, &features, &found),
            FeatureCacheStatus::kOk);
  EXPECT_EQ(found, (std::vector<bool>{false, true, true}));
  ASSERT_EQ(features.size(), 3u);
  EXPECT_TRUE(features[0].empty());
  EXPECT_EQ(features[1], cache_.features[1]);
  EXPECT_EQ(features[2], cache_.features[0]);
}

}  // namespace
}  // namespace crop4d::features
