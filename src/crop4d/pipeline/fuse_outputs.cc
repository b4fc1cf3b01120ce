#include "crop4d/pipeline/fuse_outputs.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <iomanip>
#include <map>
#include <set>
#include <sstream>

#include "crop4d/io/colmap_text.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/slam/reprojection_factor.h"

namespace crop4d::pipeline::fuse {
namespace {

// The clouds of a session's passes re-triangulated from the given cameras, with each point's
// track length and reprojection error.
io::PlyPointCloud SessionCloud(const std::vector<const LoadedPass*>& passes,
                               const geometry::PinholeRadTan& camera,
                               const std::vector<std::vector<geometry::Rigid3>>& cameras,
                               const slam::TriangulationOptions& options) {
  io::PlyPointCloud cloud;
  io::PlyScalarField length{"track_length", io::PlyType::kInt32, {}};
  io::PlyScalarField error{"reprojection_error", io::PlyType::kFloat32, {}};
  for (std::size_t p = 0; p < passes.size(); ++p) {
    const slam::TrackCloud pass_cloud = CloudOfTracks(*passes[p], camera, cameras[p], options);
    cloud.points.insert(cloud.points.end(), pass_cloud.points_world.begin(),
                        pass_cloud.points_world.end());
    cloud.colors.insert(cloud.colors.end(), pass_cloud.colors.begin(), pass_cloud.colors.end());
    length.values.insert(length.values.end(), pass_cloud.track_lengths.begin(),
                         pass_cloud.track_lengths.end());
    error.values.insert(error.values.end(), pass_cloud.reprojection_errors_px.begin(),
                        pass_cloud.reprojection_errors_px.end());
  }
  cloud.scalars = {length, error};
  return cloud;
}

}  // namespace

std::vector<workspace::FusedCamera> FusedIntrinsics(
    const std::vector<std::unique_ptr<LoadedPass>>& passes,
    const fusion::JointOptimiser::Result& result) {
  std::vector<workspace::FusedCamera> out(passes.size());
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (passes[p]->input.camera != nullptr) out[p].intrinsics = *passes[p]->input.camera;
    out[p].body_from_camera = passes[p]->input.body_from_camera;
  }
  for (const fusion::RefinedCalibration& c : result.calibrations) {
    for (const int p : c.passes) {
      out[p] = {c.camera, c.body_from_camera, c.refined, c.RotationChangeDeg()};
    }
  }
  return out;
}

void WriteSessionOutputs(const std::vector<std::unique_ptr<LoadedPass>>& passes,
                         const std::vector<std::vector<geometry::Rigid3>>& cameras,
                         const std::vector<workspace::FusedCamera>& intrinsics,
                         const std::vector<std::string>& sessions, const FuseStageOptions& options,
                         const workspace::Layout& layout) {
  for (const std::string& session : sessions) {
    std::vector<io::StampedPose> poses;
    std::vector<const LoadedPass*> session_passes;
    std::vector<std::vector<geometry::Rigid3>> session_cameras;
    const workspace::FusedCamera* camera = nullptr;
    for (std::size_t p = 0; p < passes.size(); ++p) {
      if (passes[p]->data.session != session) continue;
      if (camera == nullptr) camera = &intrinsics[p];
      session_passes.push_back(passes[p].get());
      session_cameras.push_back(cameras[p]);
      for (std::size_t k = 0; k < cameras[p].size(); ++k) {
        poses.push_back({passes[p]->data.times[k], cameras[p][k]});
      }
    }
    std::sort(poses.begin(), poses.end(),
              [](const io::StampedPose& a, const io::StampedPose& b) { return a.t < b.t; });
    io::WriteTum(layout.FusedPoses(session).string(), poses,
                 "world_from_camera of session " + session +
                     " after 4D fusion (all passes), field ENU frame");
    if (camera != nullptr) {
      workspace::WriteFusedCamera(layout.FusedCamera(session).string(), *camera);
    }
    io::PlyWriteOptions ply;
    ply.comment = "crop4d fused sparse cloud of session " + session + ", field ENU frame (metres)";
    io::WritePly(layout.FusedSparse(session).string(),
                 SessionCloud(session_passes,
                              camera != nullptr ? camera->intrinsics : geometry::PinholeRadTan(),
                              session_cameras, options.cloud),
                 ply);
  }
}

// WS/fused/landmarks.ply: the joint landmarks, with how many passes and sessions see each.
namespace {

// Landmarks appended to landmarks.ply at a time.
constexpr std::size_t kPlyPart = 1 << 16;

io::PlyLayout LandmarkLayout() {
  io::PlyLayout layout;
  layout.colors = true;
  layout.scalars = {{"passes", io::PlyType::kInt32}, {"sessions", io::PlyType::kInt32}};
  return layout;
}

io::PlyPointCloud EmptyLandmarkPart() {
  io::PlyPointCloud part;
  part.scalars = {{"passes", io::PlyType::kInt32, {}}, {"sessions", io::PlyType::kInt32, {}}};
  return part;
}

}  // namespace

SeasonLandmarkWriter::SeasonLandmarkWriter(
    const std::vector<std::unique_ptr<LoadedPass>>& passes,
    const std::vector<std::vector<geometry::Rigid3>>& cameras,
    const std::vector<workspace::FusedCamera>& intrinsics, bool colmap,
    const workspace::Layout& layout)
    : passes_(passes), cameras_(cameras), intrinsics_(intrinsics), part_(EmptyLandmarkPart()) {
  io::PlyWriteOptions ply;
  ply.comment = "crop4d joint 4D landmarks (all sessions), field ENU frame (metres)";
  ply_ = std::make_unique<io::PlyStreamWriter>(layout.FusedLandmarks().string(), LandmarkLayout(),
                                               ply);
  if (!colmap) return;
  std::vector<io::ColmapCamera> colmap_cameras;
  std::vector<io::ColmapImage> images;
  std::vector<std::uint32_t> groups;  // the run of passes of one session: a group of images
  std::map<std::string, std::uint32_t> camera_of_session;
  std::uint32_t group = 0;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    const std::string& session = passes[p]->data.session;
    if (p > 0 && session != passes[p - 1]->data.session) ++group;
    if (!camera_of_session.count(session)) {
      const auto id = static_cast<std::uint32_t>(colmap_cameras.size() + 1);
      camera_of_session[session] = id;
      colmap_cameras.push_back({id, intrinsics[p].intrinsics});
    }
    first_image_.push_back(images.size());
    const std::map<Timestamp, std::string> names = ImageNames(*passes[p]);
    for (std::size_t k = 0; k < cameras[p].size(); ++k) {
      io::ColmapImage image;
      image.image_id = static_cast<std::uint32_t>(images.size() + 1);
      image.camera_id = camera_of_session[session];
      const auto it = names.find(passes[p]->data.times[k]);
      const std::string file =
          it != names.end() ? it->second : std::to_string(passes[p]->data.times[k]) + ".png";
      image.name = io::ColmapImageName(session + "/" + passes[p]->data.pass.id + "/" + file);
      image.world_from_camera = cameras[p][k];
      images.push_back(std::move(image));
      groups.push_back(group);
    }
  }
  colmap_ = std::make_unique<io::ColmapTextWriter>(layout.FusedColmapDir().string(),
                                                   std::move(colmap_cameras), std::move(images),
                                                   std::move(groups));
}

SeasonLandmarkWriter::~SeasonLandmarkWriter() = default;

void SeasonLandmarkWriter::Add(const fusion::JointLandmark& landmark,
                               const Eigen::Vector3d& position, const std::vector<bool>& kept) {
  std::set<int> seen_passes;
  std::set<std::string> seen_sessions;
  std::vector<io::ColmapObservation> observations;
  double error_sum = 0;
  for (std::size_t o = 0; o < landmark.observations.size(); ++o) {
    if (!kept[o]) continue;
    const fusion::JointObservation& obs = landmark.observations[o];
    seen_passes.insert(obs.pass);
    seen_sessions.insert(passes_[obs.pass]->data.session);
    if (!colmap_) continue;
    observations.push_back({first_image_[obs.pass] + obs.state, obs.pixel});
    // From the fused camera (at its capture instant, with the fused intrinsics).
    const double e = slam::ReprojectionError(intrinsics_[obs.pass].intrinsics, geometry::Rigid3(),
                                             cameras_[obs.pass][obs.state], position, obs.pixel);
    error_sum += std::isfinite(e) ? e : 0.0;
  }
  part_.points.push_back(position);
  part_.colors.push_back(landmark.color);
  part_.scalars[0].values.push_back(static_cast<double>(seen_passes.size()));
  part_.scalars[1].values.push_back(static_cast<double>(seen_sessions.size()));
  if (part_.size() >= kPlyPart) AppendPly();
  if (colmap_) {
    const double error = observations.empty() ? 0.0 : error_sum / observations.size();
    colmap_->AddPoint(count_, position, landmark.color, error, observations);
  }
  ++count_;
}

void SeasonLandmarkWriter::AppendPly() {
  ply_->Append(part_);
  part_ = EmptyLandmarkPart();
}

void SeasonLandmarkWriter::Finish() {
  AppendPly();
  ply_->Finish();
  if (colmap_) colmap_->Finish();
}

void WriteSeasonLandmarks(const std::vector<std::unique_ptr<LoadedPass>>& passes,
                          const std::vector<std::vector<geometry::Rigid3>>& cameras,
                          const std::vector<workspace::FusedCamera>& intrinsics,
                          const std::vector<fusion::JointLandmark>& landmarks,
                          const fusion::JointOptimiser::Result& result, bool colmap,
                          const workspace::Layout& layout) {
  SeasonLandmarkWriter writer(passes, cameras, intrinsics, colmap, layout);
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    writer.Add(landmarks[result.landmark_ids[l]], result.landmarks_world[l],
               result.observations_kept[l]);
  }
  writer.Finish();
}

using json = nlohmann::json;

namespace {

json IntrinsicsJson(const geometry::PinholeRadTan& c) {
  return {{"fx", c.fx}, {"fy", c.fy}, {"cx", c.cx}, {"cy", c.cy}, {"k1", c.k1}, {"k2", c.k2}};
}

// The rig's cameras in the joint problem: the passes of each, whether its calibration was
// refined, from how many cross observations, the intrinsics as written and after the solve, and
// the turn of its T_BS.
json CamerasJson(const std::vector<fusion::RefinedCalibration>& calibrations,
                 const std::vector<FusePassReport>& passes) {
  json list = json::array();
  for (const fusion::RefinedCalibration& c : calibrations) {
    json pass_ids = json::array();
    for (const int p : c.passes) pass_ids.push_back(passes[p].session + "/" + passes[p].pass);
    list.push_back({{"passes", pass_ids},
                    {"refined", c.refined},
                    {"cross_observations", c.num_cross_observations},
                    {"written", IntrinsicsJson(c.written_camera)},
                    {"intrinsics", IntrinsicsJson(c.camera)},
                    {"rotation_change_deg", c.RotationChangeDeg()},
                    {"lever_arm_change_m",
                     {c.LeverArmChange().x(), c.LeverArmChange().y(), c.LeverArmChange().z()}}});
  }
  return list;
}

}  // namespace

json JointSummaryJson(const fusion::JointOptimiser::Summary& s) {
  return {{"passes", s.num_passes},
          {"states", s.num_states},
          {"landmarks_given", s.num_landmarks_given},
          {"landmarks", s.num_landmarks},
          {"shared_landmarks", s.num_shared_landmarks},
          {"observations", s.num_observations},
          {"cross_observations", s.num_cross_observations},
          {"rejected_observations", s.num_rejected_observations},
          {"rejected_cross_observations", s.num_rejected_cross_observations},
          {"initial_cost", s.initial_cost},
          {"final_cost", s.final_cost},
          {"iterations", s.iterations},
          {"reprojection_rms_px", s.reprojection_rms_px},
          {"cross_reprojection_rms_px", s.cross_reprojection_rms_px},
          {"ground_ties", s.num_ground_ties},
          {"ground_tie_rms_across_m", s.ground_tie_rms_across_m},
          {"ground_tie_rms_vertical_m", s.ground_tie_rms_vertical_m},
          {"gps_rejected", s.num_gps_rejected},
          {"cameras_refined", s.num_cameras_refined},
          {"passes_aligned", s.num_passes_aligned},
          {"max_alignment_shift_m", s.max_alignment_shift_m},
          {"time_offsets_estimated", s.num_time_offsets_estimated},
          {"time_offsets_held", s.num_time_offsets_held},
          {"converged", s.converged},
          {"blocks", s.num_blocks},
          {"sweeps", s.num_sweeps},
          {"seconds",
           {{"triangulation", s.triangulation_seconds},
            {"solve", s.solve_seconds},
            {"final_solve", s.final_solve_seconds}}}};
}

json TiePairsJson(const std::vector<FuseTiePairReport>& pairs) {
  json tie_list = json::array();
  for (const FuseTiePairReport& t : pairs) {
    tie_list.push_back({{"a", t.a},
                        {"b", t.b},
                        {"cross_matches", t.cross_matches},
                        {"soil_points_a", t.ties.soil_points_a},
                        {"soil_points_b", t.ties.soil_points_b},
                        {"segments", t.ties.segments},
                        {"ties", t.ties.ties},
                        {"median_across_m", t.ties.median_across_m},
                        {"median_vertical_m", t.ties.median_vertical_m},
                        {"median_spread_m", t.ties.median_spread_m}});
  }
  return tie_list;
}

fusion::JointOptimiser::Summary JointSummaryFromJson(const json& j) {
  fusion::JointOptimiser::Summary s;
  s.num_passes = j.at("passes").get<int>();
  s.num_states = j.at("states").get<int>();
  s.num_landmarks_given = j.at("landmarks_given").get<int>();
  s.num_landmarks = j.at("landmarks").get<int>();
  s.num_shared_landmarks = j.at("shared_landmarks").get<int>();
  s.num_observations = j.at("observations").get<std::int64_t>();
  s.num_cross_observations = j.at("cross_observations").get<std::int64_t>();
  s.num_rejected_observations = j.at("rejected_observations").get<std::int64_t>();
  s.num_rejected_cross_observations = j.at("rejected_cross_observations").get<std::int64_t>();
  s.initial_cost = j.at("initial_cost").get<double>();
  s.final_cost = j.at("final_cost").get<double>();
  s.iterations = j.at("iterations").get<int>();
  s.reprojection_rms_px = j.at("reprojection_rms_px").get<double>();
  s.cross_reprojection_rms_px = j.at("cross_reprojection_rms_px").get<double>();
  s.num_ground_ties = j.at("ground_ties").get<int>();
  s.ground_tie_rms_across_m = j.at("ground_tie_rms_across_m").get<double>();
  s.ground_tie_rms_vertical_m = j.at("ground_tie_rms_vertical_m").get<double>();
  s.num_gps_rejected = j.at("gps_rejected").get<int>();
  s.num_cameras_refined = j.at("cameras_refined").get<int>();
  s.num_passes_aligned = j.at("passes_aligned").get<int>();
  s.max_alignment_shift_m = j.at("max_alignment_shift_m").get<double>();
  s.num_time_offsets_estimated = j.at("time_offsets_estimated").get<int>();
  s.num_time_offsets_held = j.at("time_offsets_held").get<int>();
  s.converged = j.at("converged").get<bool>();
  // (absent from the steps of crop4d before blocks: one problem)
  s.num_blocks = j.value("blocks", 1);
  s.num_sweeps = j.value("sweeps", 1);
  const json& seconds = j.at("seconds");
  s.triangulation_seconds = seconds.at("triangulation").get<double>();
  s.solve_seconds = seconds.at("solve").get<double>();
  s.final_solve_seconds = seconds.at("final_solve").get<double>();
  return s;
}

void AddJointSummary(const fusion::JointOptimiser::Summary& step,
                     fusion::JointOptimiser::Summary* total) {
  fusion::JointOptimiser::Summary& t = *total;
  // RMS values over the steps, weighted by their observations (cross ones for the cross RMS) and
  // ties.
  const auto rms = [](double a, double wa, double b, double wb) {
    return wa + wb > 0 ? std::sqrt((a * a * wa + b * b * wb) / (wa + wb)) : 0.0;
  };
  t.reprojection_rms_px = rms(t.reprojection_rms_px, static_cast<double>(t.num_observations),
                              step.reprojection_rms_px, static_cast<double>(step.num_observations));
  t.cross_reprojection_rms_px =
      rms(t.cross_reprojection_rms_px, static_cast<double>(t.num_cross_observations),
          step.cross_reprojection_rms_px, static_cast<double>(step.num_cross_observations));
  t.ground_tie_rms_across_m = rms(t.ground_tie_rms_across_m, t.num_ground_ties,
                                  step.ground_tie_rms_across_m, step.num_ground_ties);
  t.ground_tie_rms_vertical_m = rms(t.ground_tie_rms_vertical_m, t.num_ground_ties,
                                    step.ground_tie_rms_vertical_m, step.num_ground_ties);
  t.converged = (t.num_passes == 0 || t.converged) && step.converged;
  t.num_passes += step.num_passes;
  t.num_states += step.num_states;
  t.num_landmarks_given += step.num_landmarks_given;
  t.num_passes_aligned += step.num_passes_aligned;
  t.max_alignment_shift_m = std::max(t.max_alignment_shift_m, step.max_alignment_shift_m);
  t.num_landmarks += step.num_landmarks;
  t.num_shared_landmarks += step.num_shared_landmarks;
  t.num_observations += step.num_observations;
  t.num_cross_observations += step.num_cross_observations;
  t.num_rejected_observations += step.num_rejected_observations;
  t.num_rejected_cross_observations += step.num_rejected_cross_observations;
  t.initial_cost += step.initial_cost;
  t.final_cost += step.final_cost;
  t.iterations += step.iterations;
  t.num_ground_ties += step.num_ground_ties;
  t.triangulation_seconds += step.triangulation_seconds;
  t.solve_seconds += step.solve_seconds;
  t.final_solve_seconds += step.final_solve_seconds;
  t.num_time_offsets_estimated += step.num_time_offsets_estimated;
  t.num_time_offsets_held += step.num_time_offsets_held;
  t.num_gps_rejected += step.num_gps_rejected;
  t.num_cameras_refined = std::max(t.num_cameras_refined, step.num_cameras_refined);
  // The most blocks and sweeps of any step.
  t.num_blocks = std::max(t.num_blocks, step.num_blocks);
  t.num_sweeps = std::max(t.num_sweeps, step.num_sweeps);
}

// The stage's summary.json (before its outputs are recorded): fingerprint, options, counts,
// the joint solve, the ground ties and the per-pass corrections.
json FuseSummaryJson(const FuseReport& report, const fusion::JointOptimiser::Result& result,
                     const std::string& stamp, const FuseStageOptions& options,
                     const std::vector<std::string>& sessions) {
  const fusion::JointOptimiser::Summary& s = result.summary;
  json summary;
  summary["fingerprint"] = stamp;
  summary["options"] = FuseOptionsJson(options);
  summary["sessions"] = sessions;
  summary["associations"] = {{"files", report.num_association_files},
                             {"cross_matches", report.num_cross_matches},
                             {"thinned_matches", report.num_thinned_matches},
                             {"conflicting_matches", report.num_conflicting_matches},
                             {"invalid_matches", report.num_invalid_matches}};
  summary["joint"] = JointSummaryJson(s);
  summary["ground_ties"] = TiePairsJson(report.tie_pairs);
  json pass_list = json::array();
  for (std::size_t p = 0; p < report.passes.size(); ++p) {
    const FusePassReport& pr = report.passes[p];
    pass_list.push_back(
        {{"session", pr.session},
         {"pass", pr.pass},
         {"images", pr.images},
         {"mean_shift_m", {pr.mean_shift.x(), pr.mean_shift.y(), pr.mean_shift.z()}},
         {"rotation_change_deg", pr.rotation_change_deg}});
    // The camera-IMU time offset the joint problem used (docs/fusion.md), when there is one.
    if (result.time_offsets_s[p]) pass_list.back()["time_offset_s"] = *result.time_offsets_s[p];
  }
  summary["passes"] = pass_list;
  summary["cameras"] = CamerasJson(result.calibrations, report.passes);
  summary["seconds"] = {{"triangulation", s.triangulation_seconds},
                        {"solve", s.solve_seconds},
                        {"final_solve", s.final_solve_seconds},
                        {"total", report.seconds}};
  return summary;
}

}  // namespace crop4d::pipeline::fuse

namespace crop4d::pipeline {

std::string FormatFuseReport(const FuseReport& report) {
  std::ostringstream out;
  if (report.skipped) {
    out << "fuse: up to date (" << report.num_passes << " passes of " << report.num_sessions
        << " sessions)\n";
    return out.str();
  }
  const fusion::JointOptimiser::Summary& s = report.joint;
  out << "fused " << report.num_passes << " passes of " << report.num_sessions << " sessions in "
      << std::fixed << std::setprecision(1) << report.seconds << " s\n";
  if (!report.steps.empty()) {
    const auto sweeps = std::count_if(report.steps.begin(), report.steps.end(),
                                      [](const FuseStepReport& step) { return step.sweep > 0; });
    out << "  session by session in " << report.steps.size() - sweeps << " steps";
    if (sweeps > 0) out << ", then " << sweeps << " steps of refinement sweeps over the season";
    out << "; the counts below are summed over them (a pass is in several)\n";
  }
  out << "  cross matches " << report.num_cross_matches << " from " << report.num_association_files
      << " files (" << report.num_thinned_matches << " left out by the per-image-pair cap, "
      << report.num_conflicting_matches << " inconsistent, " << report.num_invalid_matches
      << " stale)\n";
  out << "  landmarks " << s.num_landmarks << " (" << s.num_shared_landmarks
      << " shared by passes), observations " << s.num_observations << " (cross "
      << s.num_cross_observations << ", rejected cross " << s.num_rejected_cross_observations
      << ")\n";
  out << std::setprecision(2) << "  reprojection RMS " << s.reprojection_rms_px << " px (cross "
      << s.cross_reprojection_rms_px << " px), cost " << std::setprecision(1) << s.initial_cost
      << " -> " << s.final_cost << ", " << s.iterations << " iterations\n";
  if (s.num_ground_ties > 0) {
    out << std::setprecision(2) << "  ground ties " << s.num_ground_ties << " on "
        << report.tie_pairs.size() << " pairs of passes without cross matches, RMS after fusion "
        << 100 * s.ground_tie_rms_across_m << " cm across, " << 100 * s.ground_tie_rms_vertical_m
        << " cm vertical\n";
  }
  for (const fusion::RefinedCalibration& c : report.calibrations) {
    if (!c.refined) continue;
    char line[320];
    std::snprintf(line, sizeof(line),
                  "  camera of %zu passes refined from %lld cross observations: fx %+.2f fy %+.2f "
                  "cx %+.2f cy %+.2f px, k1 %+.4f k2 %+.4f, T_BS turned %.3f deg, lever arm "
                  "moved (%+.1f, %+.1f, %+.1f) mm\n",
                  c.passes.size(), static_cast<long long>(c.num_cross_observations),
                  c.camera.fx - c.written_camera.fx, c.camera.fy - c.written_camera.fy,
                  c.camera.cx - c.written_camera.cx, c.camera.cy - c.written_camera.cy,
                  c.camera.k1 - c.written_camera.k1, c.camera.k2 - c.written_camera.k2,
                  c.RotationChangeDeg(), 1e3 * c.LeverArmChange().x(), 1e3 * c.LeverArmChange().y(),
                  1e3 * c.LeverArmChange().z());
    out << line;
  }
  if (!report.steps.empty()) {
    out << "  step  folder                optimised             held                    landmarks  "
           "observations  moved [cm]  seconds\n";
    for (std::size_t s = 0; s < report.steps.size(); ++s) {
      const FuseStepReport& step = report.steps[s];
      if (step.skipped) {
        out << "  " << std::setw(4) << s + 1 << "  " << std::left << std::setw(21)
            << (step.name.empty() ? step.session : step.name) << std::right << " up to date\n";
        continue;
      }
      std::string optimised, held;
      for (const std::string& x : step.optimised) optimised += (optimised.empty() ? "" : ",") + x;
      for (const std::string& x : step.held) held += (held.empty() ? "" : ",") + x;
      char line[320];
      std::snprintf(line, sizeof(line), "  %4zu  %-21s %-21s %-23s %9d  %12lld  %10.2f  %7.1f\n",
                    s + 1, (step.name.empty() ? step.session : step.name).c_str(),
                    optimised.c_str(), held.empty() ? "-" : held.c_str(), step.landmarks,
                    static_cast<long long>(step.observations), 100 * step.moved_m, step.seconds);
      out << line;
    }
  }
  out << "  session      pass     shift east/north/up [cm]   rotation [deg]\n";
  for (const FusePassReport& pr : report.passes) {
    char line[160];
    std::snprintf(line, sizeof(line), "  %-12s %-8s %7.2f %7.2f %7.2f          %6.3f\n",
                  pr.session.c_str(), pr.pass.c_str(), 100 * pr.mean_shift.x(),
                  100 * pr.mean_shift.y(), 100 * pr.mean_shift.z(), pr.rotation_change_deg);
    out << line;
  }
  for (const SessionGrade* g : report.quality.Degraded()) {
    for (const std::string& reason : g->reasons) {
      out << "  degraded " << g->session << ": " << reason << "\n";
    }
  }
  if (!report.quality.Degraded().empty()) {
    out << (report.quality.any_trusted
                ? "  (degraded sessions were registered onto the trusted ones, held fixed)\n"
                : "  (no session is trusted: all were fused together)\n");
  }
  return out.str();
}

}  // namespace crop4d::pipeline
