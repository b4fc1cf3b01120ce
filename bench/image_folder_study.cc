// Rigs without an IMU (bench/RESULTS.md, "Rigs without an IMU"): each session of a simulated
// field is written as a folder of JPEGs tagged with EXIF time and GPS, once with the RTK
// receiver's track (gps0) and once with the metre-level one's (gps1), imported with
// `crop4d import --images` into a field with the simulated field's origin and rows, and solved by
// row SLAM with the camera and that GPS only (cam+rtk, cam+gps). The trajectory errors against the
// simulator's truth, over the whole passes and over the parts inside the true row passes (a pass
// segmented from a metre-level track can reach into the U-turn, where the GP prior alone follows
// the turn badly).
//
//   image_folder_study FIELD OUT [SESSION...]
//
// FIELD: a simulated field (crop4d simulate); OUT: a scratch folder (removed first).

#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/exif_import.h"
#include "crop4d/io/exif_test_writer.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/workspace/pass_data.h"

namespace fs = std::filesystem;
using namespace crop4d;

namespace {

std::vector<std::pair<Timestamp, Timestamp>> TruePasses(const std::string& field,
                                                        const std::string& session) {
  std::vector<std::pair<Timestamp, Timestamp>> truth;
  io::CsvReader reader(field + "/ground_truth/" + session + "/passes.csv");
  io::CsvRecord record;
  while (reader.Next(&record)) {
    std::int64_t begin = 0, end = 0;
    if (record.fields.size() < 6 || !io::ParseInt64(record.fields[4], &begin) ||
        !io::ParseInt64(record.fields[5], &end)) {
      continue;
    }
    truth.emplace_back(begin, end);
  }
  return truth;
}

void PrintRow(const std::string& session, const std::string& sensors, const std::string& part,
              const eval::OverallEval& o) {
  std::printf("| %s | %s | %s | %d/%d | %.2f | %.2f | %.2f | %.3f |\n", session.c_str(),
              sensors.c_str(), part.c_str(), o.num_evaluated, o.num_passes, 100 * o.ate_raw_m.rmse,
              100 * o.ate_aligned_m.rmse, o.rpe_translation_percent.rmse, o.rotation_deg.rmse);
  std::fflush(stdout);
}

void Study(const std::string& field_folder, const std::string& session, const std::string& gps,
           io::GpsKind kind, const fs::path& out) {
  const io::Field sim(field_folder);
  const std::string folder = sim.SessionFolder(session);
  fs::remove_all(out);
  io::testing::WriteExifImageFolder((out / "jpegs").string(),
                                    io::testing::ExifImagesFromSession(folder, "cam0", gps));
  io::FieldInfo info = sim.info();
  info.sessions.clear();
  fs::create_directories(out / "field");
  io::WriteFieldYaml((out / "field" / "field.yaml").string(), info);
  io::ExifImportOptions o;
  o.image_folder = (out / "jpegs").string();
  o.field_folder = (out / "field").string();
  o.session_id = session;
  o.camera = io::ReadCameraSensorYaml(folder + "/cam0/sensor.yaml");
  o.camera_source = "the simulated rig";
  o.gps_kind = kind;
  o.antenna_in_body = io::ReadGpsSensorYaml(folder + "/" + gps + "/sensor.yaml").antenna_in_body;
  io::ImportExifFolder(o);

  pipeline::SlamStageOptions options;
  options.show_progress = false;
  const std::string ws = (out / "ws").string();
  const std::vector<pipeline::PassReport> reports =
      pipeline::RunSlamStage(o.field_folder, ws, options);
  const std::string sensors = reports.empty() ? "-" : reports.front().sensors;
  PrintRow(session, sensors, "passes", eval::EvaluateWorkspace(ws, field_folder).overall);
  // The same poses inside the true row passes only.
  const auto truth = TruePasses(field_folder, session);
  for (const slam::RowPass& pass : workspace::ReadPassList(ws, session)) {
    const std::string file = pipeline::PassFolder(ws, session, pass.id) + "/poses.tum";
    if (!fs::exists(file)) continue;
    std::vector<io::StampedPose> inside;
    for (const io::StampedPose& p : io::ReadTum(file)) {
      for (const auto& [begin, end] : truth) {
        if (p.t >= begin && p.t <= end) inside.push_back(p);
      }
    }
    io::WriteTum(file, inside, "poses inside the true row passes");
  }
  PrintRow(session, sensors, "inside rows", eval::EvaluateWorkspace(ws, field_folder).overall);
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s FIELD OUT [SESSION...]\n", argv[0]);
    return 2;
  }
  spdlog::set_level(spdlog::level::warn);
  Progress::SetGloballySilent(true);
  try {
    const std::string field = argv[1];
    const fs::path out = argv[2];
    std::vector<std::string> sessions(argv + 3, argv + argc);
    if (sessions.empty()) sessions = io::Field(field).session_ids();
    std::printf(
        "| session | sensors | poses | passes | ATE raw cm | ATE aligned cm | RPE %% | "
        "rot deg |\n|---|---|---|---|---|---|---|---|\n");
    for (const std::string& session : sessions) {
      Study(field, session, "gps0", io::GpsKind::kRtk, out / (session + "_rtk"));
      Study(field, session, "gps1", io::GpsKind::kStandard, out / (session + "_gps"));
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
