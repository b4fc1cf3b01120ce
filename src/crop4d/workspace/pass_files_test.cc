#include "crop4d/workspace/pass_files.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <iterator>

#include "crop4d/core/error.h"

namespace crop4d::workspace {
namespace {

namespace fs = std::filesystem;

class PassFilesTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_pass_files_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  static PassTracks Example() {
    PassTracks t;
    t.landmarks.push_back({Eigen::Vector3d(1.5, -2.25, 0.125), {10, 200, 30}, {{0, 3}, {1, 7}}});
    t.cloud.push_back({Eigen::Vector3d(0.1, 0.2, 0.3), {1, 2, 3}, {{2, 0}, {4, 1}, {5, 9}}});
    t.cloud.push_back({Eigen::Vector3d(-4, 5, 6), {7, 8, 9}, {{0, 0}, {1, 1}}});
    return t;
  }

  std::string ReadBytes(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
  }
  void WriteBytes(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
  }

  fs::path dir_;
};

TEST_F(PassFilesTest, TracksRoundTrip) {
  const std::string path = (dir_ / "tracks.bin").string();
  WritePassTracks(path, Example());
  EXPECT_EQ(ReadPassTracks(path), Example());
}

TEST_F(PassFilesTest, TracksRejectsDamage) {
  const fs::path path = dir_ / "tracks.bin";
  EXPECT_THROW(ReadPassTracks(path.string()), InputError);  // missing
  WritePassTracks(path.string(), Example());
  const std::string good = ReadBytes(path);

  std::string flipped = good;
  flipped[30] ^= 0x40;
  WriteBytes(path, flipped);
  EXPECT_THROW(ReadPassTracks(path.string()), InputError);

  WriteBytes(path, good.substr(0, good.size() - 20));
  EXPECT_THROW(ReadPassTracks(path.string()), InputError);

  std::string foreign = good;
  foreign[0] = 'X';
  WriteBytes(path, foreign);
  EXPECT_THROW(ReadPassTracks(path.string()), InputError);

  std::string version = good;
  version[8] = 9;
  WriteBytes(path, version);
  try {
    ReadPassTracks(path.string());
    FAIL() << "a future version was accepted";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("version"), std::string::npos) << e.what();
  }
}

TEST_F(PassFilesTest, StatesRoundTripExactly) {
  std::vector<slam::RowState> states(2);
  states[0].t = 1464792748146793805;
  states[0].nav.world_from_body = geometry::Rigid3(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized())),
      Eigen::Vector3d(0.1, -1e-9, 123.456789));
  states[0].nav.vel_world = Eigen::Vector3d(1.5, 0.01, -0.02);
  states[0].nav.rate_body = Eigen::Vector3d(0.001, 0.2, -0.3);
  states[0].bias << 1e-4, -2e-4, 3e-4, 0.01, -0.02, 0.03;
  states[1] = states[0];
  states[1].t += 133333333;
  const std::string path = (dir_ / "states.csv").string();
  WritePassStates(path, states);
  const std::vector<slam::RowState> read = ReadPassStates(path);
  ASSERT_EQ(read.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(read[i].t, states[i].t);
    EXPECT_EQ(read[i].nav.world_from_body.translation(),
              states[i].nav.world_from_body.translation());
    EXPECT_LT(read[i].nav.world_from_body.rotation().angularDistance(
                  states[i].nav.world_from_body.rotation()),
              1e-12);
    EXPECT_EQ(read[i].nav.vel_world, states[i].nav.vel_world);
    EXPECT_EQ(read[i].nav.rate_body, states[i].nav.rate_body);
    EXPECT_EQ(read[i].bias, states[i].bias);
  }
}

TEST_F(PassFilesTest, StatesRejectMalformedRows) {
  const fs::path path = dir_ / "states.csv";
  std::ofstream(path) << "1,0,0,0,0,0,0,1,0,0,0,0,0,0,0,0,0,0,0,0\n2,0,0\n";
  EXPECT_THROW(ReadPassStates(path.string()), InputError);
  std::ofstream(path) << "1,0,0,0,0,0,0,2,0,0,0,0,0,0,0,0,0,0,0,0\n";  // not a unit quaternion
  EXPECT_THROW(ReadPassStates(path.string()), InputError);
  std::ofstream(path) << "2,0,0,0,0,0,0,1,0,0,0,0,0,0,0,0,0,0,0,0\n"
                         "1,0,0,0,0,0,0,1,0,0,0,0,0,0,0,0,0,0,0,0\n";
  EXPECT_THROW(ReadPassStates(path.string()), InputError);
}

}  // namespace
}  // namespace crop4d::workspace
