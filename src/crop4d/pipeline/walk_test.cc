// The row SLAM stage on a real recording: the handheld IMU + RTK walk of
// ../shared/data/gnss_imu_walk (its README), imported with its datasheet IMU noise, default
// options (imu+rtk). With every fix fused the antenna track must agree with the RTK-fixed epochs
// within their sigmas once the noise fits the data; with GNSS removed over the README's two 15 s
// windows (25–40 s and 70–85 s after the first fix) the largest horizontal error over each must
// be at most half the source's EKF's (55 and 22 cm). bench/gnss_outage_study.cc measures more
// windows (bench/RESULTS.md).

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/core/progress.h"
#include "crop4d/eval/gnss_check.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/importer.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

const std::string kWalk = std::string(CROP4D_SHARED_DATA_DIR) + "/gnss_imu_walk";
const char* kSession = "2025-08-28";
constexpr double kPi = 3.14159265358979323846;
constexpr double kG = 9.80665;

// The walk is imported with its README's datasheet noise and run with default options: the
// stated noise is overconfident for this handheld rig (the all-fixes residuals are 4.25 σ with
// it), and row SLAM's IMU noise that fits the data (docs/slam.md) inflates it, ×8 here. The
// source's own configuration multiplies it by 4 by hand ("to account for unmodeled errors").
//
// Bounds (bench/RESULTS.md, "GNSS outages on a real walk"). All fixes: normalised residual RMS
// 1.17 (horizontal 1.01), 98 % of the fixed epochs within 3σ_h horizontally, horizontal RMS
// 1.4 cm; the bound on the normalised RMS is 1.5.
constexpr double kMaxNormalisedRms = 1.5;
constexpr double kMaxNormalisedRmsHorizontal = 1.3;
constexpr double kMinWithin3Sigma = 0.9;
constexpr double kMaxHorizontalRms = 0.02;
// The README's 15 s outages: at most half the source's EKF's largest horizontal error (55 and
// 22 cm); measured 25.0 and 10.7 cm.
constexpr double kMaxHorizontal25To40 = 0.27;
constexpr double kMaxHorizontal70To85 = 0.11;

class WalkTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    if (!fs::exists(kWalk + "/gnss_1730_sf.pos") || !fs::exists(kWalk + "/imu_1730_sf.csv")) {
      return;
    }
    Progress::SetGloballySilent(true);
    dir_ =
        new fs::path(fs::temp_directory_path() / ("crop4d_walk_test_" + std::to_string(getpid())));
    fs::remove_all(*dir_);
    // The README's rig: IMU mounted roll 180°, yaw −90°; its datasheet noise.
    io::SessionImporter::Options o;
    o.field_folder = (*dir_ / "walk").string();
    o.session_id = kSession;
    o.pos_path = kWalk + "/gnss_1730_sf.pos";
    o.imu_path = kWalk + "/imu_1730_sf.csv";
    o.imu.columns = io::ParseImuColumns("t,ax,ay,az,gx,gy,gz,...");
    o.imu.accel_unit = io::AccelUnit::kStandardGravity;
    o.imu_rpy_deg = Eigen::Vector3d(180, 0, -90);
    o.gyroscope_noise_density = 0.0038 * kPi / 180;
    o.gyroscope_random_walk = 3.8e-5 * kPi / 180;
    o.accelerometer_noise_density = 70e-6 * kG;
    o.accelerometer_random_walk = 7e-6 * kG;
    io::SessionImporter(o).Run();

    const io::Field field(o.field_folder);
    const io::Session session = field.OpenSession(kSession);
    const slam::SessionStreams streams = slam::LoadSessionStreams(field, session);
    const slam::GpsStream* gps = streams.FindGps(io::GpsKind::kRtk);
    ASSERT_NE(gps, nullptr);
    first_fix_ = gps->fixes.front().t;
    imu_span_ = {streams.imu->samples.front().timestamp, streams.imu->samples.back().timestamp};
    fixed_ = new std::vector<eval::GnssFix>;
    for (const slam::GpsFixWorld& g : gps->fixes) {
      if (g.fix == io::GpsFix::kRtkFixed) {
        fixed_->push_back({g.t, g.position_world, g.sigma_h, g.sigma_v});
      }
    }
  }

  static void TearDownTestSuite() {
    if (dir_ != nullptr) fs::remove_all(*dir_);
    delete dir_;
    delete fixed_;
    dir_ = nullptr;
    fixed_ = nullptr;
  }

  void SetUp() override {
    if (dir_ == nullptr) GTEST_SKIP() << kWalk << " not present";
    ASSERT_NE(fixed_, nullptr) << "the walk could not be imported";
  }

  // Runs the stage with default options (imu+rtk, the walk having no camera; states at 10 Hz)
  // and returns the residuals of the fixed epochs; `noise_factor` gets the IMU noise factor the
  // pass used.
  static std::vector<eval::GnssResidual> Run(const std::string& name,
                                             const std::vector<GpsOutage>& outages,
                                             double* noise_factor = nullptr) {
    SlamStageOptions o;
    o.gps_outages = outages;
    o.show_progress = false;
    const std::vector<PassReport> reports =
        RunSlamStage((*dir_ / "walk").string(), (*dir_ / name).string(), o);
    if (reports.size() != 1 || reports[0].failed) {
      ADD_FAILURE() << "the slam stage failed: "
                    << (reports.empty() ? std::string("no pass") : reports[0].message);
      return {};
    }
    // A walk has no rows: one trajectory over every IMU sample, nothing dropped.
    EXPECT_EQ(reports[0].pass.id, "all");
    EXPECT_EQ(reports[0].pass.t_begin, imu_span_.first);
    EXPECT_EQ(reports[0].pass.t_end, imu_span_.second);
    if (noise_factor != nullptr) {
      std::ifstream in(reports[0].folder + "/summary.json");
      *noise_factor = nlohmann::json::parse(in).at("problem").at("imu_noise_factor");
    }
    const std::vector<io::StampedPose> poses = io::ReadTum(reports[0].folder + "/poses.tum");
    return eval::CompareWithFixes(poses, *fixed_, Eigen::Vector3d::Zero());
  }

  static fs::path* dir_;
  static std::vector<eval::GnssFix>* fixed_;
  static Timestamp first_fix_;
  static std::pair<Timestamp, Timestamp> imu_span_;
};

fs::path* WalkTest::dir_ = nullptr;
std::vector<eval::GnssFix>* WalkTest::fixed_ = nullptr;
Timestamp WalkTest::first_fix_ = 0;
std::pair<Timestamp, Timestamp> WalkTest::imu_span_;

// The comparison itself (eval/gnss_check.h) on a synthetic track: a body turning at a constant
// rate while moving at constant velocity, the antenna on a lever arm.
TEST(GnssCheckTest, ResidualsOfAKnownTrajectory) {
  const Eigen::Vector3d lever(0.3, -0.1, 0.5);
  const Eigen::Vector3d velocity(1.2, -0.4, 0.05);
  auto pose_at = [&](double s) {
    return geometry::Rigid3(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.2 * s, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(3, 4, 1) + s * velocity);
  };
  std::vector<io::StampedPose> trajectory;
  for (int k = 0; k <= 100; ++k) {
    if (k > 60 && k < 70) continue;  // a 1 s gap
    trajectory.push_back({SecondsToTimestamp(0.1 * k), pose_at(0.1 * k)});
  }
  std::vector<eval::GnssFix> fixes;
  for (double s : {0.05, 2.37, 5.0, 6.5, 9.99, 10.5}) {
    fixes.push_back({SecondsToTimestamp(s), pose_at(s) * lever + Eigen::Vector3d(0.03, 0.04, 0.02),
                     0.01, 0.02});
  }
  const std::vector<eval::GnssResidual> residuals =
      eval::CompareWithFixes(trajectory, fixes, lever);
  // 6.5 s lies in the gap, 10.5 s after the end.
  ASSERT_EQ(residuals.size(), 4u);
  for (const eval::GnssResidual& r : residuals) {
    // The turn bends the antenna's path: the cubic is within 0.2 mm of it.
    EXPECT_NEAR(r.error_world.x(), -0.03, 2e-4);
    EXPECT_NEAR(r.error_world.y(), -0.04, 2e-4);
    EXPECT_NEAR(r.error_world.z(), -0.02, 1e-9);
  }
  const eval::GnssResidualStats s = eval::SummariseResiduals(residuals);
  EXPECT_EQ(s.count, 4);
  EXPECT_NEAR(s.horizontal_m.rmse, 0.05, 2e-4);
  EXPECT_NEAR(s.normalised_rms_horizontal, std::sqrt((9.0 + 16.0) / 2), 0.05);
  EXPECT_NEAR(s.normalised_rms, std::sqrt((9.0 + 16.0 + 1.0) / 3), 0.05);
  EXPECT_EQ(s.within_sigma[2], 0.0);
  EXPECT_EQ(s.last.t, SecondsToTimestamp(9.99));
  const eval::GnssResidualStats window =
      eval::SummariseResiduals(residuals, SecondsToTimestamp(2.0), SecondsToTimestamp(5.0));
  EXPECT_EQ(window.count, 1);
  EXPECT_EQ(window.last.t, SecondsToTimestamp(2.37));
}

TEST_F(WalkTest, AllFixesAgreeWithTheirSigmasOnceTheNoiseFitsTheData) {
  double noise_factor = 0;
  const std::vector<eval::GnssResidual> residuals = Run("ws_all", {}, &noise_factor);
  // The datasheet noise was found overconfident and inflated (×8 measured).
  EXPECT_GE(noise_factor, 4.0);
  EXPECT_LE(noise_factor, 16.0);
  const eval::GnssResidualStats s = eval::SummariseResiduals(residuals);
  // 349 RTK-fixed epochs, 5 of them before the IMU's first sample.
  EXPECT_EQ(s.count, 344);
  // RTK-fixed sigmas are about 1 cm horizontally and 1–2 cm vertically.
  EXPECT_LT(s.normalised_rms, kMaxNormalisedRms);
  EXPECT_LT(s.normalised_rms_horizontal, kMaxNormalisedRmsHorizontal);
  EXPECT_GT(s.within_sigma[2], kMinWithin3Sigma);
  EXPECT_LT(s.horizontal_m.rmse, kMaxHorizontalRms);
}

TEST_F(WalkTest, FifteenSecondOutagesBridgedByTheImu) {
  for (const auto& [outage, bound] : {std::pair{GpsOutage{25.0, 15.0}, kMaxHorizontal25To40},
                                      std::pair{GpsOutage{70.0, 15.0}, kMaxHorizontal70To85}}) {
    const std::vector<eval::GnssResidual> residuals =
        Run("ws_outage_" + std::to_string(static_cast<int>(outage.start_s)), {outage});
    const eval::GnssResidualStats s = eval::SummariseResiduals(
        residuals, first_fix_ + SecondsToTimestamp(outage.start_s),
        first_fix_ + SecondsToTimestamp(outage.start_s + outage.duration_s));
    // 4 Hz over 15 s, all RTK-fixed.
    EXPECT_EQ(s.count, 60) << outage.start_s;
    EXPECT_LT(s.horizontal_m.max, bound) << outage.start_s;
  }
}

}  // namespace
}  // namespace crop4d::pipeline
