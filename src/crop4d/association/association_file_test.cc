#include "crop4d/association/association_file.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "crop4d/core/error.h"
#include "crop4d/core/file_bytes_test_util.h"

namespace crop4d::association {
namespace {

namespace fs = std::filesystem;

class AssociationFileTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_association_file_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    association_.a = {"2016-05-25", "row03"};
    association_.b = {"2016-06-01", "row04_2"};
    association_.method = "robust";
    for (int k = 0; k < 5; ++k) {
      CrossMatch m;
      m.image_a = k;
      m.feature_a = 100 + k;
      m.image_b = 40 - k;
      m.feature_b = 7 * k;
      m.t_a = 1464184987000000000 + k * 133333333;
      m.t_b = 1464789787000000000 - k * 133333333;
      m.xa = 10.25f * k;
      m.ya = 479.5f - k;
      m.xb = 639.0f - 3 * k;
      m.yb = 0.125f * k;
      m.distance = 120.5f + k;
      m.landmark_a = 1000 * k - 1;
      association_.matches.push_back(m);
    }
    path_ = (dir_ / "associations" / AssociationFileName(association_.a, association_.b)).string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  std::string ReadBytes() const { return crop4d::testing::ReadFileBytes(path_); }
  void WriteBytes(const std::string& bytes) const { crop4d::testing::WriteFileBytes(path_, bytes); }
  AssociationFileStatus Read(std::string* detail = nullptr) const {
    PassAssociation read;
    read.method = "left over";
    const AssociationFileStatus status = ReadAssociationFile(path_, &read, detail);
    if (status != AssociationFileStatus::kOk) {
      EXPECT_EQ(read, PassAssociation());
    }
    return status;
  }

  fs::path dir_;
  std::string path_;
  PassAssociation association_;
};

// Bytes before the matches: magic, version, five strings with their lengths, the count.
std::size_t HeaderBytes(const PassAssociation& a) {
  return 8 + 4 + 5 * 4 + a.a.session.size() + a.a.pass.size() + a.b.session.size() +
         a.b.pass.size() + a.method.size() + 8;
}

TEST_F(AssociationFileTest, RoundTripIsExact) {
  WriteAssociationFile(path_, association_);
  PassAssociation read;
  std::string detail = "stale";
  ASSERT_EQ(ReadAssociationFile(path_, &read, &detail), AssociationFileStatus::kOk) << detail;
  EXPECT_TRUE(detail.empty());
  EXPECT_EQ(read, association_);
  // Exactly the documented layout: header, 56 bytes per match, 8-byte checksum.
  EXPECT_EQ(ReadBytes().size(), HeaderBytes(association_) + 56 * association_.matches.size() + 8);
  // No temporary file is left behind.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(dir_ / "associations")) {
    (void)entry;
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST_F(AssociationFileTest, EmptyAssociationRoundTrips) {
  association_.matches.clear();
  association_.method = "naive";
  WriteAssociationFile(path_, association_);
  PassAssociation read;
  ASSERT_EQ(ReadAssociationFile(path_, &read), AssociationFileStatus::kOk);
  EXPECT_EQ(read, association_);
}

TEST_F(AssociationFileTest, OverwriteReplacesTheFile) {
  WriteAssociationFile(path_, association_);
  association_.matches.resize(2);
  WriteAssociationFile(path_, association_);
  PassAssociation read;
  ASSERT_EQ(ReadAssociationFile(path_, &read), AssociationFileStatus::kOk);
  EXPECT_EQ(read, association_);
}

TEST_F(AssociationFileTest, FileNameNamesBothPasses) {
  EXPECT_EQ(AssociationFileName({"2016-05-25", "row03"}, {"2016-06-01", "row04_2"}),
            "2016-05-25_row03__2016-06-01_row04_2.bin");
}

TEST_F(AssociationFileTest, MissingFile) {
  std::string detail;
  EXPECT_EQ(Read(&detail), AssociationFileStatus::kMissing);
  EXPECT_FALSE(detail.empty());
  EXPECT_EQ(ToString(AssociationFileStatus::kMissing), "missing");
  // The format's own wording where it has one, the container's otherwise.
  EXPECT_EQ(ToString(AssociationFileStatus::kBadMagic), "not an association file");
  EXPECT_EQ(ToString(AssociationFileStatus::kTruncated), "truncated");
  EXPECT_EQ(ToString(AssociationFileStatus::kCorrupt), "corrupt");
}

TEST_F(AssociationFileTest, FolderIsUnreadable) {
  fs::create_directories(path_);
  EXPECT_EQ(Read(), AssociationFileStatus::kUnreadable);
}

TEST_F(AssociationFileTest, ForeignFileHasBadMagic) {
  fs::create_directories(fs::path(path_).parent_path());
  WriteBytes("session,pass\n2016-05-25,row03\n");
  EXPECT_EQ(Read(), AssociationFileStatus::kBadMagic);
  WriteBytes("C4D");  // shorter than the magic
  EXPECT_EQ(Read(), AssociationFileStatus::kBadMagic);
  WriteAssociationFile(path_, association_);
  std::string bytes = ReadBytes();
  bytes[3] = 'X';
  WriteBytes(bytes);
  EXPECT_EQ(Read(), AssociationFileStatus::kBadMagic);
}

TEST_F(AssociationFileTest, OtherVersionIsRefused) {
  WriteAssociationFile(path_, association_);
  std::string bytes = ReadBytes();
  for (const std::uint32_t version : {kAssociationFileVersion + 1, 0u}) {
    std::memcpy(&bytes[8], &version, 4);
    WriteBytes(bytes);
    std::string detail;
    EXPECT_EQ(Read(&detail), AssociationFileStatus::kWrongVersion);
    EXPECT_NE(detail.find(std::to_string(version)), std::string::npos) << detail;
  }
}

TEST_F(AssociationFileTest, TruncatedFileIsDetected) {
  WriteAssociationFile(path_, association_);
  const std::string bytes = ReadBytes();
  // Cut inside the version, the names, the count, a match, the checksum.
  for (const std::size_t size :
       {std::size_t{10}, std::size_t{20}, HeaderBytes(association_) - 3,
        HeaderBytes(association_) + 56 * 2 + 17, bytes.size() - 8, bytes.size() - 1}) {
    WriteBytes(bytes.substr(0, size));
    EXPECT_EQ(Read(), AssociationFileStatus::kTruncated) << "cut at " << size;
  }
}

TEST_F(AssociationFileTest, FlippedByteIsCorrupt) {
  WriteAssociationFile(path_, association_);
  const std::string bytes = ReadBytes();
  // A flipped byte in the matches or the checksum: the checksum catches it.
  for (const std::size_t at : {HeaderBytes(association_) + 5, HeaderBytes(association_) + 56 * 3,
                               bytes.size() - 9, bytes.size() - 1}) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ 0x10);
    WriteBytes(flipped);
    std::string detail;
    EXPECT_EQ(Read(&detail), AssociationFileStatus::kCorrupt) << "byte " << at << ": " << detail;
  }
  // Anywhere else the file is refused too, whatever the reason given.
  for (std::size_t at = 0; at < bytes.size(); ++at) {
    std::string flipped = bytes;
    flipped[at] = static_cast<char>(flipped[at] ^ 0x01);
    WriteBytes(flipped);
    EXPECT_NE(Read(), AssociationFileStatus::kOk) << "byte " << at;
  }
}

TEST_F(AssociationFileTest, TrailingBytesAreCorrupt) {
  WriteAssociationFile(path_, association_);
  WriteBytes(ReadBytes() + "x");
  EXPECT_EQ(Read(), AssociationFileStatus::kCorrupt);
}

TEST_F(AssociationFileTest, ImpossibleNameLengthIsCorrupt) {
  WriteAssociationFile(path_, association_);
  std::string bytes = ReadBytes();
  const std::uint32_t huge = 1u << 30;
  std::memcpy(&bytes[12], &huge, 4);  // length of session a
  WriteBytes(bytes);
  EXPECT_EQ(Read(), AssociationFileStatus::kCorrupt);
}

TEST_F(AssociationFileTest, UnwritablePathThrowsInputError) {
  fs::create_directories(path_);  // a folder where the file should go
  EXPECT_THROW(WriteAssociationFile(path_, association_), InputError);
}

}  // namespace
}  // namespace crop4d::association
