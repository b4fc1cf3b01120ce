#pragma once

// Initial states of a row pass from GPS and IMU (DESIGN.md §2.2): position and velocity from the
// GPS track, roll and pitch from the accelerometer (gravity), heading from the GPS course.
//
// Heading. A ground vehicle (or a person carrying the rig) moves along one fixed axis of the
// body, the forward axis f_B, so the body's heading is the GPS course once f_B is known. f_B is
// estimated once per session where the motion is rich (headland turns): over short windows
// (gyro integration only, so the gyro bias hardly matters) the attitude R₀ at the window start
// solves Wahba's problem
//     min_R₀ Σ_k ‖(v(t_k+1) − v(t_k) − g Δt_k) − R₀ u_k‖²,   u_k = ∫ ΔR(t) f̃(t) dt
// between GPS velocity changes and the integrated specific force (the loosely coupled
// in-motion alignment of Groves, "Principles of GNSS, Inertial, and Multisensor Integrated
// Navigation Systems", 2nd ed., §14.2.1, solved in closed form by SVD, Markley 1988). The
// horizontal velocity change makes the heading observable only when it is large, so windows
// are kept when it exceeds a threshold; each gives f_B = R(t)ᵀ course(t), and their mean is the
// session's forward axis. Without such windows f_B falls back to the body x axis.
//
// Per state: up_B = mean accelerometer over a short window (normalised), and R_world_body maps
// the body basis [f_B⊥, up_B × f_B⊥, up_B] onto [c, e_z × c, e_z] with c the horizontal course.
// Where the speed is too low for a course, the heading is carried from the neighbouring state
// with the gyro. Position: p_body = p_antenna − R p_B_antenna; velocity: the GPS track's; angular
// rate: the gyro; biases: zero.

#include <optional>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/slam/gp_prior.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::slam {

// One state of the back end (state_layout.h) as values.
struct RowState {
  Timestamp t = 0;
  GpState nav;
  Vector6d bias = Vector6d::Zero();
};

// Position and velocity of a GPS track at a time, from a local least-squares line fit.
struct GpsTrackSample {
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();
};

// Fits p(t) = p₀ + v (t − t₀) to the fixes within ±half_window_s of t (at least 2 fixes spanning
// ≥ half_window_s, else nullopt). Fixes sorted by time.
std::optional<GpsTrackSample> FitGpsTrack(const std::vector<GpsFixWorld>& fixes, Timestamp t,
                                          double half_window_s);

class StateInitialiser {
 public:
  struct Options {
    // Half-width of the GPS line fit for position and velocity, s.
    double gps_half_window_s = 0.6;
    // Half-width of the accelerometer mean used for roll and pitch, s.
    double gravity_half_window_s = 0.5;
    // Below this GPS speed the course is not used for the heading, m/s.
    double min_speed_for_course = 0.3;
    // Windows of the forward-axis estimation (file comment), s, and their sub-intervals.
    double alignment_window_s = 4.0;
    double alignment_step_s = 1.0;
    // A window is used when Σ ‖horizontal velocity change‖ over its sub-intervals exceeds this,
    // m/s (a 1.5 m/s headland turn gives several m/s; a straight row a few cm/s).
    double alignment_min_horizontal_change = 1.5;
    // Gravity, m/s².
    double gravity = 9.81;

    OptionCheck Check() const;
  };

  struct Summary {
    // Windows used for the forward axis, and whether the fallback (body x) was taken.
    int num_alignment_windows = 0;
    bool forward_axis_fallback = false;
    Eigen::Vector3d forward_axis_body = Eigen::Vector3d::UnitX();
    // States whose heading came from the gyro (no course), and states without GPS nearby.
    int num_states_heading_from_gyro = 0;
    int num_states_without_gps = 0;
  };

  // `imu` may be empty (a rig without an IMU: cam+rtk, cam+gps): then the body's z axis is taken
  // as up (a level rig), angular rates are zero, attitudes between courses are held, and the
  // forward axis is the body x axis.
  StateInitialiser(Options options, const ImuStream& imu, const GpsStream* gps);
  bool has_imu() const { return !imu_.samples.empty(); }

  // The forward axis in the body frame, estimated over the whole session's streams (call once
  // per session; Initialise uses it). The GPS antenna sits at p_body_antenna: its velocity
  // v_antenna = v_body + R (ω × p_body_antenna) is corrected for the turn rate (a 1.2 m mast
  // in a 0.5 rad/s headland turn adds 0.6 m/s sideways).
  Eigen::Vector3d EstimateForwardAxis(const Eigen::Vector3d& p_body_antenna,
                                      Summary* summary = nullptr);
  void set_forward_axis(const Eigen::Vector3d& forward_axis_body);
  const Eigen::Vector3d& forward_axis() const { return forward_axis_body_; }

  // States at `times` (sorted) from the GPS track and the IMU. The antenna sits at
  // p_body_antenna. Needs the GPS near the first state at least; states without GPS nearby are
  // propagated from their neighbours with constant velocity and the gyro.
  std::vector<RowState> Initialise(const std::vector<Timestamp>& times,
                                   const Eigen::Vector3d& p_body_antenna,
                                   Summary* summary = nullptr) const;

  // Dead-reckoning initialisation from one anchor state (no GPS after it): rotations from the
  // gyro and the accelerometer's gravity, positions at the anchor's constant velocity.
  std::vector<RowState> InitialiseFromAnchor(const RowState& anchor,
                                             const std::vector<Timestamp>& times) const;

  // Without any GPS: the state at t in the local level frame of a session (docs/slam.md, "Without
  // GPS"): z up along gravity (the mean specific force around t), x along the horizontal
  // direction of the forward axis, origin at the body; at rest, angular rate from the gyro.
  RowState LocalLevelState(Timestamp t) const;

  // Up direction in the body (normalised mean specific force around t).
  Eigen::Vector3d UpInBody(Timestamp t) const;

 private:
  Eigen::Matrix3d AttitudeFromCourse(const Eigen::Vector3d& up_body,
                                     const Eigen::Vector3d& course_world) const;
  // The gyro's rate at t, and its rotation from `from` to `to` (zero and identity without IMU).
  Eigen::Vector3d Rate(Timestamp t) const;
  Eigen::Matrix3d Turn(Timestamp from, Timestamp to) const;

  Options options_;
  const ImuStream& imu_;
  const GpsStream* gps_;
  Eigen::Vector3d forward_axis_body_ = Eigen::Vector3d::UnitX();
};

}  // namespace crop4d::slam
