#include "crop4d/slam/pass_graph.h"

#include <ceres/normal_prior.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <functional>
#include <mutex>
#include <stdexcept>
#include <thread>

#include "crop4d/core/error.h"
#include "crop4d/slam/camera_height_scale.h"
#include "crop4d/slam/gps_factor.h"
#include "crop4d/slam/motion_constraint_factor.h"
#include "crop4d/slam/pose_prior_factor.h"
#include "crop4d/slam/reprojection_factor.h"
#include "crop4d/slam/standstill.h"
#include "crop4d/slam/tilt_prior_factor.h"
#include "crop4d/slam/time_offset_reprojection_factor.h"

// OpenBLAS's thread count (CMakeLists.txt links SuiteSparse to OpenBLAS); weak, so that
// another BLAS links too.
extern "C" void openblas_set_num_threads(int num_threads) __attribute__((weak));

namespace crop4d::slam {
namespace {

// One BLAS thread. OpenBLAS starts a thread per core whose idle threads spin; beside Ceres' and
// oneTBB's own threads (and two test or stage processes side by side) they oversubscribe the
// cores: a row-SLAM test took 12.8 s alone (4.4 s of system time) and 2.4x as long beside
// another. One thread: 11.1 s (0.65 s); the demo's joint solve, which has the largest
// supernodes, is 6 % slower (41.8 -> 44.5 s).
void UseOneBlasThread() {
  static std::once_flag once;
  std::call_once(once, [] {
    if (openblas_set_num_threads != nullptr) openblas_set_num_threads(1);
  });
}

// True when the samples cover [t_i, t_j] with no two consecutive samples (including the last
// one at or before t_i and the first at or after t_j) further apart than max_gap.
bool ImuCovers(const std::vector<ImuSample>& samples, Timestamp t_i, Timestamp t_j,
               Timestamp max_gap) {
  if (samples.empty() || samples.front().timestamp > t_i || samples.back().timestamp < t_j) {
    return false;
  }
  auto it = std::upper_bound(samples.begin(), samples.end(), t_i,
                             [](Timestamp t, const ImuSample& s) { return t < s.timestamp; });
  --it;  // last sample at or before t_i
  for (; it + 1 != samples.end() && it->timestamp < t_j; ++it) {
    if ((it + 1)->timestamp - it->timestamp > max_gap) return false;
  }
  return true;
}

}  // namespace

StateBlocks ToBlocks(const RowState& s) {
  StateBlocks b;
  const Vector7d pose = PoseToBlock(s.nav.world_from_body);
  std::copy(pose.data(), pose.data() + 7, b.pose);
  for (int k = 0; k < 3; ++k) {
    b.vel[k] = s.nav.vel_world(k);
    b.rate[k] = s.nav.rate_body(k);
  }
  for (int k = 0; k < 6; ++k) b.bias[k] = s.bias(k);
  return b;
}

RowState FromBlocks(Timestamp t, const StateBlocks& b) {
  RowState s;
  s.t = t;
  s.nav.world_from_body = BlockToPose(b.pose);
  s.nav.vel_world = Eigen::Vector3d(b.vel[0], b.vel[1], b.vel[2]);
  s.nav.rate_body = Eigen::Vector3d(b.rate[0], b.rate[1], b.rate[2]);
  s.bias = Eigen::Map<const Vector6d>(b.bias);
  return s;
}

PassGraph::PassGraph(const RowOptimiser::Options& options, const RowOptimiser::Input& input,
                     std::span<StateBlocks> blocks)
    : options_(options), input_(input), blocks_(blocks) {
  time_offset_s_ = input.time_offset_s.value_or(0.0);
  if (estimates_time_offset()) {
    time_offset_s_ =
        std::clamp(time_offset_s_, -options.max_abs_time_offset_s, options.max_abs_time_offset_s);
  }
  reprojection_loss_ = std::make_unique<ceres::HuberLoss>(options.reprojection_loss_scale);
  gps_loss_ = std::make_unique<ceres::HuberLoss>(options.gps_loss_scale);
  CROP4D_CHECK_MSG(
      input.image_sharpness.empty() || input.image_sharpness.size() == input.initial_states.size(),
      "image_sharpness: one value per state, or none");
  if (!input.image_sharpness.empty()) {
    image_sigma_scales_ = ImageSigmaScales(input.image_sharpness, options.image_weighting);
  }
}

// (Re)integrates the IMU between consecutive states at each state's current bias estimate.
void PassGraph::Preintegrate(RowOptimiser::Summary* summary) {
  const std::size_t n = blocks_.size();
  preintegrations_.assign(n > 0 ? n - 1 : 0, std::nullopt);
  if (!has_imu()) return;
  const Timestamp max_gap = SecondsToTimestamp(options_.max_imu_gap_s);
  int gaps = 0;
  for (std::size_t k = 0; k + 1 < n; ++k) {
    const Timestamp t_i = input_.initial_states[k].t, t_j = input_.initial_states[k + 1].t;
    if (!ImuCovers(*input_.imu_samples, t_i, t_j, max_gap)) {
      ++gaps;
      continue;
    }
    ImuPreintegration pre(input_.imu_noise, Eigen::Map<const Vector6d>(blocks_[k].bias));
    pre.Integrate(*input_.imu_samples, t_i, t_j);
    preintegrations_[k] = std::move(pre);
  }
  if (summary != nullptr) {
    summary->num_imu_gaps = gaps;
    summary->num_imu_factors = static_cast<int>(n - 1) - gaps;
  }
}

// States, motion factors (IMU, bias walk, rate, GP prior), GPS and the priors.
void PassGraph::AddMotion(ceres::Problem* problem, RowOptimiser::Summary* summary) const {
  const std::size_t n = blocks_.size();
  for (StateBlocks& b : blocks_) {
    problem->AddParameterBlock(b.pose, kPoseSize, &pose_manifold_);
    problem->AddParameterBlock(b.vel, kVelocitySize);
    problem->AddParameterBlock(b.rate, kRateSize);
    problem->AddParameterBlock(b.bias, kBiasSize);
  }
  const std::vector<RowState>& st = input_.initial_states;
  const double sigma_rate =
      input_.imu_noise.gyro_noise_density * std::sqrt(std::max(input_.imu_rate_hz, 1.0));
  for (std::size_t k = 0; k < n; ++k) {
    StateBlocks& b = blocks_[k];
    if (has_imu() && st[k].t >= input_.imu_samples->front().timestamp &&
        st[k].t <= input_.imu_samples->back().timestamp) {
      const ImuSample gyro = InterpolateImu(*input_.imu_samples, st[k].t);
      problem->AddResidualBlock(AngularRateFactor::Create(gyro.gyro_body, sigma_rate), nullptr,
                                b.rate, b.bias);
    }
    if (k + 1 == n) break;
    StateBlocks& c = blocks_[k + 1];
    const double dt = DurationSeconds(st[k].t, st[k + 1].t);
    problem->AddResidualBlock(GpPriorFactor::Create(options_.gp, dt), nullptr, b.pose, b.vel,
                              b.rate, c.pose, c.vel, c.rate);
    if (has_imu()) {
      problem->AddResidualBlock(
          BiasRandomWalkFactor::Create(input_.imu_noise.gyro_random_walk,
                                       input_.imu_noise.accel_random_walk, dt),
          nullptr, b.bias, c.bias);
      if (preintegrations_[k]) {
        problem->AddResidualBlock(ImuFactor::Create(*preintegrations_[k]), nullptr, b.pose, b.vel,
                                  b.bias, c.pose, c.vel);
      }
    }
  }
  if (n == 0) return;
  if (input_.length_prior_m && n >= 2) {
    problem->AddResidualBlock(
        PassLengthFactor::Create(*input_.length_prior_m, input_.length_prior_sigma_m), nullptr,
        blocks_.front().pose, blocks_.back().pose);
  }
  if (input_.forward_axis_body) {
    for (StateBlocks& b : blocks_) {
      problem->AddResidualBlock(MotionConstraintFactor::Create(*input_.forward_axis_body,
                                                               options_.motion_constraint_sigma),
                                nullptr, b.pose, b.vel);
    }
  }
  if (has_imu()) {
    // Weak prior on the turn-on bias.
    Eigen::Matrix<double, 6, 6> A = Eigen::Matrix<double, 6, 6>::Zero();
    if (input_.bias_prior_sigma) {
      A.diagonal() = input_.bias_prior_sigma->cwiseInverse();
    } else {
      A.diagonal() << Eigen::Vector3d::Constant(1.0 / options_.bias_prior_sigma_gyro),
          Eigen::Vector3d::Constant(1.0 / options_.bias_prior_sigma_accel);
    }
    problem->AddResidualBlock(new ceres::NormalPrior(A, input_.bias_prior_mean), nullptr,
                              blocks_[0].bias);
  } else {
    for (StateBlocks& b : blocks_) problem->SetParameterBlockConstant(b.bias);
    if (input_.level_up_body) {
      for (StateBlocks& b : blocks_) {
        problem->AddResidualBlock(
            TiltPriorFactor::Create(*input_.level_up_body, options_.level_prior_sigma_rad), nullptr,
            b.pose);
      }
    }
  }
  AddStandstills(problem, summary);
  int gps_factors = 0;
  ForEachGpsFix([&](std::size_t i, const GpsMeasurement& m, double dt, double s, std::size_t) {
    const std::size_t j = i + 1;
    problem->AddResidualBlock(GpsInterpolatedFactor::Create(m, input_.p_body_antenna, dt, s),
                              gps_loss_.get(), blocks_[i].pose, blocks_[i].vel, blocks_[i].rate,
                              blocks_[j].pose, blocks_[j].vel, blocks_[j].rate);
    ++gps_factors;
  });
  if (summary != nullptr) summary->num_gps_factors = gps_factors;
  if (gps_factors == 0) {
    const std::size_t anchor = std::min<std::size_t>(input_.anchor_state, n - 1);
    // The gauge: position, heading and velocity of the first state as initialised.
    problem->AddResidualBlock(
        PosePriorFactor::Create(input_.initial_states[anchor].nav.world_from_body,
                                options_.anchor_sigma_position, options_.anchor_sigma_rotation),
        nullptr, blocks_[anchor].pose);
    const Eigen::Matrix3d A = Eigen::Matrix3d::Identity() /
                              input_.anchor_sigma_velocity.value_or(options_.anchor_sigma_velocity);
    problem->AddResidualBlock(
        new ceres::NormalPrior(A, input_.initial_states[anchor].nav.vel_world), nullptr,
        blocks_[anchor].vel);
  }
}

template <typename F>
void PassGraph::ForEachGpsFix(F&& f) const {
  const std::vector<RowState>& st = input_.initial_states;
  const std::size_t n = st.size();
  for (std::size_t index = 0; index < input_.gps_fixes.size(); ++index) {
    const GpsFixWorld& fix = input_.gps_fixes[index];
    if (n < 2 || fix.t < st.front().t || fix.t > st.back().t) continue;
    if (!gps_rejected_.empty() && gps_rejected_[index]) continue;
    // The states i, j = i + 1 around the fix: t_i ≤ τ ≤ t_j.
    std::size_t j = std::lower_bound(st.begin(), st.end(), fix.t,
                                     [](const RowState& s, Timestamp t) { return s.t < t; }) -
                    st.begin();
    if (j == 0) j = 1;
    if (j >= n) continue;
    const std::size_t i = j - 1;
    GpsMeasurement m;
    m.position_world = fix.position_world;
    m.sigma_horizontal = std::max(fix.sigma_h, 1e-3);
    m.sigma_vertical = std::max(fix.sigma_v, 1e-3);
    const double dt = DurationSeconds(st[i].t, st[j].t);
    f(i, m, dt, std::clamp(DurationSeconds(st[i].t, fix.t), 0.0, dt), index);
  }
}

int PassGraph::GateGps(double chi2) {
  std::vector<std::pair<double, std::size_t>> excess;  // squared norm, fix index
  std::size_t inside = 0;
  ForEachGpsFix([&](std::size_t i, const GpsMeasurement& m, double dt, double s, std::size_t k) {
    const GpsInterpolatedFactor factor(m, input_.p_body_antenna, dt, s);
    const StateBlocks& a = blocks_[i];
    const StateBlocks& b = blocks_[i + 1];
    Eigen::Vector3d r;
    factor(a.pose, a.vel, a.rate, b.pose, b.vel, b.rate, r.data());
    ++inside;
    if (r.squaredNorm() > chi2) excess.emplace_back(r.squaredNorm(), k);
  });
  if (gps_rejected_.empty()) gps_rejected_.assign(input_.gps_fixes.size(), false);
  int already = 0;
  for (bool r : gps_rejected_) already += r ? 1 : 0;
  const std::size_t total = inside + static_cast<std::size_t>(already);
  std::sort(excess.begin(), excess.end(), std::greater<>());
  int dropped = 0;
  for (const auto& [norm, k] : excess) {
    if (2 * static_cast<std::size_t>(already + dropped + 1) > total) break;
    gps_rejected_[k] = true;
    ++dropped;
  }
  return dropped;
}

std::vector<Eigen::Vector3d> PassGraph::GpsNormalisedResiduals() const {
  std::vector<Eigen::Vector3d> residuals;
  ForEachGpsFix([&](std::size_t i, const GpsMeasurement& m, double dt, double s, std::size_t) {
    const GpsInterpolatedFactor factor(m, input_.p_body_antenna, dt, s);
    const StateBlocks& a = blocks_[i];
    const StateBlocks& b = blocks_[i + 1];
    Eigen::Vector3d r;
    factor(a.pose, a.vel, a.rate, b.pose, b.vel, b.rate, r.data());
    residuals.push_back(r);
  });
  return residuals;
}

// Over each still interval: the two poses are one; the velocity and the angular rate of its
// states are zero.
void PassGraph::AddStandstills(ceres::Problem* problem, RowOptimiser::Summary* summary) const {
  const std::vector<bool>& still = input_.still_intervals;
  if (still.empty()) return;
  if (still.size() + 1 != blocks_.size()) {
    throw std::invalid_argument("RowOptimiser: still_intervals needs one entry per interval");
  }
  const StandstillOptions& o = options_.standstill;
  std::vector<bool> still_state(blocks_.size(), false);
  int count = 0;
  for (std::size_t k = 0; k < still.size(); ++k) {
    if (!still[k]) continue;
    problem->AddResidualBlock(StandstillPoseFactor::Create(o.sigma_translation, o.sigma_rotation),
                              nullptr, blocks_[k].pose, blocks_[k + 1].pose);
    still_state[k] = still_state[k + 1] = true;
    ++count;
  }
  const Eigen::Matrix3d velocity_information = Eigen::Matrix3d::Identity() / o.sigma_velocity;
  const Eigen::Matrix3d rate_information = Eigen::Matrix3d::Identity() / o.sigma_rate;
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    if (!still_state[k]) continue;
    problem->AddResidualBlock(new ceres::NormalPrior(velocity_information, Eigen::Vector3d::Zero()),
                              nullptr, blocks_[k].vel);
    problem->AddResidualBlock(new ceres::NormalPrior(rate_information, Eigen::Vector3d::Zero()),
                              nullptr, blocks_[k].rate);
  }
  if (summary != nullptr) summary->num_still_intervals = count;
}

// Reprojection factors of the landmarks (observations with keep[l][o] true).
std::int64_t PassGraph::AddLandmarks(ceres::Problem* problem,
                                     std::vector<Eigen::Vector3d>* landmarks,
                                     const std::vector<int>& tracks,
                                     const std::vector<std::vector<bool>>& keep) const {
  std::int64_t count = 0;
  for (std::size_t l = 0; l < landmarks->size(); ++l) {
    const LandmarkTrack& track = input_.tracks[tracks[l]];
    for (std::size_t o = 0; o < track.observations.size(); ++o) {
      if (!keep[l][o]) continue;
      const LandmarkObservation& obs = track.observations[o];
      AddObservation(problem, obs.state, obs.pixel, (*landmarks)[l].data());
      ++count;
    }
  }
  return count;
}

void PassGraph::AddObservation(ceres::Problem* problem, std::size_t state,
                               const Eigen::Vector2d& pixel, double* point_world) const {
  StateBlocks& b = blocks_[state];
  const double sigma_px = options_.reprojection_sigma_px * ImageSigmaScale(state);
  if (!uses_time_offset() && calibration_ == nullptr) {
    problem->AddResidualBlock(
        ReprojectionFactor::Create(*input_.camera, input_.body_from_camera, pixel, sigma_px),
        reprojection_loss_.get(), b.pose, point_world);
    return;
  }
  if (!problem->HasParameterBlock(&time_offset_s_)) {
    problem->AddParameterBlock(&time_offset_s_, 1);
    if (estimates_time_offset()) {
      problem->SetParameterLowerBound(&time_offset_s_, 0, -options_.max_abs_time_offset_s);
      problem->SetParameterUpperBound(&time_offset_s_, 0, options_.max_abs_time_offset_s);
      const Eigen::Matrix<double, 1, 1> information(1.0 / options_.time_offset_prior_sigma_s);
      problem->AddResidualBlock(
          new ceres::NormalPrior(information, Eigen::Matrix<double, 1, 1>::Zero()), nullptr,
          &time_offset_s_);
    } else {
      problem->SetParameterBlockConstant(&time_offset_s_);
    }
  }
  // The state's velocity and rate as they are when the problem is built: a factor on them too
  // would couple them all through the landmarks' Schur complement, for an effect of order
  // td · (their change) (time_offset_reprojection_factor.h).
  TimeOffsetReprojectionFactor::FixedMotion motion;
  motion.vel_world = Eigen::Map<const Eigen::Vector3d>(b.vel);
  motion.rate_body = Eigen::Map<const Eigen::Vector3d>(b.rate);
  if (calibration_ != nullptr) {
    problem->AddResidualBlock(new CalibratedReprojectionFactor(
                                  *input_.camera, input_.body_from_camera, pixel, sigma_px, motion),
                              reprojection_loss_.get(), b.pose, point_world, &time_offset_s_,
                              calibration_->intrinsics, calibration_->rotation,
                              calibration_->lever_arm);
    return;
  }
  problem->AddResidualBlock(TimeOffsetReprojectionFactor::Create(
                                *input_.camera, input_.body_from_camera, pixel, sigma_px, motion),
                            reprojection_loss_.get(), b.pose, point_world, &time_offset_s_);
}

geometry::Rigid3 PassGraph::BodyAtCapture(std::size_t k) const {
  const StateBlocks& b = blocks_[k];
  if (!uses_time_offset()) return BlockToPose(b.pose);
  return slam::BodyAtCapture(BlockToPose(b.pose), Eigen::Map<const Eigen::Vector3d>(b.vel),
                             Eigen::Map<const Eigen::Vector3d>(b.rate), time_offset_s_);
}

std::vector<geometry::Rigid3> PassGraph::CapturePoses() const {
  const geometry::Rigid3 body_from_camera = BodyFromCamera();
  std::vector<geometry::Rigid3> poses;
  poses.reserve(blocks_.size());
  for (std::size_t k = 0; k < blocks_.size(); ++k) {
    poses.push_back(BodyAtCapture(k) * body_from_camera);
  }
  return poses;
}

geometry::PinholeRadTan PassGraph::Camera() const {
  if (input_.camera == nullptr) return {};
  return calibration_ != nullptr ? calibration_->Camera(*input_.camera) : *input_.camera;
}

geometry::Rigid3 PassGraph::BodyFromCamera() const {
  return calibration_ != nullptr ? calibration_->BodyFromCamera(input_.body_from_camera)
                                 : input_.body_from_camera;
}

ceres::Problem::Options ProblemOptions() {
  ceres::Problem::Options o;
  // Manifolds and losses are shared between blocks and owned by the builder.
  o.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  o.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  return o;
}

ceres::Solver::Summary RunSolver(const RowOptimiser::Options& options, ceres::Problem* problem,
                                 const std::vector<double*>& schur_blocks,
                                 const std::vector<double*>& last_blocks) {
  ceres::Solver::Options so;
  so.max_num_iterations = options.max_iterations;
  so.function_tolerance = options.function_tolerance;
  so.num_threads = options.num_threads > 0 ? options.num_threads
                                           : static_cast<int>(std::thread::hardware_concurrency());
  so.logging_type = ceres::SILENT;
  so.minimizer_progress_to_stdout = false;
  if (!schur_blocks.empty()) {
    // Landmarks first: eliminated by the Schur complement.
    if (options.iterative_schur) {
      so.linear_solver_type = ceres::ITERATIVE_SCHUR;
      so.preconditioner_type = ceres::SCHUR_JACOBI;
      so.max_linear_solver_iterations = options.max_linear_iterations;
    } else {
      so.linear_solver_type = ceres::SPARSE_SCHUR;
    }
    auto ordering = std::make_shared<ceres::ParameterBlockOrdering>();
    std::vector<double*> blocks;
    problem->GetParameterBlocks(&blocks);
    for (double* block : blocks) ordering->AddElementToGroup(block, 1);
    for (double* block : schur_blocks) ordering->AddElementToGroup(block, 0);
    int group = 2;
    for (double* block : last_blocks) {
      if (problem->HasParameterBlock(block)) ordering->AddElementToGroup(block, group++);
    }
    so.linear_solver_ordering = ordering;
  } else {
    so.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  }
  ceres::Solver::Summary summary;
  UseOneBlasThread();
  ceres::Solve(so, problem, &summary);
  if (spdlog::should_log(spdlog::level::trace)) {
    for (const ceres::IterationSummary& it : summary.iterations) {
      spdlog::trace(
          "solver iteration {:3d}: cost {:.6e}, change {:.3e}, step {:.3e}, {} linear "
          "iterations, {}, {:.2f} s",
          it.iteration, it.cost, it.cost_change, it.step_norm, it.linear_solver_iterations,
          it.step_is_successful ? "accepted" : "rejected", it.cumulative_time_in_seconds);
    }
  }
  return summary;
}

ceres::Solver::Summary RunSolver(const RowOptimiser::Options& options, ceres::Problem* problem,
                                 std::vector<Eigen::Vector3d>* landmarks,
                                 const std::vector<double*>& last_blocks) {
  std::vector<double*> blocks;
  if (landmarks != nullptr) {
    for (Eigen::Vector3d& p : *landmarks) blocks.push_back(p.data());
  }
  return RunSolver(options, problem, blocks, last_blocks);
}

std::vector<geometry::Rigid3> CameraPoses(std::span<const StateBlocks> blocks,
                                          const geometry::Rigid3& body_from_camera) {
  std::vector<geometry::Rigid3> poses;
  poses.reserve(blocks.size());
  for (const StateBlocks& b : blocks) poses.push_back(BlockToPose(b.pose) * body_from_camera);
  return poses;
}

}  // namespace crop4d::slam
