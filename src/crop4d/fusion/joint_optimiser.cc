#include "crop4d/fusion/joint_optimiser.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <optional>
#include <set>
#include <span>
#include <stdexcept>
#include <string>
#include <utility>

#include "crop4d/core/stopwatch.h"
#include "crop4d/fusion/clock_line.h"
#include "crop4d/fusion/ground_tie_factor.h"
#include "crop4d/slam/pass_graph.h"
#include "crop4d/slam/reprojection_factor.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::fusion {
namespace {

using Clock = std::chrono::steady_clock;

// A ground tie with its point in the body frame of each state.
struct BodyTie {
  int pass_a, state_a, pass_b, state_b;
  Eigen::Vector3d point_a, point_b, across;
};

// Everything the phases share: the state blocks and graph of every pass, and the ground ties.
class JointProblem {
 public:
  JointProblem(const JointOptimiser::Options& options,
               const std::vector<JointOptimiser::Pass>& passes, std::vector<BodyTie> ties,
               std::vector<bool> fixed, const std::vector<bool>& own_camera)
      : joint_options_(options),
        options_(options.row),
        passes_(passes),
        ties_(std::move(ties)),
        fixed_(std::move(fixed)),
        ground_tie_loss_(std::make_unique<ceres::HuberLoss>(options.ground_tie_loss_scale)) {
    for (const JointOptimiser::Pass& pass : passes) {
      for (const slam::RowState& s : pass.initial_states) storage_.push_back(slam::ToBlocks(s));
    }
    std::size_t begin = 0;
    for (std::size_t p = 0; p < passes.size(); ++p) {
      blocks_.emplace_back(storage_.data() + begin, passes[p].initial_states.size());
      begin += passes[p].initial_states.size();
      // The pass's options: the joint ones, with its own choice of estimating td.
      auto pass_options = std::make_unique<slam::RowOptimiser::Options>(options_);
      pass_options->estimate_time_offset =
          passes[p].camera != nullptr &&
          options.estimate_time_offset.value_or(passes[p].time_offset_s.has_value());
      graphs_.push_back(std::make_unique<slam::PassGraph>(*pass_options, passes_[p], blocks_[p]));
      pass_options_.push_back(std::move(pass_options));
    }
    rig_cameras_ = GroupPassesByCamera(passes, own_camera);
    for (const RigCamera& camera : rig_cameras_) {
      calibrations_.push_back(slam::CameraCalibrationBlocks::From(camera.camera));
    }
    refined_.assign(rig_cameras_.size(), false);
    BuildClockLines();
  }

  const std::vector<RigCamera>& RigCameras() const { return rig_cameras_; }

  // The clock lines that took part in a solve, as solved (ClockLine: offset at t_ref and drift
  // per second).
  std::vector<ClockLine> ClockLines() const {
    std::vector<ClockLine> lines;
    for (std::size_t g = 0; g < clock_lines_.size(); ++g) {
      if (!line_used_[g]) continue;
      lines.push_back(clock_lines_[g]);
      lines.back().offset_s = line_blocks_[g][0];
      lines.back().drift = line_blocks_[g][1] / 1000.0;
    }
    return lines;
  }

  // From now on, the calibration of rig camera c is refined with the poses (refine[c]).
  void RefineCameras(const std::vector<bool>& refine) {
    refined_ = refine;
    for (std::size_t c = 0; c < rig_cameras_.size(); ++c) {
      for (const int p : rig_cameras_[c].passes) {
        graphs_[p]->set_calibration(refined_[c] ? &calibrations_[c] : nullptr);
      }
    }
  }

  // Every rig camera as written and as the problem has it now.
  std::vector<RefinedCalibration> Calibrations() const {
    std::vector<RefinedCalibration> out;
    for (std::size_t c = 0; c < rig_cameras_.size(); ++c) {
      const RigCamera& rig = rig_cameras_[c];
      RefinedCalibration r;
      r.passes = rig.passes;
      r.refined = refined_[c];
      r.written_camera = rig.camera;
      r.written_body_from_camera = rig.body_from_camera;
      r.camera = refined_[c] ? calibrations_[c].Camera(rig.camera) : rig.camera;
      r.body_from_camera = refined_[c] ? calibrations_[c].BodyFromCamera(rig.body_from_camera)
                                       : rig.body_from_camera;
      out.push_back(std::move(r));
    }
    return out;
  }

  // The time offset of pass p as the reprojection factors use it (unset when they do not), and
  // whether the solve refines it.
  std::optional<double> TimeOffset(std::size_t p) const {
    if (!graphs_[p]->uses_time_offset()) return std::nullopt;
    return graphs_[p]->time_offset_s();
  }
  bool EstimatesTimeOffset(std::size_t p) const { return graphs_[p]->estimates_time_offset(); }
  // Per pass: whether its reprojections use its time offset (refined or held).
  std::vector<bool> UsesTimeOffsets() const {
    std::vector<bool> uses;
    for (const auto& graph : graphs_) uses.push_back(graph->uses_time_offset());
    return uses;
  }

  // The GPS outlier gate of every pass (slam::PassGraph::GateGps); the number of fixes dropped.
  int GateGps(double chi2) {
    int dropped = 0;
    for (std::size_t p = 0; p < graphs_.size(); ++p) {
      if (fixed_.empty() || !fixed_[p]) dropped += graphs_[p]->GateGps(chi2);
    }
    return dropped;
  }

  void Preintegrate() {
    for (auto& graph : graphs_) graph->Preintegrate(nullptr);
  }

  // world_from_camera of every state of every pass at its capture instant (world_from_body for
  // camera-less passes).
  std::vector<std::vector<geometry::Rigid3>> CameraPoses() const {
    std::vector<std::vector<geometry::Rigid3>> poses(passes_.size());
    for (std::size_t p = 0; p < passes_.size(); ++p) poses[p] = graphs_[p]->CapturePoses();
    return poses;
  }

  double Error(const JointObservation& obs, const Eigen::Vector3d& point) const {
    const slam::PassGraph& graph = *graphs_[obs.pass];
    return slam::ReprojectionError(graph.Camera(), graph.BodyFromCamera(),
                                   graph.BodyAtCapture(obs.state), point, obs.pixel);
  }

  // Builds and solves the problem with the kept observations of `landmarks`.
  ceres::Solver::Summary Solve(const std::vector<JointLandmark>& given, const std::vector<int>& ids,
                               std::vector<Eigen::Vector3d>* landmarks,
                               const std::vector<std::vector<bool>>& keep,
                               std::int64_t* num_observations) {
    ceres::Problem problem(slam::ProblemOptions());
    for (auto& graph : graphs_) graph->AddMotion(&problem, nullptr);
    std::int64_t count = 0;
    for (std::size_t l = 0; l < landmarks->size(); ++l) {
      const JointLandmark& landmark = given[ids[l]];
      for (std::size_t o = 0; o < landmark.observations.size(); ++o) {
        if (!keep[l][o]) continue;
        const JointObservation& obs = landmark.observations[o];
        graphs_[obs.pass]->AddObservation(&problem, obs.state, obs.pixel, (*landmarks)[l].data());
        ++count;
      }
    }
    if (num_observations != nullptr) *num_observations = count;
    for (std::size_t c = 0; c < rig_cameras_.size(); ++c) {
      if (refined_[c]) {
        AddCalibrationPriors(joint_options_.calibration, rig_cameras_[c], &calibrations_[c],
                             &problem);
      }
    }
    for (const BodyTie& tie : ties_) {
      problem.AddResidualBlock(GroundTieFactor::Create(tie.point_a, tie.point_b, tie.across,
                                                       joint_options_.ground_tie_sigma_across_m,
                                                       joint_options_.ground_tie_sigma_vertical_m),
                               ground_tie_loss_.get(), blocks_[tie.pass_a][tie.state_a].pose,
                               blocks_[tie.pass_b][tie.state_b].pose);
    }
    for (std::size_t p = 0; p < fixed_.size(); ++p) {
      if (!fixed_[p]) continue;
      for (slam::StateBlocks& b : blocks_[p]) {
        for (double* block : {b.pose, b.vel, b.rate, b.bias}) {
          if (problem.HasParameterBlock(block)) problem.SetParameterBlockConstant(block);
        }
      }
      double* td = graphs_[p]->time_offset_block();
      if (problem.HasParameterBlock(td)) problem.SetParameterBlockConstant(td);
    }
    AddClockLineFactors(&problem);
    // The time offsets (one per pass, each in its graph) and the calibrations after the states,
    // in pass and camera order: the same order, and sums, in every process.
    std::vector<double*> last_blocks;
    for (const auto& graph : graphs_) last_blocks.push_back(graph->time_offset_block());
    for (slam::CameraCalibrationBlocks& c : calibrations_) {
      last_blocks.insert(last_blocks.end(), {c.intrinsics, c.rotation, c.lever_arm});
    }
    for (std::array<double, 2>& line : line_blocks_) last_blocks.push_back(line.data());
    return slam::RunSolver(options_, &problem, landmarks, last_blocks);
  }

  // RMS disagreement of the ties across the row and vertically, m.
  Eigen::Vector2d TieRms() const {
    Eigen::Vector2d sum = Eigen::Vector2d::Zero();
    for (const BodyTie& tie : ties_) {
      const Eigen::Vector3d d =
          slam::BlockToPose(blocks_[tie.pass_b][tie.state_b].pose) * tie.point_b -
          slam::BlockToPose(blocks_[tie.pass_a][tie.state_a].pose) * tie.point_a;
      sum += Eigen::Vector2d(std::pow(d.dot(tie.across), 2), d.z() * d.z());
    }
    return ties_.empty() ? sum : Eigen::Vector2d((sum / ties_.size()).cwiseSqrt());
  }

  std::vector<std::vector<slam::RowState>> States() const {
    std::vector<std::vector<slam::RowState>> states(passes_.size());
    for (std::size_t p = 0; p < passes_.size(); ++p) {
      for (std::size_t k = 0; k < blocks_[p].size(); ++k) {
        states[p].push_back(slam::FromBlocks(passes_[p].initial_states[k].t, blocks_[p][k]));
      }
    }
    return states;
  }

 private:
  // The passes of each clock (Pass::clock) that use a time offset, three at least with one of
  // them refined, and a line through their offsets as row SLAM left them (clock_line.h).
  void BuildClockLines() {
    if (joint_options_.clock_line_sigma_s <= 0) return;
    std::map<std::string, std::vector<int>> by_clock;
    for (std::size_t p = 0; p < passes_.size(); ++p) {
      if (passes_[p].clock.empty() || !graphs_[p]->uses_time_offset()) continue;
      by_clock[passes_[p].clock].push_back(static_cast<int>(p));
    }
    for (auto& [clock, members] : by_clock) {
      const bool any_refined = std::any_of(members.begin(), members.end(), [&](int p) {
        return graphs_[p]->estimates_time_offset() && (fixed_.empty() || !fixed_[p]);
      });
      if (members.size() < 3 || !any_refined) continue;
      ClockLine line;
      line.clock = clock;
      line.passes = members;
      line.t_ref_s = std::numeric_limits<double>::infinity();
      for (const int p : members) {
        line.t_ref_s =
            std::min(line.t_ref_s, TimestampToSeconds(passes_[p].initial_states.front().t));
      }
      std::vector<double> times_ks, offsets_s;
      for (const int p : members) {
        times_ks.push_back(PassMidTimeKs(p, line.t_ref_s));
        offsets_s.push_back(graphs_[p]->time_offset_s());
      }
      line_blocks_.push_back(*FitClockLine(times_ks, offsets_s));
      clock_lines_.push_back(std::move(line));
      line_used_.push_back(false);
    }
  }

  // The middle of pass p's span, in units of 1000 s since t_ref_s.
  double PassMidTimeKs(int p, double t_ref_s) const {
    const auto& states = passes_[p].initial_states;
    const double mid =
        0.5 * (TimestampToSeconds(states.front().t) + TimestampToSeconds(states.back().t));
    return (mid - t_ref_s) / 1000.0;
  }

  // Each clock line's factors on the offsets of its passes that this problem holds (three at
  // least).
  void AddClockLineFactors(ceres::Problem* problem) {
    for (std::size_t g = 0; g < clock_lines_.size(); ++g) {
      const ClockLine& line = clock_lines_[g];
      std::vector<int> present;
      for (const int p : line.passes) {
        if (problem->HasParameterBlock(graphs_[p]->time_offset_block())) present.push_back(p);
      }
      if (present.size() < 3) continue;
      line_used_[g] = true;
      for (const int p : present) {
        problem->AddResidualBlock(ClockLineFactor::Create(PassMidTimeKs(p, line.t_ref_s),
                                                          joint_options_.clock_line_sigma_s),
                                  nullptr, graphs_[p]->time_offset_block(), line_blocks_[g].data());
      }
    }
  }

  const JointOptimiser::Options& joint_options_;
  const slam::RowOptimiser::Options& options_;
  const std::vector<JointOptimiser::Pass>& passes_;
  std::vector<BodyTie> ties_;
  std::vector<bool> fixed_;  // per pass (empty: none)
  // Shared by every tie: the problem options leave losses to their owner (slam::ProblemOptions).
  std::unique_ptr<ceres::LossFunction> ground_tie_loss_;
  // Every pass's state blocks in one array, in pass and state order, and each pass's part of it.
  // Ceres orders the blocks of a linear-solver group by their address: with the addresses in the
  // problem's order, a solve repeats to the last bit in any process (separate vectors per pass
  // lie wherever the heap put them, which depends on what the process did before).
  std::vector<slam::StateBlocks> storage_;
  std::vector<std::span<slam::StateBlocks>> blocks_;
  // The rig's cameras, their calibration blocks (the graphs of refined cameras point into
  // them: sized once) and whether each is refined.
  std::vector<RigCamera> rig_cameras_;
  std::vector<slam::CameraCalibrationBlocks> calibrations_;
  std::vector<bool> refined_;
  // Each pass's options (the graphs hold references to them) and graph.
  std::vector<std::unique_ptr<slam::RowOptimiser::Options>> pass_options_;
  std::vector<std::unique_ptr<slam::PassGraph>> graphs_;
  // The clock lines and their parameter blocks [offset s, drift s per 1000 s] (sized once: the
  // problem holds their addresses).
  std::vector<ClockLine> clock_lines_;
  std::vector<std::array<double, 2>> line_blocks_;
  std::vector<bool> line_used_;
};

// Whether observation o of a landmark comes from a pass other than its first observation's.
bool IsCross(const JointLandmark& landmark, std::size_t o) {
  return landmark.observations[o].pass != landmark.observations.front().pass;
}

// Per rig camera, the kept observations of landmarks from a pass other than the landmark's
// first one, in the camera's images: what observes its calibration beyond a single pass.
std::vector<std::int64_t> CrossObservationsPerCamera(const std::vector<RigCamera>& cameras,
                                                     std::size_t num_passes,
                                                     const std::vector<JointLandmark>& landmarks,
                                                     const std::vector<int>& ids,
                                                     const std::vector<std::vector<bool>>& keep) {
  std::vector<int> camera_of_pass(num_passes, -1);
  for (std::size_t c = 0; c < cameras.size(); ++c) {
    for (const int p : cameras[c].passes) camera_of_pass[p] = static_cast<int>(c);
  }
  std::vector<std::int64_t> counts(cameras.size(), 0);
  for (std::size_t l = 0; l < ids.size(); ++l) {
    const JointLandmark& landmark = landmarks[ids[l]];
    for (std::size_t o = 0; o < landmark.observations.size(); ++o) {
      if (keep[l][o] && IsCross(landmark, o))
        ++counts[camera_of_pass[landmark.observations[o].pass]];
    }
  }
  return counts;
}

// Which rig cameras the joint problem refines (CalibrationRefinementOptions::refine). A camera
// with a fixed pass is held as written: its calibration is shared with the pass, whose cameras
// would move with it (a degraded session must not move a trusted one).
// `uses_time_offset[p]`: pass p's reprojections use its time offset (auto needs it).
std::vector<bool> CamerasToRefine(const CalibrationRefinementOptions& options,
                                  const std::vector<RigCamera>& cameras,
                                  const std::vector<std::int64_t>& cross_observations,
                                  const std::vector<bool>& uses_time_offset,
                                  const std::vector<bool>& fixed_passes) {
  std::vector<bool> refine(cameras.size());
  for (std::size_t c = 0; c < refine.size(); ++c) {
    bool every_offset = true;
    for (const int p : cameras[c].passes) every_offset = every_offset && uses_time_offset[p];
    refine[c] = options.refine.value_or(every_offset &&
                                        cross_observations[c] >= options.min_cross_observations);
    int num_fixed = 0;
    for (const int p : cameras[c].passes) num_fixed += !fixed_passes.empty() && fixed_passes[p];
    if (refine[c] && num_fixed > 0) {
      refine[c] = false;
      if (num_fixed < static_cast<int>(cameras[c].passes.size())) {
        spdlog::info("joint problem: camera {} has held passes: its calibration is held as given",
                     c);
      }
    }
  }
  return refine;
}

// The rigid motion (b_from_a) that carries pass a's placement of its ties' ground points onto
// pass b's across the row and vertically: across offset = α + β s along the track (β a yaw
// about the vertical through the ties' centroid), vertical offset = their median.
geometry::Rigid3 TieAlignment(const std::vector<const GroundTie*>& ties) {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d across = Eigen::Vector3d::Zero();
  for (const GroundTie* t : ties) {  // (the sign of `across` varies with the pair)
    centroid += t->point_a;
    across += t->across.dot(ties.front()->across) < 0 ? -t->across : t->across;
  }
  centroid /= static_cast<double>(ties.size());
  across.z() = 0;
  across.normalize();
  const Eigen::Vector3d along(across.y(), -across.x(), 0.0);  // across = up × along
  Eigen::Matrix2d normal = Eigen::Matrix2d::Zero();
  Eigen::Vector2d rhs = Eigen::Vector2d::Zero();
  std::vector<double> vertical;
  for (const GroundTie* t : ties) {
    const Eigen::Vector2d row(1.0, along.dot(t->point_a - centroid));
    normal += row * row.transpose();
    rhs += row * across.dot(t->point_b - t->point_a);
    vertical.push_back(t->point_b.z() - t->point_a.z());
  }
  // Too short a stretch of ties for a slope: a translation only.
  Eigen::Vector2d line(rhs(0) / normal(0, 0), 0.0);
  if (ties.size() >= 3 && normal(1, 1) > 1.0) line = normal.ldlt().solve(rhs);
  std::nth_element(vertical.begin(), vertical.begin() + vertical.size() / 2, vertical.end());
  const double dz = vertical[vertical.size() / 2];
  const Eigen::Matrix3d yaw =
      Eigen::AngleAxisd(line(1), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return geometry::Rigid3(
      yaw, centroid + line(0) * across + dz * Eigen::Vector3d::UnitZ() - yaw * centroid);
}

// Step (0): each landmark seen from several passes is triangulated by each pass alone; pairs of
// passes with enough common points are aligned (4 DOF), pairs with ground ties by their ties,
// and the passes without a precise GPS are moved along a spanning tree of the best-supported
// alignments, grown from the precise passes (or from the first pass of a group without any).
void AlignPasses(const JointOptimiser::Options& options,
                 const std::vector<JointLandmark>& landmarks,
                 const std::vector<JointGroundTie>& ground_ties, const std::vector<bool>& fixed,
                 std::vector<JointOptimiser::Pass>* passes_io, JointOptimiser::Summary* summary) {
  std::vector<JointOptimiser::Pass>& passes = *passes_io;
  const std::size_t n = passes.size();
  std::vector<bool> precise(n);  // fixed passes define the frame like precise ones
  for (std::size_t p = 0; p < n; ++p) {
    precise[p] =
        (!fixed.empty() && fixed[p]) || MedianGpsSigma(passes[p]) <= options.precise_gps_sigma_m;
  }
  if (std::all_of(precise.begin(), precise.end(), [](bool b) { return b; })) return;
  std::vector<std::vector<geometry::Rigid3>> cameras(n);
  for (std::size_t p = 0; p < n; ++p) {
    for (const slam::RowState& state : passes[p].initial_states) {
      cameras[p].push_back(state.nav.world_from_body * passes[p].body_from_camera);
    }
  }
  // Per landmark, the point of each pass that sees it at least twice.
  std::vector<std::vector<std::pair<int, Eigen::Vector3d>>> per_pass(landmarks.size());
  tbb::parallel_for(std::size_t{0}, landmarks.size(), [&](std::size_t l) {
    const JointLandmark& landmark = landmarks[l];
    if (landmark.observations.front().pass == landmark.observations.back().pass) return;
    std::map<int, std::pair<std::vector<geometry::Rigid3>, std::vector<Eigen::Vector2d>>> views;
    for (const JointObservation& obs : landmark.observations) {
      views[obs.pass].first.push_back(cameras[obs.pass][obs.state]);
      views[obs.pass].second.push_back(obs.pixel);
    }
    for (const auto& [pass, v] : views) {
      if (v.first.size() < 2) continue;
      const slam::TriangulationResult tri = slam::TriangulatePoint(
          *passes[pass].camera, v.first, v.second, options.row.triangulation);
      if (tri.ok()) per_pass[l].emplace_back(pass, tri.point_world);
    }
  });
  std::map<std::pair<int, int>,
           std::pair<std::vector<Eigen::Vector3d>, std::vector<Eigen::Vector3d>>>
      common;
  for (const auto& points : per_pass) {
    for (std::size_t i = 0; i < points.size(); ++i) {
      for (std::size_t j = i + 1; j < points.size(); ++j) {
        auto& c = common[{points[i].first, points[j].first}];
        c.first.push_back(points[i].second);
        c.second.push_back(points[j].second);
      }
    }
  }
  struct Edge {
    int p, q;
    PassAlignment alignment;  // q_from_p
  };
  std::vector<Edge> edges;
  for (const auto& [key, c] : common) {
    const PassAlignment a = AlignPasses4Dof(c.first, c.second, options.alignment);
    if (a.ok) edges.push_back({key.first, key.second, a});
  }
  const std::size_t num_landmark_edges = edges.size();
  // Ground ties: a rotation about the vertical and a translation across the row and vertically
  // (the across offsets of a pair's ties fitted as a line along the track, the median of their
  // vertical offsets), supported by as many inliers as ties — so they join passes that share
  // no landmarks rather than overrule the landmarks.
  std::map<std::pair<int, int>, std::vector<const GroundTie*>> pair_ties;
  for (const JointGroundTie& t : ground_ties) pair_ties[{t.pass_a, t.pass_b}].push_back(&t.tie);
  for (const auto& [key, ties] : pair_ties) {
    PassAlignment a;
    a.ok = true;
    a.b_from_a = TieAlignment(ties);
    a.num_inliers = static_cast<int>(ties.size());
    edges.push_back({key.first, key.second, a});
  }
  // Prim's algorithm from the precise passes, best-supported edge first.
  std::vector<std::optional<geometry::Rigid3>> correction(n);
  std::vector<bool> frame_pass = precise;  // passes that stay where they are
  for (std::size_t p = 0; p < n; ++p) {
    if (precise[p]) correction[p] = geometry::Rigid3();
  }
  for (;;) {
    const Edge* best = nullptr;
    for (const Edge& e : edges) {
      if (correction[e.p].has_value() == correction[e.q].has_value()) continue;
      if (best == nullptr || e.alignment.num_inliers > best->alignment.num_inliers) best = &e;
    }
    if (best == nullptr) {
      // A group without a precise pass: its first pass stays where it is.
      std::size_t start = n;
      for (std::size_t p = 0; p < n && start == n; ++p) {
        if (correction[p].has_value()) continue;
        for (const Edge& e : edges) {
          if (e.p == static_cast<int>(p) || e.q == static_cast<int>(p)) start = p;
        }
      }
      if (start == n) break;
      correction[start] = geometry::Rigid3();
      frame_pass[start] = true;
      continue;
    }
    // x_q = A x_p: C_q = C_p A⁻¹, C_p = C_q A.
    const geometry::Rigid3& A = best->alignment.b_from_a;
    if (correction[best->p]) {
      correction[best->q] = *correction[best->p] * A.Inverse();
    } else {
      correction[best->p] = *correction[best->q] * A;
    }
  }
  // A group of passes that only ties join to the passes defining the frame is moved by the
  // alignment of all its ties with the passes outside it (the spanning tree used one pair's),
  // then slid along the row back to the mean position its own GPS gave it: ties say nothing
  // along the row.
  if (!pair_ties.empty()) {
    std::vector<int> group(n);
    std::iota(group.begin(), group.end(), 0);
    const auto find = [&](int x) {
      while (group[x] != x) x = group[x] = group[group[x]];
      return x;
    };
    for (std::size_t e = 0; e < num_landmark_edges; ++e) group[find(edges[e].p)] = find(edges[e].q);
    std::set<int> anchored, tied;
    for (std::size_t p = 0; p < n; ++p) {
      if (frame_pass[p]) anchored.insert(find(static_cast<int>(p)));
    }
    for (const JointGroundTie& t : ground_ties) {
      tied.insert(find(t.pass_a));
      tied.insert(find(t.pass_b));
    }
    for (const int g : tied) {
      if (anchored.count(g)) continue;
      // The ties between the group and the rest, as the corrected passes place them, the
      // group's side as b.
      std::vector<GroundTie> outside;
      for (const JointGroundTie& t : ground_ties) {
        const bool a_in = find(t.pass_a) == g, b_in = find(t.pass_b) == g;
        if (a_in == b_in || !correction[t.pass_a] || !correction[t.pass_b]) continue;
        GroundTie c = t.tie;
        c.point_a = *correction[t.pass_a] * t.tie.point_a;
        c.point_b = *correction[t.pass_b] * t.tie.point_b;
        if (a_in) std::swap(c.point_a, c.point_b);
        outside.push_back(c);
      }
      if (outside.empty()) continue;
      std::vector<const GroundTie*> views;
      for (const GroundTie& c : outside) views.push_back(&c);
      const geometry::Rigid3 fix = TieAlignment(views).Inverse();
      const Eigen::Vector3d& across = outside.front().across;
      const Eigen::Vector3d along = Eigen::Vector3d(-across.y(), across.x(), 0).normalized();
      double shift = 0;
      int count = 0;
      for (std::size_t p = 0; p < n; ++p) {
        if (find(static_cast<int>(p)) != g || !correction[p]) continue;
        correction[p] = fix * *correction[p];
        for (const geometry::Rigid3& c : cameras[p]) {
          shift += along.dot(c.translation() - (*correction[p]) * c.translation());
          ++count;
        }
      }
      const geometry::Rigid3 slide(Eigen::Quaterniond::Identity(), along * (shift / count));
      for (std::size_t p = 0; p < n; ++p) {
        if (find(static_cast<int>(p)) == g && correction[p]) correction[p] = slide * *correction[p];
      }
    }
  }
  for (std::size_t p = 0; p < n; ++p) {
    if (precise[p] || !correction[p]) continue;
    double shift = 0;
    for (const geometry::Rigid3& c : cameras[p]) {
      shift = std::max(shift, ((*correction[p]) * c.translation() - c.translation()).norm());
    }
    // The initial states move, and with them the gauge prior of a pass without GPS
    // (Input::anchor_state).
    for (slam::RowState& state : passes[p].initial_states) {
      state.nav.world_from_body = *correction[p] * state.nav.world_from_body;
      state.nav.vel_world = correction[p]->rotation() * state.nav.vel_world;
    }
    ++summary->num_passes_aligned;
    summary->max_alignment_shift_m = std::max(summary->max_alignment_shift_m, shift);
  }
  if (summary->num_passes_aligned > 0) {
    spdlog::info("joint problem: {} passes aligned onto their neighbours (largest move {:.2f} m)",
                 summary->num_passes_aligned, summary->max_alignment_shift_m);
  }
}

}  // namespace

double MedianGpsSigma(const JointOptimiser::Pass& pass) {
  if (pass.gps_fixes.empty()) return std::numeric_limits<double>::infinity();
  std::vector<double> sigmas;
  for (const slam::GpsFixWorld& fix : pass.gps_fixes) sigmas.push_back(fix.sigma_h);
  std::nth_element(sigmas.begin(), sigmas.begin() + sigmas.size() / 2, sigmas.end());
  return sigmas[sigmas.size() / 2];
}

slam::TriangulationResult TriangulateJointLandmark(
    const slam::RowOptimiser::Options& options,
    const std::vector<slam::RowOptimiser::Input>& passes,
    const std::vector<std::vector<geometry::Rigid3>>& cameras, const JointLandmark& landmark,
    std::vector<bool>* kept) {
  const geometry::PinholeRadTan& reference = *passes[landmark.observations.front().pass].camera;
  std::vector<geometry::Rigid3> poses;
  std::vector<Eigen::Vector2d> pixels;
  for (const JointObservation& obs : landmark.observations) {
    poses.push_back(cameras[obs.pass][obs.state]);
    const geometry::PinholeRadTan& camera = *passes[obs.pass].camera;
    Eigen::Vector2d pixel = obs.pixel;
    Eigen::Vector3d ray;
    if (!SameIntrinsics(camera, reference) &&
        !(camera.Unproject(obs.pixel, &ray) && reference.Project(ray, &pixel))) {
      pixel = obs.pixel;  // outside the reference's model: let the error bound judge it
    }
    pixels.push_back(pixel);
  }
  return slam::TriangulateDroppingWorstViews(reference, poses, pixels, options.triangulation,
                                             options.max_outliers_per_track,
                                             options.min_observations, kept);
}

OptionCheck JointOptimiser::Options::Check() const {
  if (const OptionCheck why = row.Check(); !why.empty()) return "row." + why;
  if (const OptionCheck why = alignment.Check(); !why.empty()) return "alignment." + why;
  if (const OptionCheck why = calibration.Check(); !why.empty()) return "calibration." + why;
  for (const auto& [name, value] :
       {std::pair{"precise_gps_sigma_m", precise_gps_sigma_m},
        std::pair{"ground_tie_sigma_across_m", ground_tie_sigma_across_m},
        std::pair{"ground_tie_sigma_vertical_m", ground_tie_sigma_vertical_m},
        std::pair{"ground_tie_loss_scale", ground_tie_loss_scale}}) {
    if (!(value > 0)) return fmt::format("{}: must be > 0 (got {})", name, value);
  }
  if (!(clock_line_sigma_s >= 0) || !std::isfinite(clock_line_sigma_s)) {
    return fmt::format("clock_line_sigma_s: must be >= 0 (got {})", clock_line_sigma_s);
  }
  return {};
}

JointOptimiser::JointOptimiser(Options options) : options_(std::move(options)) {
  if (const std::string why = options_.Error(); !why.empty()) {
    throw std::invalid_argument("JointOptimiser: " + why);
  }
}

namespace {

// The fit of the final solve into `summary`: landmarks, shared landmarks, cross observations,
// the reprojection RMS of all and of the cross observations, the ground ties' RMS.
void SummariseFinalSolve(const JointProblem& problem, const std::vector<JointLandmark>& landmarks,
                         const std::vector<Eigen::Vector3d>& points, const std::vector<int>& ids,
                         const std::vector<std::vector<bool>>& masks,
                         JointOptimiser::Summary* summary) {
  double sum_sq = 0, cross_sq = 0;
  std::int64_t count = 0, cross = 0;
  for (std::size_t l = 0; l < points.size(); ++l) {
    const JointLandmark& landmark = landmarks[ids[l]];
    bool shared = false;
    for (std::size_t o = 0; o < landmark.observations.size(); ++o) {
      if (!masks[l][o]) continue;
      const double e = problem.Error(landmark.observations[o], points[l]);
      if (!std::isfinite(e)) continue;
      sum_sq += e * e;
      ++count;
      if (IsCross(landmark, o)) {
        cross_sq += e * e;
        ++cross;
        shared = true;
      }
    }
    summary->num_shared_landmarks += shared ? 1 : 0;
  }
  summary->num_cross_observations = cross;
  summary->reprojection_rms_px = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
  summary->cross_reprojection_rms_px = cross > 0 ? std::sqrt(cross_sq / cross) : 0.0;
  summary->num_landmarks = static_cast<int>(points.size());
  const Eigen::Vector2d tie_rms = problem.TieRms();
  summary->ground_tie_rms_across_m = tie_rms.x();
  summary->ground_tie_rms_vertical_m = tie_rms.y();
}

// The rig's cameras after the solve with their cross observations; each refined one is counted
// in `summary` and logged.
std::vector<RefinedCalibration> SummariseCalibrations(
    const JointProblem& problem, const std::vector<std::int64_t>& cross_per_camera,
    JointOptimiser::Summary* summary) {
  std::vector<RefinedCalibration> calibrations = problem.Calibrations();
  for (std::size_t c = 0; c < calibrations.size(); ++c) {
    RefinedCalibration& r = calibrations[c];
    r.num_cross_observations = cross_per_camera[c];
    if (!r.refined) continue;
    ++summary->num_cameras_refined;
    spdlog::info(
        "joint problem: camera of {} passes refined from {} cross observations: fx {:+.2f} px, "
        "fy {:+.2f} px, cx {:+.2f} px, cy {:+.2f} px, k1 {:+.4f}, k2 {:+.4f}, T_BS rotation "
        "{:.3f} deg, lever arm ({:+.1f}, {:+.1f}, {:+.1f}) mm",
        r.passes.size(), r.num_cross_observations, r.camera.fx - r.written_camera.fx,
        r.camera.fy - r.written_camera.fy, r.camera.cx - r.written_camera.cx,
        r.camera.cy - r.written_camera.cy, r.camera.k1 - r.written_camera.k1,
        r.camera.k2 - r.written_camera.k2, r.RotationChangeDeg(), 1e3 * r.LeverArmChange().x(),
        1e3 * r.LeverArmChange().y(), 1e3 * r.LeverArmChange().z());
  }
  return calibrations;
}

}  // namespace

JointOptimiser::Result JointOptimiser::Solve(const std::vector<Pass>& passes,
                                             const std::vector<JointLandmark>& landmarks,
                                             const std::vector<JointGroundTie>& ground_ties,
                                             const std::vector<bool>& fixed_passes,
                                             const std::vector<bool>& own_camera_passes,
                                             const std::vector<bool>& camera_follows) const {
  const slam::RowOptimiser::Options& op = options_.row;
  Result result;
  Summary& summary = result.summary;
  summary.num_passes = static_cast<int>(passes.size());
  if (!fixed_passes.empty() && fixed_passes.size() != passes.size()) {
    throw std::invalid_argument("JointOptimiser: fixed_passes does not match the passes");
  }
  if (!own_camera_passes.empty() && own_camera_passes.size() != passes.size()) {
    throw std::invalid_argument("JointOptimiser: own_camera_passes does not match the passes");
  }
  if (!camera_follows.empty() && camera_follows.size() != passes.size()) {
    throw std::invalid_argument("JointOptimiser: camera_follows does not match the passes");
  }
  summary.num_landmarks_given = static_cast<int>(landmarks.size());
  for (const Pass& pass : passes) {
    if (pass.initial_states.size() < 2) {
      throw std::invalid_argument("JointOptimiser: a pass has fewer than 2 states");
    }
    for (std::size_t k = 1; k < pass.initial_states.size(); ++k) {
      if (pass.initial_states[k].t <= pass.initial_states[k - 1].t) {
        throw std::invalid_argument("JointOptimiser: state times not increasing");
      }
    }
    summary.num_states += static_cast<int>(pass.initial_states.size());
  }
  for (const JointLandmark& landmark : landmarks) {
    if (landmark.observations.empty()) {
      throw std::invalid_argument("JointOptimiser: a landmark without observations");
    }
    for (const JointObservation& obs : landmark.observations) {
      if (obs.pass < 0 || obs.pass >= static_cast<int>(passes.size()) ||
          passes[obs.pass].camera == nullptr || obs.state < 0 ||
          obs.state >= static_cast<int>(passes[obs.pass].initial_states.size())) {
        throw std::invalid_argument("JointOptimiser: an observation out of range");
      }
    }
  }

  // The ties' points in the body frames of the given initial states (which the pre-alignment
  // may move: a body-frame point moves with its pass).
  std::vector<BodyTie> ties;
  for (const JointGroundTie& t : ground_ties) {
    const auto valid = [&](int pass, int state) {
      return pass >= 0 && pass < static_cast<int>(passes.size()) && state >= 0 &&
             state < static_cast<int>(passes[pass].initial_states.size());
    };
    if (!valid(t.pass_a, t.tie.state_a) || !valid(t.pass_b, t.tie.state_b)) {
      throw std::invalid_argument("JointOptimiser: a ground tie out of range");
    }
    const auto body = [&](int pass, int state, const Eigen::Vector3d& p) {
      return passes[pass].initial_states[state].nav.world_from_body.Inverse() * p;
    };
    ties.push_back({t.pass_a, t.tie.state_a, t.pass_b, t.tie.state_b,
                    body(t.pass_a, t.tie.state_a, t.tie.point_a),
                    body(t.pass_b, t.tie.state_b, t.tie.point_b), t.tie.across});
  }
  summary.num_ground_ties = static_cast<int>(ties.size());

  // (0) Pre-alignment, on a copy of the inputs whose initial states it moves.
  std::vector<Pass> aligned = passes;
  if (options_.align_passes) {
    AlignPasses(options_, landmarks, ground_ties, fixed_passes, &aligned, &summary);
  }
  JointProblem problem(options_, aligned, std::move(ties), fixed_passes, own_camera_passes);
  problem.Preintegrate();

  // (1) Landmarks from the row-SLAM poses.
  auto start = Clock::now();
  const std::vector<std::vector<geometry::Rigid3>> cameras = problem.CameraPoses();
  std::vector<slam::TriangulationResult> tri(landmarks.size());
  std::vector<std::vector<bool>> masks(landmarks.size());
  tbb::parallel_for(std::size_t{0}, landmarks.size(), [&](std::size_t l) {
    tri[l] = TriangulateJointLandmark(op, passes, cameras, landmarks[l], &masks[l]);
  });
  std::vector<Eigen::Vector3d> points;
  std::vector<int> ids;
  std::vector<std::vector<bool>> keep;
  for (std::size_t l = 0; l < landmarks.size(); ++l) {
    if (!tri[l].ok()) continue;
    for (std::size_t o = 0; o < masks[l].size(); ++o) {
      if (masks[l][o]) continue;
      ++summary.num_rejected_observations;
      if (IsCross(landmarks[l], o)) ++summary.num_rejected_cross_observations;
    }
    points.push_back(tri[l].point_world);
    ids.push_back(static_cast<int>(l));
    keep.push_back(std::move(masks[l]));
  }
  summary.triangulation_seconds = SecondsSince(start);
  const std::vector<std::int64_t> cross_per_camera =
      CrossObservationsPerCamera(problem.RigCameras(), passes.size(), landmarks, ids, keep);
  // The fixed passes that hold the camera they share.
  std::vector<bool> holding = fixed_passes;
  for (std::size_t p = 0; p < holding.size() && !camera_follows.empty(); ++p) {
    holding[p] = holding[p] && !camera_follows[p];
  }
  problem.RefineCameras(CamerasToRefine(options_.calibration, problem.RigCameras(),
                                        cross_per_camera, problem.UsesTimeOffsets(), holding));

  // (2) The whole problem.
  start = Clock::now();
  {
    const ceres::Solver::Summary s = problem.Solve(landmarks, ids, &points, keep, nullptr);
    summary.initial_cost = s.initial_cost;
    summary.iterations += static_cast<int>(s.iterations.size());
    spdlog::trace("joint problem, first solve: {}", s.FullReport());
    spdlog::debug("joint problem, first solve: {}", s.BriefReport());
  }
  summary.solve_seconds = SecondsSince(start);
  spdlog::info("joint problem: {} landmarks, first solve in {:.1f} s", points.size(),
               summary.solve_seconds);

  // (3) Reject (observations, and GPS fixes with the gate on), re-preintegrate, final solve.
  start = Clock::now();
  if (op.gps_gate_chi2 > 0) {
    summary.num_gps_rejected = problem.GateGps(op.gps_gate_chi2);
    if (summary.num_gps_rejected > 0) {
      spdlog::info("joint problem: GPS outlier gate dropped {} fixes", summary.num_gps_rejected);
    }
  }
  std::vector<Eigen::Vector3d> kept_points;
  std::vector<int> kept_ids;
  std::vector<std::vector<bool>> kept_masks;
  for (std::size_t l = 0; l < points.size(); ++l) {
    const JointLandmark& landmark = landmarks[ids[l]];
    std::vector<bool> mask = keep[l];
    int good = 0;
    for (std::size_t o = 0; o < mask.size(); ++o) {
      if (!mask[o]) continue;
      mask[o] = problem.Error(landmark.observations[o], points[l]) <= op.max_reprojection_error_px;
      if (mask[o]) {
        ++good;
      } else {
        ++summary.num_rejected_observations;
        if (IsCross(landmark, o)) ++summary.num_rejected_cross_observations;
      }
    }
    if (good < op.min_observations) {
      summary.num_rejected_observations += good;
      continue;
    }
    kept_points.push_back(points[l]);
    kept_ids.push_back(ids[l]);
    kept_masks.push_back(std::move(mask));
  }
  problem.Preintegrate();
  {
    const ceres::Solver::Summary s =
        problem.Solve(landmarks, kept_ids, &kept_points, kept_masks, &summary.num_observations);
    summary.final_cost = s.final_cost;
    summary.iterations += static_cast<int>(s.iterations.size());
    summary.converged = s.termination_type == ceres::CONVERGENCE;
  }
  summary.final_solve_seconds = SecondsSince(start);
  for (std::size_t p = 0; p < passes.size(); ++p) {
    const std::optional<double> td = problem.TimeOffset(p);
    result.time_offsets_s.push_back(td);
    if (!td) continue;
    if (problem.EstimatesTimeOffset(p) && (fixed_passes.empty() || !fixed_passes[p])) {
      ++summary.num_time_offsets_estimated;
      spdlog::debug("joint problem: pass {} camera-IMU time offset {:+.2f} ms (given {:+.2f} ms)",
                    p, 1e3 * *td, 1e3 * passes[p].time_offset_s.value_or(0.0));
    } else {
      ++summary.num_time_offsets_held;
    }
  }
  result.clock_lines = problem.ClockLines();
  for (const ClockLine& line : result.clock_lines) {
    spdlog::info(
        "joint problem: clock {} of {} passes: time offset {:+.2f} ms at its first pass's start, "
        "drift {:+.1f} ppm",
        line.clock, line.passes.size(), 1e3 * line.offset_s, 1e6 * line.drift);
  }

  SummariseFinalSolve(problem, landmarks, kept_points, kept_ids, kept_masks, &summary);
  result.calibrations = SummariseCalibrations(problem, cross_per_camera, &summary);
  result.states = problem.States();
  result.cameras = problem.CameraPoses();
  result.landmarks_world = std::move(kept_points);
  result.landmark_ids = std::move(kept_ids);
  result.observations_kept = std::move(kept_masks);
  return result;
}

}  // namespace crop4d::fusion
