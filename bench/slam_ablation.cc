// Row SLAM ablation (issue: "bench/ prints the ablation table"): runs `crop4d slam` on a field
// with each sensor set and prints, per set, the trajectory errors against the ground truth
// (crop4d eval's metrics): ATE without and with SE(3) alignment, RPE per metre, rotation RMSE.
//
//   build/release/bench/slam_ablation [FIELD] [WORKSPACE] [--session S]
//
// FIELD defaults to demo/field (made by `make demo`), WORKSPACE to /tmp/crop4d_ablation. The
// feature cache of the first set is copied to the others, so the front end runs once per pass.

#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/logging.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/slam_stage.h"

namespace fs = std::filesystem;
using namespace crop4d;

namespace {

// Copies every rows/*/features.bin of `from` into the same place under `to`.
void CopyFeatureCaches(const fs::path& from, const fs::path& to) {
  if (!fs::exists(from / "sessions")) return;
  for (const auto& entry : fs::recursive_directory_iterator(from / "sessions")) {
    if (entry.path().filename() != "features.bin") continue;
    const fs::path target = to / fs::relative(entry.path(), from);
    fs::create_directories(target.parent_path());
    fs::copy_file(entry.path(), target, fs::copy_options::skip_existing);
  }
}

// The error of each GPS receiver's fixes against the true antenna positions the simulator
// wrote (ground_truth/<session>/<gps>_antenna.csv): {receiver: {3D RMS, horizontal RMS}}.
std::map<std::string, std::pair<double, double>> ReceiverErrors(const std::string& field_folder,
                                                                const std::string& only) {
  const io::Field field(field_folder);
  const geometry::LocalEnu enu = field.Enu();
  std::map<std::string, std::pair<double, double>> sums;
  std::map<std::string, int> counts;
  for (const std::string& id : field.session_ids()) {
    if (!only.empty() && id != only) continue;
    const io::Session session = field.OpenSession(id);
    for (const io::GpsSensor& gps : session.gps_receivers()) {
      std::ifstream in(fs::path(field_folder) / "ground_truth" / id / (gps.name + "_antenna.csv"));
      std::map<Timestamp, Eigen::Vector3d> truth;
      std::string line;
      while (std::getline(in, line)) {
        if (line.empty() || line[0] == '#') continue;
        std::istringstream fields(line);
        std::string t, x, y, z;
        std::getline(fields, t, ',');
        std::getline(fields, x, ',');
        std::getline(fields, y, ',');
        std::getline(fields, z, ',');
        truth[std::stoll(t)] = Eigen::Vector3d(std::stod(x), std::stod(y), std::stod(z));
      }
      for (const io::GpsSample& s : session.ReadGps(gps.name)) {
        const auto it = truth.find(s.t);
        if (it == truth.end()) continue;
        const Eigen::Vector3d e = enu.ToEnu(s.position) - it->second;
        sums[gps.name].first += e.squaredNorm();
        sums[gps.name].second += e.head<2>().squaredNorm();
        ++counts[gps.name];
      }
    }
  }
  for (auto& [name, sum] : sums) {
    sum.first = std::sqrt(sum.first / counts[name]);
    sum.second = std::sqrt(sum.second / counts[name]);
  }
  return sums;
}

}  // namespace

int main(int argc, char** argv) {
  std::string field = "demo/field";
  std::string workspace = "/tmp/crop4d_ablation";
  std::string session;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--session" && i + 1 < argc) {
      session = argv[++i];
    } else if (arg == "-h" || arg == "--help") {
      std::printf("usage: slam_ablation [FIELD] [WORKSPACE] [--session S]\n");
      return 0;
    } else {
      positional.push_back(arg);
    }
  }
  if (!positional.empty()) field = positional[0];
  if (positional.size() > 1) workspace = positional[1];
  InitLogging(Verbosity::kQuiet);
  try {
    struct Row {
      std::string sensors;
      eval::OverallEval overall;
      double seconds = 0;
      int images = 0;
    };
    std::vector<Row> rows;
    fs::path previous;
    for (const std::string& name : slam::SensorSetNames()) {
      const fs::path ws = fs::path(workspace) / name;
      if (!previous.empty()) CopyFeatureCaches(previous, ws);
      pipeline::SlamStageOptions options;
      options.sensors = slam::ParseSensorSet(name);
      options.session = session;
      options.show_progress = false;
      std::fprintf(stderr, "slam_ablation: %s ...\n", name.c_str());
      const std::vector<pipeline::PassReport> reports =
          pipeline::RunSlamStage(field, ws.string(), options);
      Row row;
      row.sensors = name;
      for (const pipeline::PassReport& r : reports) {
        row.seconds += r.seconds;
        row.images += r.num_images;
      }
      eval::WorkspaceEvalOptions eval_options;
      if (!session.empty()) eval_options.sessions = {session};
      const eval::WorkspaceEval e = eval::EvaluateWorkspace(ws.string(), field, eval_options);
      eval::WriteWorkspaceEval(e);
      row.overall = e.overall;
      rows.push_back(row);
      previous = ws;
    }
    std::printf("\nRow SLAM ablation on %s%s (all passes pooled; RMSE)\n\n", field.c_str(),
                session.empty() ? "" : (", session " + session).c_str());
    std::printf(
        "| sensors | passes | poses | ATE raw [cm] | ATE aligned [cm] | RPE [%%] | "
        "rotation [deg] | max position error [cm] |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const Row& r : rows) {
      const eval::OverallEval& o = r.overall;
      std::printf("| %s | %d | %d | %.2f | %.2f | %.2f | %.3f | %.2f |\n", r.sensors.c_str(),
                  o.num_evaluated, o.num_poses, 100 * o.ate_raw_m.rmse, 100 * o.ate_aligned_m.rmse,
                  o.rpe_translation_percent.rmse, o.rotation_deg.rmse, 100 * o.ate_raw_m.max);
    }
    for (const auto& [name, rms] : ReceiverErrors(field, session)) {
      std::printf("\nReceiver %s against the true antenna: %.2f cm RMS (3D), %.2f cm horizontal",
                  name.c_str(), 100 * rms.first, 100 * rms.second);
    }
    std::printf("\n");
    std::printf(
        "\nRPE: translation error of the relative pose over 1 m of true path, in %% of "
        "the distance. Per-pass metrics: %s/<set>/eval/metrics.json\n",
        workspace.c_str());
  } catch (const std::exception& e) {
    std::fprintf(stderr, "slam_ablation: %s\n", e.what());
    return 1;
  }
  return 0;
}
