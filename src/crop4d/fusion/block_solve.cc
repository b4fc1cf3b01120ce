#include "crop4d/fusion/block_solve.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <deque>
#include <map>
#include <numeric>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/fusion/camera_refinement.h"
#include "crop4d/fusion/pass_subset.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::fusion {
namespace {

bool IsSet(const std::vector<bool>& flags, std::size_t p) { return !flags.empty() && flags[p]; }

// The horizontal direction of travel shared by the passes: each pass's first-to-last
// displacement, turned to agree with the longest one (rows are driven both ways), summed.
Eigen::Vector2d MeanDirection(const std::vector<JointOptimiser::Pass>& passes) {
  std::vector<Eigen::Vector2d> moves;
  for (const JointOptimiser::Pass& pass : passes) {
    const Eigen::Vector3d d = pass.initial_states.back().nav.world_from_body.translation() -
                              pass.initial_states.front().nav.world_from_body.translation();
    moves.push_back(d.head<2>());
  }
  Eigen::Vector2d reference = Eigen::Vector2d::UnitX();
  double longest = 0;
  for (const Eigen::Vector2d& m : moves) {
    if (m.norm() > longest) {
      longest = m.norm();
      reference = m;
    }
  }
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& m : moves) sum += m.dot(reference) < 0 ? -m : m;
  return sum.norm() > 0 ? Eigen::Vector2d(sum.normalized()) : Eigen::Vector2d::UnitX();
}

// world_from_camera (world_from_body without a camera) of every state at its stamp.
std::vector<geometry::Rigid3> CamerasAtStamps(const JointOptimiser::Pass& pass) {
  std::vector<geometry::Rigid3> cameras;
  for (const slam::RowState& s : pass.initial_states) {
    cameras.push_back(pass.camera != nullptr ? s.nav.world_from_body * pass.body_from_camera
                                             : s.nav.world_from_body);
  }
  return cameras;
}

// What the sweeps gather for the merged result.
struct Merge {
  std::map<int, std::pair<Eigen::Vector3d, std::vector<bool>>> landmarks;  // by given index
  double sum_sq = 0, cross_sq = 0, tie_across_sq = 0, tie_vertical_sq = 0;
  std::int64_t count = 0, cross = 0, ties = 0;
};

// The landmarks each block observes (indices into `landmarks`, ascending), found once for every
// sweep.
std::vector<std::vector<int>> LandmarksOfBlocks(const std::vector<JointLandmark>& landmarks,
                                                const std::vector<std::vector<int>>& blocks,
                                                std::size_t num_passes) {
  std::vector<int> block_of(num_passes, -1);
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    for (const int p : blocks[b]) block_of[p] = static_cast<int>(b);
  }
  std::vector<std::vector<int>> out(blocks.size());
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    for (const JointObservation& o : landmarks[l].observations) {
      const int b = block_of[o.pass];
      if (b >= 0 && (out[b].empty() || out[b].back() != static_cast<int>(l))) {
        out[b].push_back(static_cast<int>(l));
      }
    }
  }
  return out;
}

// The landmarks, passes and ties of block `in_block`: its landmarks (`ids`, LandmarksOfBlocks),
// with their observations from the passes with `usable[p]` (the block's among them), every such
// pass that observes one of them, and the ties of the block with such passes; per landmark, the
// indices of the observations it keeps.
PassSubset BlockProblem(const std::vector<JointOptimiser::Pass>& current,
                        const std::vector<JointLandmark>& landmarks,
                        const std::vector<JointGroundTie>& ties, const std::vector<bool>& in_block,
                        const std::vector<bool>& usable, const std::vector<int>& ids,
                        std::vector<std::vector<int>>* kept_observations) {
  std::vector<bool> keep = in_block;
  std::vector<JointLandmark> selected;
  kept_observations->clear();
  for (const int l : ids) {
    const auto& obs = landmarks[l].observations;
    JointLandmark landmark;
    landmark.color = landmarks[l].color;
    std::vector<int> used;
    for (std::size_t o = 0; o < obs.size(); ++o) {
      if (!usable[obs[o].pass]) continue;
      keep[obs[o].pass] = true;
      landmark.observations.push_back(obs[o]);
      used.push_back(static_cast<int>(o));
    }
    kept_observations->push_back(std::move(used));
    selected.push_back(std::move(landmark));
  }
  for (const JointGroundTie& t : ties) {
    if ((in_block[t.pass_a] || in_block[t.pass_b]) && usable[t.pass_a] && usable[t.pass_b]) {
      keep[t.pass_a] = keep[t.pass_b] = true;
    }
  }
  return RestrictToPasses(current, std::move(selected), ties, keep);
}

// Places the landmarks that no block solved because only fixed passes see them, as one problem's
// triangulation places them against those passes' cameras (`cameras`, at the capture instants):
// one problem would also refine them, with the same poses held.
void PlaceLandmarksOfFixedPasses(const JointOptimiser::Options& options,
                                 const std::vector<JointOptimiser::Pass>& passes,
                                 const std::vector<JointLandmark>& landmarks,
                                 const std::vector<bool>& free,
                                 const std::vector<std::vector<geometry::Rigid3>>& cameras,
                                 Merge* merge) {
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    const auto& obs = landmarks[l].observations;
    if (std::any_of(obs.begin(), obs.end(),
                    [&](const JointObservation& o) { return free[o.pass]; })) {
      continue;
    }
    std::vector<bool> kept;
    const slam::TriangulationResult tri =
        TriangulateJointLandmark(options.row, passes, cameras, landmarks[l], &kept);
    if (tri.ok()) merge->landmarks[static_cast<int>(l)] = {tri.point_world, std::move(kept)};
  }
}

}  // namespace

OptionCheck BlockSolveOptions::Check() const {
  OptionChecker c;
  c.AtLeast("max_observations", max_observations, 0).AtLeast("sweeps", sweeps, 1);
  return c.Result();
}

std::vector<std::vector<int>> PartitionPasses(const std::vector<JointOptimiser::Pass>& passes,
                                              const std::vector<std::int64_t>& observations,
                                              const std::vector<bool>& free,
                                              std::int64_t max_observations) {
  CROP4D_CHECK_MSG(observations.size() == passes.size() && free.size() == passes.size(),
                   "PartitionPasses: one count and one flag per pass");
  const Eigen::Vector2d along = MeanDirection(passes);
  const Eigen::Vector2d across(-along.y(), along.x());
  std::vector<std::pair<double, int>> order;
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (!free[p]) continue;
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (const slam::RowState& s : passes[p].initial_states) {
      mean += s.nav.world_from_body.translation().head<2>();
    }
    mean /= static_cast<double>(passes[p].initial_states.size());
    order.emplace_back(mean.dot(across), static_cast<int>(p));
  }
  std::sort(order.begin(), order.end());
  // As many blocks as the bound needs, of about equal size: a block ends before the pass that
  // would take it past the bound, or whose middle would lie past the mean size.
  std::int64_t total = 0;
  for (const auto& [key, p] : order) total += observations[p];
  const std::int64_t bound = std::max<std::int64_t>(1, max_observations);
  const std::int64_t count = std::max<std::int64_t>(1, (total + bound - 1) / bound);
  const double target = static_cast<double>(total) / static_cast<double>(count);
  std::vector<std::vector<int>> blocks;
  std::int64_t in_last = 0;
  for (const auto& [key, p] : order) {
    if (blocks.empty() || in_last + observations[p] > max_observations ||
        (in_last > 0 && static_cast<double>(in_last) + 0.5 * observations[p] > target)) {
      blocks.emplace_back();
      in_last = 0;
    }
    blocks.back().push_back(p);
    in_last += observations[p];
  }
  return blocks;
}

JointOptimiser::Result SolveInBlocks(const JointOptimiser::Options& options,
                                     const BlockSolveOptions& blocks,
                                     const std::vector<JointOptimiser::Pass>& passes,
                                     const std::vector<JointLandmark>& landmarks,
                                     const std::vector<JointGroundTie>& ground_ties,
                                     const std::vector<bool>& fixed_passes,
                                     const std::vector<bool>& own_camera_passes) {
  CROP4D_CHECK_MSG(blocks.Check().empty(), "SolveInBlocks: " + blocks.Check());
  const JointOptimiser optimiser(options);
  const std::size_t n = passes.size();
  if (!fixed_passes.empty() && fixed_passes.size() != n) {
    throw std::invalid_argument("SolveInBlocks: fixed_passes does not match the passes");
  }
  for (const JointOptimiser::Pass& pass : passes) {
    if (pass.initial_states.size() < 2) {
      throw std::invalid_argument("SolveInBlocks: a pass has fewer than 2 states");
    }
  }
  std::vector<std::int64_t> observations(n, 0);
  std::int64_t total = 0, free_total = 0;
  for (const JointLandmark& landmark : landmarks) {
    for (const JointObservation& o : landmark.observations) {
      if (o.pass < 0 || o.pass >= static_cast<int>(n) || passes[o.pass].camera == nullptr ||
          o.state < 0 || o.state >= static_cast<int>(passes[o.pass].initial_states.size())) {
        throw std::invalid_argument("SolveInBlocks: an observation out of range");
      }
      ++observations[o.pass];
      ++total;
      free_total += IsSet(fixed_passes, o.pass) ? 0 : 1;
    }
  }
  std::vector<bool> free(n);
  for (std::size_t p = 0; p < n; ++p) free[p] = !IsSet(fixed_passes, p);
  const std::vector<std::vector<int>> parts =
      blocks.max_observations > 0 && free_total > blocks.max_observations
          ? PartitionPasses(passes, observations, free, blocks.max_observations)
          : std::vector<std::vector<int>>{};
  if (parts.size() <= 1) {
    return optimiser.Solve(passes, landmarks, ground_ties, fixed_passes, own_camera_passes);
  }
  spdlog::info(
      "joint problem: {} observations of free passes in {} blocks of at most {} (blocks of "
      "passes, {} sweeps)",
      free_total, parts.size(), blocks.max_observations, blocks.sweeps);

  // The passes as the latest solves left them, and the cameras they point to.
  std::vector<JointOptimiser::Pass> current = passes;
  std::deque<geometry::PinholeRadTan> refined_cameras;
  // Passes whose camera the blocks' refinements do not carry: those with a calibration of their
  // own (held passes).
  std::vector<bool> keep_camera(n);
  for (std::size_t p = 0; p < n; ++p) {
    keep_camera[p] = IsSet(fixed_passes, p) || IsSet(own_camera_passes, p);
  }
  JointOptimiser::Options holding_options = options;
  holding_options.calibration.refine = false;
  const JointOptimiser holding(holding_options);

  JointOptimiser::Result result;
  JointOptimiser::Summary& summary = result.summary;
  result.states.resize(n);
  result.cameras.resize(n);
  result.time_offsets_s.resize(n);
  std::vector<bool> placed(n, false), camera_refined(n, false);
  std::vector<std::int64_t> cross_of_pass(n, 0);
  Merge merge;
  const std::vector<std::vector<int>> block_landmarks = LandmarksOfBlocks(landmarks, parts, n);
  summary.converged = true;
  for (int sweep = 0; sweep < blocks.sweeps; ++sweep) {
    const bool last_sweep = sweep + 1 == blocks.sweeps;
    for (std::size_t b = 0; b < parts.size(); ++b) {
      std::vector<bool> in_block(n, false);
      for (const int p : parts[b]) in_block[p] = true;
      // The first sweep uses the passes already placed (the held ones and the blocks before),
      // not the free ones still where row SLAM put them: a block would be pulled towards them
      // and its calibration would take up their error.
      std::vector<bool> usable(n, true);
      if (sweep == 0) {
        for (std::size_t p = 0; p < n; ++p) usable[p] = in_block[p] || !free[p] || placed[p];
      }
      const std::vector<int>& ids = block_landmarks[b];
      std::vector<std::vector<int>> used;
      PassSubset sub = BlockProblem(current, landmarks, ground_ties, in_block, usable, ids, &used);
      // The block's neighbours are held; those that are free passes of other blocks share the
      // block's camera (its refinement moves their images too); the fixed passes of the whole
      // problem keep their own camera or hold the one they share, as in one problem.
      std::vector<bool> held(sub.passes.size()), own(sub.passes.size()), follows(sub.passes.size());
      for (std::size_t k = 0; k < held.size(); ++k) {
        const int p = sub.original_pass[k];
        held[k] = !in_block[p];
        own[k] = IsSet(own_camera_passes, p);
        follows[k] = held[k] && free[p];
      }
      spdlog::info("joint problem: sweep {}/{}, block {}/{}: {} passes ({} held), {} landmarks",
                   sweep + 1, blocks.sweeps, b + 1, parts.size(), sub.passes.size(),
                   sub.passes.size() - parts[b].size(), sub.landmarks.size());
      const JointOptimiser::Result r =
          (!last_sweep || blocks.sweeps == 1 ? optimiser : holding)
              .Solve(sub.passes, sub.landmarks, sub.ties, held, own, follows);
      const JointOptimiser::Summary& s = r.summary;
      summary.iterations += s.iterations;
      summary.triangulation_seconds += s.triangulation_seconds;
      summary.solve_seconds += s.solve_seconds;
      summary.final_solve_seconds += s.final_solve_seconds;
      if (sweep == 0) {
        summary.initial_cost += s.initial_cost;
        summary.num_passes_aligned += s.num_passes_aligned;
        summary.max_alignment_shift_m =
            std::max(summary.max_alignment_shift_m, s.max_alignment_shift_m);
      }
      for (std::size_t k = 0; k < sub.passes.size(); ++k) {
        const int p = sub.original_pass[k];
        if (in_block[p]) {
          current[p].initial_states = r.states[k];
          if (r.time_offsets_s[k]) current[p].time_offset_s = *r.time_offsets_s[k];
        }
        if (in_block[p] || (!free[p] && !placed[p])) {
          result.cameras[p] = r.cameras[k];
          result.time_offsets_s[p] = r.time_offsets_s[k];
          placed[p] = true;
        }
      }
      // The clock lines of the last sweep, in the passes' numbering; a clock that several
      // blocks hold keeps the last block's line.
      if (last_sweep) {
        for (ClockLine line : r.clock_lines) {
          for (int& k : line.passes) k = sub.original_pass[k];
          const auto same = std::find_if(result.clock_lines.begin(), result.clock_lines.end(),
                                         [&](const ClockLine& l) { return l.clock == line.clock; });
          if (same != result.clock_lines.end()) {
            *same = std::move(line);
          } else {
            result.clock_lines.push_back(std::move(line));
          }
        }
      }
      // The calibration the block refined, carried to every pass that shares it.
      for (const RefinedCalibration& c : r.calibrations) {
        for (const int k : c.passes) {
          const int p = sub.original_pass[k];
          if (!in_block[p]) continue;
          camera_refined[p] = camera_refined[p] || c.refined;
          cross_of_pass[p] = std::max(cross_of_pass[p], c.num_cross_observations);
        }
      }
      UseRefinedCalibrations(r.calibrations, &current, &refined_cameras, keep_camera);
      if (!last_sweep) continue;
      summary.final_cost += s.final_cost;
      summary.converged = summary.converged && s.converged;
      summary.num_gps_rejected += s.num_gps_rejected;
      merge.sum_sq += s.reprojection_rms_px * s.reprojection_rms_px * s.num_observations;
      merge.count += s.num_observations;
      merge.cross_sq +=
          s.cross_reprojection_rms_px * s.cross_reprojection_rms_px * s.num_cross_observations;
      merge.cross += s.num_cross_observations;
      merge.tie_across_sq +=
          s.ground_tie_rms_across_m * s.ground_tie_rms_across_m * s.num_ground_ties;
      merge.tie_vertical_sq +=
          s.ground_tie_rms_vertical_m * s.ground_tie_rms_vertical_m * s.num_ground_ties;
      merge.ties += s.num_ground_ties;
      for (std::size_t j = 0; j < r.landmarks_world.size(); ++j) {
        const int b_id = r.landmark_ids[j];
        std::vector<bool> kept(landmarks[ids[b_id]].observations.size(), false);
        for (std::size_t o = 0; o < used[b_id].size(); ++o) {
          kept[used[b_id][o]] = r.observations_kept[j][o];
        }
        merge.landmarks[ids[b_id]] = {r.landmarks_world[j], std::move(kept)};
      }
    }
  }

  // The passes: the free ones as their block's last solve left them, the fixed ones as given
  // (placed as the blocks that held them placed them, or at their stamps).
  for (std::size_t p = 0; p < n; ++p) {
    result.states[p] = current[p].initial_states;
    summary.num_states += static_cast<int>(current[p].initial_states.size());
    if (!placed[p]) {
      result.cameras[p] = CamerasAtStamps(current[p]);
      result.time_offsets_s[p] = current[p].time_offset_s;
    }
    if (!result.time_offsets_s[p]) continue;
    const bool estimated =
        free[p] && current[p].camera != nullptr &&
        options.estimate_time_offset.value_or(passes[p].time_offset_s.has_value());
    ++(estimated ? summary.num_time_offsets_estimated : summary.num_time_offsets_held);
  }
  PlaceLandmarksOfFixedPasses(options, passes, landmarks, free, result.cameras, &merge);
  // The rig's cameras as given, each now as the blocks left its passes.
  for (RigCamera& rig : GroupPassesByCamera(passes, keep_camera)) {
    RefinedCalibration c;
    c.written_camera = rig.camera;
    c.written_body_from_camera = rig.body_from_camera;
    const JointOptimiser::Pass& now = current[rig.passes.front()];
    c.camera = *now.camera;
    c.body_from_camera = now.body_from_camera;
    for (const int p : rig.passes) {
      c.refined = c.refined || camera_refined[p];
      c.num_cross_observations = std::max(c.num_cross_observations, cross_of_pass[p]);
    }
    c.passes = std::move(rig.passes);
    summary.num_cameras_refined += c.refined ? 1 : 0;
    result.calibrations.push_back(std::move(c));
  }
  // The landmarks in the order given, with the counts of one problem's summary.
  std::int64_t given_cross = 0;
  for (const JointLandmark& landmark : landmarks) {
    for (const JointObservation& o : landmark.observations) {
      given_cross += o.pass != landmark.observations.front().pass ? 1 : 0;
    }
  }
  std::int64_t kept = 0, kept_cross = 0;
  for (auto& [id, point] : merge.landmarks) {
    const JointLandmark& landmark = landmarks[id];
    bool shared = false;
    for (std::size_t o = 0; o < point.second.size(); ++o) {
      if (!point.second[o]) continue;
      ++kept;
      if (landmark.observations[o].pass != landmark.observations.front().pass) {
        ++kept_cross;
        shared = true;
      }
    }
    summary.num_shared_landmarks += shared ? 1 : 0;
    result.landmarks_world.push_back(point.first);
    result.landmark_ids.push_back(id);
    result.observations_kept.push_back(std::move(point.second));
  }
  summary.num_passes = static_cast<int>(n);
  summary.num_landmarks_given = static_cast<int>(landmarks.size());
  summary.num_landmarks = static_cast<int>(result.landmarks_world.size());
  summary.num_observations = kept;
  summary.num_cross_observations = kept_cross;
  summary.num_rejected_observations = total - kept;
  summary.num_rejected_cross_observations = given_cross - kept_cross;
  summary.num_ground_ties = static_cast<int>(ground_ties.size());
  const auto rms = [](double sum_sq, std::int64_t count) {
    return count > 0 ? std::sqrt(sum_sq / static_cast<double>(count)) : 0.0;
  };
  summary.reprojection_rms_px = rms(merge.sum_sq, merge.count);
  summary.cross_reprojection_rms_px = rms(merge.cross_sq, merge.cross);
  summary.ground_tie_rms_across_m = rms(merge.tie_across_sq, merge.ties);
  summary.ground_tie_rms_vertical_m = rms(merge.tie_vertical_sq, merge.ties);
  summary.num_blocks = static_cast<int>(parts.size());
  summary.num_sweeps = blocks.sweeps;
  return result;
}

}  // namespace crop4d::fusion
