#include "crop4d/io/las.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <random>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

using testing::ReadText;
using testing::TempDir;
using testing::WriteText;

template <typename T>
T At(const std::string& bytes, std::size_t offset) {
  T value;
  std::memcpy(&value, bytes.data() + offset, sizeof(T));
  return value;
}

// Points around a UTM position of zone 17N (Tifton, Georgia), with every attribute varied.
std::vector<LasPoint> SomePoints(int n, unsigned seed = 7) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> dx(-40.0, 40.0), dz(-1.0, 3.0);
  std::vector<LasPoint> points(n);
  for (int i = 0; i < n; ++i) {
    LasPoint& p = points[i];
    p.xyz = Eigen::Vector3d(254321.123 + dx(rng), 3485000.456 + dx(rng), 100.0 + dz(rng));
    p.intensity = static_cast<std::uint16_t>(i * 37);
    p.return_number = 1 + i % 3;
    p.number_of_returns = 3;
    p.classification = static_cast<std::uint8_t>(i % 20);
    p.user_data = static_cast<std::uint8_t>(i % 256);
    p.scan_angle = static_cast<std::int16_t>(i - 50);
    p.point_source_id = static_cast<std::uint16_t>(i % 4);
    p.gps_time = 1000.25 + i;
    p.rgb = {static_cast<std::uint16_t>(i * 257), 65535, 0};
  }
  return points;
}

LasWriteOptions Utm17N() {
  LasWriteOptions options;
  options.epsg = 32617;
  options.creation_year = 2016;
  options.creation_day_of_year = 177;
  return options;
}

TEST(LasTest, RoundTripKeepsPointsWithinTheScale) {
  const TempDir dir;
  const std::vector<LasPoint> points = SomePoints(500);
  WriteLas(dir / "a.las", points, Utm17N());
  const LasFile las = ReadLas(dir / "a.las");
  ASSERT_EQ(las.points.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    const LasPoint& a = points[i];
    const LasPoint& b = las.points[i];
    EXPECT_LE((a.xyz - b.xyz).cwiseAbs().maxCoeff(), 0.0005 + 1e-9) << i;
    LasPoint same = b;
    same.xyz = a.xyz;
    EXPECT_EQ(same, a) << i;
  }
  EXPECT_EQ(las.header.system_identifier, "crop4d export");
  EXPECT_EQ(las.header.generating_software, "crop4d");
  EXPECT_EQ(las.header.creation_year, 2016);
  EXPECT_EQ(las.header.creation_day_of_year, 177);
  EXPECT_TRUE(las.evlrs.empty());
}

TEST(LasTest, HeaderFieldsFollowTheSpecification) {
  const TempDir dir;
  const std::vector<LasPoint> points = SomePoints(123);
  WriteLas(dir / "a.las", points, Utm17N());
  const std::string bytes = ReadText(dir / "a.las");
  const std::string wkt = EpsgWkt(32617);
  const std::size_t offset = 375 + 54 + wkt.size() + 1;
  ASSERT_EQ(bytes.size(), offset + 36 * points.size());

  // Public header block, LAS 1.4 R15 Table 3 (offsets in bytes).
  EXPECT_EQ(bytes.substr(0, 4), "LASF");
  EXPECT_EQ(At<std::uint16_t>(bytes, 6), (1 << 4) | 1);  // global encoding: WKT, adjusted GPS time
  EXPECT_EQ(At<std::uint8_t>(bytes, 24), 1);             // version major
  EXPECT_EQ(At<std::uint8_t>(bytes, 25), 4);             // version minor
  EXPECT_EQ(At<std::uint16_t>(bytes, 90), 177);
  EXPECT_EQ(At<std::uint16_t>(bytes, 92), 2016);
  EXPECT_EQ(At<std::uint16_t>(bytes, 94), 375);  // header size
  EXPECT_EQ(At<std::uint32_t>(bytes, 96), offset);
  EXPECT_EQ(At<std::uint32_t>(bytes, 100), 1u);  // one VLR
  EXPECT_EQ(At<std::uint8_t>(bytes, 104), 7);    // point data record format
  EXPECT_EQ(At<std::uint16_t>(bytes, 105), 36);  // record length
  EXPECT_EQ(At<std::uint32_t>(bytes, 107), 0u);  // legacy count: 0 for formats 6-10
  EXPECT_EQ(At<double>(bytes, 131), 0.001);
  EXPECT_EQ(At<double>(bytes, 139), 0.001);
  EXPECT_EQ(At<double>(bytes, 147), 0.001);
  EXPECT_EQ(At<std::uint64_t>(bytes, 235), 0u);  // no EVLR
  EXPECT_EQ(At<std::uint32_t>(bytes, 243), 0u);
  EXPECT_EQ(At<std::uint64_t>(bytes, 247), points.size());
  // Points by return: 1, 2, 3 in turn.
  EXPECT_EQ(At<std::uint64_t>(bytes, 255), 41u);
  EXPECT_EQ(At<std::uint64_t>(bytes, 263), 41u);
  EXPECT_EQ(At<std::uint64_t>(bytes, 271), 41u);
  EXPECT_EQ(At<std::uint64_t>(bytes, 279), 0u);

  // Offsets near the data and bounds of the stored points.
  Eigen::Vector3d lo = points[0].xyz, hi = points[0].xyz;
  for (const LasPoint& p : points) {
    lo = lo.cwiseMin(p.xyz);
    hi = hi.cwiseMax(p.xyz);
  }
  for (int k = 0; k < 3; ++k) {
    const double off = At<double>(bytes, 155 + 8 * k);
    EXPECT_EQ(off, std::round(off));
    EXPECT_LE(std::abs(off - 0.5 * (lo[k] + hi[k])), 0.5 + 1e-9);
    EXPECT_NEAR(At<double>(bytes, 179 + 16 * k), hi[k], 0.0005 + 1e-9);  // max
    EXPECT_NEAR(At<double>(bytes, 187 + 16 * k), lo[k], 0.0005 + 1e-9);  // min
  }

  // The CRS VLR right after the header.
  EXPECT_EQ(std::string(bytes.data() + 375 + 2), kLasProjectionUserId);
  EXPECT_EQ(At<std::uint16_t>(bytes, 375 + 18), 2112);
  EXPECT_EQ(At<std::uint16_t>(bytes, 375 + 20), wkt.size() + 1);
  EXPECT_EQ(bytes.substr(375 + 54, wkt.size()), wkt);
  EXPECT_EQ(bytes[375 + 54 + wkt.size()], '\0');

  // The first point, decoded by hand.
  const std::size_t p0 = offset;
  for (int k = 0; k < 3; ++k) {
    const double value =
        At<std::int32_t>(bytes, p0 + 4 * k) * 0.001 + At<double>(bytes, 155 + 8 * k);
    EXPECT_NEAR(value, points[0].xyz[k], 0.0005 + 1e-9);
  }
  EXPECT_EQ(At<std::uint8_t>(bytes, p0 + 14), 1 | (3 << 4));
  EXPECT_EQ(At<double>(bytes, p0 + 22), points[0].gps_time);
  EXPECT_EQ(At<std::uint16_t>(bytes, p0 + 32), 65535);

  const LasFile las = ReadLas(dir / "a.las");
  EXPECT_EQ(las.header.point_count, points.size());
  EXPECT_EQ(las.header.offset_to_point_data, offset);
  ASSERT_EQ(las.vlrs.size(), 1u);
  EXPECT_EQ(las.Wkt(), wkt);
}

TEST(LasTest, WktNamesTheUtmZone) {
  EXPECT_NE(EpsgWkt(32617).find("UTM zone 17N"), std::string::npos);
  EXPECT_NE(EpsgWkt(32617).find("32617"), std::string::npos);
  EXPECT_NE(EpsgWkt(32733).find("UTM zone 33S"), std::string::npos);
  EXPECT_THROW(EpsgWkt(-3), InputError);
}

TEST(LasTest, EnuCloudBecomesUtmWithEllipsoidalHeights) {
  // The tiny field's origin: zone 17N.
  const geometry::GeodeticPoint origin{31.47, -83.53, 100.0};
  const FieldUtm utm(origin);
  ASSERT_EQ(utm.epsg(), 32617);
  PlyPointCloud cloud;
  cloud.points = {{0, 0, 0}, {1.5, 8.25, 0.3}, {-120.0, 300.0, -2.0}};
  cloud.colors = {{{0, 128, 255}}, {{1, 2, 3}}, {{255, 255, 255}}};
  const std::vector<LasPoint> points = LasPointsFromEnu(cloud, origin, utm.epsg(), 9);
  ASSERT_EQ(points.size(), 3u);
  const geometry::LocalEnu enu(origin);
  for (std::size_t i = 0; i < 3; ++i) {
    const Eigen::Vector2d en = utm.UtmFromEnu(cloud.points[i]);
    EXPECT_NEAR(points[i].xyz.x(), en.x(), 1e-6);
    EXPECT_NEAR(points[i].xyz.y(), en.y(), 1e-6);
    // Height: the origin's + up (the convention of dtm.tif), within the curvature (d²/2R < 9 mm
    // at 330 m) of the exact geodetic height.
    EXPECT_DOUBLE_EQ(points[i].xyz.z(), 100.0 + cloud.points[i].z());
    EXPECT_NEAR(points[i].xyz.z(), enu.ToGeodetic(cloud.points[i]).alt_m, 0.01);
    // Back to ENU: exact with the exact height.
    const Eigen::Vector3d back =
        utm.EnuFromUtm(points[i].xyz.x(), points[i].xyz.y(), enu.ToGeodetic(cloud.points[i]).alt_m);
    EXPECT_LE((back - cloud.points[i]).norm(), 1e-6);
    EXPECT_EQ(points[i].point_source_id, 9);
  }
  EXPECT_EQ(points[0].rgb, (std::array<std::uint16_t, 3>{0, 128 * 257, 65535}));

  const TempDir dir;
  LasWriteOptions options;
  options.epsg = utm.epsg();
  WriteLas(dir / "enu.las", points, options);
  const LasFile las = ReadLas(dir / "enu.las");
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_LE((las.points[i].xyz - points[i].xyz).cwiseAbs().maxCoeff(), 0.0005 + 1e-9);
  }
}

TEST(LasTest, EmptyCloudIsAValidFile) {
  const TempDir dir;
  WriteLas(dir / "empty.las", {}, Utm17N());
  const LasFile las = ReadLas(dir / "empty.las");
  EXPECT_EQ(las.header.point_count, 0u);
  EXPECT_TRUE(las.points.empty());
  EXPECT_NE(las.Wkt().find("UTM zone 17N"), std::string::npos);
}

TEST(LasTest, WithoutCrsThereIsNoVlr) {
  const TempDir dir;
  WriteLas(dir / "a.las", SomePoints(3));
  const LasFile las = ReadLas(dir / "a.las");
  EXPECT_TRUE(las.vlrs.empty());
  EXPECT_EQ(las.header.offset_to_point_data, 375u);
  EXPECT_EQ(las.Wkt(), "");
}

TEST(LasTest, WriteRejectsBadPoints) {
  const TempDir dir;
  std::vector<LasPoint> points = SomePoints(3);
  points[1].xyz.x() = NAN;
  EXPECT_THROW(WriteLas(dir / "a.las", points), InputError);
  points = SomePoints(3);
  points[2].xyz.x() += 5e6;  // 5000 km: beyond int32 millimetres
  EXPECT_THROW(WriteLas(dir / "a.las", points), InputError);
  points = SomePoints(3);
  points[0].return_number = 0;
  EXPECT_THROW(WriteLas(dir / "a.las", points), InputError);
  EXPECT_FALSE(std::filesystem::exists(dir / "a.las"));
}

TEST(LasTest, ReadRejectsMalformedFiles) {
  const TempDir dir;
  WriteLas(dir / "good.las", SomePoints(20), Utm17N());
  const std::string good = ReadText(dir / "good.las");

  EXPECT_THROW(ReadLas(dir / "missing.las"), InputError);
  WriteText(dir / "garbage.las", "this is not a point cloud, just some text\n");
  EXPECT_THROW(ReadLas(dir / "garbage.las"), InputError);
  WriteText(dir / "empty.las", "");
  EXPECT_THROW(ReadLas(dir / "empty.las"), InputError);
  // Header cut short.
  WriteText(dir / "short_header.las", good.substr(0, 200));
  EXPECT_THROW(ReadLas(dir / "short_header.las"), InputError);
  // Inside the VLR.
  WriteText(dir / "short_vlr.las", good.substr(0, 375 + 30));
  EXPECT_THROW(ReadLas(dir / "short_vlr.las"), InputError);
  // Last point cut short.
  WriteText(dir / "short_points.las", good.substr(0, good.size() - 10));
  try {
    ReadLas(dir / "short_points.las");
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("truncated"), std::string::npos) << e.what();
    EXPECT_EQ(e.file(), dir / "short_points.las");
  }
  // Another point format, version, and a VLR count that runs into the points.
  std::string bad = good;
  bad[104] = 2;
  WriteText(dir / "format2.las", bad);
  EXPECT_THROW(ReadLas(dir / "format2.las"), InputError);
  bad = good;
  bad[25] = 2;
  WriteText(dir / "v12.las", bad);
  EXPECT_THROW(ReadLas(dir / "v12.las"), InputError);
  bad = good;
  bad[100] = 5;
  WriteText(dir / "vlrs.las", bad);
  EXPECT_THROW(ReadLas(dir / "vlrs.las"), InputError);
  // An EVLR that points past the end of the file.
  bad = good;
  const std::uint64_t far = good.size() + 100;
  std::memcpy(bad.data() + 235, &far, 8);
  bad[243] = 1;
  WriteText(dir / "evlr.las", bad);
  EXPECT_THROW(ReadLas(dir / "evlr.las"), InputError);
  // The good file still reads.
  EXPECT_EQ(ReadLas(dir / "good.las").points.size(), 20u);
}

TEST(LasTest, ReadsAnEvlrWithTheCrs) {
  // A file whose WKT sits in an EVLR after the points (allowed by LAS 1.4), built by hand from
  // a file without a CRS.
  const TempDir dir;
  WriteLas(dir / "a.las", SomePoints(4));
  std::string bytes = ReadText(dir / "a.las");
  const std::uint64_t start = bytes.size();
  const std::string wkt = EpsgWkt(32617);
  std::string evlr(60, '\0');
  std::memcpy(evlr.data() + 2, "LASF_Projection", 15);
  const std::uint16_t id = 2112;
  std::memcpy(evlr.data() + 18, &id, 2);
  const std::uint64_t length = wkt.size() + 1;
  std::memcpy(evlr.data() + 20, &length, 8);
  bytes += evlr + wkt + '\0';
  std::memcpy(bytes.data() + 235, &start, 8);
  bytes[243] = 1;
  WriteText(dir / "evlr.las", bytes);
  const LasFile las = ReadLas(dir / "evlr.las");
  ASSERT_EQ(las.evlrs.size(), 1u);
  EXPECT_EQ(las.Wkt(), wkt);
  EXPECT_EQ(las.points.size(), 4u);
}

TEST(LasTest, AdjustedStandardGpsTimeOfKnownInstants) {
  // The LAS 1.4 convention: GPS seconds since 1980-01-06 00:00:00 UTC minus 10^9.
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(1980, 1, 6)), 0);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(1981, 7, 1) - 1), 0);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(1981, 7, 1)), 1);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(2006, 1, 1)), 14);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(2015, 7, 1)), 17);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(2016, 12, 31)), 17);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(2017, 1, 1)), 18);
  EXPECT_EQ(GpsMinusUtcSeconds(FromDate(2026, 5, 1)), 18);
  // The GPS epoch is -10^9; 2017-01-01 00:00:00 UTC is GPS second 1167264018.
  EXPECT_EQ(AdjustedStandardGpsTime(FromDate(1980, 1, 6)), -1e9);
  EXPECT_EQ(AdjustedStandardGpsTime(FromDate(2017, 1, 1)), 167264018.0);
  // 2016-06-10: Unix 1465516800 s, 17 leap seconds.
  EXPECT_EQ(AdjustedStandardGpsTime(FromDate(2016, 6, 10)), 1465516800.0 - 315964800.0 + 17 - 1e9);
  const Timestamp noon = FromDate(2016, 6, 10) + 12 * 3600 * kNanosPerSecond + 250'000'000;
  EXPECT_NEAR(AdjustedStandardGpsTime(noon) - AdjustedStandardGpsTime(FromDate(2016, 6, 10)),
              12 * 3600 + 0.25, 1e-7);
  // And back, within a microsecond (a double near 1.5e8 s keeps ~30 ns).
  for (const Timestamp t : {FromDate(2016, 6, 10), noon, FromDate(2017, 1, 1),
                            FromDate(2017, 1, 1) - 1 * kNanosPerSecond, FromDate(2025, 3, 4)}) {
    EXPECT_LE(std::llabs(UtcFromAdjustedStandardGpsTime(AdjustedStandardGpsTime(t)) - t), 1000)
        << FormatTimestamp(t);
  }
}

TEST(LasTest, VegetationClassesByHeight) {
  EXPECT_EQ(AsprsVegetationClass(0.02), kAsprsLowVegetation);
  EXPECT_EQ(AsprsVegetationClass(0.49), kAsprsLowVegetation);
  EXPECT_EQ(AsprsVegetationClass(0.5), kAsprsMediumVegetation);
  EXPECT_EQ(AsprsVegetationClass(1.99), kAsprsMediumVegetation);
  EXPECT_EQ(AsprsVegetationClass(2.0), kAsprsHighVegetation);
  EXPECT_EQ(kAsprsGround, 2);
  EXPECT_EQ(kAsprsUnclassified, 1);
}

// The per-point GPS time (the session's date) and class come back from the reader, with the
// header's GPS time type bit.
TEST(LasTest, GpsTimeAndClassificationRoundTrip) {
  const TempDir dir;
  const geometry::GeodeticPoint origin{31.47, -83.53, 100.0};
  PlyPointCloud cloud;
  cloud.points = {{0, 0, 0}, {1.5, 8.25, 0.3}, {-1.0, 3.0, 0.8}, {2.0, 2.0, 2.5}, {0, 1, -0.4}};
  const double session = AdjustedStandardGpsTime(FromDate(2016, 6, 10));
  std::vector<LasPoint> points = LasPointsFromEnu(cloud, origin, 32617, 3, session);
  const std::uint8_t classes[] = {kAsprsGround, kAsprsLowVegetation, kAsprsMediumVegetation,
                                  kAsprsHighVegetation, kAsprsUnclassified};
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(points[i].gps_time, session);
    EXPECT_EQ(points[i].classification, kAsprsCreatedNeverClassified);
    points[i].classification = classes[i];
  }
  LasWriteOptions options;
  options.epsg = 32617;
  WriteLas(dir / "classes.las", points, options);
  const LasFile las = ReadLas(dir / "classes.las");
  EXPECT_EQ(las.header.global_encoding & kLasGpsTimeAdjustedStandard, kLasGpsTimeAdjustedStandard);
  EXPECT_EQ(las.header.global_encoding & kLasCrsIsWkt, kLasCrsIsWkt);
  EXPECT_NE(las.Wkt().find("UTM zone 17N"), std::string::npos);
  ASSERT_EQ(las.points.size(), points.size());
  for (std::size_t i = 0; i < points.size(); ++i) {
    EXPECT_EQ(las.points[i].classification, classes[i]) << i;
    EXPECT_EQ(las.points[i].gps_time, session) << i;
    EXPECT_EQ(UtcFromAdjustedStandardGpsTime(las.points[i].gps_time), FromDate(2016, 6, 10));
    EXPECT_EQ(las.points[i].point_source_id, 3);
  }
  // GPS week time on request: the bit is clear.
  options.adjusted_standard_gps_time = false;
  WriteLas(dir / "week.las", points, options);
  EXPECT_EQ(ReadLas(dir / "week.las").header.global_encoding, kLasCrsIsWkt);
}

}  // namespace
}  // namespace crop4d::io
