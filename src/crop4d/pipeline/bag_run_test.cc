// A recording that comes as a ROS 1 bag, end to end (issue 25): the simulated tiny session
// written into a bag (lz4) with every sensor on its own topic, imported with `crop4d import
// --bag` into a field with the simulated field's origin, rows and sites, and `crop4d run` on both
// fields: row SLAM, fusion and the analysis must give the same results to the byte.

#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/core/progress.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/rosbag/bag_import.h"
#include "crop4d/io/rosbag/session_bag_writer.h"
#include "crop4d/pipeline/season_run.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/sim/cached_field_test_util.h"
#include "crop4d/workspace/pass_data.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

std::string Slurp(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

class BagRunTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Progress::SetGloballySilent(true);
    dir_ = fs::path(::testing::TempDir()) / ("crop4d_bag_run_" + std::to_string(getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (std::getenv("CROP4D_KEEP_TEST_OUTPUT") == nullptr) fs::remove_all(dir_);
  }

  // `crop4d run FIELD --workspace WS` with one thread (the results do not depend on the thread
  // count, but one thread keeps every step in one order). No evaluation (the imported field has
  // no ground truth) and no report: neither changes what is compared. Coarser dense clouds than
  // the default (1.5 cm cells) keep the test quick; the stages are the same.
  RunResult Run(const std::string& field, const std::string& workspace) {
    RunOptions options;
    options.show_progress = false;
    options.config.threads = 1;
    options.config.eval = "never";
    options.config.report = false;
    options.config.densify_options.stereo.cell_m = 0.015;
    return RunSeason(field, workspace, options);
  }

  fs::path dir_;
};

TEST_F(BagRunTest, ImportedBagRunsLikeTheOriginalSession) {
  const io::Field sim(sim::testing::TinyOneSessionField());
  ASSERT_EQ(sim.session_ids().size(), 1u);
  const std::string id = sim.session_ids().front();
  const fs::path original(sim.SessionFolder(id));

  // The session into a bag: every sensor folder (cam0, imu0, gps0 RTK, gps1 metre-level, mag0)
  // on its own topic.
  const std::string bag = (dir_ / "session.bag").string();
  io::testing::SessionBagOptions bag_options;
  bag_options.compression = io::BagCompression::kLz4;
  const std::map<std::string, std::string> topics =
      io::testing::WriteSessionBag(original.string(), bag, bag_options);
  EXPECT_EQ(topics, (std::map<std::string, std::string>{{"cam0", "/cam0/image_raw"},
                                                        {"gps0", "/gps0/fix"},
                                                        {"gps1", "/gps1/fix"},
                                                        {"imu0", "/imu0/data"},
                                                        {"mag0", "/mag0/mag"}}));

  // The field as its owner declares it (origin, rows, sites; not its sessions), and the bag
  // imported into it with the rig's calibration (--sensor-yaml) and every topic named.
  io::FieldInfo field_info = sim.info();
  field_info.sessions.clear();
  const fs::path imported_field = dir_ / "field";
  fs::create_directories(imported_field);
  io::WriteFieldYaml((imported_field / "field.yaml").string(), field_info);
  io::BagImportOptions import;
  import.bag_path = bag;
  import.field_folder = imported_field.string();
  import.origin = sim.info().origin;
  import.topics = topics;
  io::testing::UseSessionCalibration(original.string(), &import);
  const io::BagImportSummary summary = io::ImportBag(import);
  ASSERT_EQ(summary.sensors.size(), 5u);
  EXPECT_EQ(fs::path(summary.session_folder).filename().string(), id);  // the date of the data
  const fs::path imported(summary.session_folder);

  // What the pipeline reads comes back exactly: sensor.yaml files and data.csv of the camera,
  // the IMU and both receivers (the simulator writes no RTK-float fix, the only GPS value a
  // NavSatFix cannot carry), and the images' pixels (PNG re-encoded by the importer). The
  // magnetometer's values are rounded to 1e-9 µT by the importer (tesla -> microtesla; the
  // simulator writes 17 digits); nothing in slam, fuse, densify or analyze reads them.
  for (const char* sensor : {"cam0", "imu0", "gps0", "gps1", "mag0"}) {
    EXPECT_EQ(Slurp(imported / sensor / io::kSensorYaml),
              Slurp(original / sensor / io::kSensorYaml))
        << sensor;
  }
  for (const char* sensor : {"cam0", "imu0", "gps0", "gps1"}) {
    EXPECT_EQ(Slurp(imported / sensor / io::kDataCsv), Slurp(original / sensor / io::kDataCsv))
        << sensor;
  }
  for (const io::ImageEntry& e : io::Session(original.string()).ReadImageList("cam0")) {
    const cv::Mat pa =
        cv::imread((original / "cam0/data" / e.filename).string(), cv::IMREAD_UNCHANGED);
    const cv::Mat pb =
        cv::imread((imported / "cam0/data" / e.filename).string(), cv::IMREAD_UNCHANGED);
    ASSERT_FALSE(pb.empty()) << e.filename;
    ASSERT_EQ(pa.type(), pb.type()) << e.filename;
    ASSERT_EQ(cv::norm(pa, pb, cv::NORM_INF), 0.0) << e.filename;
  }
  const std::vector<io::MagSample> mag_a = io::Session(original.string()).ReadMag("mag0");
  const std::vector<io::MagSample> mag_b = io::Session(imported.string()).ReadMag("mag0");
  ASSERT_EQ(mag_a.size(), mag_b.size());
  for (std::size_t i = 0; i < mag_a.size(); ++i) {
    ASSERT_EQ(mag_a[i].t, mag_b[i].t);
    ASSERT_LT((mag_a[i].field_ut - mag_b[i].field_ut).cwiseAbs().maxCoeff(), 1e-9) << i;
  }

  // `crop4d run` on both.
  const fs::path ws_a = dir_ / "ws_original";
  const fs::path ws_b = dir_ / "ws_imported";
  const RunResult a = Run(sim.folder(), ws_a.string());
  const RunResult b = Run(imported_field.string(), ws_b.string());
  for (const RunResult* result : {&a, &b}) {
    SCOPED_TRACE(result->record.workspace);
    EXPECT_TRUE(result->complete());
    EXPECT_TRUE(result->record.skipped.empty());
    RunRecord record = result->record;
    for (const char* stage : {"slam", "fuse", "densify", "analyze"}) {
      EXPECT_EQ(record.Stage(stage)->status, "done") << stage;
    }
  }

  // The same row passes, and per pass the same row-SLAM poses.
  EXPECT_EQ(Slurp(ws_b / "sessions" / id / "passes.csv"),
            Slurp(ws_a / "sessions" / id / "passes.csv"));
  const std::vector<slam::RowPass> passes_a = workspace::ReadPassList(ws_a.string(), id);
  const std::vector<slam::RowPass> passes_b = workspace::ReadPassList(ws_b.string(), id);
  ASSERT_FALSE(passes_a.empty());
  ASSERT_EQ(passes_a.size(), passes_b.size());
  for (std::size_t k = 0; k < passes_a.size(); ++k) {
    SCOPED_TRACE(passes_a[k].id);
    ASSERT_EQ(passes_b[k].id, passes_a[k].id);
    const std::string poses_a = Slurp(PassFolder(ws_a.string(), id, passes_a[k].id) + "/poses.tum");
    const std::string poses_b = Slurp(PassFolder(ws_b.string(), id, passes_b[k].id) + "/poses.tum");
    EXPECT_FALSE(poses_a.empty());
    EXPECT_EQ(poses_b, poses_a);
  }

  // The same fused poses of the session and the same canopy heights per site.
  const std::string fused_a = Slurp(ws_a / "fused" / id / "poses.tum");
  EXPECT_FALSE(fused_a.empty());
  EXPECT_EQ(Slurp(ws_b / "fused" / id / "poses.tum"), fused_a);
  const std::string heights_a = Slurp(ws_a / "analysis" / "site_heights.csv");
  EXPECT_GT(std::count(heights_a.begin(), heights_a.end(), '\n'), 1);  // header + sites
  EXPECT_EQ(Slurp(ws_b / "analysis" / "site_heights.csv"), heights_a);

  // And so is every other output (clouds, tracks, matches, rasters, COLMAP model), except the
  // records of what ran (JSON summaries, logs and the workspace lock: times, and fingerprints
  // that hash the input files, whose bytes differ: PNG encoding, mag0's rounding, session.yaml's
  // notes) and the plots, which show the measured heights of the original field's ground truth.
  std::vector<std::string> files_a, files_b;
  for (const auto& [ws, files] : {std::pair{ws_a, &files_a}, std::pair{ws_b, &files_b}}) {
    for (const fs::directory_entry& e : fs::recursive_directory_iterator(ws)) {
      const std::string relative = fs::relative(e.path(), ws).string();
      const std::string ext = e.path().extension().string();
      if (!e.is_regular_file() || ext == ".json" || ext == ".jsonl" || ext == ".log" ||
          ext == ".lock" || relative.starts_with("analysis/plots/")) {
        continue;
      }
      files->push_back(relative);
    }
    std::sort(files->begin(), files->end());
  }
  EXPECT_EQ(files_b, files_a);
  EXPECT_GT(files_a.size(), 10u);
  for (const std::string& file : files_a) {
    EXPECT_TRUE(Slurp(ws_b / file) == Slurp(ws_a / file)) << file;
  }
}

}  // namespace
}  // namespace crop4d::pipeline
