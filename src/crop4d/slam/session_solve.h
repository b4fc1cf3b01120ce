#pragma once

// The session-wide IMU + GPS solve of row SLAM (docs/slam.md): one RowOptimiser problem over the
// whole session at a low state rate, with a precise receiver. It measures three things the
// passes use:
//   - the IMU noise that fits the recording: a fit whose GPS residuals are more than
//     kNoiseMisfit times the fixes' sigmas (RMS) says the stated noise is overconfident; with
//     `imu_noise_auto` it is multiplied by 2, 4, 8, ... (at most kMaxNoiseFactor) until the
//     residuals are within kNoiseTarget of the sigmas;
//   - the forward axis in the body frame (the IMU's mounting on the vehicle): the direction of
//     the body-frame velocity over the states in turns, where IMU + GPS observe the heading
//     (the centripetal acceleration ties the attitude to the GPS track); on straight stretches
//     the heading is only as good as the initial guess;
//   - the states themselves: interpolated (InterpolateState), the passes' initial guess and
//     bias prior.
// Also: the GPS windows of the initialisation for the receiver at hand (InitialisationFor).

#include <Eigen/Core>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/initialisation.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::slam {

// Noise that fits the data (file comment).
inline constexpr double kNoiseMisfit = 1.5;
inline constexpr double kNoiseTarget = 1.2;
inline constexpr double kMaxNoiseFactor = 32.0;

// The IMU noise of sensor.yaml times `factor` (white noise and bias random walks).
ImuPreintegration::Options ImuNoise(const io::ImuSensor& sensor, double factor);

struct ForwardAxisOptions {
  // States turning at least this fast about the body z axis, rad/s: in a turn the heading of
  // an IMU + GPS solution is observed (straight driving leaves it to the initial guess); a
  // headland turn runs at about 0.5 rad/s, driving along a row far below this.
  double min_turn_rate_rad_s = 0.15;
  // ... and moving at least this fast, m/s: below it the velocity's direction is noise.
  double min_speed_m_s = 0.5;
  // At least this many such states, else no estimate (a session without turns: the axis stays
  // the initialisation's).
  int min_states = 10;

  // Empty when valid, else the option that is wrong and why.
  OptionCheck Check() const;
};

struct ForwardAxisEstimate {
  // Unit vector in the body frame.
  Eigen::Vector3d axis_body = Eigen::Vector3d::UnitX();
  int num_states = 0;
};

// The mean direction of the body-frame velocity over the states in turns (nullopt when fewer
// than options.min_states qualify).
std::optional<ForwardAxisEstimate> EstimateForwardAxisFromStates(
    const std::vector<RowState>& states, const ForwardAxisOptions& options = {});

// The state at t from a solution sorted by time: linear between its states (rotation and
// translation separately); outside the solution, its first or last state at time t.
RowState InterpolateState(const std::vector<RowState>& states, Timestamp t);

struct SessionSolveOptions {
  // States per second, > 0.
  double state_rate_hz = 5.0;
  // Inflate an overconfident IMU noise (file comment).
  bool imu_noise_auto = true;
  StateInitialiser::Options initialisation;
  RowOptimiser::Options optimiser;
  ForwardAxisOptions forward_axis;

  // Empty when valid, else the option that is wrong and why.
  OptionCheck Check() const;
};

struct SessionSolveResult {
  // Empty when the streams overlap for less than two states (nothing solved).
  std::vector<RowState> states;
  // The factor on sensor.yaml's IMU noise the fit asked for (1: the stated noise fits).
  double imu_noise_factor = 1.0;
  // GPS residuals over their sigmas (RMS) with the stated noise, and after the inflation.
  double stated_misfit = 0;
  double final_misfit = 0;
  // The forward axis from the states in turns (nullopt: too few).
  std::optional<ForwardAxisEstimate> forward_axis;
};

// The IMU + GPS solve over the time both streams cover, started from the initialisation with
// `forward_axis_body` (the axis estimated from the GPS track). `imu` must hold samples and `gps`
// fixes.
SessionSolveResult SolveSession(const ImuStream& imu, const GpsStream& gps,
                                const Eigen::Vector3d& forward_axis_body,
                                const SessionSolveOptions& options);

// The GPS half-window of a cam+imu pass's anchor, s (at least): the best receiver anchors the
// pass at one instant, its middle, where the motion is steady; a line fit over ±2 s of its
// track there gives the gauge (position, heading and velocity), nothing else.
inline constexpr double kAnchorGpsHalfWindowS = 2.0;
// The GPS half-window of the initialisation with a metre-level receiver, s (at least): its
// course is usable only from a long fit.
inline constexpr double kMetreGpsHalfWindowS = 3.0;

// The initialisation's options for a pass anchored by a receiver at one instant (cam+imu).
StateInitialiser::Options AnchorInitialisation(StateInitialiser::Options options);
// The initialisation's options for a session whose factors use a receiver of `kind`.
StateInitialiser::Options InitialisationFor(StateInitialiser::Options options, io::GpsKind kind);

}  // namespace crop4d::slam
