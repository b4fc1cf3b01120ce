// Camera + IMU without GPS over a real standstill: the start of EuRoC V1_01_easy
// (../shared/data/euroc_v101_start; the MAV stands on the floor with its rotors spinning for all
// 95 images). Imports the sequence as `crop4d import --euroc` does, runs row SLAM with and
// without the standstill constraints, and prints how far each estimate wanders from its first
// pose, its tilt against the ground truth, the aligned ATE and the pass's trust flags
// (bench/RESULTS.md, "EuRoC V1_01 standstill").
//
//   build/release/bench/euroc_standstill [SEQUENCE] [WORK_FOLDER]

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/eval/trajectory_metrics.h"
#include "crop4d/io/euroc_import.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/slam_stage.h"

namespace fs = std::filesystem;
using namespace crop4d;

int main(int argc, char** argv) {
  const std::string sequence =
      argc > 1 ? argv[1] : std::string(CROP4D_SHARED_DATA_DIR) + "/euroc_v101_start";
  const fs::path work = argc > 2 ? argv[2] : "/tmp/crop4d_euroc_standstill";
  try {
    spdlog::set_level(spdlog::level::warn);
    fs::remove_all(work);
    io::EurocImportOptions import;
    import.sequence_folder = sequence;
    import.field_folder = (work / "field").string();
    const io::EurocImportSummary imported = io::ImportEuroc(import);
    const std::string session = fs::path(imported.session_folder).filename().string();
    std::map<Timestamp, geometry::Rigid3> truth_at;
    for (const io::StampedPose& p :
         io::ReadTum((work / "field" / "ground_truth" / session / "cam0_poses.tum").string())) {
      truth_at[p.t] = p.pose;
    }
    std::printf("%-14s %7s %12s %12s %10s %10s %9s %8s  %s\n", "standstills", "images",
                "yaw chg deg", "pos chg mm", "tilt deg", "ATE al cm", "still s", "time s",
                "trust flags");
    for (const bool standstills : {true, false}) {
      pipeline::SlamStageOptions options;
      options.show_progress = false;
      options.standstills = standstills;
      const fs::path ws = work / (standstills ? "ws_on" : "ws_off");
      const auto start = std::chrono::steady_clock::now();
      const std::vector<pipeline::PassReport> reports =
          pipeline::RunSlamStage(import.field_folder, ws.string(), options);
      const double seconds =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      if (reports.size() != 1 || reports[0].failed) {
        std::fprintf(stderr, "row SLAM failed: %s\n",
                     reports.empty() ? "no pass" : reports[0].message.c_str());
        return 1;
      }
      const fs::path pass = fs::path(reports[0].folder);
      std::vector<geometry::Rigid3> estimate, truth;
      for (const io::StampedPose& p : io::ReadTum((pass / "poses.tum").string())) {
        if (!truth_at.count(p.t)) continue;
        estimate.push_back(p.pose);
        truth.push_back(truth_at[p.t]);
      }
      const eval::Wander wander = eval::TrajectoryWander(estimate);
      const eval::TrajectoryMetrics metrics = eval::ComputeTrajectoryMetrics(estimate, truth);
      std::ifstream in(pass / "summary.json");
      const nlohmann::json summary = nlohmann::json::parse(in);
      double still = 0;
      for (const auto& span : summary.at("standstills_s")) {
        still += span.at(1).get<double>() - span.at(0).get<double>();
      }
      std::string flags;
      for (const auto& flag : summary.at("trust")) {
        flags += (flags.empty() ? "" : ", ") + flag.get<std::string>();
      }
      std::printf("%-14s %7zu %12.3f %12.2f %10.2f %10.2f %9.1f %8.1f  %s\n",
                  standstills ? "on" : "off", estimate.size(), wander.max_heading_change_deg,
                  1000 * wander.max_displacement_m, eval::MaxTiltErrorDeg(estimate, truth),
                  100 * metrics.ate_aligned_m.rmse, still, seconds, flags.c_str());
    }
  } catch (const InputError& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 2;
  }
  return 0;
}
