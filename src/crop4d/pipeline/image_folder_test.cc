// A rig without an IMU, end to end: a simulated session written as a folder of JPEGs with EXIF
// time and GPS (as a phone or a drone tags them), imported with `crop4d import --images`, and
// row SLAM with the camera and the GPS only (cam+rtk, cam+gps), evaluated against the
// simulator's ground truth.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>

#include "crop4d/core/progress.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/exif_import.h"
#include "crop4d/io/exif_test_writer.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/sim/cached_field_test_util.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/workspace/pass_data.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

const std::string& TinyField() { return sim::testing::TinyOneSessionField(); }

class ImageFolderTest : public ::testing::Test {
 protected:
  void SetUp() override {
    Progress::SetGloballySilent(true);
    dir_ = fs::path(::testing::TempDir()) /
           ("crop4d_images_" + std::to_string(getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (std::getenv("CROP4D_KEEP_TEST_OUTPUT") == nullptr) fs::remove_all(dir_);
  }

  // Writes the tiny session's images tagged with receiver `gps`'s track, imports them into a
  // field with the simulated field's origin and rows, with the rig's camera calibration and
  // antenna, runs row SLAM with the default sensor set and evaluates it.
  eval::WorkspaceEval ImportAndSolve(const std::string& gps, io::GpsKind kind,
                                     std::string* sensors) {
    const io::Field sim(TinyField());
    const std::string id = sim.session_ids().front();
    const std::string session = sim.SessionFolder(id);
    io::testing::WriteExifImageFolder((dir_ / "jpegs").string(),
                                      io::testing::ExifImagesFromSession(session, "cam0", gps));

    // The field as its owner declares it: its origin and its rows (not its sessions).
    io::FieldInfo field = sim.info();
    field.sessions.clear();
    fs::create_directories(dir_ / "field");
    io::WriteFieldYaml((dir_ / "field" / "field.yaml").string(), field);

    io::ExifImportOptions o;
    o.image_folder = (dir_ / "jpegs").string();
    o.field_folder = (dir_ / "field").string();
    o.camera = io::ReadCameraSensorYaml(session + "/cam0/sensor.yaml");
    o.camera_source = "the simulated rig";
    o.gps_kind = kind;
    o.antenna_in_body = io::ReadGpsSensorYaml(session + "/" + gps + "/sensor.yaml").antenna_in_body;
    const io::ExifImportSummary summary = io::ImportExifFolder(o);
    // The receiver's track starts after the first image and ends before the last.
    EXPECT_LE(summary.images_without_gps, 4);
    EXPECT_EQ(fs::path(summary.session_folder).filename().string(), id);

    SlamStageOptions options;
    options.show_progress = false;
    const std::vector<PassReport> reports =
        RunSlamStage(o.field_folder, (dir_ / "ws").string(), options);
    EXPECT_FALSE(reports.empty());
    for (const PassReport& r : reports) EXPECT_FALSE(r.failed) << r.pass.id << ": " << r.message;
    *sensors = reports.empty() ? "" : reports.front().sensors;
    // The truth is the simulated field's: the imported session has its name and frame.
    return eval::EvaluateWorkspace((dir_ / "ws").string(), TinyField());
  }

  fs::path dir_;
};

TEST_F(ImageFolderTest, JpegsWithRtkPositionsRunCamRtkToCentimetres) {
  std::string sensors;
  const eval::WorkspaceEval e = ImportAndSolve("gps0", io::GpsKind::kRtk, &sensors);
  EXPECT_EQ(sensors, "cam+rtk");  // no IMU in the session: the default
  ASSERT_GT(e.overall.num_evaluated, 0);
  EXPECT_EQ(e.overall.num_evaluated, e.overall.num_passes);
  // Issue 25's bound: camera ATE ≤ 3 cm.
  EXPECT_LT(e.overall.ate_raw_m.rmse, 0.03);
  EXPECT_LT(e.overall.rpe_translation_percent.rmse, 1.5);
}

TEST_F(ImageFolderTest, JpegsWithPhoneGradePositionsRunCamGpsWithoutLosingTheShape) {
  std::string sensors;
  ImportAndSolve("gps1", io::GpsKind::kStandard, &sensors);
  EXPECT_EQ(sensors, "cam+gps");
  // The passes come from the metre-level track alone (no better receiver): each reaches at most
  // 2 s beyond the true row pass and covers at least half of it (the segmenter's noisy-receiver
  // boundaries; measured 3.1 s inside at the end of row00, 1.7 s outside at the start of row01).
  const io::Field sim(TinyField());
  const std::string id = sim.session_ids().front();
  std::vector<std::pair<Timestamp, Timestamp>> truth;
  io::CsvReader reader(TinyField() + "/ground_truth/" + id + "/passes.csv");
  io::CsvRecord record;
  while (reader.Next(&record)) {
    const std::vector<std::string_view>& f = record.fields;
    std::int64_t begin = 0, end = 0;
    if (f.size() < 6 || !io::ParseInt64(f[4], &begin) || !io::ParseInt64(f[5], &end)) continue;
    truth.emplace_back(begin, end);
  }
  const std::vector<slam::RowPass> passes = workspace::ReadPassList((dir_ / "ws").string(), id);
  ASSERT_EQ(passes.size(), truth.size());
  for (std::size_t k = 0; k < passes.size(); ++k) {
    SCOPED_TRACE(k);
    EXPECT_GT(TimestampToSeconds(passes[k].t_begin - truth[k].first), -2.0);
    EXPECT_LT(TimestampToSeconds(passes[k].t_end - truth[k].second), 2.0);
    const double overlap = TimestampToSeconds(std::min(passes[k].t_end, truth[k].second) -
                                              std::max(passes[k].t_begin, truth[k].first));
    EXPECT_GT(overlap, 0.5 * TimestampToSeconds(truth[k].second - truth[k].first));
  }
  // Inside the rows the camera and the GP prior keep the shape. The part of a pass that reaches
  // into a U-turn is left out: there the GP prior alone, without an IMU, follows the turn less
  // well (measured inside the rows: RPE 0.75 / 1.15 % and ATE aligned 0.5 / 2.7 cm; over the
  // whole passes 0.97 % pooled; bench/RESULTS.md, "Rigs without an IMU").
  for (const slam::RowPass& pass : passes) {
    const std::string file = PassFolder((dir_ / "ws").string(), id, pass.id) + "/poses.tum";
    std::vector<io::StampedPose> inside;
    for (const io::StampedPose& p : io::ReadTum(file)) {
      for (const auto& [begin, end] : truth) {
        if (p.t >= begin && p.t <= end) inside.push_back(p);
      }
    }
    io::WriteTum(file, inside, "poses inside the true row pass");
  }
  const eval::WorkspaceEval e = eval::EvaluateWorkspace((dir_ / "ws").string(), TinyField());
  ASSERT_EQ(e.overall.num_evaluated, 2);
  for (const eval::PassEval& p : e.passes) {
    SCOPED_TRACE(p.pass);
    EXPECT_LT(p.metrics.rpe_translation_percent.rmse, 1.5);
    EXPECT_LT(p.metrics.ate_aligned_m.rmse, 0.04);
  }
}

}  // namespace
}  // namespace crop4d::pipeline
