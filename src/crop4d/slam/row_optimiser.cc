#include "crop4d/slam/row_optimiser.h"

#include <ceres/ceres.h>
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <stdexcept>
#include <thread>
#include <utility>

#include "crop4d/core/stopwatch.h"
#include "crop4d/slam/pass_graph.h"
#include "crop4d/slam/reprojection_factor.h"

namespace crop4d::slam {
namespace {

using Clock = std::chrono::steady_clock;

// Rounds of the GPS outlier gate after the solve without the camera (Options::gps_gate_chi2).
constexpr int kGpsGateRounds = 3;

// Phase 4 (Input::camera_height_m): the soil's depth below the camera gives the pass's scale; the
// pass (states and landmarks) is scaled about its mean position to it, and solved once more with
// its length held there.
void ApplyCameraHeight(const RowOptimiser::Options& options, const RowOptimiser::Input& input,
                       const std::vector<int>& tracks, const std::vector<std::vector<bool>>& masks,
                       PassGraph* builder, std::vector<StateBlocks>* blocks,
                       std::vector<Eigen::Vector3d>* landmarks, RowOptimiser::Summary* summary) {
  const std::vector<geometry::Rigid3> cameras = builder->CapturePoses();
  std::vector<Eigen::Vector3d> centres;
  for (const geometry::Rigid3& c : cameras) centres.push_back(c.translation());
  std::vector<TriangulationResult> tri(input.depth_tracks.size());
  tbb::parallel_for(std::size_t{0}, input.depth_tracks.size(), [&](std::size_t i) {
    std::vector<geometry::Rigid3> views;
    std::vector<Eigen::Vector2d> pixels;
    for (const LandmarkObservation& obs : input.depth_tracks[i].observations) {
      views.push_back(cameras[obs.state]);
      pixels.push_back(obs.pixel);
    }
    tri[i] = TriangulatePoint(*input.camera, views, pixels, options.camera_height.triangulation);
  });
  std::vector<Eigen::Vector3d> points;
  std::vector<std::array<std::uint8_t, 3>> colors;
  for (std::size_t i = 0; i < tri.size(); ++i) {
    if (!tri[i].ok()) continue;
    points.push_back(tri[i].point_world);
    colors.push_back(input.depth_tracks[i].color);
  }
  const std::optional<SoilDepth> depth =
      SoilDepthBelowCamera(centres, points, colors, options.camera_height);
  if (!depth || !(depth->depth_m > 0)) {
    spdlog::warn(
        "too few soil points below the camera ({} needed): the camera height does not set "
        "this pass's scale",
        options.camera_height.min_points);
    return;
  }
  const double scale = *input.camera_height_m / depth->depth_m;
  summary->soil_depth_m = depth->depth_m;
  summary->soil_points = depth->num_points;
  if (std::abs(scale - 1.0) > options.camera_height.max_scale_change) {
    spdlog::warn(
        "the soil lies {:.3f} m below the camera, not the {:.3f} m given as the camera height: a "
        "scale change of {:+.1f} %, beyond {:.0f} %, is not applied (is the height right?)",
        depth->depth_m, *input.camera_height_m, 100.0 * (scale - 1.0),
        100.0 * options.camera_height.max_scale_change);
    return;
  }
  summary->camera_height_scale = scale;
  Eigen::Vector3d centre = Eigen::Vector3d::Zero();
  for (const StateBlocks& b : *blocks) centre += Eigen::Map<const Eigen::Vector3d>(b.pose);
  centre /= static_cast<double>(blocks->size());
  for (StateBlocks& b : *blocks) {
    Eigen::Map<Eigen::Vector3d> p(b.pose);
    p = centre + scale * (p - centre);
    Eigen::Map<Eigen::Vector3d>(b.vel) *= scale;
  }
  for (Eigen::Vector3d& l : *landmarks) l = centre + scale * (l - centre);
  const double length = (Eigen::Map<const Eigen::Vector3d>(blocks->back().pose) -
                         Eigen::Map<const Eigen::Vector3d>(blocks->front().pose))
                            .norm();
  if (!(length > 0)) return;
  summary->length_prior_m = length;
  summary->length_prior_sigma_m = options.camera_height.sigma_relative * length;
  ceres::Problem problem(ProblemOptions());
  builder->AddMotion(&problem, summary);
  builder->AddLandmarks(&problem, landmarks, tracks, masks);
  problem.AddResidualBlock(PassLengthFactor::Create(length, summary->length_prior_sigma_m), nullptr,
                           blocks->front().pose, blocks->back().pose);
  const ceres::Solver::Summary s = RunSolver(options, &problem, landmarks);
  summary->final_cost = s.final_cost;
  summary->iterations += static_cast<int>(s.iterations.size());
  summary->converged = s.termination_type == ceres::CONVERGENCE;
}

}  // namespace

OptionCheck RowOptimiser::Options::Check() const {
  const auto positive = [](const char* name, double value) -> std::string {
    return value > 0 ? std::string() : fmt::format("{}: must be > 0 (got {})", name, value);
  };
  for (const auto& [name, value] :
       {std::pair{"reprojection_sigma_px", reprojection_sigma_px},
        std::pair{"reprojection_loss_scale", reprojection_loss_scale},
        std::pair{"max_reprojection_error_px", max_reprojection_error_px},
        std::pair{"gps_loss_scale", gps_loss_scale},
        std::pair{"bias_prior_sigma_gyro", bias_prior_sigma_gyro},
        std::pair{"bias_prior_sigma_accel", bias_prior_sigma_accel},
        std::pair{"anchor_sigma_position", anchor_sigma_position},
        std::pair{"anchor_sigma_rotation", anchor_sigma_rotation},
        std::pair{"anchor_sigma_velocity", anchor_sigma_velocity},
        std::pair{"motion_constraint_sigma", motion_constraint_sigma},
        std::pair{"level_prior_sigma_rad", level_prior_sigma_rad},
        std::pair{"max_imu_gap_s", max_imu_gap_s},
        std::pair{"time_offset_prior_sigma_s", time_offset_prior_sigma_s}}) {
    if (std::string why = positive(name, value); !why.empty()) return why;
  }
  if (min_observations < 2) {
    return fmt::format("min_observations: must be >= 2 (got {})", min_observations);
  }
  if (max_outliers_per_track < 0) {
    return fmt::format("max_outliers_per_track: must be >= 0 (got {})", max_outliers_per_track);
  }
  if (max_iterations <= 0)
    return fmt::format("max_iterations: must be > 0 (got {})", max_iterations);
  if (max_linear_iterations <= 0) {
    return fmt::format("max_linear_iterations: must be > 0 (got {})", max_linear_iterations);
  }
  if (!(function_tolerance > 0 && function_tolerance < 1)) {
    return fmt::format("function_tolerance: must be in (0, 1) (got {})", function_tolerance);
  }
  if (num_threads < 0) return fmt::format("num_threads: must be >= 0 (got {})", num_threads);
  if (!(gps_gate_chi2 >= 0)) {
    return fmt::format("gps_gate_chi2: must be >= 0 (0: off) (got {})", gps_gate_chi2);
  }
  // Beyond a second the first-order prediction of the pose from its state is meaningless.
  if (!(max_abs_time_offset_s > 0 && max_abs_time_offset_s <= 1.0)) {
    return fmt::format("max_abs_time_offset_s: must be in (0, 1] s (got {})",
                       max_abs_time_offset_s);
  }
  OptionChecker nested;
  nested.Nested("triangulation", triangulation.Check())
      .Nested("gp", gp.Check())
      .Nested("camera_height", camera_height.Check())
      .Nested("standstill", standstill.Check())
      .Nested("image_weighting", image_weighting.Check());
  return nested.Result();
}

RowOptimiser::RowOptimiser(Options options) : options_(std::move(options)) {
  const std::string error = options_.Error();
  if (!error.empty()) throw std::invalid_argument("RowOptimiser: " + error);
}

RowOptimiser::Result RowOptimiser::Solve(const Input& input) const {
  Result result;
  Summary& summary = result.summary;
  const std::size_t n = input.initial_states.size();
  summary.num_states = static_cast<int>(n);
  summary.num_tracks = static_cast<int>(input.tracks.size());
  if (n < 2) throw std::invalid_argument("RowOptimiser: fewer than 2 states");
  for (std::size_t k = 1; k < n; ++k) {
    if (input.initial_states[k].t <= input.initial_states[k - 1].t) {
      throw std::invalid_argument("RowOptimiser: state times not increasing");
    }
  }
  std::vector<StateBlocks> blocks;
  blocks.reserve(n);
  for (const RowState& s : input.initial_states) blocks.push_back(ToBlocks(s));
  PassGraph builder(options_, input, blocks);
  for (std::size_t k = 0; k < n; ++k) {
    const double scale = builder.ImageSigmaScale(k);
    summary.num_downweighted_images += scale > 1.1;
    summary.max_image_sigma_scale = std::max(summary.max_image_sigma_scale, scale);
  }
  builder.Preintegrate(&summary);
  if (summary.num_imu_gaps > 0) {
    spdlog::warn(
        "{} of {} intervals have an IMU gap: no IMU factor there (the GP prior bridges "
        "them)",
        summary.num_imu_gaps, n - 1);
  }

  // Phase 1: IMU + GP + GPS, no camera. Skipped without an IMU when there is a camera: the GP
  // prior and the fixes alone observe no rotation and would only undo the initial guess's, which
  // then comes from the images (visual_initialisation.h).
  auto start = Clock::now();
  const bool use_camera = input.camera != nullptr && !input.tracks.empty();
  if (!use_camera || (builder.has_gps() && builder.has_imu())) {
    ceres::Problem problem(ProblemOptions());
    builder.AddMotion(&problem, &summary);
    const ceres::Solver::Summary s = RunSolver(options_, &problem, nullptr);
    summary.iterations += static_cast<int>(s.iterations.size());
    summary.initial_cost = s.initial_cost;
    summary.final_cost = s.final_cost;
    summary.converged = s.termination_type == ceres::CONVERGENCE;
    builder.Preintegrate(&summary);
    // The outlier gate: the trajectory of a solve is pulled a little towards every outlier, so
    // the worst are dropped, the motion solved again without them, and the gate applied again
    // (a few rounds).
    for (int round = 0; round < kGpsGateRounds && options_.gps_gate_chi2 > 0; ++round) {
      const int dropped = builder.GateGps(options_.gps_gate_chi2);
      summary.num_gps_rejected += dropped;
      if (dropped == 0) break;
      ceres::Problem again(ProblemOptions());
      builder.AddMotion(&again, &summary);
      const ceres::Solver::Summary a = RunSolver(options_, &again, nullptr);
      summary.iterations += static_cast<int>(a.iterations.size());
    }
    if (input.camera == nullptr || input.tracks.empty()) {
      // Without a camera this is the final solve: once more at the re-preintegrated biases.
      ceres::Problem final_problem(ProblemOptions());
      builder.AddMotion(&final_problem, &summary);
      const ceres::Solver::Summary f = RunSolver(options_, &final_problem, nullptr);
      summary.iterations += static_cast<int>(f.iterations.size());
      summary.final_cost = f.final_cost;
      summary.converged = f.termination_type == ceres::CONVERGENCE;
    }
  }
  summary.inertial_seconds = SecondsSince(start);

  if (use_camera) {
    // Phase 2: landmarks from the current poses, then the full problem.
    start = Clock::now();
    std::vector<geometry::Rigid3> cameras = builder.CapturePoses();
    std::vector<Eigen::Vector3d> landmarks;
    std::vector<int> tracks;
    std::vector<std::vector<bool>> keep;
    for (std::size_t t = 0; t < input.tracks.size(); ++t) {
      const LandmarkTrack& track = input.tracks[t];
      // A track with an outlier observation (above the triangulation's error bound) loses its
      // worst view and is triangulated again, a few times at most.
      std::vector<geometry::Rigid3> poses;
      std::vector<Eigen::Vector2d> pixels;
      for (const LandmarkObservation& obs : track.observations) {
        poses.push_back(cameras[obs.state]);
        pixels.push_back(obs.pixel);
      }
      std::vector<bool> mask;
      const TriangulationResult tri = TriangulateDroppingWorstViews(
          *input.camera, poses, pixels, options_.triangulation, options_.max_outliers_per_track,
          options_.min_observations, &mask);
      const int remaining = static_cast<int>(std::count(mask.begin(), mask.end(), true));
      if (tri.status != TriangulationStatus::kOk) continue;
      summary.num_rejected_observations += static_cast<int>(track.observations.size()) - remaining;
      landmarks.push_back(tri.point_world);
      tracks.push_back(static_cast<int>(t));
      keep.push_back(std::move(mask));
    }
    summary.num_landmarks_triangulated = static_cast<int>(landmarks.size());
    summary.triangulation_seconds = SecondsSince(start);

    start = Clock::now();
    {
      ceres::Problem problem(ProblemOptions());
      builder.AddMotion(&problem, &summary);
      builder.AddLandmarks(&problem, &landmarks, tracks, keep);
      const ceres::Solver::Summary s = RunSolver(options_, &problem, &landmarks);
      summary.initial_cost = s.initial_cost;
      summary.iterations += static_cast<int>(s.iterations.size());
    }
    summary.full_solve_seconds = SecondsSince(start);

    // Phase 3: reject, re-preintegrate, final solve.
    start = Clock::now();
    cameras = builder.CapturePoses();
    std::vector<Eigen::Vector3d> kept_landmarks;
    std::vector<int> kept_tracks;
    std::vector<std::vector<bool>> kept_masks;
    for (std::size_t l = 0; l < landmarks.size(); ++l) {
      const LandmarkTrack& track = input.tracks[tracks[l]];
      std::vector<bool> mask(track.observations.size(), false);
      int good = 0;
      for (std::size_t o = 0; o < track.observations.size(); ++o) {
        if (!keep[l][o]) continue;  // already removed at triangulation
        const LandmarkObservation& obs = track.observations[o];
        const double error =
            ReprojectionError(*input.camera, input.body_from_camera,
                              builder.BodyAtCapture(obs.state), landmarks[l], obs.pixel);
        mask[o] = error <= options_.max_reprojection_error_px;
        good += mask[o] ? 1 : 0;
        summary.num_rejected_observations += mask[o] ? 0 : 1;
      }
      if (good < options_.min_observations) {
        summary.num_rejected_observations += good;
        continue;
      }
      kept_landmarks.push_back(landmarks[l]);
      kept_tracks.push_back(tracks[l]);
      kept_masks.push_back(std::move(mask));
    }
    builder.Preintegrate(&summary);
    if (options_.gps_gate_chi2 > 0) {
      summary.num_gps_rejected += builder.GateGps(options_.gps_gate_chi2);
    }
    {
      ceres::Problem problem(ProblemOptions());
      builder.AddMotion(&problem, &summary);
      summary.num_observations =
          builder.AddLandmarks(&problem, &kept_landmarks, kept_tracks, kept_masks);
      const ceres::Solver::Summary s = RunSolver(options_, &problem, &kept_landmarks);
      summary.final_cost = s.final_cost;
      summary.iterations += static_cast<int>(s.iterations.size());
      summary.converged = s.termination_type == ceres::CONVERGENCE;
    }
    if (input.camera_height_m) {
      ApplyCameraHeight(options_, input, kept_tracks, kept_masks, &builder, &blocks,
                        &kept_landmarks, &summary);
    }
    double sum_sq = 0;
    std::int64_t count = 0;
    for (std::size_t l = 0; l < kept_landmarks.size(); ++l) {
      const LandmarkTrack& track = input.tracks[kept_tracks[l]];
      for (std::size_t o = 0; o < track.observations.size(); ++o) {
        if (!kept_masks[l][o]) continue;
        const LandmarkObservation& obs = track.observations[o];
        const double e =
            ReprojectionError(*input.camera, input.body_from_camera,
                              builder.BodyAtCapture(obs.state), kept_landmarks[l], obs.pixel);
        if (std::isfinite(e)) {
          sum_sq += e * e;
          ++count;
        }
      }
    }
    summary.reprojection_rms_px = count > 0 ? std::sqrt(sum_sq / count) : 0.0;
    summary.num_landmarks_final = static_cast<int>(kept_landmarks.size());
    summary.final_solve_seconds = SecondsSince(start);
    result.landmarks_world = std::move(kept_landmarks);
    result.landmark_tracks = std::move(kept_tracks);
    result.landmark_observations_kept = std::move(kept_masks);
  }

  if (summary.num_gps_rejected > 0) {
    spdlog::info("GPS outlier gate: {} of the pass's fixes dropped (residual beyond chi2 {})",
                 summary.num_gps_rejected, options_.gps_gate_chi2);
  }
  if (builder.estimates_time_offset() && summary.num_observations > 0) {
    summary.time_offset_estimated = true;
    summary.time_offset_s = builder.time_offset_s();
  }
  if (builder.has_gps()) {
    double all = 0, horizontal = 0;
    const std::vector<Eigen::Vector3d> residuals = builder.GpsNormalisedResiduals();
    for (const Eigen::Vector3d& r : residuals) {
      all += r.squaredNorm();
      horizontal += r.head<2>().squaredNorm();
    }
    if (!residuals.empty()) {
      summary.gps_normalised_rms = std::sqrt(all / (3.0 * residuals.size()));
      summary.gps_normalised_rms_horizontal = std::sqrt(horizontal / (2.0 * residuals.size()));
    }
  }
  result.states.reserve(n);
  for (std::size_t k = 0; k < n; ++k) {
    result.states.push_back(FromBlocks(input.initial_states[k].t, blocks[k]));
  }
  return result;
}

}  // namespace crop4d::slam
