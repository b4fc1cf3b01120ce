#include "crop4d/io/importer.h"

#include <gtest/gtest.h>

#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/io/validator.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

const std::string kWalk = std::string(CROP4D_SHARED_DATA_DIR) + "/gnss_imu_walk/";

SessionImporter::Options WalkOptions(const std::string& field) {
  SessionImporter::Options options;
  options.field_folder = field;
  options.session_id = "2025-08-28";
  options.pos_path = kWalk + "gnss_1730_sf.pos";
  options.imu_path = kWalk + "imu_1730_sf.csv";
  options.imu.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz,...");
  options.imu.accel_unit = AccelUnit::kStandardGravity;
  options.imu_rpy_deg = Eigen::Vector3d(180, 0, -90);
  return options;
}

std::string Messages(const ValidationReport& report) {
  std::string out;
  for (const Diagnostic& d : report.diagnostics) out += d.ToString() + "\n";
  return out;
}

TEST(ImporterTest, RollPitchYawConvention) {
  // Yaw 90°: the sensor's x axis points along the body's y axis.
  const Eigen::Matrix3d yaw = RotationFromRollPitchYawDeg(Eigen::Vector3d(0, 0, 90));
  EXPECT_TRUE((yaw * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d::UnitY(), 1e-12));
  // Roll 180°, yaw −90° (the walk's mounting): sensor z (up at rest) is body −z.
  const Eigen::Matrix3d walk = RotationFromRollPitchYawDeg(Eigen::Vector3d(180, 0, -90));
  EXPECT_TRUE((walk * Eigen::Vector3d::UnitZ()).isApprox(-Eigen::Vector3d::UnitZ(), 1e-12));
  EXPECT_TRUE((walk * Eigen::Vector3d::UnitX()).isApprox(-Eigen::Vector3d::UnitY(), 1e-12));
}

TEST(ImporterTest, WalkBecomesAReadableValidSession) {
  if (!fs::exists(kWalk + "gnss_1730_sf.pos")) GTEST_SKIP() << kWalk << " not present";
  testing::TempDir dir;
  const std::string field_folder = dir / "walk";
  const SessionImporter::Summary summary = SessionImporter(WalkOptions(field_folder)).Run();
  EXPECT_TRUE(summary.field_created);
  EXPECT_EQ(summary.gps_samples, 536);
  EXPECT_EQ(summary.imu_samples, 20455);
  EXPECT_EQ(summary.time_scale, "GPST");
  EXPECT_EQ(summary.date, FromDate(2025, 8, 28));
  EXPECT_NEAR(summary.gps_rate_hz, 4.0, 0.01);
  // GPS time is not UTC: the summary says which scale its stamps are in, and no `Z`.
  const std::string text = FormatImportSummary(summary);
  EXPECT_NE(text.find("2025-08-28T17:30:39.749000000 GPST"), std::string::npos) << text;
  EXPECT_EQ(text.find("0Z"), std::string::npos) << text;

  const Field field(field_folder);
  EXPECT_EQ(field.info().name, "walk");
  EXPECT_DOUBLE_EQ(field.info().origin.lat_deg, 40.0966916);
  EXPECT_DOUBLE_EQ(field.info().origin.lon_deg, -105.1471665);
  EXPECT_TRUE(field.info().rows.empty());
  ASSERT_EQ(field.session_ids(), std::vector<std::string>{"2025-08-28"});
  const Session session = field.OpenSession("2025-08-28");
  EXPECT_EQ(session.info().date, FromDate(2025, 8, 28));
  EXPECT_TRUE(session.cameras().empty());
  ASSERT_NE(session.FindGps("gps0"), nullptr);
  EXPECT_EQ(session.FindGps("gps0")->kind, GpsKind::kRtk);
  ASSERT_NE(session.FindImu("imu0"), nullptr);
  const ImuSensor& imu_sensor = *session.FindImu("imu0");
  EXPECT_NEAR(imu_sensor.rate_hz, 152.3, 0.1);
  EXPECT_TRUE(imu_sensor.body_from_sensor.RotationMatrix().isApprox(
      RotationFromRollPitchYawDeg(Eigen::Vector3d(180, 0, -90)), 1e-9));
  EXPECT_DOUBLE_EQ(imu_sensor.gyroscope_noise_density, 1.6968e-4);

  const std::vector<GpsSample> gps = session.ReadGps("gps0");
  ASSERT_EQ(gps.size(), 536u);
  int fixed = 0;
  for (const GpsSample& s : gps) fixed += s.fix == GpsFix::kRtkFixed;
  EXPECT_EQ(fixed, 349);
  EXPECT_EQ(gps.front().t, 1756402239'749000000);
  EXPECT_NEAR(gps.front().sigma_h, 0.0098995, 1e-9);
  // RTKLIB's velocities are kept (east, north, up).
  EXPECT_EQ(summary.gps_velocities, 536);
  ASSERT_TRUE(gps.front().velocity_enu.has_value());
  EXPECT_DOUBLE_EQ(gps.front().velocity_enu->y(), 0.001);
  const std::vector<ImuSample> imu = session.ReadImu("imu0");
  ASSERT_EQ(imu.size(), 20455u);
  EXPECT_EQ(imu.front().t, 1756402240'961000000);
  EXPECT_NEAR(imu.front().accel.z(), 1.0109805 * 9.80665, 1e-9);

  const ValidationReport report = ValidateField(field_folder);
  EXPECT_EQ(report.errors, 0u) << Messages(report);
  EXPECT_TRUE(report.ok()) << Messages(report);
}

TEST(ImporterTest, SecondSessionKeepsTheOriginAndRefusesToOverwrite) {
  if (!fs::exists(kWalk + "gnss_1730_sf.pos")) GTEST_SKIP() << kWalk << " not present";
  testing::TempDir dir;
  SessionImporter::Options options = WalkOptions(dir / "walk");
  options.imu_path.clear();
  options.origin = geometry::GeodeticPoint{40.0, -105.0, 1600.0};
  SessionImporter(options).Run();
  EXPECT_THROW(SessionImporter(options).Run(), InputError);  // the session exists
  options.overwrite = true;
  EXPECT_NO_THROW(SessionImporter(options).Run());

  options.overwrite = false;
  options.session_id = "2025-08-28_utc";
  options.pos.leap_seconds = 18;
  options.origin.reset();
  const SessionImporter::Summary second = SessionImporter(options).Run();
  EXPECT_FALSE(second.field_created);
  EXPECT_EQ(second.time_scale, "UTC");
  EXPECT_NE(FormatImportSummary(second).find("17:30:21.749000000Z"), std::string::npos)
      << FormatImportSummary(second);
  EXPECT_EQ(second.gps_first_t, 1756402239'749000000 - 18 * kNanosPerSecond);
  const Field field(dir / "walk");
  EXPECT_DOUBLE_EQ(field.info().origin.lat_deg, 40.0);
  EXPECT_EQ(field.session_ids().size(), 2u);
}

TEST(ImporterTest, BadInputWritesNothing) {
  if (!fs::exists(kWalk + "gnss_1730_sf.pos")) GTEST_SKIP() << kWalk << " not present";
  testing::TempDir dir;
  SessionImporter::Options options = WalkOptions(dir / "walk");
  options.imu.time_unit = ImuTimeUnit::kMilliseconds;  // 1000x too early: no overlap
  try {
    SessionImporter(options).Run();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("do not overlap the GNSS epochs"), std::string::npos) << e.message();
  }
  options.imu.time_unit = ImuTimeUnit::kSeconds;
  options.imu.columns = ParseImuColumns("t,ax,ay,az,gx,gy,gz");  // the file has 11 columns
  try {
    SessionImporter(options).Run();
    FAIL() << "no error";
  } catch (const InputError& e) {
    EXPECT_EQ(e.line(), 1);
    EXPECT_EQ(e.message(), "expected 7 columns (as --imu-columns maps them), found 11");
  }
  EXPECT_FALSE(fs::exists(dir / "walk"));

  SessionImporter::Options nothing;
  nothing.field_folder = dir / "x";
  nothing.session_id = "s";
  EXPECT_THROW(SessionImporter(nothing).Run(), InputError);
  nothing.pos_path = kWalk + "gnss_1730_sf.pos";
  nothing.session_id = "../escape";
  EXPECT_THROW(SessionImporter(nothing).Run(), InputError);
}

}  // namespace
}  // namespace crop4d::io
