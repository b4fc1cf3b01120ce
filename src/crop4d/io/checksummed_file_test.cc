#include "crop4d/io/checksummed_file.h"

#include <gtest/gtest.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <string>

#include "crop4d/core/hash.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

using testing::ReadText;
using testing::TempDir;
using testing::WriteText;

constexpr char kMagic[8] = {'C', '4', 'D', 'T', 'E', 'S', 'T', '\0'};
constexpr std::uint32_t kVersion = 3;

class ChecksummedFileTest : public ::testing::Test {
 protected:
  // Magic, version, then a u32, a string and a u64: 12 + 4 + (4 + 5) + 8 payload bytes + 8.
  void WriteExample() {
    ChecksummedFileWriter writer(path_, kMagic, kVersion);
    ByteBuffer first;
    first.Put<std::uint32_t>(42);
    first.PutString("hello", 16, "test string");
    writer.Write(first);
    ByteBuffer second;  // a second chunk, as the feature cache streams one per image
    second.Put<std::uint64_t>(0x0123456789abcdefULL);
    writer.Write(second);
    writer.Commit();
  }

  // Reads the example back; returns the status of the header or of Finish().
  ChecksummedFileStatus ReadExample(std::string* detail = nullptr) {
    ChecksummedFileReader reader(path_, kMagic, kVersion, "test file");
    if (detail != nullptr) *detail = reader.detail();
    if (reader.status() != ChecksummedFileStatus::kOk) return reader.status();
    std::uint32_t number = 0, length = 0;
    std::string text;
    std::uint64_t big = 0;
    if (!reader.Get(&number) || !reader.Get(&length) || length > 16) {
      return ChecksummedFileStatus::kTruncated;
    }
    text.resize(length);
    if (!reader.Read(text.data(), length) || !reader.Get(&big)) {
      return ChecksummedFileStatus::kTruncated;
    }
    const ChecksummedFileStatus status = reader.Finish("the example");
    if (detail != nullptr) *detail = reader.detail();
    if (status == ChecksummedFileStatus::kOk) {
      EXPECT_EQ(number, 42u);
      EXPECT_EQ(text, "hello");
      EXPECT_EQ(big, 0x0123456789abcdefULL);
    }
    return status;
  }

  TempDir dir_;
  std::string path_ = dir_ / "sub/example.bin";
};

TEST_F(ChecksummedFileTest, RoundTrip) {
  WriteExample();
  const std::string bytes = ReadText(path_);
  ASSERT_EQ(bytes.size(), 12u + 4 + 9 + 8 + 8);
  EXPECT_EQ(std::memcmp(bytes.data(), kMagic, 8), 0);
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + 8, 4);
  EXPECT_EQ(version, kVersion);
  // The footer is the FNV-1a hash of every byte before it, magic and version included.
  Fnv1aHasher hasher;
  hasher.AddBytes(bytes.data(), bytes.size() - 8);
  std::uint64_t checksum = 0;
  std::memcpy(&checksum, bytes.data() + bytes.size() - 8, 8);
  EXPECT_EQ(checksum, hasher.hash());

  std::string detail = "stale";
  EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kOk) << detail;
  EXPECT_TRUE(detail.empty());
}

TEST_F(ChecksummedFileTest, EmptyPayloadRoundTrips) {
  ChecksummedFileWriter writer(path_, kMagic, kVersion);
  writer.Commit();
  ChecksummedFileReader reader(path_, kMagic, kVersion, "test file");
  ASSERT_EQ(reader.status(), ChecksummedFileStatus::kOk);
  EXPECT_EQ(reader.remaining(), 0u);
  EXPECT_EQ(reader.Finish("nothing"), ChecksummedFileStatus::kOk);
}

TEST_F(ChecksummedFileTest, UncommittedWriterLeavesNoFile) {
  {
    ChecksummedFileWriter writer(path_, kMagic, kVersion);
    writer.Write("partial");
  }
  EXPECT_FALSE(std::filesystem::exists(path_));
}

TEST_F(ChecksummedFileTest, MissingFile) {
  std::string detail;
  EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kMissing);
  EXPECT_FALSE(detail.empty());
}

TEST_F(ChecksummedFileTest, FolderIsUnreadable) {
  std::filesystem::create_directories(path_);
  EXPECT_EQ(ReadExample(), ChecksummedFileStatus::kUnreadable);
}

TEST_F(ChecksummedFileTest, WrongMagic) {
  WriteText(path_, "not a checksummed file at all");
  std::string detail;
  EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kBadMagic);
  EXPECT_NE(detail.find("test file magic"), std::string::npos) << detail;
  WriteText(path_, "C4D");  // shorter than the magic
  EXPECT_EQ(ReadExample(), ChecksummedFileStatus::kBadMagic);
  WriteText(path_, "");
  EXPECT_EQ(ReadExample(), ChecksummedFileStatus::kBadMagic);
}

TEST_F(ChecksummedFileTest, WrongVersion) {
  WriteExample();
  std::string bytes = ReadText(path_);
  for (const std::uint32_t version : {kVersion + 1, 0u}) {
    std::memcpy(&bytes[8], &version, 4);
    WriteText(path_, bytes);
    std::string detail;
    EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kWrongVersion);
    EXPECT_NE(detail.find("version"), std::string::npos) << detail;
    EXPECT_NE(detail.find(std::to_string(version)), std::string::npos) << detail;
    ChecksummedFileReader reader(path_, kMagic, kVersion, "test file");
    EXPECT_EQ(reader.found_version(), version);
  }
}

TEST_F(ChecksummedFileTest, Truncated) {
  WriteExample();
  const std::string bytes = ReadText(path_);
  // Inside the version, before the footer could fit, inside the payload, inside the footer.
  for (const std::size_t size : {std::size_t{10}, std::size_t{12}, std::size_t{19}, std::size_t{25},
                                 bytes.size() - 9, bytes.size() - 1}) {
    WriteText(path_, bytes.substr(0, size));
    EXPECT_EQ(ReadExample(), ChecksummedFileStatus::kTruncated) << "cut at " << size;
  }
}

TEST_F(ChecksummedFileTest, FlippedPayloadByteIsCorrupt) {
  WriteExample();
  const std::string bytes = ReadText(path_);
  // In the u32, in the string, in the u64, in the checksum itself.
  for (const std::size_t at :
       {std::size_t{13}, std::size_t{21}, std::size_t{27}, bytes.size() - 1}) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ 0x01);
    WriteText(path_, flipped);
    std::string detail;
    EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kCorrupt) << "byte " << at;
    EXPECT_EQ(detail, "checksum mismatch");
  }
}

TEST_F(ChecksummedFileTest, TrailingBytesAreCorrupt) {
  WriteExample();
  // The footer is always the last 8 bytes, so an appended byte shows up as unread payload.
  WriteText(path_, ReadText(path_) + "x");
  std::string detail;
  EXPECT_EQ(ReadExample(&detail), ChecksummedFileStatus::kCorrupt);
  EXPECT_EQ(detail, "1 unexpected bytes after the example");
}

TEST_F(ChecksummedFileTest, ReadPastThePayloadEndFails) {
  WriteExample();
  ChecksummedFileReader reader(path_, kMagic, kVersion, "test file");
  ASSERT_EQ(reader.status(), ChecksummedFileStatus::kOk);
  EXPECT_EQ(reader.remaining(), 4u + 9 + 8);
  char payload[21];
  // One byte more than the payload would reach into the footer: refused, nothing consumed.
  char too_much[22];
  EXPECT_FALSE(reader.Read(too_much, sizeof(too_much)));
  EXPECT_EQ(reader.remaining(), 21u);
  ASSERT_TRUE(reader.Read(payload, sizeof(payload)));
  EXPECT_EQ(reader.remaining(), 0u);
  std::uint8_t byte = 0;
  EXPECT_FALSE(reader.Get(&byte));
  EXPECT_EQ(reader.Finish("the payload"), ChecksummedFileStatus::kOk) << reader.detail();
}

TEST_F(ChecksummedFileTest, ReadsFailAfterABadHeader) {
  WriteText(path_, "definitely not it");
  ChecksummedFileReader reader(path_, kMagic, kVersion, "test file");
  EXPECT_EQ(reader.status(), ChecksummedFileStatus::kBadMagic);
  EXPECT_EQ(reader.remaining(), 0u);
  char c = 0;
  EXPECT_FALSE(reader.Read(&c, 1));
  EXPECT_EQ(reader.Finish("anything"), ChecksummedFileStatus::kBadMagic);
}

TEST(ByteBufferTest, PutsLittleEndianBytes) {
  ByteBuffer buffer;
  buffer.reserve(32);
  buffer.Put<std::uint32_t>(0x04030201u);
  buffer.PutBytes("ab", 2);
  buffer.PutString("xyz", 3, "name");
  EXPECT_EQ(buffer.bytes(), std::string("\x01\x02\x03\x04"
                                        "ab"
                                        "\x03\x00\x00\x00"
                                        "xyz",
                                        13));
  EXPECT_EQ(buffer.size(), 13u);
  buffer.clear();
  EXPECT_EQ(buffer.size(), 0u);
}

TEST(ByteBufferDeathTest, RefusesOverlongString) {
  ByteBuffer buffer;
  EXPECT_DEATH(buffer.PutString("toolong", 3, "name"), "name too long");
}

}  // namespace
}  // namespace crop4d::io
