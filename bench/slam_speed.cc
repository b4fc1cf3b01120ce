// Speed of the row SLAM stage (`crop4d slam`, pipeline/slam_stage.h) on one row pass, in images
// per second, front end and back end apart and together, at 640x480 and 1280x960, with the
// accuracy of each configuration (`crop4d eval`, eval/workspace_eval.h) so that the speed /
// accuracy trade-off is visible. The camera delivers 7.5 images per second: a configuration
// keeps up with it when its total is at least that. Results: bench/RESULTS.md, "Row SLAM speed".
//
//   taskset -c 0,1 build/release/bench/slam_speed_bench [options]
//
// Without --field, the demo field's first session (2016-06-01), cut after 24 s of driving (row
// pass row00 and the start of the first turn), is simulated at both sizes into --work (and
// reused from there by later runs). Options:
//   --field PATH      a field to measure instead (repeatable; the image size is read from it)
//   --session ID      the session (default: the field's first)
//   --pass ID         the pass (default: row00)
//   --configs A,B     the configurations to run (see AllConfigs(); default: before (only at
//                     640 px wide or less: ~15 min at 1280x960), grid+exact, slam2048, slam,
//                     slam480)
//   --repeat N        run each configuration N times and keep the fastest (default 1)
//   --profile         also time the front end's phases one by one on one thread
//   --work DIR        simulated fields and workspaces (default: $TMPDIR/crop4d_slam_speed)
//
// Columns: img = images of the pass; feat/img = features per image; lm = landmarks the back end
// kept; fe, be, total = images per second of the front end (image loading, feature extraction,
// feature cache, matching, tracks), of the back end (initialisation, Ceres solves, triangulated
// cloud and outputs) and of the whole pass; cpu s/img = CPU time of all threads per image
// (steadier than the wall time on a loaded machine); ATE = camera position error RMSE against
// the ground truth, raw (no alignment) and SE(3)-aligned, cm; rot = rotation error RMSE, deg.

#include <spdlog/spdlog.h>
#include <sys/resource.h>
#include <tbb/global_control.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "crop4d/core/progress.h"
#include "crop4d/eval/workspace_eval.h"
#include "crop4d/features/front_end.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace {

namespace fs = std::filesystem;
namespace features = crop4d::features;
namespace pipeline = crop4d::pipeline;
using nlohmann::json;

// CPU seconds of every thread of the process so far.
double CpuSeconds() {
  rusage usage{};
  getrusage(RUSAGE_SELF, &usage);
  return usage.ru_utime.tv_sec + usage.ru_stime.tv_sec +
         1e-6 * (usage.ru_utime.tv_usec + usage.ru_stime.tv_usec);
}

// ---- Configurations -------------------------------------------------------------------------

struct Config {
  std::string name;
  std::string description;
  features::FrontEnd::Options front_end;
  // Run without --configs (the others only when named).
  bool default_run = true;
};

// The front end before this benchmark existed: the features module's defaults of the time.
features::FrontEnd::Options Before() {
  features::FrontEnd::Options o;
  o.extraction.max_num_features = 8192;
  o.extraction.max_image_size = 0;
  o.extraction.spatial_grid_cells = 0;
  o.matching.descriptors.num_trees = 4;
  o.matching.descriptors.num_checks = 64;
  o.matching_block_size = 32;
  return o;
}

// The SLAM front end recommended by this benchmark (the values of SlamStageOptions::front_end).
features::FrontEnd::Options Slam() {
  features::FrontEnd::Options o = Before();
  o.extraction.max_num_features = 1024;
  o.extraction.spatial_grid_cells = 8;
  o.extraction.max_image_size = 640;
  o.matching.descriptors.method = features::DescriptorMatchOptions::Method::kExhaustive;
  return o;
}

// Configurations by name; those with default_run false run only when --configs names them.
std::vector<Config> AllConfigs() {
  using Method = features::DescriptorMatchOptions::Method;
  std::vector<Config> configs;
  configs.push_back({"before", "8192 features, full size, FLANN 4 trees / 64 checks", Before()});
  {
    features::FrontEnd::Options o = Before();
    o.extraction.max_num_features = 2048;
    configs.push_back({"budget", "before + the 2048 strongest features", o, false});
  }
  {
    features::FrontEnd::Options o = Before();
    o.extraction.max_num_features = 2048;
    o.extraction.spatial_grid_cells = 8;
    configs.push_back({"grid", "before + 2048 features spread over an 8x8 grid", o, false});
  }
  {
    features::FrontEnd::Options o = Before();
    o.extraction.max_num_features = 2048;
    o.extraction.spatial_grid_cells = 8;
    o.matching.descriptors.method = Method::kExhaustive;
    configs.push_back({"grid+exact", "grid + exhaustive (exact) matching", o});
  }
  {
    features::FrontEnd::Options o = Slam();
    o.extraction.max_num_features = 2048;
    configs.push_back({"slam2048", "grid+exact on images downscaled to <= 640 px", o});
  }
  configs.push_back(
      {"slam", "slam2048 with 1024 features (recommended for SlamStageOptions)", Slam()});
  {
    features::FrontEnd::Options o = Slam();
    o.extraction.max_image_size = 480;
    configs.push_back({"slam480", "slam on images downscaled to <= 480 px", o});
  }
  {
    features::FrontEnd::Options o = Slam();
    o.extraction.max_image_size = 320;
    configs.push_back({"slam320", "slam on images downscaled to <= 320 px", o, false});
  }
  {
    features::FrontEnd::Options o = Slam();
    o.extraction.spatial_grid_cells = 0;
    configs.push_back({"slam-nogrid", "slam with the 1024 strongest features (no grid)", o, false});
  }
  configs.push_back({"stage", "pipeline::SlamStageOptions{}.front_end (what crop4d slam uses)",
                     pipeline::SlamStageOptions{}.front_end, false});
  return configs;
}

// ---- Fields ---------------------------------------------------------------------------------

// The demo field's first session at width x height, cut after 24 s (row00 and part of a turn).
std::string SimulateField(const fs::path& work, int width, int height) {
  const fs::path folder = work / ("field_" + std::to_string(width) + "x" + std::to_string(height));
  if (fs::exists(folder / "field.yaml")) return folder.string();
  fs::remove_all(folder);
  crop4d::sim::SimConfig config = crop4d::sim::PresetConfig("demo");
  config.sessions = {config.sessions.front()};
  const double scale = width / static_cast<double>(config.camera.width);
  config.camera.width = width;
  config.camera.height = height;
  config.camera.fx *= scale;
  config.camera.fy *= scale;
  config.camera.cx *= scale;
  config.camera.cy *= scale;
  config.drive.max_duration_s = 24.0;
  std::printf("simulating %dx%d into %s ...\n", width, height, folder.string().c_str());
  std::fflush(stdout);
  crop4d::sim::Simulator simulator(config);
  const crop4d::sim::Simulator::Summary summary = simulator.Write(folder.string());
  std::printf("  %lld images in %.0f s\n", static_cast<long long>(summary.images),
              summary.total_seconds);
  return folder.string();
}

struct FieldInfo {
  std::string folder;
  std::string session;
  int width = 0, height = 0;
};

FieldInfo DescribeField(const std::string& folder, const std::string& session_arg) {
  FieldInfo info;
  info.folder = folder;
  const crop4d::io::Field field(folder);
  info.session = session_arg.empty() ? field.session_ids().front() : session_arg;
  const crop4d::io::Session session = field.OpenSession(info.session);
  const std::vector<crop4d::io::ImageEntry> images = session.ReadImageList("cam0");
  if (!images.empty()) {
    const cv::Mat image =
        cv::imread(session.ImagePath("cam0", images.front().filename), cv::IMREAD_COLOR);
    info.width = image.cols;
    info.height = image.rows;
  }
  return info;
}

// ---- Stage runs -----------------------------------------------------------------------------

struct StageRun {
  int images = 0;
  double features_per_image = 0;
  int landmarks = 0;
  double front_end_s = 0, back_end_s = 0, total_s = 0, cpu_s = 0;
  double ate_raw_cm = -1, ate_aligned_cm = -1, rotation_deg = -1;
};

StageRun RunStage(const FieldInfo& field, const std::string& pass, const Config& config,
                  const fs::path& workspace) {
  fs::remove_all(workspace);
  pipeline::SlamStageOptions options;
  options.session = field.session;
  options.pass = pass;
  options.front_end = config.front_end;
  options.force = true;
  options.show_progress = false;
  const double cpu_start = CpuSeconds();
  const std::vector<pipeline::PassReport> reports =
      pipeline::RunSlamStage(field.folder, workspace.string(), options);
  StageRun run;
  run.cpu_s = CpuSeconds() - cpu_start;
  if (reports.size() != 1 || reports.front().failed) {
    std::fprintf(stderr, "%s: pass %s not found or failed: %s\n", config.name.c_str(), pass.c_str(),
                 reports.empty() ? "no pass" : reports.front().message.c_str());
    std::exit(1);
  }
  std::ifstream in(fs::path(reports.front().folder) / "summary.json");
  const json summary = json::parse(in);
  const json& seconds = summary.at("seconds");
  run.images = summary.at("images").get<int>();
  run.features_per_image =
      summary.at("front_end").at("features").get<double>() / std::max(1, run.images);
  run.landmarks = summary.at("back_end").at("landmarks").get<int>();
  run.front_end_s = seconds.at("front_end").get<double>();
  run.total_s = seconds.at("total").get<double>();
  run.back_end_s = run.total_s - run.front_end_s;

  crop4d::eval::WorkspaceEvalOptions eval_options;
  eval_options.sessions = {field.session};
  const crop4d::eval::WorkspaceEval eval =
      crop4d::eval::EvaluateWorkspace(workspace.string(), field.folder, eval_options);
  for (const crop4d::eval::PassEval& p : eval.passes) {
    if (p.pass != pass || !p.ok()) continue;
    run.ate_raw_cm = 100 * p.metrics.ate_raw_m.rmse;
    run.ate_aligned_cm = 100 * p.metrics.ate_aligned_m.rmse;
    run.rotation_deg = p.metrics.rotation_deg.rmse;
  }
  return run;
}

// ---- Phase profile --------------------------------------------------------------------------

// The front end's phases one after the other on one thread (OpenCV and oneTBB limited to one),
// on the images of the pass: CPU ms per image (per pair for knn and RANSAC). CPU time, not wall
// time, so that other processes on the machine do not inflate it.
struct Profile {
  double load_ms = 0, extract_ms = 0, index_ms = 0, knn_ms_per_pair = 0, ransac_ms_per_pair = 0,
         tracks_ms = 0;
  double features = 0, putative_per_pair = 0, inliers_per_pair = 0;
  int landmarks = 0, images = 0, pairs = 0;
};

Profile ProfileFrontEnd(const FieldInfo& field, const fs::path& pass_folder,
                        const features::FrontEnd::Options& options) {
  const crop4d::io::Field f(field.folder);
  const crop4d::io::Session session = f.OpenSession(field.session);
  std::ifstream in(pass_folder / "summary.json");
  const json summary = json::parse(in);
  const std::int64_t t_begin = summary.at("t_begin_ns"), t_end = summary.at("t_end_ns");
  std::vector<std::string> paths;
  for (const crop4d::io::ImageEntry& e : session.ReadImageList("cam0")) {
    if (e.t >= t_begin && e.t <= t_end) paths.push_back(session.ImagePath("cam0", e.filename));
  }
  const crop4d::geometry::PinholeRadTan& camera = session.FindCamera("cam0")->camera;

  const int saved_threads = cv::getNumThreads();
  cv::setNumThreads(1);
  tbb::global_control one_thread(tbb::global_control::max_allowed_parallelism, 1);
  Profile p;
  const int n = static_cast<int>(paths.size());
  p.images = n;
  std::vector<cv::Mat> images(n);
  double start = CpuSeconds();
  for (int i = 0; i < n; ++i) images[i] = cv::imread(paths[i], cv::IMREAD_COLOR);
  p.load_ms = 1e3 * (CpuSeconds() - start) / n;

  const features::FeatureExtractor extractor(options.extraction);
  std::vector<features::FeatureSet> sets(n);
  start = CpuSeconds();
  for (int i = 0; i < n; ++i) sets[i] = extractor.Extract(images[i]);
  p.extract_ms = 1e3 * (CpuSeconds() - start) / n;
  for (const auto& s : sets) p.features += static_cast<double>(s.size()) / n;

  const features::DescriptorMatchOptions& dm = options.matching.descriptors;
  std::vector<std::unique_ptr<features::DescriptorIndex>> indices(n);
  start = CpuSeconds();
  for (int i = 0; i < n; ++i) indices[i] = std::make_unique<features::DescriptorIndex>(sets[i], dm);
  p.index_ms = 1e3 * (CpuSeconds() - start) / n;

  const std::vector<std::pair<int, int>> schedule =
      features::SequentialPairs(n, options.num_neighbors);
  p.pairs = static_cast<int>(schedule.size());
  std::vector<features::PairMatches> pairs(schedule.size());
  double knn_s = 0, ransac_s = 0;
  for (std::size_t k = 0; k < schedule.size(); ++k) {
    const auto [i, j] = schedule[k];
    features::PairMatches& pair = pairs[k];
    pair.image1 = i;
    pair.image2 = j;
    start = CpuSeconds();
    pair.matches = features::MatchDescriptors(sets[i], *indices[i], sets[j], *indices[j], dm);
    knn_s += (CpuSeconds() - start);
    start = CpuSeconds();
    std::vector<Eigen::Vector2d> points1, points2;
    for (const features::FeatureMatch& m : pair.matches) {
      for (int side = 0; side < 2; ++side) {
        const Eigen::Vector2d pixel =
            side == 0 ? sets[i].Point(m.feature1) : sets[j].Point(m.feature2);
        Eigen::Vector3d ray;
        Eigen::Vector2d point = pixel;
        if (camera.Unproject(pixel, &ray)) {
          point = Eigen::Vector2d(camera.fx * ray.x() + camera.cx, camera.fy * ray.y() + camera.cy);
        }
        (side == 0 ? points1 : points2).push_back(point);
      }
    }
    features::EpipolarGeometry geometry =
        features::EstimateEpipolarGeometry(points1, points2, options.matching.verification);
    ransac_s += (CpuSeconds() - start);
    pair.summary.num_putative = static_cast<int>(pair.matches.size());
    pair.summary.verified = geometry.verified;
    if (geometry.verified) pair.inliers = std::move(geometry.inliers);
    pair.summary.num_inliers = static_cast<int>(pair.inliers.size());
    p.putative_per_pair += pair.summary.num_putative;
    p.inliers_per_pair += pair.summary.num_inliers;
  }
  p.knn_ms_per_pair = 1e3 * knn_s / std::max(1, p.pairs);
  p.ransac_ms_per_pair = 1e3 * ransac_s / std::max(1, p.pairs);
  p.putative_per_pair /= std::max(1, p.pairs);
  p.inliers_per_pair /= std::max(1, p.pairs);

  std::vector<int> num_features(n);
  for (int i = 0; i < n; ++i) num_features[i] = static_cast<int>(sets[i].size());
  start = CpuSeconds();
  features::TrackBuilder::Summary tracks;
  features::TrackBuilder(options.tracks).Build(num_features, pairs, &tracks);
  p.tracks_ms = 1e3 * (CpuSeconds() - start) / n;
  p.landmarks = tracks.num_accepted_tracks;
  cv::setNumThreads(saved_threads);
  return p;
}

std::vector<std::string> Split(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream in(text);
  for (std::string item; std::getline(in, item, ',');) {
    if (!item.empty()) out.push_back(item);
  }
  return out;
}

int Usage() {
  std::fprintf(stderr,
               "usage: slam_speed_bench [--field PATH]... [--session ID] [--pass ID] "
               "[--configs A,B] [--repeat N] [--profile] [--work DIR]\n");
  return 2;
}

}  // namespace

int main(int argc, char** argv) {
  std::vector<std::string> field_paths;
  std::string session, pass = "row00", work;
  std::vector<std::string> config_names;
  int repeat = 1;
  bool profile = false;
  for (int a = 1; a < argc; ++a) {
    const std::string arg = argv[a];
    const bool has_value = a + 1 < argc;
    if (arg == "--field" && has_value) {
      field_paths.push_back(argv[++a]);
    } else if (arg == "--session" && has_value) {
      session = argv[++a];
    } else if (arg == "--pass" && has_value) {
      pass = argv[++a];
    } else if (arg == "--configs" && has_value) {
      config_names = Split(argv[++a]);
    } else if (arg == "--repeat" && has_value) {
      repeat = std::max(1, std::atoi(argv[++a]));
    } else if (arg == "--work" && has_value) {
      work = argv[++a];
    } else if (arg == "--profile") {
      profile = true;
    } else {
      return Usage();
    }
  }
  crop4d::Progress::SetGloballySilent(true);
  spdlog::set_level(spdlog::level::warn);
  const fs::path work_dir =
      work.empty() ? fs::temp_directory_path() / "crop4d_slam_speed" : fs::path(work);
  fs::create_directories(work_dir);
  if (field_paths.empty()) {
    field_paths.push_back(SimulateField(work_dir, 640, 480));
    field_paths.push_back(SimulateField(work_dir, 1280, 960));
  }
  std::vector<Config> configs;
  for (const Config& c : AllConfigs()) {
    if (config_names.empty()
            ? c.default_run
            : std::find(config_names.begin(), config_names.end(), c.name) != config_names.end()) {
      configs.push_back(c);
    }
  }
  if (configs.empty()) return Usage();
  std::printf("configurations:\n");
  for (const Config& c : configs)
    std::printf("  %-12s %s\n", c.name.c_str(), c.description.c_str());

  std::vector<std::string> rows, profile_rows;
  for (const std::string& path : field_paths) {
    const FieldInfo field = DescribeField(path, session);
    const std::string size = std::to_string(field.width) + "x" + std::to_string(field.height);
    for (const Config& config : configs) {
      if (config.name == "before" && config_names.empty() && field.width > 640) {
        continue;  // ≈ 15 min at 1280x960; name it in --configs to run it
      }
      const fs::path workspace = work_dir / ("ws_" + size + "_" + config.name);
      StageRun best;
      for (int r = 0; r < repeat; ++r) {
        const StageRun run = RunStage(field, pass, config, workspace);
        if (r == 0 || run.total_s < best.total_s) best = run;
      }
      char line[512];
      std::snprintf(line, sizeof(line),
                    "| %s | %s | %d | %.0f | %d | %.1f | %.1f | %.1f | %.2f | %.2f | %.2f | %.3f |",
                    size.c_str(), config.name.c_str(), best.images, best.features_per_image,
                    best.landmarks, best.images / best.front_end_s, best.images / best.back_end_s,
                    best.images / best.total_s, best.cpu_s / best.images, best.ate_raw_cm,
                    best.ate_aligned_cm, best.rotation_deg);
      rows.push_back(line);
      std::printf("%s\n", line);
      std::fflush(stdout);
      if (profile) {
        const Profile p = ProfileFrontEnd(
            field, pipeline::PassFolder(workspace.string(), field.session, pass), config.front_end);
        std::snprintf(line, sizeof(line),
                      "| %s | %s | %.0f | %.1f | %.1f | %.1f | %.1f | %.1f | %.2f | %.0f | %.0f | "
                      "%.0f |",
                      size.c_str(), config.name.c_str(), p.features, p.load_ms, p.extract_ms,
                      p.index_ms, p.knn_ms_per_pair, p.ransac_ms_per_pair, p.tracks_ms,
                      p.putative_per_pair, p.inliers_per_pair,
                      (p.load_ms + p.extract_ms + p.index_ms + p.tracks_ms) +
                          (p.knn_ms_per_pair + p.ransac_ms_per_pair) * p.pairs / p.images);
        profile_rows.push_back(line);
        std::printf("%s\n", line);
        std::fflush(stdout);
      }
    }
  }
  std::printf(
      "\nRow SLAM, session %s, pass %s (images/s: higher is better; the camera runs at 7.5)\n\n",
      session.empty() ? "(first)" : session.c_str(), pass.c_str());
  std::printf(
      "| image | config | img | feat/img | lm | fe img/s | be img/s | total img/s | cpu s/img | "
      "ATE raw cm | ATE aligned cm | rot deg "
      "|\n|---|---|---|---|---|---|---|---|---|---|---|---|\n");
  for (const std::string& r : rows) std::printf("%s\n", r.c_str());
  if (profile) {
    std::printf(
        "\nFront-end phases on one thread (ms per image; knn and RANSAC per pair; total = ms of "
        "one core per image)\n\n| image | config | feat/img | load | extract | index | knn/pair | "
        "ransac/pair | tracks | putative/pair | inliers/pair | total |\n"
        "|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for (const std::string& r : profile_rows) std::printf("%s\n", r.c_str());
  }
  return 0;
}
