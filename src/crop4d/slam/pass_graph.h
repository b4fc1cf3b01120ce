#pragma once

// The factor graph of one row pass in pieces (row_optimiser.h describes the factors): the
// parameter blocks of its states, the motion factors (IMU, bias walk, angular rate, GP prior,
// GPS, non-holonomic constraint, priors) and the reprojection factors of its landmarks. The row
// optimiser solves one pass with them; the joint 4D problem (fusion/joint_optimiser.h) puts the
// graphs of every pass of every session into one Ceres problem.

#include <ceres/ceres.h>

#include <cstdint>
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "crop4d/slam/calibrated_reprojection_factor.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

// The four parameter blocks of one state (state_layout.h).
struct StateBlocks {
  double pose[kPoseSize];
  double vel[kVelocitySize];
  double rate[kRateSize];
  double bias[kBiasSize];
};

StateBlocks ToBlocks(const RowState& s);
RowState FromBlocks(Timestamp t, const StateBlocks& b);

// The graph of one pass over its state blocks. `options`, `input` and `blocks` must outlive it
// (factors hold pointers into `blocks`).
class PassGraph {
 public:
  PassGraph(const RowOptimiser::Options& options, const RowOptimiser::Input& input,
            std::span<StateBlocks> blocks);

  bool has_imu() const { return input_.imu_samples != nullptr && !input_.imu_samples->empty(); }
  bool has_gps() const { return !input_.gps_fixes.empty(); }

  // (Re)integrates the IMU between consecutive states at each state's current bias estimate.
  void Preintegrate(RowOptimiser::Summary* summary);
  // States, motion factors (IMU, bias walk, rate, GP prior), GPS and the priors.
  void AddMotion(ceres::Problem* problem, RowOptimiser::Summary* summary) const;
  // Reprojection factors of the landmarks (landmark l is Input::tracks[tracks[l]]; observations
  // with keep[l][o] true); returns their number. With uses_time_offset(): the factors of
  // time_offset_reprojection_factor.h on the pass's time offset (AddObservation).
  std::int64_t AddLandmarks(ceres::Problem* problem, std::vector<Eigen::Vector3d>* landmarks,
                            const std::vector<int>& tracks,
                            const std::vector<std::vector<bool>>& keep) const;
  // One reprojection factor: the landmark `point_world` (a 3-vector parameter block) seen at
  // `pixel` in the image of state `state`. With uses_time_offset(), the first observation of a
  // problem adds the time offset's block: with estimates_time_offset() its prior and bounds,
  // otherwise held constant.
  void AddObservation(ceres::Problem* problem, std::size_t state, const Eigen::Vector2d& pixel,
                      double* point_world) const;
  // The GPS residuals at the current states, whitened (error / σ: east, north, up), one per fix
  // inside the states' span: how well the solve fits the fixes' stated sigmas.
  std::vector<Eigen::Vector3d> GpsNormalisedResiduals() const;
  // The outlier gate (RowOptimiser::Options::gps_gate_chi2): drops, from the next AddMotion on,
  // the fixes whose whitened residual at the current states has a squared norm above `chi2`,
  // worst first, while more than half of the fixes inside the states' span remain. Returns
  // how many it dropped now.
  int GateGps(double chi2);
  // True when the reprojection factors estimate the camera–IMU time offset
  // (Options::estimate_time_offset, with a camera).
  bool estimates_time_offset() const {
    return options_.estimate_time_offset && input_.camera != nullptr;
  }
  // True when the reprojection factors use the capture instants: the offset is estimated, or
  // known (Input::time_offset_s), with a camera.
  bool uses_time_offset() const {
    return input_.camera != nullptr &&
           (options_.estimate_time_offset || input_.time_offset_s.has_value());
  }
  // The pass's time offset td (capture instant = image stamp + td), s: its parameter block (one
  // double, owned by the graph) and its value; Input::time_offset_s (clamped to the bounds
  // when estimated) or 0 until a solve changes it.
  double* time_offset_block() const { return &time_offset_s_; }
  double time_offset_s() const { return time_offset_s_; }
  // With `calibration` set (the joint problem's calibration refinement; it must outlive the
  // graph's problems), the reprojection factors refine it (calibrated_reprojection_factor.h,
  // on the pass's time offset block, held at 0 when the pass has none) and Camera(),
  // BodyFromCamera() and CapturePoses() follow it. Unset (nullptr): the pass's calibration as
  // given.
  void set_calibration(CameraCalibrationBlocks* calibration) { calibration_ = calibration; }
  // The camera's intrinsics and body_from_camera as the reprojection factors use them now.
  geometry::PinholeRadTan Camera() const;
  geometry::Rigid3 BodyFromCamera() const;
  // world_from_body of state k at its capture instant (time_offset_reprojection_factor.h), and
  // world_from_camera of every state there: the poses the reprojection factors use. Without
  // the time offset: the states' poses.
  geometry::Rigid3 BodyAtCapture(std::size_t k) const;
  std::vector<geometry::Rigid3> CapturePoses() const;
  // The robust loss of the reprojection factors (owned by the graph).
  ceres::LossFunction* reprojection_loss() const { return reprojection_loss_.get(); }
  // The factor on the reprojection sigma of state k's image (Options::image_weighting of
  // Input::image_sharpness; 1 without sharpness).
  double ImageSigmaScale(std::size_t k) const {
    return k < image_sigma_scales_.size() ? image_sigma_scales_[k] : 1.0;
  }

 private:
  // Calls f(i, measurement, dt, s, index) for every GPS fix inside the states' span that the
  // gate kept: the states i and i + 1 around it, dt between them and s from state i to the fix,
  // seconds, and its index in Input::gps_fixes.
  template <typename F>
  void ForEachGpsFix(F&& f) const;
  // The standstill constraints of Input::still_intervals.
  void AddStandstills(ceres::Problem* problem, RowOptimiser::Summary* summary) const;

  const RowOptimiser::Options& options_;
  const RowOptimiser::Input& input_;
  std::span<StateBlocks> blocks_;
  std::vector<std::optional<ImuPreintegration>> preintegrations_;
  // Per Input::gps_fixes entry: dropped by GateGps.
  std::vector<bool> gps_rejected_;
  std::unique_ptr<ceres::LossFunction> reprojection_loss_, gps_loss_;
  std::vector<double> image_sigma_scales_;  // per state, or empty
  mutable PoseManifold pose_manifold_;
  // Ceres writes the estimate here (a parameter block, as the state blocks are).
  mutable double time_offset_s_ = 0.0;
  // The camera calibration refined jointly (set_calibration); Ceres writes into it.
  CameraCalibrationBlocks* calibration_ = nullptr;
};

// Problem options for graphs whose manifolds and losses the PassGraph owns.
ceres::Problem::Options ProblemOptions();

// Solves with Levenberg–Marquardt; `schur_blocks` (landmarks) are eliminated first by the
// Schur complement (SPARSE_SCHUR), none: sparse normal Cholesky. With Schur elimination,
// `last_blocks` (those in the problem) come after every other block, each in a group of its
// own, in the given order. Ceres orders the blocks of one group by their address: blocks that
// live outside the states' one array (a pass's time offset, a camera's calibration) would land
// before or after the states as the heap placed them, which differs between processes, and so
// would the solve's sums in their last bits.
ceres::Solver::Summary RunSolver(const RowOptimiser::Options& options, ceres::Problem* problem,
                                 const std::vector<double*>& schur_blocks,
                                 const std::vector<double*>& last_blocks = {});
ceres::Solver::Summary RunSolver(const RowOptimiser::Options& options, ceres::Problem* problem,
                                 std::vector<Eigen::Vector3d>* landmarks,
                                 const std::vector<double*>& last_blocks = {});

// world_from_camera of every state.
std::vector<geometry::Rigid3> CameraPoses(std::span<const StateBlocks> blocks,
                                          const geometry::Rigid3& body_from_camera);

}  // namespace crop4d::slam
