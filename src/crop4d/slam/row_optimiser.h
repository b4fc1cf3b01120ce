#pragma once

// The back end of one row pass (DESIGN.md §2.2): one Ceres factor graph with a state per image
// time (pose, velocity, angular rate, IMU bias; state_layout.h) and
//   - reprojection factors of the front end's landmarks with a Huber loss, landmarks eliminated by
//     the Schur complement (SPARSE_SCHUR, landmarks in the first elimination group);
//   - preintegrated IMU factors and bias random-walk factors between consecutive states, and an
//     angular-rate factor per state (imu_preintegration.h);
//   - the Gaussian-process white-noise-on-acceleration prior between consecutive states
//     (gp_prior.h);
//   - a GPS factor at every GPS time, interpolating the GP trajectory between its two
//     neighbouring states, with the antenna lever arm and the fix's sigmas (gps_factor.h);
//   - a prior on the first bias (turn-on bias of a MEMS IMU), and, without GPS, a prior on the
//     pose and velocity of one state (Input::anchor_state) that fixes the gauge;
//   - over a standstill (Input::still_intervals, standstill.h): one pose for consecutive states,
//     zero velocity and zero angular rate;
//   - without an IMU, a weak prior per state that the rig is level (tilt_prior_factor.h).
// Solving runs in phases: (1) without the camera (IMU + GP + GPS) to refine the initial states;
// (2) landmarks triangulated from those poses, then the full problem; (3) observations whose
// reprojection error exceeds 10 px removed, the IMU re-preintegrated at the estimated biases,
// and a final solve; (4) with a known camera height, the scale it implies and one more solve. An
// IMU gap inside an interval drops that interval's IMU factor (the GP prior bridges it) with a
// warning.

#include <array>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/camera_height_scale.h"
#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/image_quality.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/session_streams.h"
#include "crop4d/slam/standstill.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::slam {

// One observation of a landmark: the state (image) index and the distorted pixel.
struct LandmarkObservation {
  int state = -1;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

struct LandmarkTrack {
  std::vector<LandmarkObservation> observations;
  std::array<std::uint8_t, 3> color{128, 128, 128};
};

class RowOptimiser {
 public:
  struct Options {
    // Standard deviation of a keypoint position, px.
    double reprojection_sigma_px = 1.0;
    // Huber loss threshold of the reprojection factors, in sigmas.
    double reprojection_loss_scale = 2.0;
    // Observations whose reprojection error exceeds this are removed before the final solve, px.
    double max_reprojection_error_px = 10.0;
    // A landmark keeps its place in the final solve with at least this many observations.
    int min_observations = 3;
    // Triangulation of the landmarks from the poses of phase 1 (a looser reprojection bound than
    // the output cloud's, since those poses are not final).
    TriangulationOptions triangulation = [] {
      TriangulationOptions o;
      o.min_parallax_deg = 0.5;
      o.max_reprojection_error_px = 10.0;
      return o;
    }();
    // A track whose triangulation fails on the error bound loses its worst view and is
    // triangulated again, at most this many times (those views count as rejected).
    int max_outliers_per_track = 3;
    // Huber loss threshold of the GPS factors, in sigmas.
    double gps_loss_scale = 3.0;
    // Outlier gate of the GPS fixes (multipath), 0: off. After the solve without the camera and
    // again before the final solve, a fix whose whitened residual against the current
    // trajectory (error / the fix's own sigmas, so an RTK-float fix is judged by its float
    // sigmas) has a squared norm above this is dropped: chi-square with 3 degrees of freedom,
    // 21.1 for a false rejection rate of 1e-4. The Huber loss alone bounds an outlier's pull but
    // keeps it (a 0.5 m multipath fix of an RTK receiver still pulls like a 6 cm one). At most
    // half of a pass's fixes are dropped.
    double gps_gate_chi2 = 0.0;
    // GP prior power spectral densities.
    GpPriorFactor::Options gp;
    // Prior on the first state's bias (turn-on bias): gyroscope rad/s, accelerometer m/s².
    double bias_prior_sigma_gyro = 0.01;
    double bias_prior_sigma_accel = 0.2;
    // Gauge prior on the first state when there is no GPS factor: position m, rotation rad,
    // velocity m/s.
    double anchor_sigma_position = 0.01;
    double anchor_sigma_rotation = 0.002;
    double anchor_sigma_velocity = 0.02;
    // Standard deviation of the body velocity across the forward axis (non-holonomic
    // constraint of a ground vehicle, motion_constraint_factor.h), m/s; used when
    // Input::forward_axis_body is set.
    double motion_constraint_sigma = 0.05;
    // Without an IMU: the standard deviation of the prior that Input::level_up_body points up,
    // per state, rad (tilt_prior_factor.h).
    double level_prior_sigma_rad = 0.1;
    // An interval whose IMU samples are further apart than this has no IMU factor, s.
    double max_imu_gap_s = 0.1;
    // The constraints of a standstill (its sigma_* fields; detection is the caller's).
    StandstillOptions standstill;
    // Images less sharp than their neighbours (blur, exposure) get a larger reprojection sigma
    // (Input::image_sharpness; image_quality.h).
    ImageWeightOptions image_weighting;
    // Ceres iterations per phase and threads (0: all cores).
    int max_iterations = 50;
    // The linear solver with landmarks: the exact Schur complement factorised by sparse Cholesky
    // (SPARSE_SCHUR), or conjugate gradients on the implicit Schur complement with the
    // Schur-Jacobi preconditioner (ITERATIVE_SCHUR): cheaper per iteration once many passes
    // share landmarks (the joint 4D problem).
    bool iterative_schur = false;
    // Conjugate-gradient iterations per step of ITERATIVE_SCHUR: an inexact step costs a
    // fraction of an exact one and Levenberg–Marquardt still converges (measured on the demo's
    // joint problem: 50 iterations reach the same cost as 500 in a fifth of the time).
    int max_linear_iterations = 50;
    // A solve stops when an iteration lowers the cost by less than this fraction of it (Ceres'
    // function tolerance).
    double function_tolerance = 1e-6;
    int num_threads = 0;
    // How the soil's depth below the camera is measured and trusted (Input::camera_height_m).
    CameraHeightOptions camera_height;
    // Estimate the camera–IMU time offset td of the pass (capture instant = image stamp + td, s):
    // one parameter per pass, each reprojection predicted from its state to the capture instant
    // (time_offset_reprojection_factor.h). Off: the stamps are taken as the capture instants.
    bool estimate_time_offset = false;
    // Zero-mean prior on td, s: keeps it defined when nothing observes it (a standstill, a
    // straight pass at constant speed).
    double time_offset_prior_sigma_s = 0.05;
    // td is bounded to [−max, +max], s: the first-order prediction from the state at the stamp
    // holds only over a short time.
    double max_abs_time_offset_s = 0.2;

    // Empty when the options are valid, otherwise the first invalid option and why, as
    // "name: must be ... (got x)" (core/option_check.h; nested options "triangulation.name: ...").
    OptionCheck Check() const;
    std::string Error() const { return Check(); }
  };

  struct Input {
    // Initial states at the state times (sorted).
    std::vector<RowState> initial_states;
    // Camera (null: no camera factors), its extrinsics and the landmark tracks.
    const geometry::PinholeRadTan* camera = nullptr;
    geometry::Rigid3 body_from_camera;
    std::vector<LandmarkTrack> tracks;
    // IMU samples in the body frame (null or empty: no IMU factors) and its noise.
    const std::vector<ImuSample>* imu_samples = nullptr;
    ImuPreintegration::Options imu_noise;
    double imu_rate_hz = 167.0;
    // GPS fixes (world frame) and the antenna lever arm; fixes outside the states' span are
    // ignored.
    std::vector<GpsFixWorld> gps_fixes;
    Eigen::Vector3d p_body_antenna = Eigen::Vector3d::Zero();
    // The vehicle's forward axis in the body frame: when set, every state gets the
    // non-holonomic motion constraint (a wheeled vehicle in a row; not a person walking).
    std::optional<Eigen::Vector3d> forward_axis_body;
    // Without GPS factors, the gauge prior (pose and velocity as initialised) sits on this state;
    // its velocity's standard deviation, m/s (unset: Options::anchor_sigma_velocity; a pass that
    // starts moving without GPS does not know its velocity).
    int anchor_state = 0;
    std::optional<double> anchor_sigma_velocity;
    // Without an IMU: the body axis that points up when the rig is level. Every state gets a weak
    // prior that it does (Options::level_prior_sigma_rad): nothing else fixes a straight pass's
    // rotation about its line of travel. Ignored with IMU samples (gravity observes the tilt).
    std::optional<Eigen::Vector3d> level_up_body;
    // Per state (empty, or one per state: the image of state k): the sharpness of its image
    // (features::FeatureSet::sharpness; 0: not measured). Options::image_weighting turns it into
    // a factor on the reprojection sigma of the image's observations (image_quality.h).
    std::vector<double> image_sharpness;
    // Per interval between consecutive states (empty, or one entry per interval): true when the
    // rig stands still over it (standstill.h).
    std::vector<bool> still_intervals;
    // Prior on the first state's bias [bg; ba]: mean and standard deviations (unset: zero mean
    // and Options::bias_prior_sigma_*). A session-wide inertial solve, whose turns make the
    // biases observable, gives a much tighter prior than a straight pass alone.
    Vector6d bias_prior_mean = Vector6d::Zero();
    std::optional<Vector6d> bias_prior_sigma;
    // The optical centre's height above the ground the vehicle stands on, m (measured on the
    // rig). When set, with a camera: after the final solve the pass is rescaled so that its soil
    // lies this deep below the camera (camera_height_scale.h), and solved once more with its
    // length held there (PassLengthFactor). For passes without a precise receiver: with RTK the
    // pass's own scale is better than the soil's depth measures it.
    std::optional<double> camera_height_m;
    // The tracks whose points measure the soil's depth for camera_height_m, triangulated from the
    // solved poses: every track of two or more images (the landmarks alone hold too little soil
    // for a quantile: bench/RESULTS.md, "Row SLAM ablation").
    std::vector<LandmarkTrack> depth_tracks;
    // A prior on the distance between the first and the last state (PassLengthFactor), m, and its
    // standard deviation: how the joint 4D problem keeps the scale that the camera-height step
    // set (Summary::length_prior_m, recorded in the pass's summary.json). Row SLAM leaves it
    // unset.
    std::optional<double> length_prior_m;
    double length_prior_sigma_m = 0;
    // The pass's camera–IMU time offset td when it is known beforehand, s (the joint 4D problem
    // gives row SLAM's estimate here). Set, with a camera: the reprojection factors use the
    // capture instants from the start, td starts from this value and is refined with
    // Options::estimate_time_offset, held at it otherwise. Unset: td starts at 0 and enters only
    // with Options::estimate_time_offset.
    std::optional<double> time_offset_s;
    // The joint 4D problem only: the camera clock of the pass (its session's; empty: none).
    // Passes of one clock have their time offsets on one line over time (fusion/clock_line.h).
    std::string clock;
  };

  struct Summary {
    int num_states = 0;
    int num_imu_factors = 0;
    int num_imu_gaps = 0;
    int num_gps_factors = 0;
    // GPS fixes dropped by the outlier gate (Options::gps_gate_chi2).
    int num_gps_rejected = 0;
    // Intervals between states held by the standstill constraints.
    int num_still_intervals = 0;
    int num_tracks = 0;
    // Landmarks triangulated for phase 2 and kept for the final solve.
    int num_landmarks_triangulated = 0;
    int num_landmarks_final = 0;
    std::int64_t num_observations = 0;
    std::int64_t num_rejected_observations = 0;
    // Cost of the full problem before phase 2 and after the final solve (Ceres' ½‖r‖²).
    double initial_cost = 0;
    double final_cost = 0;
    int iterations = 0;
    // RMS of the GPS residuals after the final solve in units of the fixes' stated sigmas, over
    // the three axes and over east and north (0 without GPS factors). About 1 when the solve fits
    // the fixes as closely as their sigmas say; well above 1 when something else (an
    // overconfident IMU noise) pulls the trajectory off them.
    double gps_normalised_rms = 0;
    double gps_normalised_rms_horizontal = 0;
    // RMS reprojection error of the kept observations after the final solve, px.
    double reprojection_rms_px = 0;
    // Images whose reprojection sigma was raised by more than 10 % for their sharpness
    // (Options::image_weighting), and the largest factor.
    int num_downweighted_images = 0;
    double max_image_sigma_scale = 1.0;
    // Wall-clock seconds.
    double inertial_seconds = 0;
    double triangulation_seconds = 0;
    double full_solve_seconds = 0;
    double final_solve_seconds = 0;
    bool converged = false;
    // With Input::camera_height_m: the soil's depth below the camera before the rescale, the soil
    // points measured, and the scale applied (1: none — too few soil points, or a change beyond
    // CameraHeightOptions::max_scale_change).
    double soil_depth_m = 0;
    int soil_points = 0;
    double camera_height_scale = 1.0;
    // The length the pass was held at after the rescale and its standard deviation, m (0: none).
    double length_prior_m = 0;
    double length_prior_sigma_m = 0;
    // With Options::estimate_time_offset, a camera and landmarks: the estimated camera–IMU time
    // offset td of the pass (capture instant = image stamp + td), s.
    bool time_offset_estimated = false;
    double time_offset_s = 0;
  };

  struct Result {
    std::vector<RowState> states;
    // Landmarks of the final solve: position and the index of their track in Input::tracks.
    std::vector<Eigen::Vector3d> landmarks_world;
    std::vector<int> landmark_tracks;
    // Per landmark, which observations of its track the final solve kept.
    std::vector<std::vector<bool>> landmark_observations_kept;
    Summary summary;
  };

  explicit RowOptimiser(Options options);
  Result Solve(const Input& input) const;
  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace crop4d::slam
