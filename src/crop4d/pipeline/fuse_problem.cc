#include "crop4d/pipeline/fuse_problem.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <string>

#include "crop4d/association/match_thinning.h"
#include "crop4d/core/error.h"
#include "crop4d/fusion/block_solve.h"
#include "crop4d/fusion/pass_subset.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_files.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::pipeline::fuse {

namespace fs = std::filesystem;

SeasonPasses ListSeasonPasses(const std::vector<std::string>& field_sessions,
                              const std::string& workspace) {
  SeasonPasses season;
  for (const std::string& session : field_sessions) {
    bool any = false;
    for (const slam::RowPass& pass : workspace::ReadPassList(workspace, session)) {
      auto loaded = std::make_unique<LoadedPass>();
      loaded->data = workspace::LoadPassData(workspace, session, pass, {});
      if (!loaded->data.has_camera()) continue;
      season.index[{session, pass.id}] = static_cast<int>(season.passes.size());
      season.passes.push_back(std::move(loaded));
      any = true;
    }
    if (any) season.sessions.push_back(session);
  }
  if (season.passes.empty()) {
    throw InputError(workspace + ": no row pass with a camera (run `crop4d slam` first)");
  }
  return season;
}

// The joint landmarks over the passes with `use[p]` (fusion/cross_pass_tracks.h), each
// observation with its keypoint, each landmark with the mean colour of its keypoints.
std::vector<fusion::JointLandmark> JoinLandmarks(const fusion::CrossPassTracks& graph,
                                                 const PassList& passes,
                                                 const std::vector<bool>& use,
                                                 std::int64_t* num_conflicting) {
  const fusion::CrossPassTracks::Result joined = graph.Join(use);
  *num_conflicting = joined.num_conflicting_matches;
  std::vector<fusion::JointLandmark> landmarks(joined.landmarks.size());
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    Eigen::Vector3i color_sum = Eigen::Vector3i::Zero();
    for (const fusion::PassFeature& n : joined.landmarks[l]) {
      const features::FeatureSet& f = passes[n.pass]->data.features[n.image];
      landmarks[l].observations.push_back({n.pass, n.image, f.Point(n.feature)});
      if (!f.colors.empty()) {
        for (int c = 0; c < 3; ++c) color_sum(c) += f.colors[n.feature][c];
      }
    }
    const int count = static_cast<int>(joined.landmarks[l].size());
    for (int c = 0; c < 3; ++c) {
      landmarks[l].color[c] = static_cast<std::uint8_t>(color_sum(c) / count);
    }
  }
  return landmarks;
}

// Whether fused/ holds every session's outputs, a readable summary with `stamp` and intact
// outputs (why not is logged).
bool FusedUpToDate(const workspace::Layout& layout, const std::vector<std::string>& sessions,
                   const std::string& stamp) {
  if (!fs::exists(layout.FusedSummary())) return false;
  for (const std::string& s : sessions) {
    if (!fs::exists(layout.FusedPoses(s)) || !fs::exists(layout.FusedSparse(s))) return false;
  }
  try {
    workspace::ReadFusedSummary(layout.FusedSummary().string());
  } catch (const InputError& e) {
    spdlog::info("fuse: fused again: {}", e.what());
    return false;
  }
  std::string why;
  if (workspace::SummaryUpToDate(layout.FusedSummary(), stamp, &why)) return true;
  spdlog::info("fuse: fused again: {}", why);
  return false;
}

namespace {

// A pass as the ground ties see it: its row-SLAM cameras and cloud.
fusion::GroundTiePass TiePass(const LoadedPass& pass, const slam::TriangulationOptions& options) {
  fusion::GroundTiePass tie;
  for (const slam::RowState& state : pass.input.initial_states) {
    tie.cameras.push_back(state.nav.world_from_body * pass.input.body_from_camera);
  }
  const slam::TrackCloud cloud = CloudOfTracks(pass, *pass.input.camera, tie.cameras, options);
  tie.points = cloud.points_world;
  tie.colors = cloud.colors;
  return tie;
}

}  // namespace

// The landmark graph (fusion/cross_pass_tracks.h): each pass's landmarks, then the cross
// matches of the association files (thinned, stale ones counted and left out) with the cloud
// tracks they join. The pairs of passes of two sessions, with their number of cross matches, go
// to `session_pairs`.
fusion::CrossPassTracks BuildLandmarkGraph(const PassList& passes,
                                           const std::map<association::PassRef, int>& pass_index,
                                           const std::vector<fs::path>& association_files,
                                           const FuseStageOptions& options, FuseReport* report,
                                           std::vector<SessionPair>* session_pairs) {
  fusion::CrossPassTracks graph;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    for (const workspace::PassTrack& t : passes[p]->data.tracks.landmarks) {
      graph.AddPassLandmark(static_cast<int>(p), t.observations);
    }
  }
  for (const fs::path& path : association_files) {
    association::PassAssociation assoc;
    std::string detail;
    const association::AssociationFileStatus status =
        association::ReadAssociationFile(path.string(), &assoc, &detail);
    if (status != association::AssociationFileStatus::kOk) {
      throw InputError(path.string() + ": " + std::string(association::ToString(status)) + " (" +
                       detail + "); rerun `crop4d associate`");
    }
    ++report->num_association_files;
    const auto ia = pass_index.find(assoc.a), ib = pass_index.find(assoc.b);
    if (ia == pass_index.end() || ib == pass_index.end()) {
      spdlog::warn("{}: its passes are not in the workspace; ignored", path.string());
      continue;
    }
    const int pa = ia->second, pb = ib->second;
    if (assoc.a.session != assoc.b.session) {
      session_pairs->emplace_back(pa, pb, static_cast<std::int64_t>(assoc.matches.size()));
    }
    const std::vector<association::CrossMatch> matches = association::ThinCrossMatches(
        assoc.matches, passes[pa]->input.camera->width, passes[pa]->input.camera->height,
        options.max_matches_per_image_pair);
    report->num_cross_matches += static_cast<std::int64_t>(assoc.matches.size());
    report->num_thinned_matches += static_cast<std::int64_t>(assoc.matches.size() - matches.size());
    for (const association::CrossMatch& m : matches) {
      const workspace::PassData& a = passes[pa]->data;
      const workspace::PassData& b = passes[pb]->data;
      const bool valid =
          m.image_a >= 0 && m.image_a < static_cast<int>(a.times.size()) && m.image_b >= 0 &&
          m.image_b < static_cast<int>(b.times.size()) && a.times[m.image_a] == m.t_a &&
          b.times[m.image_b] == m.t_b && m.feature_a >= 0 &&
          m.feature_a < static_cast<int>(a.features[m.image_a].size()) && m.feature_b >= 0 &&
          m.feature_b < static_cast<int>(b.features[m.image_b].size());
      if (!valid) {
        ++report->num_invalid_matches;
        continue;
      }
      // The tracks of the pass each feature belongs to (none: no cloud track).
      const auto track_of = [&](int p, int image,
                                int feature) -> const std::vector<features::Observation>& {
        static const std::vector<features::Observation> kNone;
        const auto it = passes[p]->cloud_of.find(ImageFeatureKey(image, feature));
        return it == passes[p]->cloud_of.end()
                   ? kNone
                   : passes[p]->data.tracks.cloud[it->second].observations;
      };
      graph.AddCrossMatch({pa, m.image_a, m.feature_a}, {pb, m.image_b, m.feature_b}, m.distance,
                          track_of(pa, m.image_a, m.feature_a),
                          track_of(pb, m.image_b, m.feature_b));
    }
    if (report->num_invalid_matches > 0) {
      spdlog::warn(
          "{}: matches that do not fit the passes' images (stale; rerun `crop4d associate`)",
          path.string());
    }
  }
  return graph;
}

// Ground ties (fusion/ground_ties.h) where appearance left two dates of a row without cross
// matches, unless both passes have a precise GPS.
std::vector<fusion::JointGroundTie> GroundTies(const PassList& passes,
                                               const std::vector<SessionPair>& session_pairs,
                                               const FuseStageOptions& options,
                                               FuseReport* report) {
  std::vector<fusion::JointGroundTie> ties;
  if (options.ground_ties) {
    std::map<int, fusion::GroundTiePass> tie_passes;
    const auto precise = [&](int p) {
      return fusion::MedianGpsSigma(passes[p]->input) <= options.optimiser.precise_gps_sigma_m;
    };
    for (const auto& [pa, pb, matches] : session_pairs) {
      // Two precise receivers register the passes better than the ground can.
      if (matches >= options.ground_tie_max_matches || (precise(pa) && precise(pb))) continue;
      for (int p : {pa, pb}) {
        if (!tie_passes.count(p)) tie_passes[p] = TiePass(*passes[p], options.cloud);
      }
      FuseTiePairReport pair{passes[pa]->data.label(), passes[pb]->data.label(), matches, {}};
      const std::vector<fusion::GroundTie> found =
          fusion::ComputeGroundTies(tie_passes[pa], tie_passes[pb], options.ground_tie, &pair.ties);
      for (const fusion::GroundTie& tie : found) ties.push_back({pa, pb, tie});
      if (found.empty()) {
        spdlog::warn(
            "fuse: {} ~ {}: {} cross matches and no ground tie (tracks not parallel or no common "
            "soil): nothing but the GPS relates them",
            pair.a, pair.b, matches);
      } else {
        spdlog::info(
            "fuse: {} ~ {}: {} cross matches; {} ground ties (b lies {:+.2f} m across, {:+.2f} m "
            "up; spread {:.1f} cm)",
            pair.a, pair.b, matches, pair.ties.ties, pair.ties.median_across_m,
            pair.ties.median_vertical_m, 100 * pair.ties.median_spread_m);
      }
      report->tie_pairs.push_back(std::move(pair));
    }
  }
  return ties;
}

// The grades of the sessions (season_quality.h, into report->quality), and whether each pass
// belongs to a session that the others must not move.
std::vector<bool> GradeSessions(const PassList& passes, const FuseStageOptions& options,
                                FuseReport* report) {
  std::vector<PassFacts> facts;
  for (const auto& pass : passes) {
    workspace::PassSummary summary;
    summary.sensors = pass->data.sensors;
    summary.longest_imu_gap_s = pass->data.longest_imu_gap_s;
    facts.push_back(PassFactsOf(pass->data.session, pass->data.pass.id, summary));
  }
  report->quality = GradeSeason(facts, options.quality);
  std::vector<bool> protects(passes.size());
  for (std::size_t p = 0; p < passes.size(); ++p) {
    protects[p] = report->quality.Protects(passes[p]->data.session);
  }
  for (const SessionGrade* g : report->quality.Degraded()) {
    std::string reasons;
    for (const std::string& r : g->reasons) reasons += (reasons.empty() ? "" : "; ") + r;
    spdlog::warn("fuse: {} is degraded ({}){}", g->session, reasons,
                 report->quality.any_trusted
                     ? ": registered onto the trusted sessions, which it does not move"
                     : "; no session is trusted: all are fused together");
  }
  return protects;
}

// The joint problem (fuse_problem.h).
fusion::JointOptimiser::Result SolveJoint(const fusion::CrossPassTracks& graph,
                                          const PassList& passes,
                                          const std::vector<fusion::JointLandmark>& landmarks,
                                          const std::vector<fusion::JointGroundTie>& ties,
                                          const std::vector<bool>& protects,
                                          const std::vector<bool>& held,
                                          const FuseStageOptions& options) {
  std::vector<fusion::JointOptimiser::Pass> inputs;
  for (const auto& pass : passes) inputs.push_back(pass->input);
  const auto is_held = [&](std::size_t p) { return !held.empty() && held[p]; };
  // Passes that the second solve holds: the held ones and, when a free pass belongs to a
  // degraded session, the trusted ones.
  std::vector<bool> fixed(passes.size()), first_keep(passes.size());
  bool two_steps = false, any_free_trusted = false;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    two_steps |= !is_held(p) && !protects[p];
    any_free_trusted |= !is_held(p) && protects[p];
    first_keep[p] = protects[p] || is_held(p);
    fixed[p] = is_held(p);
  }
  std::deque<geometry::PinholeRadTan> refined_cameras;  // the cameras the inputs point to
  std::vector<fusion::RefinedCalibration> first_calibrations;
  // Without a free trusted pass the first solve would move nothing.
  two_steps &= any_free_trusted;
  if (two_steps) {
    for (std::size_t p = 0; p < passes.size(); ++p) fixed[p] = fixed[p] || protects[p];
    std::int64_t conflicting = 0;
    const fusion::PassSubset trusted = fusion::RestrictToPasses(
        inputs, JoinLandmarks(graph, passes, first_keep, &conflicting), ties, first_keep);
    std::vector<bool> first_held;
    for (const int p : trusted.original_pass) first_held.push_back(is_held(p));
    spdlog::info("fuse: the {} trusted passes first, alone", trusted.passes.size());
    const fusion::JointOptimiser::Result first =
        fusion::SolveInBlocks(options.optimiser, options.blocks, trusted.passes, trusted.landmarks,
                              trusted.ties, first_held, first_held);
    for (std::size_t k = 0; k < trusted.original_pass.size(); ++k) {
      inputs[trusted.original_pass[k]].initial_states = first.states[k];
      if (first.time_offsets_s[k]) {
        inputs[trusted.original_pass[k]].time_offset_s = first.time_offsets_s[k];
      }
    }
    first_calibrations = first.calibrations;
    // (a held pass keeps its calibration)
    fusion::UseRefinedCalibrations(first_calibrations, &inputs, &refined_cameras, held);
  }
  // The held passes keep the calibration they were written with; the camera they share with
  // the free passes is refined on a copy of its own.
  std::vector<bool> own_camera(passes.size());
  for (std::size_t p = 0; p < passes.size(); ++p) own_camera[p] = is_held(p);
  fusion::JointOptimiser::Result result = fusion::SolveInBlocks(
      options.optimiser, options.blocks, inputs, landmarks, ties, fixed, own_camera);
  ReportEarlierRefinement(first_calibrations, &result);
  return result;
}

// The joint problem's result (fuse_problem.h).
void ReportEarlierRefinement(const std::vector<fusion::RefinedCalibration>& earlier,
                             fusion::JointOptimiser::Result* result) {
  fusion::ReportRefinedCalibrations(earlier, &result->calibrations);
  result->summary.num_cameras_refined = static_cast<int>(
      std::count_if(result->calibrations.begin(), result->calibrations.end(),
                    [](const fusion::RefinedCalibration& c) { return c.refined; }));
}

// The fused world_from_camera of every image of every pass, and each pass's correction against
// row SLAM (report->passes).
std::vector<std::vector<geometry::Rigid3>> FusedCameras(
    const PassList& passes, const fusion::JointOptimiser::Result& result, FuseReport* report) {
  std::vector<std::vector<geometry::Rigid3>> cameras(passes.size());
  for (std::size_t p = 0; p < passes.size(); ++p) {
    FusePassReport pr;
    pr.session = passes[p]->data.session;
    pr.pass = passes[p]->data.pass.id;
    pr.images = static_cast<int>(result.states[p].size());
    double rot_sq = 0;
    for (std::size_t k = 0; k < result.states[p].size(); ++k) {
      const geometry::Rigid3& pose = result.cameras[p][k];  // at the capture instant
      cameras[p].push_back(pose);
      pr.mean_shift += pose.translation() - passes[p]->data.poses[k].translation();
      const double a =
          geometry::AngleBetween(pose.rotation(), passes[p]->data.poses[k].rotation()) * 180 / M_PI;
      rot_sq += a * a;
    }
    pr.mean_shift /= std::max<std::size_t>(1, result.states[p].size());
    pr.rotation_change_deg = std::sqrt(rot_sq / std::max<std::size_t>(1, result.states[p].size()));
    report->passes.push_back(pr);
  }
  return cameras;
}

// The association files (<a>__<b>.bin) of a folder, sorted; none when it does not exist.
std::vector<fs::path> AssociationFiles(const fs::path& folder) {
  std::vector<fs::path> files;
  if (fs::is_directory(folder)) {
    for (const auto& entry : fs::directory_iterator(folder)) {
      if (entry.path().extension() == ".bin") files.push_back(entry.path());
    }
  }
  std::sort(files.begin(), files.end());
  return files;
}

}  // namespace crop4d::pipeline::fuse
