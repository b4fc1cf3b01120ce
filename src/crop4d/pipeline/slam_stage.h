#pragma once

// The row SLAM stage (`crop4d slam`, DESIGN.md §2.1–2.2): for every session of a field, split the
// drive into row passes from the GPS track (slam/row_passes.h), then per pass run the front end
// (features/front_end.h), initialise the states from GPS and IMU (slam/initialisation.h), solve
// the factor graph (slam/row_optimiser.h) and triangulate the sparse cloud from the final poses.
// Outputs per pass in WS/sessions/<session>/rows/<pass>/:
//   features.bin   the feature cache of the pass (a rerun skips extraction);
//   poses.tum      world_from_camera at every image time (world_from_body at the state times for
//                  a camera-less pass), TUM format, seconds;
//   landmarks.ply  the sparse cloud with colour, track length and reprojection error;
//   tracks.bin     the observations of the optimised landmarks and of the cloud's points
//                  (pass_files.h), for association and the joint 4D problem;
//   states.csv     the full state (pose, velocity, angular rate, biases) at every state time;
//   summary.json   counts, costs, times per phase, the options, and a fingerprint: a pass whose
//                  fingerprint is unchanged is skipped on a rerun (unless `force`).
// WS/sessions/<session>/passes.csv lists the passes of the session.

#include <optional>
#include <string>
#include <vector>

#include "crop4d/features/front_end.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/row_passes.h"
#include "crop4d/slam/sensor_set.h"
#include "crop4d/slam/triangulation.h"
#include "crop4d/slam/visual_initialisation.h"

namespace crop4d::pipeline {

// A window without GPS, seconds after the session's first fix of the receiver in use.
struct GpsOutage {
  double start_s = 0;
  double duration_s = 0;
};

// How a session is cut into passes (`crop4d slam --passes`).
enum class PassMode {
  kAuto,   // row passes where the drive has rows (declared, or clearly found), else kWhole
  kRows,   // the straight passes found along the dominant axis, even without a row structure
  kWhole,  // the whole session as one trajectory, in windows of at most max_window_s
};
const char* ToString(PassMode mode);
std::optional<PassMode> ParsePassMode(const std::string& text);

struct SlamStageOptions {
  // Only this session (empty: every session of the field).
  std::string session;
  // Only this pass: a pass id ("row03", "all") or a row index ("3"); empty: every pass.
  std::string pass;
  // Cut the selected sessions into passes (WS/sessions/<id>/passes list) and solve none: the
  // Slurm executor's first step of a session, whose passes are then solved one per task.
  bool passes_only = false;
  // The sensor set; unset: cam+imu+rtk when the session has an RTK receiver, cam+imu+gps when it
  // has only a standard one, cam+imu without GPS, imu+rtk without a camera.
  std::optional<slam::SensorSet> sensors;
  // Sensor names (empty: the session's first camera / IMU).
  std::string camera;
  std::string imu;
  // GPS removed from the factors and the initialisation (outage studies).
  std::vector<GpsOutage> gps_outages;
  // Camera-less passes: states at this rate, Hz.
  double state_rate_hz = 10.0;
  // Before the passes, one IMU + GPS solve over the whole session (turns included) at this
  // state rate, Hz (0: none), with a precise receiver (a quarter of its fixes with sigma_h ≤
  // session_solve_max_sigma_m: an RTK receiver, even when it is in float for most of a session).
  // Its attitudes in turns give the forward axis (the IMU's mounting; in every sensor set). When
  // the set's GPS factors use that receiver, its biases also become each pass's bias prior (turns
  // make the accelerometer bias observable; a straight pass confuses it with roll and pitch) and
  // its trajectory the passes' initial guess.
  double session_state_rate_hz = 5.0;
  // Precision a receiver needs for the session solve, m (RTK; a metre-level receiver does not
  // make the biases observable in the turns).
  double session_solve_max_sigma_m = 0.1;
  // Standard deviations of the bias prior taken from the session solve: gyroscope rad/s,
  // accelerometer m/s².
  double session_bias_sigma_gyro = 1e-3;
  double session_bias_sigma_accel = 0.02;
  // Stage parts. The front end's defaults for row SLAM (bench/RESULTS.md, "Row SLAM speed"):
  // 1024 features per image spread over an 8×8 grid (soil as well as plants), extracted on the
  // image downscaled to 640 px (SIFT doubles its input internally), exact matching instead of
  // FLANN (cheaper at this budget): ≥ 7.5 images/s at 1280×960 on 2 cores at the same accuracy.
  features::FrontEnd::Options front_end = [] {
    features::FrontEnd::Options o;
    o.extraction.max_num_features = 1024;
    o.extraction.spatial_grid_cells = 8;
    o.extraction.max_image_size = 640;
    o.matching.descriptors.method = features::DescriptorMatchOptions::Method::kExhaustive;
    return o;
  }();
  slam::RowPassSegmenter::Options passes;
  PassMode pass_mode = PassMode::kAuto;
  // A session processed as one trajectory is cut into windows of at most this many seconds that
  // overlap by window_overlap_s (slam::WholeDriveWindows): bounds a pass's memory and solve time
  // (a 300 s window holds 2250 images at 7.5 Hz).
  double max_window_s = 300.0;
  double window_overlap_s = 15.0;
  slam::StateInitialiser::Options initialisation;
  // Without an IMU: the initial guess's rotations and shape from the relative motion of
  // consecutive images (slam/visual_initialisation.h).
  slam::VisualInitialisationOptions visual_initialisation;
  // Real rigs rarely synchronise the camera with the IMU, and receivers have multipath outliers:
  // each pass estimates its camera–IMU time offset (with an IMU; none to estimate against
  // without one) and drops GPS fixes beyond chi-square 21.1 (3 dof, 1e-4 false rejections). On
  // the demo field with the imperfections of real rigs, row SLAM ATE 2.93 → 2.30 cm, the time
  // offsets within 1.4 ms of the truth, fused ground misalignment 1.35 → 0.60 cm; on the ideal
  // field the offsets stay near 0 (bench/RESULTS.md, "Every figure on the imperfect demo field").
  slam::RowOptimiser::Options optimiser = [] {
    slam::RowOptimiser::Options o;
    o.estimate_time_offset = true;
    o.gps_gate_chi2 = 21.1;
    return o;
  }();
  // The output cloud: every track of ≥ 2 images triangulated from the final poses with these
  // checks.
  slam::TriangulationOptions cloud;
  // The non-holonomic constraint of a vehicle (slam/motion_constraint_factor.h) on row passes.
  bool motion_constraint = true;
  // Standstills found from the IMU, the image motion and a precise GPS track hold the pose, zero
  // velocity and zero rate over them (slam/standstill.h; detection thresholds and sigmas in
  // optimiser.standstill).
  bool standstills = true;
  // IMU noise that fits the data (docs/slam.md): when the session's IMU + GPS fit misses the
  // fixes by more than 1.5 times their sigmas, multiply imu0/sensor.yaml's noise by 2, 4, 8, ...
  // until it does not (false: warn only).
  bool imu_noise_auto = true;
  // The camera's optical centre above the ground the vehicle stands on, m, measured on the rig
  // (0: the camera's sensor.yaml `height_above_ground_m`, else unknown), and whether to use it at
  // all. Sets the scale of row
  // passes solved without a precise receiver (slam/camera_height_scale.h): `cam+imu+gps`, and
  // `cam+imu` when the receiver that anchors it is not precise (session_solve_max_sigma_m).
  double camera_height_m = 0;
  bool use_camera_height = true;
  // Recompute passes whose outputs are up to date.
  bool force = false;
  bool show_progress = true;

  // Empty when the options are valid, else the option that is wrong and why ("state_rate_hz:
  // must be > 0"; the names of the configuration file's section, docs/run.md).
  std::string Check() const;
};

struct PassReport {
  std::string session;
  slam::RowPass pass;
  std::string sensors;
  std::string folder;
  // Skipped because its outputs were up to date.
  bool skipped = false;
  // Failed (message says why); the other passes go on.
  bool failed = false;
  std::string message;
  int num_states = 0;
  int num_images = 0;
  int num_landmarks = 0;
  int num_cloud_points = 0;
  double seconds = 0;
};

// Runs the stage; throws InputError for a field that cannot be read or a sensor set a session
// cannot provide. A pass that fails is reported and the others go on.
std::vector<PassReport> RunSlamStage(const std::string& field_folder, const std::string& workspace,
                                     const SlamStageOptions& options);

// The fixes outside the outages (GpsOutage: seconds after the first fix of `fixes`).
std::vector<slam::GpsFixWorld> ApplyGpsOutages(const std::vector<slam::GpsFixWorld>& fixes,
                                               const std::vector<GpsOutage>& outages);

// The folder of a pass's outputs.
std::string PassFolder(const std::string& workspace, const std::string& session,
                       const std::string& pass_id);

}  // namespace crop4d::pipeline
