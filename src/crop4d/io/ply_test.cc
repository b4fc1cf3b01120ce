#include "crop4d/io/ply.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstring>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

// A cloud that uses every feature: ENU coordinates far from the origin (float would lose
// them), normals, colours and extra scalars of several types at the edges of their ranges.
PlyPointCloud FullCloud() {
  PlyPointCloud cloud;
  PlyScalarField track{"track_length", PlyType::kInt32, {}};
  PlyScalarField error{"reprojection_error", PlyType::kFloat32, {}};
  PlyScalarField id{"landmark_id", PlyType::kUint32, {}};
  PlyScalarField offset{"offset", PlyType::kInt8, {}};
  PlyScalarField time{"time_s", PlyType::kFloat64, {}};
  for (int i = 0; i < 7; ++i) {
    cloud.points.emplace_back(1234.567890123456 + 0.001 * i, -2345.678901234567 * i,
                              0.1 + 1e-9 * i);
    cloud.normals.emplace_back(0.1f * i, -0.3f, 1.0f / 3.0f);
    cloud.colors.push_back({static_cast<std::uint8_t>(i * 40), 0, 255});
    track.values.push_back(i == 0 ? std::numeric_limits<std::int32_t>::min() : 3 * i);
    error.values.push_back(static_cast<float>(0.123456789 * i));
    id.values.push_back(i == 6 ? 4294967295.0 : i);
    offset.values.push_back(i == 0 ? -128 : 127 - i);
    time.values.push_back(1464177600.123456789 + i / 3.0);
  }
  cloud.scalars = {track, error, id, offset, time};
  return cloud;
}

void ExpectSameCloud(const PlyPointCloud& a, const PlyPointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  ASSERT_EQ(a.colors.size(), b.colors.size());
  ASSERT_EQ(a.normals.size(), b.normals.size());
  ASSERT_EQ(a.scalars.size(), b.scalars.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.points[i], b.points[i]) << i;  // Exact.
    if (!a.colors.empty()) {
      EXPECT_EQ(a.colors[i], b.colors[i]) << i;
    }
    if (!a.normals.empty()) {
      EXPECT_EQ(a.normals[i], b.normals[i]) << i;
    }
  }
  for (std::size_t k = 0; k < a.scalars.size(); ++k) {
    EXPECT_EQ(a.scalars[k].name, b.scalars[k].name);
    EXPECT_EQ(a.scalars[k].type, b.scalars[k].type);
    EXPECT_EQ(a.scalars[k].values, b.scalars[k].values) << a.scalars[k].name;
  }
}

// Little-endian bytes for hand-written binary files.
template <typename T>
void Put(T value, std::string* out) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // The test machines are little-endian.
  out->append(bytes, sizeof(T));
}

// Expects ReadPly(path) to throw an InputError for `path` whose message holds `what`.
void ExpectReadError(const std::string& path, const std::string& what) {
  try {
    ReadPly(path);
    ADD_FAILURE() << "no error, expected: " << what;
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), path);
    EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
  }
}

TEST(PlyTest, BinaryRoundTripIsExact) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  ASSERT_TRUE(cloud.Check());
  const std::string path = dir / "out/landmarks.ply";
  WritePly(path, cloud,
           {.format = PlyFormat::kBinaryLittleEndian, .comment = "crop4d landmarks\nframe: ENU"});
  const std::string text = testing::ReadText(path);
  const std::string expected_header =
      "ply\nformat binary_little_endian 1.0\ncomment crop4d landmarks\ncomment frame: ENU\n"
      "element vertex 7\nproperty double x\nproperty double y\nproperty double z\n"
      "property float nx\nproperty float ny\nproperty float nz\n"
      "property uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property int track_length\nproperty float reprojection_error\n"
      "property uint landmark_id\nproperty char offset\nproperty double time_s\nend_header\n";
  EXPECT_EQ(text.substr(0, expected_header.size()), expected_header);
  // 3 doubles, 3 floats, 3 uchars, int + float + uint + char + double per vertex.
  EXPECT_EQ(text.size(), expected_header.size() + 7u * (24 + 12 + 3 + 4 + 4 + 4 + 1 + 8));
  ExpectSameCloud(cloud, ReadPly(path));
  // Nothing but the result is left in the folder (atomic write).
  int files = 0;
  for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(dir / "out")) {
    ++files;
  }
  EXPECT_EQ(files, 1);
}

TEST(PlyTest, AsciiRoundTripIsExact) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  const std::string path = dir / "landmarks.ply";
  WritePly(path, cloud, {.format = PlyFormat::kAscii, .comment = ""});
  const std::vector<std::string> lines = testing::ReadLines(path);
  ASSERT_EQ(lines.size(), 18u + 7u);
  EXPECT_EQ(lines[1], "format ascii 1.0");
  EXPECT_EQ(lines[18],
            "1234.567890123456 -0 0.1 0 -0.3 0.33333334 0 0 255 -2147483648 0 0 -128 "
            "1464177600.1234567");
  ExpectSameCloud(cloud, ReadPly(path));
}

TEST(PlyTest, RoundTripsMinimalAndEmptyClouds) {
  testing::TempDir dir;
  PlyPointCloud cloud;
  cloud.points = {{1, 2, 3}, {-4.5, 5e-7, 6e6}};
  for (PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
    WritePly(dir / "minimal.ply", cloud, {.format = format, .comment = ""});
    ExpectSameCloud(cloud, ReadPly(dir / "minimal.ply"));
    WritePly(dir / "empty.ply", PlyPointCloud(), {.format = format, .comment = ""});
    EXPECT_EQ(ReadPly(dir / "empty.ply").size(), 0u);
  }
}

TEST(PlyTest, IntegerScalarsAreRoundedOnWrite) {
  testing::TempDir dir;
  PlyPointCloud cloud;
  cloud.points = {{0, 0, 0}, {1, 1, 1}};
  cloud.scalars = {{"count", PlyType::kUint16, {2.4, 65534.6}}};
  WritePly(dir / "a.ply", cloud);
  EXPECT_EQ(ReadPly(dir / "a.ply").scalars[0].values, (std::vector<double>{2, 65535}));
}

TEST(PlyTest, CheckRejectsInconsistentClouds) {
  PlyPointCloud cloud;
  cloud.points = {{0, 0, 0}};
  std::string why;
  cloud.colors = {{1, 2, 3}, {4, 5, 6}};
  EXPECT_FALSE(cloud.Check(&why));
  EXPECT_NE(why.find("colours"), std::string::npos);
  cloud.colors.clear();
  cloud.normals = {{0, 0, 1}, {0, 0, 1}};
  EXPECT_FALSE(cloud.Check());
  cloud.normals.clear();
  for (const char* name : {"", "two words", "x", "red", "diffuse_blue"}) {
    cloud.scalars = {{name, PlyType::kFloat32, {1.0}}};
    EXPECT_FALSE(cloud.Check()) << name;
  }
  cloud.scalars = {{"a", PlyType::kFloat32, {1.0}}, {"a", PlyType::kInt32, {1.0}}};
  EXPECT_FALSE(cloud.Check());
  cloud.scalars = {{"a", PlyType::kFloat32, {1.0, 2.0}}};
  EXPECT_FALSE(cloud.Check());
  cloud.scalars = {{"a", PlyType::kFloat32, {1.0}}};
  EXPECT_TRUE(cloud.Check());
}

TEST(PlyTest, WriteDiesOnInvalidCloud) {
  testing::TempDir dir;
  PlyPointCloud cloud;
  cloud.points = {{0, 0, 0}};
  cloud.scalars = {{"n", PlyType::kUint8, {256}}};
  EXPECT_DEATH(WritePly(dir / "a.ply", cloud), "does not fit");
  cloud.scalars = {{"n", PlyType::kUint8, {1, 2}}};
  EXPECT_DEATH(WritePly(dir / "a.ply", cloud), "values for 1 points");
}

TEST(PlyTest, ReadsAsciiVariants) {
  testing::TempDir dir;
  const std::string path = dir / "variant.ply";
  // Float xyz, CRLF line ends, comments, extra properties, a face element with a list,
  // colours before the coordinates, blank lines between records.
  testing::WriteText(path,
                     "ply\r\nformat ascii 1.0\r\ncomment made by hand\r\nobj_info x\r\n"
                     "element vertex 3\r\nproperty uchar red\r\nproperty uchar green\r\n"
                     "property uchar blue\r\nproperty float x\r\nproperty float y\r\n"
                     "property float z\r\nproperty uchar alpha\r\nproperty float intensity\r\n"
                     "property list uchar int vertex_indices\r\n"
                     "element face 1\r\nproperty list uchar int vertex_indices\r\n"
                     "end_header\r\n"
                     "255 0 10 1.5 -2 3e2 255 0.25 0\r\n"
                     "\r\n"
                     "0 128 255 0.1 +4 5 128.0 -1 2 7 8\r\n"
                     "1 2 3 7 8 9 0 0.5 1 0\r\n"
                     "3 0 1 2\r\n");
  const PlyPointCloud cloud = ReadPly(path);
  ASSERT_EQ(cloud.size(), 3u);
  EXPECT_EQ(cloud.points[0], Eigen::Vector3d(1.5, -2, 300));
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(static_cast<float>(0.1), 4, 5));
  ASSERT_EQ(cloud.colors.size(), 3u);
  EXPECT_EQ(cloud.colors[1], (std::array<std::uint8_t, 3>{0, 128, 255}));
  EXPECT_TRUE(cloud.normals.empty());
  ASSERT_EQ(cloud.scalars.size(), 2u);
  EXPECT_EQ(cloud.scalars[0].name, "alpha");
  EXPECT_EQ(cloud.scalars[0].type, PlyType::kUint8);
  EXPECT_EQ(cloud.scalars[0].values, (std::vector<double>{255, 128, 0}));
  ASSERT_NE(cloud.FindScalar("intensity"), nullptr);
  EXPECT_EQ(cloud.FindScalar("intensity")->values, (std::vector<double>{0.25, -1, 0.5}));
  EXPECT_EQ(cloud.FindScalar("vertex_indices"), nullptr);

  // No colours at all; float colours "diffuse_*" in 0..1; double normals.
  testing::WriteText(path,
                     "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\n"
                     "property double y\nproperty double z\nproperty double nx\n"
                     "property double ny\nproperty double nz\nend_header\n"
                     "1 2 3 0 0 1\n4 5 6 1 0 0\n");
  const PlyPointCloud plain = ReadPly(path);
  EXPECT_TRUE(plain.colors.empty());
  ASSERT_EQ(plain.normals.size(), 2u);
  EXPECT_EQ(plain.normals[1], Eigen::Vector3f(1, 0, 0));
  testing::WriteText(path,
                     "ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n"
                     "property float y\nproperty float z\nproperty float diffuse_red\n"
                     "property float diffuse_green\nproperty float diffuse_blue\nend_header\n"
                     "1 2 3 1.0 0.5 -0.2\n");
  const PlyPointCloud diffuse = ReadPly(path);
  ASSERT_EQ(diffuse.colors.size(), 1u);
  EXPECT_EQ(diffuse.colors[0], (std::array<std::uint8_t, 3>{255, 128, 0}));
}

TEST(PlyTest, ReadsBinaryVariants) {
  testing::TempDir dir;
  const std::string path = dir / "open3d.ply";
  // The layout Open3D and PCL write: float xyz, float normals, uchar colours, then a face
  // element holding lists, and an element before the vertices.
  std::string text =
      "ply\nformat binary_little_endian 1.0\ncomment VCGLIB generated\n"
      "element camera 1\nproperty float view_px\nproperty short id\n"
      "element vertex 2\nproperty float x\nproperty float y\nproperty float z\n"
      "property float nx\nproperty float ny\nproperty float nz\nproperty uchar red\n"
      "property uchar green\nproperty uchar blue\nproperty list uchar int ring\n"
      "property ushort label\n"
      "element face 2\nproperty list uchar int vertex_indices\nproperty uchar flags\n"
      "end_header\n";
  Put(1.5f, &text);
  Put<std::int16_t>(-3, &text);
  for (int i = 0; i < 2; ++i) {
    Put(100.25f * (i + 1), &text);
    Put(-0.5f, &text);
    Put(3.0f, &text);
    Put(0.0f, &text);
    Put(1.0f, &text);
    Put(0.0f, &text);
    Put<std::uint8_t>(10, &text);
    Put<std::uint8_t>(20, &text);
    Put<std::uint8_t>(static_cast<std::uint8_t>(30 + i), &text);
    Put<std::uint8_t>(static_cast<std::uint8_t>(i), &text);  // A ring of i ints.
    for (int k = 0; k < i; ++k) Put<std::int32_t>(k, &text);
    Put<std::uint16_t>(static_cast<std::uint16_t>(60000 + i), &text);
  }
  for (int f = 0; f < 2; ++f) {
    Put<std::uint8_t>(3, &text);
    for (int k = 0; k < 3; ++k) Put<std::int32_t>(k, &text);
    Put<std::uint8_t>(7, &text);
  }
  testing::WriteText(path, text);
  const PlyPointCloud cloud = ReadPly(path);
  ASSERT_EQ(cloud.size(), 2u);
  EXPECT_EQ(cloud.points[1], Eigen::Vector3d(200.5, -0.5, 3.0));
  EXPECT_EQ(cloud.normals[0], Eigen::Vector3f(0, 1, 0));
  EXPECT_EQ(cloud.colors[1], (std::array<std::uint8_t, 3>{10, 20, 31}));
  ASSERT_EQ(cloud.scalars.size(), 1u);
  EXPECT_EQ(cloud.scalars[0].name, "label");
  EXPECT_EQ(cloud.scalars[0].type, PlyType::kUint16);
  EXPECT_EQ(cloud.scalars[0].values, (std::vector<double>{60000, 60001}));
}

// A valid binary file of two vertices (double xyz + uchar colours) and its header.
std::string BinaryHeader(int count = 2) {
  return "ply\nformat binary_little_endian 1.0\nelement vertex " + std::to_string(count) +
         "\nproperty double x\nproperty double y\nproperty double z\nproperty uchar red\n"
         "property uchar green\nproperty uchar blue\nend_header\n";
}
std::string BinaryBody() {
  std::string body;
  for (int i = 0; i < 2; ++i) {
    for (int k = 0; k < 3; ++k) Put<double>(i + k, &body);
    for (int k = 0; k < 3; ++k) Put<std::uint8_t>(static_cast<std::uint8_t>(k), &body);
  }
  return body;
}

TEST(PlyTest, RejectsMalformedHeaders) {
  testing::TempDir dir;
  const std::string path = dir / "bad.ply";
  auto expect = [&](const std::string& text, const std::string& what, int line = -1) {
    testing::WriteText(path, text);
    try {
      ReadPly(path);
      ADD_FAILURE() << "no error, expected: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      if (line >= 0) {
        EXPECT_EQ(e.line(), line) << e.what();
      }
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  ASSERT_NO_THROW({
    testing::WriteText(path, BinaryHeader() + BinaryBody());
    ReadPly(path);
  });
  expect("", "not a PLY file", 1);
  expect("PLY\nformat ascii 1.0\nend_header\n", "not a PLY file", 1);
  expect("solid cube\nfacet normal 0 0 1\n", "not a PLY file", 1);
  expect("ply\nformat binary_big_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n",
         "unsupported format binary_big_endian", 2);
  expect("ply\nformat binary 1.0\nend_header\n", "unknown format", 2);
  expect("ply\nformat ascii 2.0\nend_header\n", "unsupported PLY version", 2);
  expect("ply\nformat ascii 1.0\nelement vertex 1\nproperty float x\n", "without \"end_header\"");
  expect("ply\nelement vertex 1\nproperty float x\nend_header\n", "before the \"format\" line", 2);
  expect("ply\nend_header\n", "no \"format\" line", 0);
  expect("ply\nformat ascii 1.0\nend_header\n", "no \"vertex\" element", 0);
  expect("ply\nformat ascii 1.0\nend_header", "not followed by a newline", 3);
}

TEST(PlyTest, RejectsMalformedHeaderLines) {
  testing::TempDir dir;
  const std::string path = dir / "bad.ply";
  auto expect = [&](const std::string& lines, const std::string& what, int line) {
    testing::WriteText(path, "ply\nformat ascii 1.0\n" + lines + "end_header\n");
    try {
      ReadPly(path);
      ADD_FAILURE() << "no error, expected: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  const std::string xyz = "property float x\nproperty float y\nproperty float z\n";
  expect("property float x\n", "before any \"element\"", 3);
  expect("element vertex -1\n", "not a non-negative integer", 3);
  expect("element vertex many\n", "not a non-negative integer", 3);
  expect("element vertex 0\nproperty float64x x\n", "unknown type", 4);
  expect("element vertex 0\nproperty list float int x\n", "list count of a floating-point", 4);
  expect("element vertex 0\nproperty float\n", "expected \"property", 4);
  expect("element vertex 0\n" + xyz + "property float x\n", "a second property \"x\"", 7);
  expect("element vertex 0\nelement vertex 0\n", "a second element", 4);
  expect("element vertex 0\nvertices 3\n", "unknown header line", 4);
  expect("element face 0\nproperty list uchar int vertex_indices\n", "no \"vertex\" element", 0);
  expect("element vertex 0\nproperty float x\nproperty float z\n", "no \"y\" property", 3);
  expect("element vertex 0\nproperty float y\nproperty float z\n", "no \"x\" property", 3);
  expect("element vertex 0\nproperty float x\nproperty float y\n", "no \"z\" property", 3);
  expect("element vertex 0\n" + xyz + "property uchar red\nproperty uchar green\n",
         "some of red, green, blue", 3);
  expect("element vertex 0\n" + xyz + "property float nx\n", "some of nx, ny, nz", 3);
  expect("element vertex 0\nproperty list uchar float x\nproperty float y\nproperty float z\n",
         "is a list", 3);
}

TEST(PlyTest, RejectsBadBinaryData) {
  testing::TempDir dir;
  const std::string path = dir / "bad.ply";
  const std::string body = BinaryBody();
  // Truncated in the middle of a record, and a file too short for the declared count.
  testing::WriteText(path, BinaryHeader() + body.substr(0, body.size() - 1));
  ExpectReadError(path, "truncated data: element \"vertex\" record 2 of 2");
  testing::WriteText(path, BinaryHeader(1000000000) + body);
  ExpectReadError(path, "truncated data");
  // More data than the header declares.
  testing::WriteText(path, BinaryHeader(1) + body);
  ExpectReadError(path, "27 bytes after the last element");
  // A list running past the end of the file in a later element.
  testing::WriteText(path,
                     "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                     "property double x\nproperty double y\nproperty double z\n"
                     "element face 1\nproperty list uchar int vertex_indices\n"
                     "end_header\n\x03\x01\x00\x00\x00");
  ExpectReadError(path, "truncated data: element \"face\" record 1 of 1");
  // A negative list length.
  testing::WriteText(path,
                     "ply\nformat binary_little_endian 1.0\nelement vertex 0\n"
                     "property double x\nproperty double y\nproperty double z\n"
                     "element face 1\nproperty list char int vertex_indices\n"
                     "end_header\n\xff");
  ExpectReadError(path, "negative list length");
  EXPECT_THROW(ReadPly(dir / "missing.ply"), InputError);
}

TEST(PlyTest, RejectsBadAsciiData) {
  testing::TempDir dir;
  const std::string path = dir / "bad.ply";
  const std::string header =
      "ply\nformat ascii 1.0\nelement vertex 2\nproperty double x\nproperty double y\n"
      "property double z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "end_header\n";  // 10 lines.
  auto expect = [&](const std::string& body, const std::string& what, int line) {
    testing::WriteText(path, header + body);
    try {
      ReadPly(path);
      ADD_FAILURE() << "no error, expected: " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  ASSERT_NO_THROW({
    testing::WriteText(path, header + "1 2 3 4 5 6\n1 2 3 4 5 6\n");
    ReadPly(path);
  });
  expect("1 2 3 4 5 6\n", "has 1 records of the 2", 11);
  expect("", "too short for 2", 0);
  expect("1 2 3 4 5 6\n1 2 3 4 5\n", "too few values", 12);
  expect("1 2 3 4 5 6\n1 2 3 4 5 6 7\n", "7 values on the line, expected 6", 12);
  expect("1 2 3 4 5 6\n1 2 3 4 5 6\n1 2 3 4 5 6\n", "data after the last element", 13);
  expect("1 2 x 4 5 6\n1 2 3 4 5 6\n", "\"x\" is not a valid double value for \"z\"", 11);
  expect("1 2 3 4 5 256\n1 2 3 4 5 6\n", "not a valid uchar value for \"blue\"", 11);
  expect("1 2 3 4 5 -1\n1 2 3 4 5 6\n", "not a valid uchar", 11);
  expect("1 2 3 4 5 6.5\n1 2 3 4 5 6\n", "not a valid uchar", 11);
  expect("1 2 3e999 4 5 6\n1 2 3 4 5 6\n", "not a valid double", 11);
  expect("1,2,3,4,5,6\n1 2 3 4 5 6\n", "not a valid double", 11);
}

// ---- PlyStreamWriter ----

// Points [start, stop) of `cloud`, with its normals, colours and scalar fields.
PlyPointCloud Slice(const PlyPointCloud& cloud, std::size_t start, std::size_t stop) {
  PlyPointCloud part;
  part.points.assign(cloud.points.begin() + start, cloud.points.begin() + stop);
  if (!cloud.normals.empty()) {
    part.normals.assign(cloud.normals.begin() + start, cloud.normals.begin() + stop);
  }
  if (!cloud.colors.empty()) {
    part.colors.assign(cloud.colors.begin() + start, cloud.colors.begin() + stop);
  }
  for (const PlyScalarField& field : cloud.scalars) {
    part.scalars.push_back(
        {field.name, field.type, {field.values.begin() + start, field.values.begin() + stop}});
  }
  return part;
}

// The names of the entries of `folder`, sorted.
std::vector<std::string> ListFolder(const std::string& folder) {
  std::vector<std::string> names;
  for (const auto& entry : std::filesystem::directory_iterator(folder)) {
    names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

// A cloud of `n` points with every feature, larger than the writer's chunk of 65536 points
// when n is.
PlyPointCloud LargeCloud(int n) {
  PlyPointCloud cloud;
  PlyScalarField count{"count", PlyType::kUint16, {}};
  PlyScalarField weight{"weight", PlyType::kFloat32, {}};
  PlyScalarField id{"id", PlyType::kInt32, {}};
  for (int i = 0; i < n; ++i) {
    cloud.points.emplace_back(512000.25 + 0.001 * i, 5400000.5 - 0.003 * i, 1e-3 * (i % 977));
    cloud.normals.emplace_back(0.0f, 0.6f, 0.8f - 1e-6f * i);
    cloud.colors.push_back({static_cast<std::uint8_t>(i % 256), static_cast<std::uint8_t>(i / 256),
                            static_cast<std::uint8_t>(7 * i)});
    count.values.push_back(i % 65536);
    weight.values.push_back(static_cast<float>(1.0 / (i + 1)));
    id.values.push_back(-i);
  }
  cloud.scalars = {count, weight, id};
  return cloud;
}

TEST(PlyStreamWriterTest, SlicesGiveTheBytesOfWritePly) {
  testing::TempDir dir;
  struct Case {
    PlyPointCloud cloud;
    std::vector<std::size_t> cuts;  // Slice boundaries, from 0 to the size.
  };
  // Slices of unequal sizes, one of them empty; the large cloud's cross the chunk boundary.
  const std::vector<Case> cases = {{FullCloud(), {0, 2, 2, 7}},
                                   {LargeCloud(150000), {0, 70000, 70000, 150000}}};
  for (const Case& c : cases) {
    ASSERT_TRUE(c.cloud.Check());
    for (PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
      SCOPED_TRACE(format == PlyFormat::kAscii ? "ascii" : "binary");
      const PlyWriteOptions options{.format = format, .comment = "crop4d\nstreamed"};
      WritePly(dir / "whole.ply", c.cloud, options);
      std::filesystem::remove(dir / "streamed.ply");
      {
        PlyStreamWriter writer(dir / "streamed.ply", LayoutOf(c.cloud), options);
        for (std::size_t k = 0; k + 1 < c.cuts.size(); ++k) {
          writer.Append(Slice(c.cloud, c.cuts[k], c.cuts[k + 1]));
          EXPECT_EQ(writer.size(), c.cuts[k + 1]);
        }
        EXPECT_FALSE(std::filesystem::exists(dir / "streamed.ply"));  // Not before Finish.
        writer.Finish();
      }
      const std::string whole = testing::ReadText(dir / "whole.ply");
      const std::string streamed = testing::ReadText(dir / "streamed.ply");
      EXPECT_EQ(streamed.size(), whole.size());
      EXPECT_TRUE(streamed == whole);  // Not EXPECT_EQ: megabytes of output on failure.
      ExpectSameCloud(c.cloud, ReadPly(dir / "streamed.ply"));
      // One Append of the whole cloud gives the same bytes too.
      {
        PlyStreamWriter writer(dir / "streamed.ply", LayoutOf(c.cloud), options);
        writer.Append(c.cloud);
        writer.Finish();
      }
      EXPECT_TRUE(testing::ReadText(dir / "streamed.ply") == whole);
      // No body or temporary file is left.
      EXPECT_EQ(ListFolder(dir.path()), (std::vector<std::string>{"streamed.ply", "whole.ply"}));
    }
  }
}

TEST(PlyStreamWriterTest, ZeroPointStreamIsAValidEmptyFile) {
  testing::TempDir dir;
  PlyLayout layout;
  layout.scalars = {{"track_length", PlyType::kInt32}, {"error", PlyType::kFloat64}};
  for (PlyFormat format : {PlyFormat::kBinaryLittleEndian, PlyFormat::kAscii}) {
    const std::string path = dir / "empty.ply";
    {
      PlyStreamWriter writer(path, layout, {.format = format, .comment = ""});
      writer.Finish();
    }
    const PlyPointCloud cloud = ReadPly(path);
    EXPECT_EQ(cloud.size(), 0u);
    EXPECT_TRUE(cloud.normals.empty());
    EXPECT_TRUE(cloud.colors.empty());
    EXPECT_EQ(LayoutOf(cloud), layout);
    ASSERT_EQ(cloud.scalars.size(), 2u);
    EXPECT_EQ(cloud.scalars[1].name, "error");
    EXPECT_EQ(cloud.scalars[1].type, PlyType::kFloat64);
  }
  // With normals and colours in the layout, and parts of no points appended.
  layout.normals = layout.colors = true;
  PlyPointCloud none;
  none.scalars = {{"track_length", PlyType::kInt32, {}}, {"error", PlyType::kFloat64, {}}};
  {
    PlyStreamWriter writer(dir / "empty.ply", layout);
    writer.Append(none);
    writer.Append(none);
    EXPECT_EQ(writer.size(), 0u);
    writer.Finish();
  }
  const std::string text = testing::ReadText(dir / "empty.ply");
  EXPECT_NE(text.find("element vertex 0\n"), std::string::npos);
  EXPECT_NE(text.find("property float nx\n"), std::string::npos);
  EXPECT_NE(text.find("property uchar red\n"), std::string::npos);
  EXPECT_EQ(text.substr(text.size() - 11), "end_header\n");  // Nothing after the header.
  EXPECT_EQ(ReadPly(dir / "empty.ply").scalars.size(), 2u);
  EXPECT_EQ(ListFolder(dir.path()), (std::vector<std::string>{"empty.ply"}));
}

TEST(PlyStreamWriterTest, DestroyedWithoutFinishLeavesNoFile) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  const std::string path = dir / "cloud.ply";
  try {
    PlyStreamWriter writer(path, LayoutOf(cloud));
    writer.Append(Slice(cloud, 0, 3));
    // Meanwhile the only file is the hidden body, named like AtomicFile's temporary files.
    const std::vector<std::string> names = ListFolder(dir.path());
    EXPECT_EQ(names.size(), 1u);
    EXPECT_EQ(names.at(0).rfind(".cloud.ply.body.tmp.", 0), 0u) << names.at(0);
    throw std::runtime_error("unwinding");
  } catch (const std::runtime_error&) {
  }
  EXPECT_EQ(ListFolder(dir.path()), std::vector<std::string>{});

  // An existing file is left as it was.
  testing::WriteText(path, "old");
  {
    PlyStreamWriter writer(path, LayoutOf(cloud), {.format = PlyFormat::kAscii, .comment = ""});
    writer.Append(cloud);
  }
  EXPECT_EQ(testing::ReadText(path), "old");
  EXPECT_EQ(ListFolder(dir.path()), (std::vector<std::string>{"cloud.ply"}));

  // A body that a killed writer would leave is a stale temporary file.
  {
    PlyStreamWriter writer(path, LayoutOf(cloud));
    writer.Append(cloud);
    EXPECT_EQ(RemoveStaleTemporaryFiles(dir.path()), 1);
  }
  EXPECT_EQ(ListFolder(dir.path()), (std::vector<std::string>{"cloud.ply"}));
}

TEST(PlyStreamWriterTest, DiesOnMisuse) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  PlyStreamWriter writer(dir / "a.ply", LayoutOf(cloud));
  writer.Append(Slice(cloud, 0, 1));

  PlyPointCloud part = Slice(cloud, 1, 3);
  part.normals.clear();
  EXPECT_DEATH(writer.Append(part), "the part has no normals, the writer's layout has them");
  part = Slice(cloud, 1, 3);
  part.colors.clear();
  EXPECT_DEATH(writer.Append(part), "the part has no colours, the writer's layout has them");
  part = Slice(cloud, 1, 3);
  part.scalars[1].type = PlyType::kFloat64;
  EXPECT_DEATH(writer.Append(part), "scalar field 2 of the part is \"reprojection_error\" .double");
  part = Slice(cloud, 1, 3);
  part.scalars.pop_back();
  EXPECT_DEATH(writer.Append(part), "scalar field 5 of the part is none");
  part = Slice(cloud, 1, 1);  // No points: the scalars still count.
  std::swap(part.scalars[0], part.scalars[1]);
  EXPECT_DEATH(writer.Append(part), "scalar field 1 of the part");
  part = Slice(cloud, 1, 3);
  part.colors.pop_back();
  EXPECT_DEATH(writer.Append(part), "1 colours for 2 points");  // Fails Check().
  part = Slice(cloud, 1, 3);
  part.scalars[0].values[0] = 1e10;
  EXPECT_DEATH(writer.Append(part), "does not fit a int");

  PlyStreamWriter plain(dir / "plain.ply", PlyLayout());
  EXPECT_DEATH(plain.Append(cloud), "the part has normals, the writer's layout has none");

  PlyLayout bad;
  bad.scalars = {{"red", PlyType::kUint8}};
  EXPECT_DEATH(PlyStreamWriter(dir / "b.ply", bad), "\"red\" is reserved");
  bad.scalars = {{"n", PlyType::kUint8}, {"n", PlyType::kInt8}};
  EXPECT_DEATH(PlyStreamWriter(dir / "b.ply", bad), "two scalar fields named \"n\"");

  writer.Append(Slice(cloud, 1, 7));
  writer.Finish();
  EXPECT_EQ(ReadPly(dir / "a.ply").size(), 7u);
  EXPECT_DEATH(writer.Append(cloud), "Append after Finish");
  EXPECT_DEATH(writer.Finish(), "Finish called twice");
}

TEST(PlyStreamWriterTest, UnwritableFolderThrowsInputError) {
  testing::TempDir dir;
  auto expect_error = [](const std::string& path) {
    try {
      PlyStreamWriter writer(path, PlyLayout());
      ADD_FAILURE() << "no error for " << path;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path) << e.what();
    }
  };
  // A "folder" that is a file.
  testing::WriteText(dir / "file", "x");
  expect_error(dir / "file/cloud.ply");
  // The output path is a folder.
  std::filesystem::create_directories(dir / "folder.ply");
  expect_error(dir / "folder.ply");
  // A read-only folder (root may write into it anyway).
  if (::geteuid() != 0) {
    std::filesystem::create_directories(dir / "readonly");
    std::filesystem::permissions(
        dir / "readonly", std::filesystem::perms::owner_read | std::filesystem::perms::owner_exec);
    expect_error(dir / "readonly/cloud.ply");
    std::filesystem::permissions(dir / "readonly", std::filesystem::perms::owner_all);
  }
  // Nothing was created.
  EXPECT_EQ(testing::ReadText(dir / "file"), "x");
  EXPECT_EQ(ListFolder(dir / "folder.ply"), std::vector<std::string>{});
  if (std::filesystem::exists(dir / "readonly")) {
    EXPECT_EQ(ListFolder(dir / "readonly"), std::vector<std::string>{});
  }
}

// The vertices read a slice at a time are those ReadPly reads, whatever the slices: binary
// (seeking to the slice) and ASCII (read whole once), a file with an element before the vertices
// and one with lists after them.
TEST(PlyVertexReaderTest, SlicesAreThoseOfReadPly) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  const auto expect_slices = [&](const std::string& path) {
    SCOPED_TRACE(path);
    const PlyPointCloud whole = ReadPly(path);
    PlyVertexReader reader(path);
    ASSERT_EQ(reader.size(), whole.size());
    EXPECT_TRUE(reader.layout() == LayoutOf(whole));
    for (const std::size_t step : {std::size_t{1}, std::size_t{2}, whole.size() + 5}) {
      PlyPointCloud joined;
      for (std::size_t start = 0; start < reader.size(); start += step) {
        const PlyPointCloud part = reader.Read(start, step);
        ASSERT_EQ(part.size(), std::min(step, reader.size() - start));
        EXPECT_TRUE(LayoutOf(part) == LayoutOf(whole) || part.size() == 0);
        joined.Append(part);
      }
      EXPECT_EQ(joined.points, whole.points);
      EXPECT_EQ(joined.normals, whole.normals);
      EXPECT_EQ(joined.colors, whole.colors);
      ASSERT_EQ(joined.scalars.size(), whole.scalars.size());
      for (std::size_t k = 0; k < whole.scalars.size(); ++k) {
        EXPECT_EQ(joined.scalars[k].values, whole.scalars[k].values) << whole.scalars[k].name;
      }
    }
    // Past the end: nothing.
    EXPECT_EQ(reader.Read(reader.size(), 3).size(), 0u);
    EXPECT_EQ(reader.Read(reader.size() + 10, 3).size(), 0u);
  };
  WritePly(dir / "binary.ply", cloud);
  expect_slices(dir / "binary.ply");
  PlyWriteOptions ascii;
  ascii.format = PlyFormat::kAscii;
  WritePly(dir / "ascii.ply", cloud, ascii);
  expect_slices(dir / "ascii.ply");
  // An element of fixed-size records before the vertices: still seekable.
  std::string text =
      "ply\nformat binary_little_endian 1.0\nelement camera 1\nproperty float view_px\n"
      "property short id\nelement vertex 3\nproperty float x\nproperty float y\n"
      "property float z\nproperty uchar red\nproperty uchar green\nproperty uchar blue\n"
      "property ushort label\nend_header\n";
  Put(1.5f, &text);
  Put<std::int16_t>(-3, &text);
  for (int i = 0; i < 3; ++i) {
    for (int k = 0; k < 3; ++k) Put(0.25f * (i + k), &text);
    for (int k = 0; k < 3; ++k) Put<std::uint8_t>(static_cast<std::uint8_t>(10 * i + k), &text);
    Put<std::uint16_t>(static_cast<std::uint16_t>(60000 + i), &text);
  }
  testing::WriteText(dir / "camera_first.ply", text);
  expect_slices(dir / "camera_first.ply");
}

// Append concatenates clouds of one layout and refuses another.
TEST(PlyTest, AppendJoinsCloudsOfOneLayout) {
  const PlyPointCloud cloud = FullCloud();
  PlyPointCloud joined;
  joined.Append(cloud);
  PlyPointCloud none;  // no points, the same fields
  for (const PlyScalarField& f : cloud.scalars) none.scalars.push_back({f.name, f.type, {}});
  joined.Append(none);
  joined.Append(cloud);
  ASSERT_EQ(joined.size(), 2 * cloud.size());
  EXPECT_EQ(joined.points[cloud.size() + 2], cloud.points[2]);
  EXPECT_EQ(joined.colors.size(), joined.size());
  EXPECT_EQ(joined.scalars[4].values[cloud.size() + 6], cloud.scalars[4].values[6]);
  std::string why;
  EXPECT_TRUE(joined.Check(&why)) << why;
  PlyPointCloud other = cloud;
  other.scalars[1].name = "error";
  EXPECT_DEATH(joined.Append(other), "other scalar fields");
  PlyPointCloud no_colours = cloud;
  no_colours.colors.clear();
  EXPECT_DEATH(joined.Append(no_colours), "other normals or colours");
}

// ReadPlyWhere keeps the vertices its test keeps, with all their properties.
TEST(PlyVertexReaderTest, ReadPlyWhereKeepsWhatItsTestKeeps) {
  testing::TempDir dir;
  const PlyPointCloud cloud = FullCloud();
  WritePly(dir / "c.ply", cloud);
  const auto above = [](const Eigen::Vector3d& p) { return p.y() > -5000; };
  const PlyPointCloud kept = ReadPlyWhere(dir / "c.ply", above);
  std::size_t n = 0;
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    if (!above(cloud.points[i])) continue;
    ASSERT_LT(n, kept.size());
    EXPECT_EQ(kept.points[n], cloud.points[i]);
    EXPECT_EQ(kept.normals[n], cloud.normals[i]);
    EXPECT_EQ(kept.colors[n], cloud.colors[i]);
    for (std::size_t k = 0; k < cloud.scalars.size(); ++k) {
      EXPECT_EQ(kept.scalars[k].values[n], cloud.scalars[k].values[i]);
    }
    ++n;
  }
  EXPECT_EQ(kept.size(), n);
  EXPECT_GT(n, 0u);
  EXPECT_LT(n, cloud.size());
  EXPECT_TRUE(LayoutOf(kept) == LayoutOf(cloud));
  // None kept: no point, the scalar fields named all the same.
  const PlyPointCloud none =
      ReadPlyWhere(dir / "c.ply", [](const Eigen::Vector3d&) { return false; });
  EXPECT_EQ(none.size(), 0u);
  EXPECT_EQ(none.scalars.size(), cloud.scalars.size());
}

// A file shorter than its header says, or longer, is refused when the reader opens it, naming
// the file; so is a file that is not PLY.
TEST(PlyVertexReaderTest, RefusesTruncatedOrOverlongFiles) {
  testing::TempDir dir;
  const std::string path = dir / "bad.ply";
  const std::string body = BinaryBody();
  const auto expect_error = [&](const std::string& what) {
    try {
      PlyVertexReader reader(path);
      ADD_FAILURE() << "no error for " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), path);
      EXPECT_NE(std::string(e.what()).find(what), std::string::npos) << e.what();
    }
  };
  testing::WriteText(path, BinaryHeader() + body.substr(0, body.size() - 1));
  expect_error("truncated data: the file holds 1 of the 2 \"vertex\" records");
  testing::WriteText(path, BinaryHeader(1000000000) + body);
  expect_error("truncated data: the file holds 2 of the 1000000000 \"vertex\" records");
  testing::WriteText(path, BinaryHeader(1) + body);
  expect_error("27 bytes after the last element");
  testing::WriteText(path, "not a ply file\n");
  expect_error("not a PLY file");
  EXPECT_THROW(PlyVertexReader(dir / "missing.ply"), InputError);
  testing::WriteText(path, BinaryHeader() + body);
  PlyVertexReader reader(path);
  EXPECT_EQ(reader.size(), 2u);
  EXPECT_EQ(reader.Read(1, 1).points[0], Eigen::Vector3d(1, 2, 3));
}

}  // namespace
}  // namespace crop4d::io
