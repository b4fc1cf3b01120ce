#include "crop4d/io/rtklib_pos.h"

#include <gtest/gtest.h>

#include <GeographicLib/Geocentric.hpp>
#include <cmath>
#include <filesystem>
#include <sstream>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

// 2025-08-28T17:30:39Z is Unix time 1756402239 s (Python: calendar.timegm((2025, 8, 28, 17, 30,
// 39))); it is GPS week 2381, 408639 s into the week ((1756402239 − 315964800) / 604800).
constexpr Timestamp kWalkStart = 1756402239'749000000;

const char* kHeader =
    "% program   : RTKLIB ver.demo5 b34k\n"
    "% (lat/lon/height=WGS84/ellipsoidal,Q=1:fix,2:float,3:sbas,4:dgps,5:single,6:ppp,ns=# of "
    "satellites)\n"
    "%  GPST          latitude(deg) longitude(deg)  height(m)   Q  ns   sdn(m)   sde(m)   sdu(m)"
    "  sdne(m)  sdeu(m)  sdun(m) age(s)  ratio\n";

std::string Line(const std::string& time, int q, double sdn, double sde, double sdu) {
  std::ostringstream out;
  out << time << "   40.096691600 -105.147166500  1601.4350   " << q << "  25   " << sdn << "   "
      << sde << "   " << sdu << "   0.0000   0.0000   0.0000   0.00    0.0\n";
  return out.str();
}

RtklibPosFile Read(const std::string& text, RtklibPosFile::Options options = {}) {
  std::istringstream in(text);
  return ReadRtklibPos(in, "test.pos", options);
}

TEST(RtklibPosTest, ReadsHeaderEpochsQualitiesAndSigmas) {
  const RtklibPosFile pos =
      Read(std::string(kHeader) + Line("2025/08/28 17:30:39.749", 1, 0.003, 0.004, 0.01) +
           Line("2025/08/28 17:30:39.999", 2, 0.05, 0.05, 0.1) +
           Line("2025/08/28 17:30:40.249", 5, 1.2, 1.6, 3.0));
  EXPECT_TRUE(pos.column_header);
  EXPECT_EQ(pos.time_system, PosTimeSystem::kGpst);
  EXPECT_EQ(pos.coordinates, PosCoordinates::kLlhDegrees);
  ASSERT_EQ(pos.samples.size(), 3u);
  EXPECT_EQ(pos.samples[0].t, kWalkStart);
  EXPECT_EQ(pos.samples[1].t, kWalkStart + 250'000'000);
  EXPECT_EQ(pos.samples[2].t, kWalkStart + 500'000'000);
  EXPECT_EQ(pos.samples[0].fix, GpsFix::kRtkFixed);
  EXPECT_EQ(pos.samples[1].fix, GpsFix::kRtkFloat);
  EXPECT_EQ(pos.samples[2].fix, GpsFix::kSingle);
  EXPECT_DOUBLE_EQ(pos.samples[0].position.lat_deg, 40.0966916);
  EXPECT_DOUBLE_EQ(pos.samples[0].position.lon_deg, -105.1471665);
  EXPECT_DOUBLE_EQ(pos.samples[0].position.alt_m, 1601.435);
  EXPECT_NEAR(pos.samples[0].sigma_h, std::sqrt((0.003 * 0.003 + 0.004 * 0.004) / 2), 1e-12);
  EXPECT_DOUBLE_EQ(pos.samples[0].sigma_v, 0.01);
  EXPECT_NEAR(pos.samples[2].sigma_h, std::sqrt((1.44 + 2.56) / 2), 1e-12);
  EXPECT_EQ(pos.quality, (std::map<int, std::int64_t>{{1, 1}, {2, 1}, {5, 1}}));
}

TEST(RtklibPosTest, MalformedLineIsAnErrorWithItsLine) {
  const std::string text = std::string(kHeader) +
                           Line("2025/08/28 17:30:39.749", 1, 0.003, 0.004, 0.01) +
                           "2025/08/28 17:30:39.999   40.0966916 -105.1471665  1601.4350   1\n" +
                           Line("2025/08/28 17:30:40.249", 5, 1.2, 1.6, 3.0);
  try {
    Read(text);
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), "test.pos");
    EXPECT_EQ(e.line(), 5);
    EXPECT_EQ(e.message(), "expected 15 fields (as the column header on line 3 says), found 6");
  }
  RtklibPosFile::Options forgiving;
  forgiving.skip_bad_lines = true;
  const RtklibPosFile pos = Read(text, forgiving);
  EXPECT_EQ(pos.samples.size(), 2u);
  EXPECT_EQ(pos.skipped_lines, 1);
}

TEST(RtklibPosTest, OtherBadLinesNameWhatIsWrong) {
  auto message = [](const std::string& line) {
    try {
      Read(std::string(kHeader) + Line("2025/08/28 17:30:39.749", 1, 0.003, 0.004, 0.01) + line);
    } catch (const InputError& e) {
      EXPECT_EQ(e.line(), 5);
      return e.message();
    }
    return std::string("no error");
  };
  EXPECT_EQ(message(Line("2025/08/28 17:30:39.749", 1, 0.003, 0.004, 0.01)),
            "time 2025-08-28T17:30:39.749000000Z is not after the previous epoch's (line 4)");
  EXPECT_EQ(message(Line("2025/02/30 17:30:40.000", 1, 0.003, 0.004, 0.01)),
            "not a valid date and time: '2025/02/30 17:30:40.000'");
  EXPECT_EQ(message(Line("2025/08/28 17:30:40.000", 9, 0.003, 0.004, 0.01)),
            "unknown solution quality Q=9 (RTKLIB: 1 fix, 2 float, 3 sbas, 4 dgps, 5 single, 6 "
            "ppp)");
  EXPECT_EQ(message("2025/08/28 17:30:40.000 40.1 x 1601 1 25 0 0 0 0 0 0 0 0\n"),
            "longitude is not a finite number: 'x'");
}

TEST(RtklibPosTest, CalendarTimeIsExactToTheNanosecond) {
  Timestamp t = 0;
  ASSERT_TRUE(ParseCalendarTime("2025/08/28", "17:30:39.749", &t));
  EXPECT_EQ(t, kWalkStart);
  // A leap day (Unix 1456790399 s, Python calendar.timegm) and nine decimals.
  ASSERT_TRUE(ParseCalendarTime("2016/02/29", "23:59:59.123456789", &t));
  EXPECT_EQ(t, 1456790399'123456789);
  ASSERT_TRUE(ParseCalendarTime("1970-01-01", "00:00:00", &t));
  EXPECT_EQ(t, 0);
  EXPECT_FALSE(ParseCalendarTime("2025/13/01", "00:00:00", &t));
  EXPECT_FALSE(ParseCalendarTime("2025/08/28", "24:00:00", &t));
  EXPECT_FALSE(ParseCalendarTime("2025/08/28", "12:00:60", &t));
  EXPECT_FALSE(ParseCalendarTime("2025/08/28", "12:00", &t));
  EXPECT_EQ(GpsWeekToTimestamp(2381, 408639'749000000), kWalkStart);
  EXPECT_EQ(GpsWeekToTimestamp(0, 0), 315964800 * kNanosPerSecond);
}

TEST(RtklibPosTest, DecimalTextIsScaledExactly) {
  std::int64_t v = 0;
  ASSERT_TRUE(ParseDecimalScaled("1756402240.9610000", kNanosPerSecond, &v));
  EXPECT_EQ(v, 1756402240'961000000);
  ASSERT_TRUE(ParseDecimalScaled("0.0000000015", kNanosPerSecond, &v));
  EXPECT_EQ(v, 2);  // rounded half away from zero
  ASSERT_TRUE(ParseDecimalScaled("-1.5", 1'000'000, &v));
  EXPECT_EQ(v, -1'500'000);
  ASSERT_TRUE(ParseDecimalScaled("+12", 1000, &v));
  EXPECT_EQ(v, 12'000);
  ASSERT_TRUE(ParseDecimalScaled("1.5e3", kNanosPerSecond, &v));
  EXPECT_EQ(v, 1'500'000'000'000);
  EXPECT_FALSE(ParseDecimalScaled("", 1, &v));
  EXPECT_FALSE(ParseDecimalScaled(".", 1, &v));
  EXPECT_FALSE(ParseDecimalScaled("1.2.3", 1, &v));
  EXPECT_FALSE(ParseDecimalScaled("12s", 1, &v));
  EXPECT_FALSE(ParseDecimalScaled("99999999999999999999", 1, &v));
  EXPECT_FALSE(ParseDecimalScaled("10000000000", kNanosPerSecond, &v));
}

TEST(RtklibPosTest, WeekTimeLeapSecondsAndJst) {
  const std::string gpst_week = std::string(kHeader) + Line("2381 408639.749", 1, 0, 0, 0);
  EXPECT_EQ(Read(gpst_week).samples[0].t, kWalkStart);
  RtklibPosFile::Options utc;
  utc.leap_seconds = 18;
  EXPECT_EQ(Read(gpst_week, utc).samples[0].t, kWalkStart - 18 * kNanosPerSecond);

  std::string jst = kHeader;
  jst.replace(jst.find("%  GPST"), 7, "%  JST ");
  const RtklibPosFile pos = Read(jst + Line("2025/08/29 02:30:39.749", 1, 0, 0, 0), utc);
  EXPECT_EQ(pos.time_system, PosTimeSystem::kJst);
  EXPECT_EQ(pos.samples[0].t, kWalkStart);  // JST − 9 h, no leap seconds
}

TEST(RtklibPosTest, DegreesMinutesSecondsAndCommaSeparator) {
  const std::string text =
      "%  GPST                  latitude(d'\")   longitude(d'\")  height(m)   Q  ns   sdn(m)   "
      "sde(m)   sdu(m)\n"
      "2025/08/28 17:30:39.749,  40 05 48.08976, -105 08 49.79940, 1601.4350, 1, 25, 0.01, "
      "0.01, 0.02\n";
  const RtklibPosFile pos = Read(text);
  EXPECT_EQ(pos.coordinates, PosCoordinates::kLlhDms);
  ASSERT_EQ(pos.samples.size(), 1u);
  EXPECT_NEAR(pos.samples[0].position.lat_deg, 40.0966916, 1e-10);
  EXPECT_NEAR(pos.samples[0].position.lon_deg, -105.1471665, 1e-10);
  EXPECT_NEAR(pos.samples[0].sigma_h, 0.01, 1e-12);
}

TEST(RtklibPosTest, EcefIsConvertedWithItsCovariance) {
  double x = 0, y = 0, z = 0;
  GeographicLib::Geocentric::WGS84().Forward(40.0966916, -105.1471665, 1601.435, x, y, z);
  std::ostringstream text;
  text.precision(12);
  text << "%  GPST                  x-ecef(m)      y-ecef(m)      z-ecef(m)   Q  ns   sdx(m)   "
          "sdy(m)   sdz(m)  sdxy(m)  sdyz(m)  sdzx(m) age(s)  ratio\n"
       << "2381 408639.749 " << x << " " << y << " " << z << " 2 12 0.03 0.03 0.03 0 0 0 1.2 0.0\n";
  const RtklibPosFile pos = Read(text.str());
  EXPECT_EQ(pos.coordinates, PosCoordinates::kEcef);
  ASSERT_EQ(pos.samples.size(), 1u);
  EXPECT_NEAR(pos.samples[0].position.lat_deg, 40.0966916, 1e-9);
  EXPECT_NEAR(pos.samples[0].position.lon_deg, -105.1471665, 1e-9);
  EXPECT_NEAR(pos.samples[0].position.alt_m, 1601.435, 1e-4);
  EXPECT_NEAR(pos.samples[0].sigma_h, 0.03, 1e-9);  // isotropic: the same in ENU
  EXPECT_NEAR(pos.samples[0].sigma_v, 0.03, 1e-9);
  EXPECT_EQ(pos.samples[0].fix, GpsFix::kRtkFloat);
}

TEST(RtklibPosTest, QualityMapping) {
  EXPECT_EQ(RtklibQualityToFix(1), 4);
  EXPECT_EQ(RtklibQualityToFix(2), 5);
  EXPECT_EQ(RtklibQualityToFix(3), 2);
  EXPECT_EQ(RtklibQualityToFix(4), 2);
  EXPECT_EQ(RtklibQualityToFix(5), 1);
  EXPECT_EQ(RtklibQualityToFix(6), 2);
  EXPECT_EQ(RtklibQualityToFix(0), 0);
  EXPECT_EQ(RtklibQualityToFix(7), 0);
  EXPECT_EQ(RtklibQualityToFix(8), -1);
}

TEST(RtklibPosTest, EmptyAndUnsupportedFiles) {
  EXPECT_THROW(Read(kHeader), InputError);
  EXPECT_THROW(Read("%  GPST  e-baseline(m) n-baseline(m) u-baseline(m) Q ns\n"), InputError);
  EXPECT_THROW(ReadRtklibPos("/nonexistent/file.pos"), InputError);
}

TEST(RtklibPosTest, RealWalkRecording) {
  const std::string path = std::string(CROP4D_SHARED_DATA_DIR) + "/gnss_imu_walk/gnss_1730_sf.pos";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
  const RtklibPosFile pos = ReadRtklibPos(path);
  EXPECT_EQ(pos.time_system, PosTimeSystem::kGpst);
  ASSERT_EQ(pos.samples.size(), 536u);
  EXPECT_EQ(pos.quality, (std::map<int, std::int64_t>{{1, 349}, {2, 187}}));
  int fixed = 0, floating = 0;
  for (const GpsSample& s : pos.samples) {
    fixed += s.fix == GpsFix::kRtkFixed;
    floating += s.fix == GpsFix::kRtkFloat;
  }
  EXPECT_EQ(fixed, 349);
  EXPECT_EQ(floating, 187);
  EXPECT_EQ(pos.samples.front().t, kWalkStart);
  EXPECT_DOUBLE_EQ(pos.samples.front().position.lat_deg, 40.0966916);
  EXPECT_DOUBLE_EQ(pos.samples.front().position.lon_deg, -105.1471665);
  EXPECT_DOUBLE_EQ(pos.samples.front().position.alt_m, 1601.435);
  EXPECT_NEAR(pos.samples.front().sigma_h, 0.0098995, 1e-9);
  EXPECT_DOUBLE_EQ(pos.samples.front().sigma_v, 0.01);
  // 2025/08/28 17:32:53.499, the last line.
  EXPECT_EQ(pos.samples.back().t, kWalkStart + (133 * 1000 + 750) * kNanosPerMillisecond);
  // Its velocities (vn 0.001, ve −0.002, vu 0.027 m/s; sdvn = sdve = sdvu = 0.0494975) are kept,
  // east first.
  ASSERT_TRUE(pos.samples.front().velocity_enu.has_value());
  EXPECT_DOUBLE_EQ(pos.samples.front().velocity_enu->x(), -0.002);
  EXPECT_DOUBLE_EQ(pos.samples.front().velocity_enu->y(), 0.001);
  EXPECT_DOUBLE_EQ(pos.samples.front().velocity_enu->z(), 0.027);
  EXPECT_NEAR(pos.samples.front().sigma_velocity, 0.0494975, 1e-9);
  for (const GpsSample& s : pos.samples) EXPECT_TRUE(s.velocity_enu.has_value());
}

}  // namespace
}  // namespace crop4d::io
