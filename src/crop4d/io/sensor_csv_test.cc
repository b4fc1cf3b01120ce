#include "crop4d/io/sensor_csv.h"

#include <gtest/gtest.h>

#include <fstream>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

const char* kImuHeader = "#timestamp [ns],w_x,w_y,w_z [rad s^-1],a_x,a_y,a_z [m s^-2]\n";

struct ImuRead {
  std::vector<ImuSample> samples;
  std::vector<std::int64_t> lines;
  DataFileStats stats;
  Diagnostics diag;
};

void ReadImuText(const std::string& text, ImuRead* out) {
  std::istringstream in(text);
  out->stats = ReadImuCsv(
      in, "imu0/data.csv",
      [&](const ImuSample& s, std::int64_t line) {
        out->samples.push_back(s);
        out->lines.push_back(line);
      },
      &out->diag);
}

std::vector<std::string> Messages(const Diagnostics& diag) {
  std::vector<std::string> out;
  for (const Diagnostic& d : diag.items()) out.push_back(d.ToString());
  return out;
}

TEST(SensorCsvTest, ReadsImuValuesExactly) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) + "100,0.1,-0.2,0.3,1e-3,2,9.81\n200,0,0,0,0,0,0\n", &r);
  ASSERT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.samples[0].t, 100);
  EXPECT_EQ(r.samples[0].gyro, Eigen::Vector3d(0.1, -0.2, 0.3));
  EXPECT_EQ(r.samples[0].accel, Eigen::Vector3d(1e-3, 2, 9.81));
  EXPECT_EQ(r.lines, (std::vector<std::int64_t>{2, 3}));
  EXPECT_TRUE(r.stats.header);
  EXPECT_EQ(r.stats.samples, 2);
  EXPECT_EQ(r.stats.lines, 3);
  EXPECT_EQ(r.diag.error_count() + r.diag.warning_count(), 0u);
}

TEST(SensorCsvTest, WrongColumnCountIsAnErrorWithLineAndTheLineIsSkipped) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) + "100,0,0,0,0,0,0\n200,0,0,0,0\n300,0,0,0,0,0,0\n", &r);
  EXPECT_EQ(Messages(r.diag),
            std::vector<std::string>{"error: imu0/data.csv:3: expected 7 columns, found 5"});
  EXPECT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.stats.bad_lines, 1);
}

TEST(SensorCsvTest, TruncatedLastLineSaysSo) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) + "100,0,0,0,0,0,0\n200,0,0,0.1", &r);
  EXPECT_EQ(Messages(r.diag),
            std::vector<std::string>{"error: imu0/data.csv:3: expected 7 columns, found 4 (the "
                                     "file ends in the middle of this line)"});
}

TEST(SensorCsvTest, NonNumericAndNonFiniteFieldsAreErrorsNamingTheColumn) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) + "100,0,abc,0,0,0,0\n200,0,0,nan,0,0,inf\n1x,0,0,0,0,0,0\n",
              &r);
  EXPECT_EQ(Messages(r.diag),
            (std::vector<std::string>{
                "error: imu0/data.csv:2: column 3 (w_y): 'abc' is not a number",
                "error: imu0/data.csv:3: column 4 (w_z): value is not finite (nan)",
                "error: imu0/data.csv:3: column 7 (a_z): value is not finite (inf)",
                "error: imu0/data.csv:4: column 1 (timestamp): '1x' is not an integer number of "
                "nanoseconds",
                "error: imu0/data.csv: no valid samples"}));
  EXPECT_TRUE(r.samples.empty());
  EXPECT_EQ(r.stats.bad_lines, 2);
  EXPECT_EQ(r.stats.non_finite, 1);
}

TEST(SensorCsvTest, EmptyFileAndHeaderOnlyAreErrors) {
  ImuRead empty;
  ReadImuText("", &empty);
  EXPECT_EQ(Messages(empty.diag),
            std::vector<std::string>{"error: imu0/data.csv: empty file: no header and no samples"});
  ImuRead header_only;
  ReadImuText(kImuHeader, &header_only);
  EXPECT_EQ(
      Messages(header_only.diag),
      std::vector<std::string>{"error: imu0/data.csv: no samples (the file has no data lines)"});
}

TEST(SensorCsvTest, MissingHeaderIsAWarningAndTheDataIsRead) {
  ImuRead r;
  ReadImuText("100,0,0,0,0,0,0\n200,0,0,0,0,0,0\n", &r);
  EXPECT_EQ(r.samples.size(), 2u);
  EXPECT_FALSE(r.stats.header);
  ASSERT_EQ(r.diag.items().size(), 1u);
  EXPECT_EQ(r.diag.items()[0].severity, Severity::kWarning);
  EXPECT_EQ(r.diag.items()[0].line, 1);
  EXPECT_NE(r.diag.items()[0].message.find("missing header line"), std::string::npos);

  ImuRead no_hash;
  ReadImuText("timestamp,w_x,w_y,w_z,a_x,a_y,a_z\n100,0,0,0,0,0,0\n", &no_hash);
  EXPECT_EQ(no_hash.samples.size(), 1u);
  ASSERT_EQ(no_hash.diag.items().size(), 1u);
  EXPECT_EQ(no_hash.diag.items()[0].severity, Severity::kWarning);
  EXPECT_NE(no_hash.diag.items()[0].message.find("should start with '#'"), std::string::npos);
}

TEST(SensorCsvTest, UnsortedAndDuplicateTimestampsAreErrorsAndSkipped) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) +
                  "1000,0,0,0,0,0,0\n2000,0,0,0,0,0,0\n2000,0,0,0,0,0,0\n1500,0,0,0,0,0,0\n"
                  "3000,0,0,0,0,0,0\n",
              &r);
  EXPECT_EQ(Messages(r.diag),
            (std::vector<std::string>{
                "error: imu0/data.csv:4: duplicate timestamp 2000 (same as line 3)",
                "error: imu0/data.csv:5: timestamp 1500 is 500 ns before the previous sample's "
                "(line 3); timestamps must be strictly increasing"}));
  ASSERT_EQ(r.samples.size(), 3u);
  EXPECT_EQ(r.samples[2].t, 3000);
  EXPECT_EQ(r.stats.duplicates, 1);
  EXPECT_EQ(r.stats.out_of_order, 1);
}

TEST(SensorCsvTest, OutOfRangeValuesAreWarningsAndKept) {
  ImuRead r;
  ReadImuText(std::string(kImuHeader) + "100,50,0,0,0,0,9.8\n200,0,0,0,0,0,300\n", &r);
  EXPECT_EQ(r.samples.size(), 2u);
  EXPECT_EQ(r.stats.out_of_range, 2);
  EXPECT_EQ(r.diag.error_count(), 0u);
  EXPECT_EQ(Messages(r.diag),
            (std::vector<std::string>{
                "warning: imu0/data.csv:2: angular rate 50 rad/s is beyond 35 rad/s",
                "warning: imu0/data.csv:3: acceleration 300 m/s^2 is beyond 160 m/s^2"}));
}

TEST(SensorCsvTest, GpsSigmasMayBeEmptyAndUnusedFixCodesBecomeNone) {
  std::istringstream in(
      "#timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix\n"
      "100,33.5,-84.25,290.5,,,4\n"
      "200,33.5,-84.25,290.5,0.5,1,6\n"
      "300,95,-84.25,290.5,0.5,1,1\n"
      "400,33.5,-84.25,290.5,-1,1,1\n"
      "500,33.5,-84.25,290.5,1,1,fixed\n"
      "600,33.5,-84.25,290.5,1,1,9\n");
  std::vector<GpsSample> samples;
  Diagnostics diag;
  const DataFileStats stats = ReadGpsCsv(
      in, "gps0/data.csv", [&](const GpsSample& s, std::int64_t) { samples.push_back(s); }, &diag);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[0].position.lat_deg, 33.5);
  EXPECT_EQ(samples[0].position.lon_deg, -84.25);
  EXPECT_EQ(samples[0].position.alt_m, 290.5);
  EXPECT_EQ(samples[0].sigma_h, 0.0);
  EXPECT_EQ(samples[0].fix, GpsFix::kRtkFixed);
  EXPECT_EQ(samples[1].fix, GpsFix::kNone);
  EXPECT_EQ(stats.fix_counts.at(4), 1);
  EXPECT_EQ(stats.fix_counts.at(6), 1);
  EXPECT_EQ(stats.invalid, 3);
  EXPECT_EQ(stats.bad_lines, 1);
  EXPECT_EQ(Messages(diag),
            (std::vector<std::string>{
                "warning: gps0/data.csv:3: fix code 6 (dead-reckoning) is not a measured "
                "position; read as 0 (none)",
                "error: gps0/data.csv:4: column 2 (lat): latitude 95 is outside [-90, 90]",
                "error: gps0/data.csv:5: negative sigma",
                "error: gps0/data.csv:6: column 7 (fix): 'fixed' is not an NMEA fix code (0-8)",
                "error: gps0/data.csv:7: column 7 (fix): 9 is not an NMEA fix code (0-8)"}));
}

TEST(SensorCsvTest, GpsVelocityColumnsAreOptionalAndRoundTrip) {
  std::istringstream in(
      "#timestamp [ns],lat [deg],lon [deg],alt [m],sigma_h [m],sigma_v [m],fix,ve [m/s],"
      "vn [m/s],vu [m/s],sigma_vel [m/s]\n"
      "100,33.5,-84.25,290.5,0.01,0.02,4,1.25,-0.5,0.125,0.05\n"
      "200,33.5,-84.25,290.5,0.01,0.02,4,,,,\n"
      "300,33.5,-84.25,290.5,0.01,0.02,4,1,2,3,-1\n"
      "400,33.5,-84.25,290.5,0.01,0.02,4\n");
  std::vector<GpsSample> samples;
  Diagnostics diag;
  ReadGpsCsv(
      in, "gps0/data.csv", [&](const GpsSample& s, std::int64_t) { samples.push_back(s); }, &diag);
  ASSERT_EQ(samples.size(), 2u);
  ASSERT_TRUE(samples[0].velocity_enu.has_value());
  EXPECT_EQ(*samples[0].velocity_enu, Eigen::Vector3d(1.25, -0.5, 0.125));
  EXPECT_EQ(samples[0].sigma_velocity, 0.05);
  EXPECT_FALSE(samples[1].velocity_enu.has_value());
  EXPECT_EQ(Messages(diag),
            (std::vector<std::string>{"error: gps0/data.csv:4: negative velocity sigma",
                                      "error: gps0/data.csv:5: expected 11 columns, found 7"}));

  // Written and read back: the columns appear only when a sample has a velocity.
  testing::TempDir dir;
  const std::string path = dir / "data.csv";
  WriteGpsCsv(path, samples);
  std::vector<GpsSample> back;
  ReadGpsCsv(
      path, [&](const GpsSample& s, std::int64_t) { back.push_back(s); }, nullptr);
  ASSERT_EQ(back.size(), 2u);
  EXPECT_EQ(*back[0].velocity_enu, *samples[0].velocity_enu);
  EXPECT_EQ(back[0].sigma_velocity, 0.05);
  EXPECT_FALSE(back[1].velocity_enu.has_value());
  samples[0].velocity_enu.reset();
  WriteGpsCsv(path, samples);
  std::ifstream file(path);
  std::string header;
  std::getline(file, header);
  EXPECT_EQ(header, kGpsCsvHeader);
}

TEST(SensorCsvTest, ImageNamesMustStayInsideTheFolderAndBeUnique) {
  std::istringstream in(
      "#timestamp [ns],filename\n100,a.png\n200,../x.png\n300,/etc/passwd\n400,a.png\n"
      "500,\n600,sub/b.png\n");
  std::vector<ImageEntry> entries;
  Diagnostics diag;
  ReadImageCsv(
      in, "cam0/data.csv", [&](const ImageEntry& e, std::int64_t) { entries.push_back(e); }, &diag);
  ASSERT_EQ(entries.size(), 2u);
  EXPECT_EQ(entries[0].filename, "a.png");
  EXPECT_EQ(entries[0].line, 2);
  EXPECT_EQ(entries[1].filename, "sub/b.png");
  EXPECT_EQ(entries[1].t, 600);
  EXPECT_EQ(Messages(diag),
            (std::vector<std::string>{
                "error: cam0/data.csv:3: column 2 (filename): '../x.png' must be a path inside "
                "the camera's data/ folder",
                "error: cam0/data.csv:4: column 2 (filename): '/etc/passwd' must be a path "
                "inside the camera's data/ folder",
                "error: cam0/data.csv:5: file name 'a.png' is listed twice",
                "error: cam0/data.csv:6: column 2 (filename): empty file name"}));
}

TEST(SensorCsvTest, WithoutCollectorBadLinesAreSkippedNotThrown) {
  std::istringstream in(std::string(kImuHeader) + "100,0,0,0,0,0,0\nbroken\n200,0,0,0,0,0,0\n");
  int count = 0;
  const DataFileStats stats = ReadImuCsv(
      in, "imu0/data.csv", [&](const ImuSample&, std::int64_t) { ++count; }, nullptr);
  EXPECT_EQ(count, 2);
  EXPECT_EQ(stats.bad_lines, 1);
}

TEST(SensorCsvTest, MagFieldBeyondLimitIsAWarning) {
  std::istringstream in("#timestamp [ns],m_x [uT],m_y [uT],m_z [uT]\n100,20,1,-40\n200,500,0,0\n");
  std::vector<MagSample> samples;
  Diagnostics diag;
  ReadMagCsv(
      in, "mag0/data.csv", [&](const MagSample& s, std::int64_t) { samples.push_back(s); }, &diag);
  ASSERT_EQ(samples.size(), 2u);
  EXPECT_EQ(samples[0].field_ut, Eigen::Vector3d(20, 1, -40));
  EXPECT_EQ(
      Messages(diag),
      std::vector<std::string>{"warning: mag0/data.csv:3: magnetic field 500 uT is beyond 200 uT"});
}

TEST(SensorCsvTest, DirectoryInsteadOfFileThrowsNamingIt) {
  testing::TempDir dir;
  std::filesystem::create_directories(dir / "imu0/data.csv");
  try {
    ReadImuCsv(
        dir / "imu0/data.csv", [](const ImuSample&, std::int64_t) {}, nullptr);
    FAIL() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(std::string(e.what()), (dir / "imu0/data.csv") + ": is a folder, expected a file");
  }
}

}  // namespace
}  // namespace crop4d::io
