#include "crop4d/pipeline/densify_stage.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/imgproc.hpp>
#include <optional>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/image_sequence.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_measurements.h"
#include "crop4d/workspace/stage_files.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// Changes whenever the stage's outputs for the same inputs change.
constexpr int kDensifyStageRevision = 2;

json BoxJson(const Eigen::AlignedBox2d& box) {
  if (box.isEmpty()) return json::array();
  return {box.min().x(), box.min().y(), box.max().x(), box.max().y()};
}

// The crop rows widened by the margin, or the sparse cloud's extent.
Eigen::AlignedBox2d FieldRegion(const io::FieldInfo& field, const io::PlyPointCloud& sparse,
                                double margin) {
  Eigen::AlignedBox2d box;
  for (const io::RowDeclaration& row : field.rows) {
    box.extend(row.start_enu);
    box.extend(row.end_enu);
  }
  if (box.isEmpty()) {
    for (const Eigen::Vector3d& p : sparse.points) {
      if (p.allFinite()) box.extend(p.head<2>());
    }
    return box;
  }
  box.min() -= Eigen::Vector2d::Constant(margin);
  box.max() += Eigen::Vector2d::Constant(margin);
  return box;
}

// The sessions to densify: those asked for (each must be in the field), or every session with
// fused poses; each must have its fused poses and sparse cloud.
std::vector<std::string> SessionsToDensify(const io::Field& field, const workspace::Layout& layout,
                                           const DensifyStageOptions& options) {
  std::vector<std::string> sessions = options.sessions;
  if (sessions.empty()) {
    for (const std::string& id : field.session_ids()) {
      if (fs::exists(layout.FusedPoses(id))) sessions.push_back(id);
    }
    if (sessions.empty()) {
      throw InputError(layout.FusedDir().string(), 0,
                       "no fused poses of any session (run `crop4d fuse` first)");
    }
  } else {
    for (const std::string& id : sessions) {
      const auto& ids = field.session_ids();
      if (std::find(ids.begin(), ids.end(), id) == ids.end()) {
        throw InputError(field.folder(), 0, "no session '" + id + "' in the field");
      }
    }
  }
  for (const std::string& id : sessions) {
    for (const fs::path& file :
         {layout.FusedPoses(id), layout.FusedSparse(id), layout.FusedCamera(id)}) {
      if (!fs::exists(file)) {
        throw InputError(
            file.string(), 0,
            "missing: session " + id + " has not been fused (run `crop4d fuse` first)");
      }
    }
  }
  return sessions;
}

// The centres of the discs the region is restricted to: the options' and, with
// `around_sites`, the field's sites.
std::vector<Eigen::Vector2d> DiscCenters(const io::Field& field,
                                         const DensifyStageOptions& options) {
  std::vector<Eigen::Vector2d> centers = options.centers;
  if (options.around_sites) {
    if (field.info().sites.empty()) {
      spdlog::warn("densify: field.yaml declares no sites; --around-sites has no effect");
    }
    for (const io::Site& site : field.info().sites) centers.push_back(site.center_enu);
  }
  return centers;
}

// The fingerprint of a session's inputs: the stage revision, the options, the fused poses,
// intrinsics and sparse cloud, the measurements of the session's passes (the camera and its image
// list) and field.yaml (rows and sites).
std::string SessionFingerprint(const workspace::Layout& layout, const std::string& id,
                               const json& options_json, const std::string& field_folder) {
  Fnv1aHasher fingerprint;
  fingerprint.Add(kDensifyStageRevision);
  fingerprint.AddString(options_json.dump());
  std::vector<fs::path> inputs = {layout.FusedPoses(id), layout.FusedSparse(id),
                                  layout.FusedCamera(id)};
  for (const slam::RowPass& pass : workspace::ReadPassList(layout.root().string(), id)) {
    inputs.push_back(layout.PassMeasurements(id, pass.id));
  }
  inputs.push_back(fs::path(field_folder) / io::kFieldYaml);
  for (const fs::path& p : inputs) fingerprint.AddString(workspace::FileHash(p));
  return std::to_string(fingerprint.hash());
}

// The report of a session whose cloud is up to date (read from its summary), or nullopt (with
// why it is densified again logged).
std::optional<DensifySessionReport> UpToDateReport(const workspace::Layout& layout,
                                                   const std::string& id, const std::string& stamp,
                                                   const DensifyStageOptions& options) {
  const fs::path json_path = layout.DenseSummary(id);
  std::string why;
  if (!options.force && fs::exists(layout.DenseCloud(id)) &&
      workspace::SummaryUpToDate(json_path, stamp, &why)) {
    try {
      const workspace::DenseSummary previous = workspace::ReadDenseSummary(json_path.string());
      spdlog::info("densify {}: up to date, skipped (--force to densify again)", id);
      DensifySessionReport report;
      report.session = id;
      report.ply_path = layout.DenseCloud(id).string();
      report.skipped = true;
      report.num_poses = previous.poses;
      report.num_views = previous.views;
      report.stereo.num_points = previous.points;
      return report;
    } catch (const InputError& e) {
      why = e.what();
    }
  }
  if (!options.force && fs::exists(json_path)) spdlog::info("densify {}: again: {}", id, why);
  return std::nullopt;
}

// The fused poses that have an image, as views (`view_image`: each view's image index).
std::vector<dense::DenseView> ViewsOfPoses(const std::vector<io::StampedPose>& poses,
                                           const io::ImageSequence& images, const std::string& id,
                                           const fs::path& poses_path,
                                           std::vector<std::size_t>* view_image) {
  std::map<Timestamp, std::size_t> image_of;
  for (std::size_t i = 0; i < images.size(); ++i) image_of[images.time(i)] = i;
  std::vector<dense::DenseView> views;
  for (const io::StampedPose& p : poses) {
    const auto it = image_of.find(p.t);
    if (it == image_of.end()) continue;
    views.push_back({p.pose, images.Path(it->second), DurationSeconds(poses.front().t, p.t)});
    view_image->push_back(it->second);
  }
  if (views.empty()) {
    throw InputError(poses_path.string(), 0,
                     "no pose matches an image row SLAM used (stale fused poses? run `crop4d "
                     "fuse` again)");
  }
  if (views.size() < poses.size()) {
    spdlog::warn("densify {}: {} of {} fused poses have no image; they are not used", id,
                 poses.size() - views.size(), poses.size());
  }
  return views;
}

// The region to densify: the field's rows (or the sparse cloud) shrunk to the boxes and discs.
dense::DenseRegion RegionToDensify(const io::Field& field, const io::PlyPointCloud& sparse,
                                   const std::vector<Eigen::Vector2d>& centers,
                                   const DensifyStageOptions& options) {
  dense::DenseRegion region;
  region.bounds = FieldRegion(field.info(), sparse, options.margin_m);
  region.boxes = options.boxes;
  region.centers = centers;
  region.radius_m = options.radius_m;
  if (!options.boxes.empty() || !centers.empty()) {
    // Shrink the bounds to what the boxes and discs cover.
    Eigen::AlignedBox2d cover;
    for (const Eigen::AlignedBox2d& b : options.boxes) cover.extend(b);
    for (const Eigen::Vector2d& c : centers) {
      cover.extend(c - Eigen::Vector2d::Constant(options.radius_m));
      cover.extend(c + Eigen::Vector2d::Constant(options.radius_m));
    }
    region.bounds = region.bounds.intersection(cover);
  }
  return region;
}

// Plants that reach the adaptive ceiling may have lost their tops to it: say so (never a
// silently cut canopy). On the imperfect demo field no dense point of any session lies within
// the 2 cm band of its ceiling; 0.05 % of a session's points is a leaf of about 10 × 10 cm.
void WarnIfCeilingReached(const std::string& session, const dense::CanopyCeiling& ceiling,
                          double near_band_m, std::int64_t num_points) {
  constexpr double kMaxShare = 0.0005;
  if (num_points <= 0 || ceiling.dense_points_near <= kMaxShare * num_points) return;
  spdlog::warn(
      "densify {}: {} of {} dense points lie within {:.0f} cm of the plant tops' search ceiling "
      "({:.2f} m above the ground, from the sparse cloud): taller plants may have lost their "
      "tops; densify again with a higher --max-canopy-height and --fixed-ceiling "
      "(densify.adaptive_ceiling: false)",
      session, ceiling.dense_points_near, num_points, 100.0 * near_band_m, ceiling.ceiling_m);
}

// The dense summary's content (before its output is recorded).
json DenseSummaryJson(const DensifySessionReport& report, const std::string& stamp,
                      const json& options_json, const dense::DenseRegion& region,
                      const dense::GroundLevels& ground) {
  const dense::HeightFieldStereo::Summary& s = report.stereo;
  json summary;
  summary["fingerprint"] = stamp;
  summary["session"] = report.session;
  summary["options"] = options_json;
  summary["region"] = BoxJson(region.bounds);
  summary["poses"] = report.num_poses;
  summary["views"] = report.num_views;
  summary["points"] = s.num_points;
  summary["top_surface_points"] = s.num_top_surface;
  summary["tiles_near_in_time"] = s.num_tiles_near_in_time;
  summary["canopy_ceiling"] = {{"m", report.ceiling.ceiling_m},
                               {"sparse_quantile_height_m", report.ceiling.quantile_height_m},
                               {"sparse_points", report.ceiling.num_points},
                               {"dense_points_near", report.ceiling.dense_points_near}};
  summary["cells"] = {{"region", s.num_cells},
                      {"with_views", s.num_cells_with_views},
                      {"low_texture", s.num_low_texture},
                      {"low_score", s.num_low_score},
                      {"not_unique", s.num_not_unique},
                      {"at_range_edge", s.num_at_range_edge},
                      {"isolated", s.num_isolated},
                      {"held_at_most", s.max_cells_held},
                      {"reference_reach_m", s.reference_reach_m}};
  summary["tiles"] = s.num_tiles;
  summary["images"] = {{"used", s.num_images_used},
                       {"failed", s.num_images_failed},
                       {"mean_views_per_tile", s.mean_views_per_tile},
                       {"blocks", s.num_blocks},
                       {"loads", s.num_image_loads},
                       {"most_in_memory", s.max_images_loaded}};
  summary["ground_tiles_measured"] = ground.num_measured_tiles();
  summary["seconds"] = {{"load", s.load_seconds},
                        {"match", s.match_seconds},
                        {"stereo", s.total_seconds},
                        {"total", report.seconds}};
  return summary;
}

// One session: its views, region and ground levels, the stereo, the cloud and its summary.
DensifySessionReport DensifySession(const io::Field& field, const workspace::Layout& layout,
                                    const std::string& id, const std::string& stamp,
                                    const json& options_json,
                                    const std::vector<Eigen::Vector2d>& centers,
                                    const DensifyStageOptions& options, tbb::task_arena* arena) {
  const Clock::time_point start = Clock::now();
  DensifySessionReport report;
  report.session = id;
  report.ply_path = layout.DenseCloud(id).string();
  const std::vector<io::StampedPose> poses = io::ReadTum(layout.FusedPoses(id).string());
  report.num_poses = static_cast<int>(poses.size());
  const io::ImageSequence images =
      workspace::SessionImages(layout.root().string(), id, field.folder(), options.camera);
  // The intrinsics the fused poses go with (refined by fuse, or as the dataset wrote them).
  const geometry::PinholeRadTan camera =
      workspace::ReadFusedCamera(layout.FusedCamera(id).string()).intrinsics;
  if (camera.width != images.camera().camera.width ||
      camera.height != images.camera().camera.height) {
    throw InputError(layout.FusedCamera(id).string(), 0,
                     fmt::format("the fused camera is {}x{} px, the session's images {}x{} (stale "
                                 "fused outputs? run `crop4d fuse --force`)",
                                 camera.width, camera.height, images.camera().camera.width,
                                 images.camera().camera.height));
  }
  std::vector<std::size_t> view_image;
  const std::vector<dense::DenseView> views =
      ViewsOfPoses(poses, images, id, layout.FusedPoses(id), &view_image);
  report.num_views = static_cast<int>(views.size());
  const io::PlyPointCloud sparse = io::ReadPly(layout.FusedSparse(id).string());
  const dense::DenseRegion region = RegionToDensify(field, sparse, centers, options);
  report.region = region.bounds;
  Eigen::AlignedBox2d ground_box = region.bounds;
  ground_box.min() -= Eigen::Vector2d::Constant(options.ground.tile_m);
  ground_box.max() += Eigen::Vector2d::Constant(options.ground.tile_m);
  const dense::GroundLevels ground(sparse.points, ground_box, options.ground);
  if (!ground.valid()) {
    throw InputError(layout.FusedSparse(id).string(), 0,
                     "no point of the sparse cloud lies in the region to densify");
  }
  spdlog::info("densify {}: {} views, region [{:.2f}, {:.2f}] x [{:.2f}, {:.2f}] m", id,
               views.size(), region.bounds.min().x(), region.bounds.max().x(),
               region.bounds.min().y(), region.bounds.max().y());

  dense::HeightFieldStereo::Options stereo_options = options.stereo;
  stereo_options.show_progress = options.show_progress;
  if (options.adaptive_ceiling) {
    report.ceiling = dense::SparseCanopyCeiling(
        sparse.points, ground, region.bounds, options.ceiling, options.stereo.max_canopy_height_m);
    stereo_options.max_canopy_height_m = report.ceiling.ceiling_m;
    spdlog::info(
        "densify {}: plant tops searched up to {:.2f} m above the ground ({:.1f} % of the {} "
        "sparse points lie below {:.3f} m; at most {:.2f} m)",
        id, report.ceiling.ceiling_m, 100.0 * options.ceiling.quantile, report.ceiling.num_points,
        report.ceiling.quantile_height_m, options.stereo.max_canopy_height_m);
  } else {
    report.ceiling.ceiling_m = options.stereo.max_canopy_height_m;
  }
  const dense::HeightFieldStereo stereo(stereo_options);
  dense::HeightFieldStereo::Result result;
  // The cloud is written as its points come, a band of the region at a time: it is never all in
  // memory (on the paper's 150 m rows, tens of millions of points per session).
  io::PlyWriteOptions ply;
  ply.comment =
      "crop4d dense cloud of session " + id + " (height-field stereo), field ENU frame (metres)";
  io::PlyStreamWriter cloud(report.ply_path, dense::HeightFieldStereo::CloudLayout(), ply);
  const bool count_near_ceiling =
      options.adaptive_ceiling && report.ceiling.ceiling_m < options.stereo.max_canopy_height_m;
  const auto write = [&](const io::PlyPointCloud& part) {
    cloud.Append(part);
    if (count_near_ceiling) {
      report.ceiling.dense_points_near += dense::PointsNearCeiling(
          part.points, ground, report.ceiling.ceiling_m, options.ceiling.near_band_m);
    }
  };
  arena->execute([&] {
    result = stereo.Run(
        camera, views,
        [&](int v) {
          dense::RgbImage out;
          const cv::Mat bgr = images.LoadImage(view_image[v]);
          if (bgr.empty()) return out;
          cv::Mat rgb;
          cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
          out.width = rgb.cols;
          out.height = rgb.rows;
          out.rgb.assign(rgb.data, rgb.data + static_cast<std::size_t>(rgb.total()) * 3);
          return out;
        },
        region, ground, write);
  });
  cloud.Finish();
  report.stereo = result.summary;
  if (count_near_ceiling) {
    WarnIfCeilingReached(id, report.ceiling, options.ceiling.near_band_m,
                         result.summary.num_points);
  }
  report.seconds = SecondsSince(start);
  json summary = DenseSummaryJson(report, stamp, options_json, region, ground);
  workspace::RecordOutputs(&summary, layout.DenseDir(),
                           {layout.DenseCloud(id).filename().string()});
  workspace::WriteDenseSummary(layout.DenseSummary(id).string(), summary);
  spdlog::info("densify {}: {} points in {:.1f} s", id, result.summary.num_points, report.seconds);
  return report;
}

}  // namespace

std::string DensifyStageOptions::Check() const {
  for (const Eigen::AlignedBox2d& b : boxes) {
    if (b.isEmpty() || !b.min().allFinite() || !b.max().allFinite()) {
      return "boxes: a box must be finite and not empty";
    }
  }
  for (const Eigen::Vector2d& c : centers) {
    if (!c.allFinite()) return "centers: a centre must be finite";
  }
  if (camera.empty()) return "camera: must name a camera";
  if (!(margin_m >= 0)) return "margin_m: must be >= 0";
  if (!(radius_m > 0)) return "radius_m: must be > 0";
  if (num_threads < 0) return "num_threads: must be >= 0 (0: all cores)";
  // The nested options of the modules (docs/run.md, densify).
  if (const std::string why = stereo.Check(); !why.empty()) return "stereo." + why;
  if (const std::string why = ground.Check(); !why.empty()) return "ground." + why;
  if (const std::string why = ceiling.Check(); !why.empty()) return "ceiling." + why;
  return {};
}

std::vector<DensifySessionReport> RunDensifyStage(const std::string& field_folder,
                                                  const std::string& workspace,
                                                  const DensifyStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("densify." + why);
  const io::Field field(field_folder);
  const workspace::Layout layout(workspace);
  const std::vector<std::string> sessions = SessionsToDensify(field, layout, options);
  const std::vector<Eigen::Vector2d> centers = DiscCenters(field, options);
  const json options_json = DensifyOptionsJson(options, centers);
  tbb::task_arena arena(options.num_threads > 0 ? options.num_threads : tbb::task_arena::automatic);
  std::vector<DensifySessionReport> reports;
  for (const std::string& id : sessions) {
    const std::string stamp = SessionFingerprint(layout, id, options_json, field_folder);
    if (std::optional<DensifySessionReport> done = UpToDateReport(layout, id, stamp, options)) {
      reports.push_back(std::move(*done));
      continue;
    }
    reports.push_back(
        DensifySession(field, layout, id, stamp, options_json, centers, options, &arena));
  }
  return reports;
}

std::string FormatDensifyReport(const std::vector<DensifySessionReport>& reports) {
  std::ostringstream out;
  out << "  session      points     cells    kept%  views/tile  images   time [s]\n";
  for (const DensifySessionReport& r : reports) {
    char line[200];
    if (r.skipped) {
      std::snprintf(line, sizeof(line), "  %-12s %8lld   (up to date)\n", r.session.c_str(),
                    static_cast<long long>(r.stereo.num_points));
    } else {
      const dense::HeightFieldStereo::Summary& s = r.stereo;
      std::snprintf(line, sizeof(line), "  %-12s %8lld %9lld  %6.1f  %10.1f  %6d  %9.1f\n",
                    r.session.c_str(), static_cast<long long>(s.num_points),
                    static_cast<long long>(s.num_cells),
                    s.num_cells > 0 ? 100.0 * s.num_points / s.num_cells : 0.0,
                    s.mean_views_per_tile, s.num_images_used, r.seconds);
    }
    out << line;
  }
  return out.str();
}

}  // namespace crop4d::pipeline
