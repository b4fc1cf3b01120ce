#include "crop4d/io/imu_csv_import.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <sstream>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

ImuCsvFile Read(const std::string& text, const ImuCsvFile::Options& options) {
  std::istringstream in(text);
  return ReadImuCsvMapped(in, "imu.csv", options);
}

// The InputError's "file:line: message", or "no error".
template <typename F>
std::string ErrorOf(F&& f) {
  try {
    f();
  } catch (const InputError& e) {
    return e.what();
  }
  return "no error";
}

TEST(ImuCsvImportTest, MapsColumnsAndConvertsUnits) {
  ImuCsvFile::Options options;
  options.columns = ParseImuColumns("t,ax,ay,az,_,gx,gy,gz");
  options.time_unit = ParseImuTimeUnit("ms");
  options.accel_unit = ParseAccelUnit("g");
  options.gyro_unit = ParseGyroUnit("degs");
  options.header_lines = 1;
  const ImuCsvFile imu = Read(
      "time accel_x accel_y accel_z temp gyro_x gyro_y gyro_z\n"
      "# a comment\n"
      "1000.5  0 0 1  25.0  180 0 -90\n"
      "\n"
      "1010.5\t0.5 0 1 25.0 0 0 0\n",
      options);
  EXPECT_EQ(imu.delimiter, ' ');
  ASSERT_EQ(imu.samples.size(), 2u);
  EXPECT_EQ(imu.samples[0].t, 1'000'500'000);
  EXPECT_EQ(imu.samples[1].t, 1'010'500'000);
  EXPECT_DOUBLE_EQ(imu.samples[0].accel.z(), 9.80665);
  EXPECT_DOUBLE_EQ(imu.samples[1].accel.x(), 0.5 * 9.80665);
  EXPECT_DOUBLE_EQ(imu.samples[0].gyro.x(), M_PI);
  EXPECT_DOUBLE_EQ(imu.samples[0].gyro.z(), -M_PI / 2);
  EXPECT_NEAR(imu.MeanRateHz(), 100.0, 1e-9);
}

TEST(ImuCsvImportTest, DefaultIsOurOrderAndTrailingColumnsNeedDots) {
  ImuCsvFile::Options options;  // t, gx, gy, gz, ax, ay, az in s, rad/s, m/s^2
  const ImuCsvFile imu = Read("5,0.1,0.2,0.3,1,2,9.8\n5.01,0,0,0,0,0,9.8\n", options);
  ASSERT_EQ(imu.samples.size(), 2u);
  EXPECT_EQ(imu.samples[0].t, 5 * kNanosPerSecond);
  EXPECT_DOUBLE_EQ(imu.samples[0].gyro.y(), 0.2);
  EXPECT_DOUBLE_EQ(imu.samples[0].accel.y(), 2.0);

  const std::string extra = "5,0.1,0.2,0.3,1,2,9.8,0,0\n";
  EXPECT_EQ(ErrorOf([&] { Read(extra, options); }),
            "imu.csv:1: expected 7 columns (as --imu-columns maps them), found 9");
  options.columns = ParseImuColumns("t gx gy gz ax ay az ...");
  EXPECT_EQ(Read(extra, options).samples.size(), 1u);
}

TEST(ImuCsvImportTest, BadUnitsAndMappingsAreClearErrors) {
  EXPECT_EQ(ErrorOf([] { ParseAccelUnit("furlong"); }),
            "--accel-unit: unknown accelerometer unit 'furlong' (expected g or mps2, i.e. m/s^2)");
  EXPECT_EQ(ErrorOf([] { ParseGyroUnit("rpm"); }),
            "--gyro-unit: unknown gyro unit 'rpm' (expected rads, i.e. rad/s, or degs, i.e. "
            "deg/s)");
  EXPECT_EQ(ErrorOf([] { ParseImuTimeUnit("min"); }),
            "--imu-time-unit: unknown time unit 'min' (expected s, ms, us or ns)");
  EXPECT_EQ(ErrorOf([] { ParseDelimiter("pipe"); }),
            "--imu-delimiter: unknown delimiter 'pipe' (expected auto, comma, semicolon, tab or "
            "space)");
  EXPECT_EQ(ErrorOf([] { ParseImuColumns("t,ax,ay,az,gx,gy,temp"); }),
            "--imu-columns: unknown column name 'temp' (expected t, ax, ay, az, gx, gy, gz, _ or "
            "skip, and ... last)");
  EXPECT_EQ(ErrorOf([] { ParseImuColumns("t,...,ax"); }),
            "--imu-columns: '...' must be the last entry");
  ImuCsvFile::Options options;
  options.columns = ParseImuColumns("t,ax,ay,az,gx,gy");
  EXPECT_EQ(ErrorOf([&] { options.Check(); }),
            "--imu-columns: the column mapping has no 'gz' column (it needs t, ax, ay, az, gx, "
            "gy, gz)");
  options.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz,ax");
  EXPECT_EQ(ErrorOf([&] { options.Check(); }),
            "--imu-columns: the column mapping names 'ax' more than once");
}

TEST(ImuCsvImportTest, BadLinesNameTheLine) {
  ImuCsvFile::Options options;
  EXPECT_EQ(ErrorOf([&] { Read("1,0,0,0,0,0,9.8\n2,0,0,0,0,0\n", options); }),
            "imu.csv:2: expected 7 columns (as --imu-columns maps them), found 6");
  EXPECT_EQ(ErrorOf([&] { Read("1,0,0,0,0,0,9.8\n2,0,0,x,0,0,9.8\n", options); }),
            "imu.csv:2: column 4 (gz) is not a finite number: 'x'");
  EXPECT_EQ(ErrorOf([&] { Read("1,0,0,0,0,0,9.8\n2,0,0,nan,0,0,9.8\n", options); }),
            "imu.csv:2: column 4 (gz) is not a finite number: 'nan'");
  EXPECT_EQ(ErrorOf([&] { Read("1,0,0,0,0,0,9.8\n1,0,0,0,0,0,9.8\n", options); }),
            "imu.csv:2: timestamp 1970-01-01T00:00:01.000000000Z is not after the previous "
            "line's (line 1)");
  EXPECT_EQ(ErrorOf([&] { Read("1s,0,0,0,0,0,9.8\n", options); }),
            "imu.csv:1: column 1 (time) is not a number: '1s'");
  EXPECT_EQ(ErrorOf([&] { Read("# only a comment\n", options); }),
            "imu.csv: no IMU samples in the file");
}

TEST(ImuCsvImportTest, RealWalkRecording) {
  const std::string path = std::string(CROP4D_SHARED_DATA_DIR) + "/gnss_imu_walk/imu_1730_sf.csv";
  if (!std::filesystem::exists(path)) GTEST_SKIP() << path << " not present";
  ImuCsvFile::Options options;
  options.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz,_,_,_,_");
  options.accel_unit = AccelUnit::kStandardGravity;
  const ImuCsvFile imu = ReadImuCsvMapped(path, options);
  ASSERT_EQ(imu.samples.size(), 20455u);
  EXPECT_EQ(imu.delimiter, ',');
  EXPECT_EQ(imu.samples.front().t, 1756402240'961000000);  // "1756402240.9610000", exactly
  EXPECT_EQ(imu.samples.back().t, 1756402375'231999900);   // "1756402375.2319999"
  for (std::size_t i = 1; i < imu.samples.size(); ++i) {
    ASSERT_LT(imu.samples[i - 1].t, imu.samples[i].t) << i;
  }
  // At rest at the start: the specific force is gravity, +z up in the sensor frame.
  double norm = 0.0;
  for (int i = 0; i < 100; ++i) norm += imu.samples[i].accel.norm() / 100;
  EXPECT_NEAR(norm, 9.81, 0.15);
  EXPECT_GT(imu.samples[0].accel.z(), 9.5);
  EXPECT_NEAR(imu.MeanRateHz(), 152.3, 0.1);
}

}  // namespace
}  // namespace crop4d::io
