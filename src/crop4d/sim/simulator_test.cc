#include "crop4d/sim/simulator.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/sensor_models.h"

namespace crop4d::sim {
namespace {
namespace fs = std::filesystem;

double Mean(const std::vector<double>& x) {
  double s = 0;
  for (double v : x) s += v;
  return s / x.size();
}
double Std(const std::vector<double>& x) {
  const double m = Mean(x);
  double s = 0;
  for (double v : x) s += (v - m) * (v - m);
  return std::sqrt(s / (x.size() - 1));
}

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// The tiny preset cut to a few seconds per session, with depth maps.
SimConfig ShortTiny(std::uint64_t seed) {
  SimConfig config = PresetConfig("tiny");
  config.seed = seed;
  config.drive.max_duration_s = 3.0;
  config.ground_truth.depth = true;
  return config;
}

TEST(SimulatorTest, SensorsHaveTheirRatesAndNeverShareATimestamp) {
  const Simulator sim(PresetConfig("tiny"));
  const SessionRecord rec = sim.SimulateSession(0);
  const double duration = rec.trajectory->Duration();
  EXPECT_GT(duration, 20.0);
  const SimConfig& c = sim.config();
  std::vector<std::pair<std::vector<Timestamp>, double>> sensors;
  sensors.push_back({rec.image_times, c.camera.rate_hz});
  std::vector<Timestamp> imu, mag, gps0, gps1;
  for (const auto& s : rec.imu) imu.push_back(s.t);
  for (const auto& s : rec.mag) mag.push_back(s.t);
  for (const auto& s : rec.gps[0]) gps0.push_back(s.t);
  for (const auto& s : rec.gps[1]) gps1.push_back(s.t);
  sensors.push_back({imu, c.imu.rate_hz});
  sensors.push_back({mag, c.mag.rate_hz});
  sensors.push_back({gps0, c.gps0.rate_hz});
  sensors.push_back({gps1, c.gps1.rate_hz});
  std::set<Timestamp> all;
  std::set<Timestamp> first_stamps;
  for (const auto& [times, rate] : sensors) {
    ASSERT_FALSE(times.empty());
    EXPECT_NEAR(static_cast<double>(times.size()), duration * rate, 1.0 + 1e-9) << rate;
    for (size_t k = 1; k < times.size(); ++k) {
      // The nominal period, within 2 ns (rounding to the nanosecond and de-duplication).
      EXPECT_NEAR(static_cast<double>(times[k] - times[k - 1]), 1e9 / rate, 2.0) << rate;
    }
    for (const Timestamp t : times) {
      EXPECT_TRUE(all.insert(t).second) << "shared timestamp " << t;
      EXPECT_GE(t, rec.start);
      EXPECT_LE(rec.Seconds(t), duration + 1e-9);
    }
    first_stamps.insert(times.front() - rec.start);
  }
  EXPECT_EQ(first_stamps.size(), sensors.size());  // every sensor has its own phase
}

TEST(SimulatorTest, CameraTriggeredOverThePassesOnly) {
  SimConfig config = PresetConfig("tiny");
  const SessionRecord continuous = Simulator(config).SimulateSession(0);
  config.camera.trigger = "passes";
  const Simulator sim(config);
  const SessionRecord rec = sim.SimulateSession(0);
  const std::vector<Pass>& passes = rec.trajectory->passes();
  ASSERT_EQ(passes.size(), 2u);
  // Every image is taken during a pass, and every pass has all of its frames.
  std::vector<int> per_pass(passes.size(), 0);
  for (const Timestamp t : rec.image_times) {
    const double s = rec.Seconds(t);
    int inside = -1;
    for (std::size_t p = 0; p < passes.size(); ++p) {
      if (s >= passes[p].t_begin && s <= passes[p].t_end) inside = static_cast<int>(p);
    }
    ASSERT_GE(inside, 0) << "image at " << s << " s is in a turn";
    ++per_pass[inside];
  }
  for (std::size_t p = 0; p < passes.size(); ++p) {
    EXPECT_NEAR(per_pass[p], (passes[p].t_end - passes[p].t_begin) * config.camera.rate_hz, 1.0);
  }
  // The same frames as the continuous recording (the clock keeps its phase), minus the turn's.
  std::size_t k = 0;
  for (const Timestamp t : rec.image_times) {
    while (k < continuous.image_times.size() && continuous.image_times[k] + 2 < t) ++k;
    ASSERT_LT(k, continuous.image_times.size());
    EXPECT_LE(std::llabs(continuous.image_times[k] - t), 2);
  }
  const double turn_s = passes[1].t_begin - passes[0].t_end;
  EXPECT_NEAR(static_cast<double>(continuous.image_times.size() - rec.image_times.size()),
              turn_s * config.camera.rate_hz, 1.0);
  // The other sensors record the whole drive.
  EXPECT_EQ(rec.imu.size(), continuous.imu.size());
  EXPECT_EQ(rec.gps[0].size(), continuous.gps[0].size());
  EXPECT_THROW(
      {
        SimConfig bad = PresetConfig("tiny");
        bad.camera.trigger = "sometimes";
        bad.Check();
      },
      InputError);
}

TEST(SimulatorTest, GpsSamplesEqualTheTrueAntennaUpToTheStatedNoise) {
  const Simulator sim(PresetConfig("tiny"));
  const SimConfig& c = sim.config();
  const geometry::LocalEnu enu(c.origin);
  std::array<std::array<std::vector<double>, 3>, 2> white;  // per receiver, per axis
  double max_bias_step = 0.0;
  for (int session = 0; session < 2; ++session) {
    const SessionRecord rec = sim.SimulateSession(session);
    for (int g = 0; g < 2; ++g) {
      const GpsOptions& o = g == 0 ? c.gps0 : c.gps1;
      for (size_t k = 0; k < rec.gps[g].size(); ++k) {
        const io::GpsSample& s = rec.gps[g][k];
        // The true antenna: the body pose and the lever arm.
        const Eigen::Vector3d antenna =
            rec.trajectory->WorldFromBody(rec.Seconds(s.t)) * o.antenna_in_body;
        EXPECT_LT((antenna - rec.gps_true_enu[g][k]).norm(), 1e-9);
        // WGS84 round trip of what was measured.
        const Eigen::Vector3d measured = enu.ToEnu(s.position);
        EXPECT_LT((measured - rec.gps_measured_enu[g][k]).norm(), 1e-6);
        const Eigen::Vector3d error = measured - antenna - rec.gps_bias[g][k];
        for (int a = 0; a < 3; ++a) white[g][a].push_back(error[a]);
        EXPECT_DOUBLE_EQ(s.sigma_h, o.ReportedSigmaH());
        EXPECT_DOUBLE_EQ(s.sigma_v, o.ReportedSigmaV());
        EXPECT_EQ(s.fix, o.Fix());
        if (g == 0) {
          EXPECT_EQ(rec.gps_bias[g][k], Eigen::Vector3d::Zero());
        }
        if (g == 1 && k > 0) {
          max_bias_step =
              std::max(max_bias_step, (rec.gps_bias[g][k] - rec.gps_bias[g][k - 1]).norm());
        }
      }
    }
  }
  for (int g = 0; g < 2; ++g) {
    const GpsOptions& o = g == 0 ? c.gps0 : c.gps1;
    for (int a = 0; a < 3; ++a) {
      const double sigma = a < 2 ? o.sigma_h_m : o.sigma_v_m;
      const double n = white[g][a].size();
      ASSERT_GT(n, 200);
      EXPECT_NEAR(Mean(white[g][a]), 0.0, 4.0 * sigma / std::sqrt(n)) << "gps" << g << " " << a;
      EXPECT_NEAR(Std(white[g][a]), sigma, 0.2 * sigma) << "gps" << g << " axis " << a;
    }
  }
  // gps1's bias drifts slowly: a step of σ_b √(2Δt/τ) ≈ 3 cm per 0.2 s, not metres.
  const double expected_step = c.gps1.bias_sigma_h_m * std::sqrt(2 * 0.2 / 600.0);
  EXPECT_GT(max_bias_step, 0.0);
  EXPECT_LT(max_bias_step, 6.0 * expected_step * std::sqrt(3.0));
}

TEST(SimulatorTest, FieldDeclaresRowsSitesAndSessions) {
  const Simulator sim(PresetConfig("demo"));
  const io::FieldInfo field = sim.MakeFieldInfo();
  EXPECT_EQ(field.name, "demo");
  EXPECT_NEAR(field.origin.lat_deg, 31.47, 1e-9);
  EXPECT_NEAR(field.origin.lon_deg, -83.53, 1e-9);
  ASSERT_EQ(field.rows.size(), 4u);
  EXPECT_EQ(field.sites.size(), 12u);
  EXPECT_EQ(field.sessions.size(), 4u);
  for (const io::Site& site : field.sites) {
    EXPECT_GE(site.radius_m, 0.3);
    EXPECT_LE(site.radius_m, 0.5);
  }
  // Conditions: rain bumps the soil epoch, the sun is up.
  EXPECT_EQ(sim.ConditionsOf(1).soil_epoch, 0);
  EXPECT_EQ(sim.ConditionsOf(2).soil_epoch, 1);
  EXPECT_TRUE(sim.ConditionsOf(2).rain_before);
  for (int i = 0; i < 4; ++i) EXPECT_GT(sim.ConditionsOf(i).sun_elevation_rad, 0.3);
}

TEST(SimulatorTest, SunPositionAtSolarNoonAndInTheMorning) {
  // Tifton, GA on the June solstice: solar noon ≈ 12:00 + 83.53° × 4 min ≈ 17:34 UTC, the sun
  // 90° − (31.47° − 23.44°) ≈ 82° high in the south.
  double elevation, azimuth;
  SunPosition(FromDate(2016, 6, 21) + SecondsToTimestamp(17.57 * 3600), 31.47, -83.53, &elevation,
              &azimuth);
  EXPECT_NEAR(elevation * 180 / M_PI, 82.0, 1.0);
  // Morning: the sun in the east, lower.
  SunPosition(FromDate(2016, 6, 21) + SecondsToTimestamp(13.0 * 3600), 31.47, -83.53, &elevation,
              &azimuth);
  EXPECT_GT(azimuth * 180 / M_PI, 60.0);
  EXPECT_LT(azimuth * 180 / M_PI, 110.0);
  EXPECT_LT(elevation * 180 / M_PI, 50.0);
  EXPECT_GT(elevation * 180 / M_PI, 10.0);
}

TEST(SimulatorTest, RefusesToOverwriteAField) {
  const fs::path dir =
      fs::path(testing::TempDir()) / ("crop4d_sim_refuse_" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir / "sessions");
  std::ofstream(dir / "field.yaml") << "name: x\n";
  std::ofstream(dir / "notes.txt") << "keep me\n";
  EXPECT_THROW(PrepareOutputFolder(dir.string(), false), InputError);
  PrepareOutputFolder(dir.string(), true);
  EXPECT_FALSE(fs::exists(dir / "field.yaml"));
  EXPECT_FALSE(fs::exists(dir / "sessions"));
  EXPECT_TRUE(fs::exists(dir / "notes.txt"));
  // Not a field: even --force refuses.
  EXPECT_THROW(PrepareOutputFolder(dir.string(), true), InputError);
  fs::remove_all(dir);
  PrepareOutputFolder(dir.string(), false);  // created
  EXPECT_TRUE(fs::is_directory(dir));
  fs::remove_all(dir);
}

// Writes the short tiny field twice with the same seed (renderer needed).
// The fields these tests compare, each written on first use: ctest runs every test in a process
// of its own, so a test writes only the fields it reads.
class SimulatorWriteTest : public testing::Test {
 protected:
  static void SetUpTestSuite() {
    root_ = new fs::path(fs::path(testing::TempDir()) /
                         ("crop4d_sim_write_" + std::to_string(::getpid())));
    fs::remove_all(*root_);
  }
  static void TearDownTestSuite() {
    fs::remove_all(*root_);
    delete root_;
  }
  // "a" and "b": the same seed; "zero": every imperfection's magnitude explicitly zero, its
  // other settings changed (the same field as "a"); "real": the real world, with JPEG images.
  static fs::path Field(const std::string& name) {
    const fs::path dir = *root_ / name;
    if (fs::exists(dir)) return dir;
    SimConfig config = ShortTiny(5);
    if (name == "zero") {
      ApplySimConfigYaml(
          "zero.yaml",
          "realism: ideal\n"
          "recording: {wind_sway_m: 0, wind_period_s: 7}\n"
          "camera: {exposure_s: 0, electrons_per_dn: 0, read_noise_dn: 0, "
          "auto_exposure_jitter: 0, auto_exposure_period_s: 3, jpeg_quality: 0}\n"
          "drive: {standstill_start_s: 0, stop_probability_row_end: 0, "
          "stop_probability_in_row: 0, stop_duration_s: 9, stop_ramp_s: 2}\n"
          "imu: {scale_factor_sigma: 0, misalignment_sigma_rad: 0}\n"
          "gps0: {outlier_probability: 0, outlier_sigma_m: 3, float_rate_per_min: 0, "
          "float_duration_s: 4, dropout_rate_per_min: 0, dropout_duration_s: 9}\n"
          "soil_change: {fraction_per_session: 0, patch_m: 0.5, drying_per_session: 0}\n"
          "weeds: {density_per_m2: 0, row_clearance_m: 0.3, first_emergence_days: 3}\n"
          "calibration_error: {focal_px: 0, principal_point_px: 0, "
          "radial_distortion: 0, tangential_distortion: 0, lever_arm_m: 0, "
          "rotation_deg: 0, camera_time_offset_s: 0, camera_clock_drift_ppm: 0}\n",
          &config);
    } else if (name == "real") {
      ApplyRealism("real", &config);
      config.image.jpeg_quality = 90;
      config.drive.standstill_start_s = 1.5;  // (5 s in the real preset: shorter for a fast test)
    }
    const Simulator::Summary summary = Simulator(config).Write(dir.string());
    if (name == "a") summary_ = summary;
    return dir;
  }
  static fs::path* root_;
  static Simulator::Summary summary_;
};
fs::path* SimulatorWriteTest::root_ = nullptr;
Simulator::Summary SimulatorWriteTest::summary_;

TEST_F(SimulatorWriteTest, WritesTheDatasetAndItsGroundTruth) {
  const fs::path field = Field("a");
  EXPECT_EQ(summary_.sessions, 2);
  EXPECT_GT(summary_.images, 40);
  for (const char* file : {"field.yaml", "ground_truth/terrain.csv", "ground_truth/site_truth.csv",
                           "ground_truth/site_measurements.csv", "ground_truth/simulate.yaml"}) {
    EXPECT_TRUE(fs::is_regular_file(field / file)) << file;
  }
  for (const char* session : {"2016-06-10", "2016-06-24"}) {
    const fs::path s = field / "sessions" / session;
    for (const char* file :
         {"session.yaml", "cam0/sensor.yaml", "cam0/data.csv", "imu0/sensor.yaml", "imu0/data.csv",
          "mag0/sensor.yaml", "mag0/data.csv", "gps0/sensor.yaml", "gps0/data.csv",
          "gps1/sensor.yaml", "gps1/data.csv"}) {
      EXPECT_TRUE(fs::is_regular_file(s / file)) << session << "/" << file;
    }
    const fs::path t = field / "ground_truth" / session;
    for (const char* file : {"cam0_poses.tum", "body_poses.tum", "imu_biases.csv", "plants.csv",
                             "passes.csv", "gps0_antenna.csv", "gps1_antenna.csv"}) {
      EXPECT_TRUE(fs::is_regular_file(t / file)) << session << "/" << file;
    }
    // One PNG and one depth map per image.
    const auto count = [](const fs::path& dir) {
      return std::distance(fs::directory_iterator(dir), fs::directory_iterator());
    };
    EXPECT_EQ(count(s / "cam0/data"), count(t / "cam0_depth"));
    EXPECT_GE(count(s / "cam0/data"), 20);
    const cv::Mat image = cv::imread((*fs::directory_iterator(s / "cam0/data")).path().string(),
                                     cv::IMREAD_UNCHANGED);
    EXPECT_EQ(image.cols, 320);
    EXPECT_EQ(image.rows, 240);
    EXPECT_EQ(image.type(), CV_8UC3);
  }
  // Measured site heights: truth plus ≈1 cm, to the centimetre.
  std::istringstream truth(ReadFile(field / "ground_truth/site_truth.csv"));
  std::istringstream measured(ReadFile(field / "ground_truth/site_measurements.csv"));
  std::string a, b;
  std::getline(truth, a);
  std::getline(measured, b);
  EXPECT_EQ(b, "site_id,date,height_m");
  int rows = 0;
  while (std::getline(truth, a) && std::getline(measured, b)) {
    const double h_true = std::stod(a.substr(a.rfind(',') + 1));
    const double h_read = std::stod(b.substr(b.rfind(',') + 1));
    EXPECT_NEAR(h_read, h_true, 0.05) << a << " vs " << b;
    ++rows;
  }
  EXPECT_EQ(rows, 2 * 2 * 2);  // 2 sessions x 2 rows x 2 sites
}

TEST_F(SimulatorWriteTest, SameSeedGivesByteIdenticalFiles) {
  std::map<std::string, fs::path> a, b;
  for (const auto& entry : fs::recursive_directory_iterator(Field("a"))) {
    if (entry.is_regular_file()) a[fs::relative(entry.path(), *root_ / "a").string()] = entry;
  }
  for (const auto& entry : fs::recursive_directory_iterator(Field("b"))) {
    if (entry.is_regular_file()) b[fs::relative(entry.path(), *root_ / "b").string()] = entry;
  }
  ASSERT_EQ(a.size(), b.size());
  EXPECT_GT(a.size(), 100u);
  for (const auto& [name, path] : a) {
    ASSERT_TRUE(b.count(name)) << name;
    EXPECT_TRUE(ReadFile(path) == ReadFile(b[name])) << name << " differs";
  }
  // Another seed gives other data (same layout).
  const Simulator other(ShortTiny(6));
  const Simulator same(ShortTiny(5));
  EXPECT_NE(other.SimulateSession(0).imu[10].accel, same.SimulateSession(0).imu[10].accel);
}

TEST_F(SimulatorWriteTest, ZeroImperfectionsGiveTheIdealFieldByteForByte) {
  std::map<std::string, fs::path> a, zero;
  for (const auto& entry : fs::recursive_directory_iterator(Field("a"))) {
    if (entry.is_regular_file()) a[fs::relative(entry.path(), *root_ / "a").string()] = entry;
  }
  for (const auto& entry : fs::recursive_directory_iterator(Field("zero"))) {
    if (entry.is_regular_file()) zero[fs::relative(entry.path(), *root_ / "zero").string()] = entry;
  }
  ASSERT_EQ(a.size(), zero.size());
  for (const auto& [name, path] : a) {
    ASSERT_TRUE(zero.count(name)) << name;
    // simulate.yaml records the configuration, whose unused settings differ.
    if (name == "ground_truth/simulate.yaml") continue;
    EXPECT_TRUE(ReadFile(path) == ReadFile(zero[name])) << name << " differs";
  }
}

TEST_F(SimulatorWriteTest, TheRealWorldWritesItsErrorsAndTheirTruth) {
  const fs::path field = Field("real");
  const fs::path ideal = Field("a");
  SimConfig real = ShortTiny(5);
  ApplyRealism("real", &real);
  EXPECT_TRUE(fs::is_regular_file(field / "ground_truth/calibration_truth.yaml"));
  for (const char* session : {"2016-06-10", "2016-06-24"}) {
    const fs::path s = field / "sessions" / session;
    const fs::path t = field / "ground_truth" / session;
    for (const char* file :
         {"standstills.csv", "cam0_exposure.csv", "gps0_faults.csv", "gps1_faults.csv"}) {
      EXPECT_TRUE(fs::is_regular_file(t / file)) << session << "/" << file;
    }
    // The calibration crop4d reads is off the truth by the configured amounts.
    const io::CameraSensor cam = io::ReadCameraSensorYaml((s / "cam0/sensor.yaml").string());
    const io::CameraSensor true_cam =
        io::ReadCameraSensorYaml((ideal / "sessions" / session / "cam0/sensor.yaml").string());
    EXPECT_NEAR(std::abs(cam.camera.fx - true_cam.camera.fx), real.calibration_error.focal_px,
                1e-6);
    EXPECT_NEAR(std::hypot(cam.camera.cx - true_cam.camera.cx, cam.camera.cy - true_cam.camera.cy),
                real.calibration_error.principal_point_px, 1e-6);
    EXPECT_NEAR(
        (cam.body_from_sensor.translation() - true_cam.body_from_sensor.translation()).norm(),
        real.calibration_error.lever_arm_m, 1e-6);
    EXPECT_NEAR(
        cam.body_from_sensor.rotation().angularDistance(true_cam.body_from_sensor.rotation()) *
            180.0 / M_PI,
        real.calibration_error.rotation_deg, 1e-6);
    // Weeds between the rows, listed with the emerged ones only, clear of the rows' bands.
    std::istringstream weeds(ReadFile(t / "weeds.csv"));
    std::string weed_line;
    std::getline(weeds, weed_line);
    EXPECT_EQ(weed_line, "id,strip,x,y,height_m,canopy_radius_m");
    int weed_rows = 0;
    while (std::getline(weeds, weed_line)) {
      int id = 0, strip = 0;
      double x = 0, y = 0, height = 0, radius = 0;
      ASSERT_EQ(std::sscanf(weed_line.c_str(), "%d,%d,%lf,%lf,%lf,%lf", &id, &strip, &x, &y,
                            &height, &radius),
                6);
      EXPECT_GT(height, 0.0);
      EXPECT_GT(radius, 0.0);
      for (int row = 0; row < real.world.num_rows; ++row) {
        EXPECT_GE(std::abs(x - row * real.world.row_spacing_m),
                  real.world.weeds.row_clearance_m - 1e-4);
      }
      ++weed_rows;
    }
    EXPECT_GT(weed_rows, 0);
    const io::GpsSensor gps = io::ReadGpsSensorYaml((s / "gps0/sensor.yaml").string());
    EXPECT_NEAR((gps.antenna_in_body - real.gps0.antenna_in_body).norm(),
                real.calibration_error.lever_arm_m, 1e-6);
    // JPEG images with sensor noise: a 3x3 neighbourhood varies more than in the ideal PNG.
    const std::vector<fs::path> jpgs = [&] {
      std::vector<fs::path> v;
      for (const auto& e : fs::directory_iterator(s / "cam0/data")) v.push_back(e.path());
      std::sort(v.begin(), v.end());
      return v;
    }();
    ASSERT_GT(jpgs.size(), 20u);
    EXPECT_EQ(jpgs[0].extension(), ".jpg");
    const cv::Mat image = cv::imread(jpgs[0].string(), cv::IMREAD_COLOR);
    ASSERT_EQ(image.cols, 320);
    // The images stand still at the start: two images of the standstill differ only by noise
    // and exposure, with a noise std-dev near the model's (JPEG smooths a little).
    const cv::Mat second = cv::imread(jpgs[1].string(), cv::IMREAD_COLOR);
    cv::Mat a, b;
    image.convertTo(a, CV_32F);
    second.convertTo(b, CV_32F);
    cv::Scalar ma = cv::mean(a), mb = cv::mean(b);
    b = b * ((ma[0] + ma[1] + ma[2]) / (mb[0] + mb[1] + mb[2]));
    cv::Scalar mean, std;
    const cv::Mat difference = a - b;
    cv::meanStdDev(difference.reshape(1), mean, std);
    const double grey = (ma[0] + ma[1] + ma[2]) / 3.0;
    const double noise = std::sqrt(grey / real.image.electrons_per_dn +
                                   real.image.read_noise_dn * real.image.read_noise_dn);
    EXPECT_GT(std[0], 0.5 * std::sqrt(2.0) * noise);
    EXPECT_LT(std[0], 1.5 * std::sqrt(2.0) * noise);
    // Image stamps are the capture times plus the clock offset; cam0_poses.tum gives the pose
    // at the capture time under the written stamp.
    std::istringstream exposure(ReadFile(t / "cam0_exposure.csv"));
    std::string line;
    std::getline(exposure, line);
    int rows = 0;
    while (std::getline(exposure, line)) {
      Timestamp stamp = 0, capture = 0;
      ASSERT_EQ(std::sscanf(line.c_str(), "%ld,%ld", &stamp, &capture), 2);
      EXPECT_NEAR(std::abs(DurationSeconds(capture, stamp)),
                  real.calibration_error.camera_time_offset_s, 1e-3);
      ++rows;
    }
    EXPECT_EQ(rows, static_cast<int>(jpgs.size()));
  }
}

// Reads a TUM file: timestamp -> pose.
std::map<Timestamp, geometry::Rigid3> ReadTum(const fs::path& path) {
  std::map<Timestamp, geometry::Rigid3> poses;
  for (const io::StampedPose& p : io::ReadTum(path.string())) poses[p.t] = p.pose;
  return poses;
}

TEST_F(SimulatorWriteTest, DepthMapsAgreeWithTheTrueGeometry) {
  const fs::path field = Field("a");
  const SimConfig config = ShortTiny(5);
  const Simulator sim(config);
  const World& world = sim.world();
  const geometry::PinholeRadTan camera = config.camera.Intrinsics();
  const std::vector<Timestamp> dates = config.SessionDates();
  for (int session = 0; session < 2; ++session) {
    const std::string id = config.sessions[session].date;
    const auto poses = ReadTum(field / "ground_truth" / id / "cam0_poses.tum");
    ASSERT_GT(poses.size(), 20u);
    int ground_checked = 0, ground_ok = 0, pixels = 0, pixels_on_truth = 0, plant_pixels = 0;
    int plants_checked = 0, plants_ok = 0;
    int frame = 0;
    for (const auto& [t, world_from_camera] : poses) {
      if (frame++ % 5 != 0) continue;
      const cv::Mat depth = cv::imread(
          (field / "ground_truth" / id / "cam0_depth" / (std::to_string(t) + ".png")).string(),
          cv::IMREAD_UNCHANGED);
      ASSERT_EQ(depth.type(), CV_16UC1);
      const geometry::Rigid3 camera_from_world = world_from_camera.Inverse();
      // (a) True ground points (between the rows) project where the depth map has them,
      // unless a plant hides them.
      for (double x = -0.5 * 0.91; x < 1.5 * 0.91 + 0.1; x += 0.91) {
        for (double y = -1.0; y < 8.0; y += 0.25) {
          const Eigen::Vector3d point(x, y, world.TerrainHeight(x, y));
          const Eigen::Vector3d in_camera = camera_from_world * point;
          Eigen::Vector2d pixel;
          if (!camera.Project(in_camera, &pixel) || !camera.IsInImage(pixel, 2.0)) continue;
          const int u = static_cast<int>(std::lround(pixel.x()));
          const int v = static_cast<int>(std::lround(pixel.y()));
          double lo = 1e9, hi = 0;
          for (int dv = -1; dv <= 1; ++dv) {
            for (int du = -1; du <= 1; ++du) {
              const double d = depth.at<std::uint16_t>(v + dv, u + du) * 1e-3;
              lo = std::min(lo, d);
              hi = std::max(hi, d);
            }
          }
          ++ground_checked;
          const double tol = 0.01 + 0.005 * in_camera.z();
          if (in_camera.z() >= lo - tol && in_camera.z() <= hi + tol) ++ground_ok;
          // Never seen through: nothing visible lies behind a true ground point.
          EXPECT_LE(lo, in_camera.z() + tol) << "ground point " << point.transpose();
        }
      }
      // (b) True plant points: the top of each plant in view projects onto a surface at its
      // depth (the plant's own canopy), not onto the ground behind it.
      for (const Plant& plant : world.plants()) {
        const PlantState state = world.StateAt(plant, dates[session]);
        if (!state.emerged || state.height_m < 0.05) continue;
        const Eigen::Vector3d top(plant.xy.x(), plant.xy.y(),
                                  world.TerrainHeight(plant.xy.x(), plant.xy.y()) + state.height_m);
        const Eigen::Vector3d in_camera = camera_from_world * top;
        Eigen::Vector2d pixel;
        if (in_camera.z() > 5.0 || !camera.Project(in_camera, &pixel) ||
            !camera.IsInImage(pixel, 3.0)) {
          continue;
        }
        const int u = static_cast<int>(std::lround(pixel.x()));
        const int v = static_cast<int>(std::lround(pixel.y()));
        double nearest = 1e9;  // the depth closest to the point's in a 5x5 neighbourhood
        for (int dv = -2; dv <= 2; ++dv) {
          for (int du = -2; du <= 2; ++du) {
            const double d = depth.at<std::uint16_t>(v + dv, u + du) * 1e-3;
            if (std::abs(d - in_camera.z()) < std::abs(nearest - in_camera.z())) nearest = d;
          }
        }
        ++plants_checked;
        if (std::abs(nearest - in_camera.z()) < state.canopy_radius_m + 0.02) ++plants_ok;
      }
      // (c) Every pixel's depth unprojects onto true geometry: the terrain or a plant's canopy.
      for (int v = 0; v < depth.rows; v += 4) {
        for (int u = 0; u < depth.cols; u += 4) {
          const double d = depth.at<std::uint16_t>(v, u) * 1e-3;
          if (d <= 0.0 || d > 6.0) continue;  // sky, or far away
          Eigen::Vector3d ray;
          ASSERT_TRUE(camera.Unproject(Eigen::Vector2d(u, v), &ray));
          const Eigen::Vector3d p = world_from_camera * (ray * d);
          if (!world.Bounds().contains(p.head<2>())) continue;
          ++pixels;
          const double above = p.z() - world.TerrainHeight(p.x(), p.y());
          if (std::abs(above) < 0.015 + 0.004 * d) {
            ++pixels_on_truth;
            continue;
          }
          for (const Plant& plant : world.plants()) {
            const PlantState s = world.StateAt(plant, dates[session]);
            if (!s.emerged) continue;
            if ((p.head<2>() - plant.xy).norm() <= 1.15 * s.canopy_radius_m + 0.03 &&
                above <= s.height_m + 0.02 && above > -0.02) {
              ++pixels_on_truth;
              ++plant_pixels;
              break;
            }
          }
        }
      }
    }
    EXPECT_GT(ground_checked, 100) << id;
    EXPECT_GT(ground_ok, 0.8 * ground_checked) << id;
    EXPECT_GT(pixels, 500) << id;
    EXPECT_GT(pixels_on_truth, 0.98 * pixels) << id;
    EXPECT_GT(plant_pixels, 50) << id;  // plants are in view
    EXPECT_GT(plants_checked, 10) << id;
    EXPECT_GT(plants_ok, 0.75 * plants_checked) << id;  // small plants: thin leaves
  }
}

}  // namespace
}  // namespace crop4d::sim
