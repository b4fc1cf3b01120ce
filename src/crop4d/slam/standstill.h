#pragma once

// Standstills: where the rig does not move (DESIGN.md §2.2). Real rigs stand still before they
// move, at row ends and whenever the driver stops; while nothing moves, neither the GPS course
// nor the camera observes the heading, and an unconstrained solve lets yaw and position wander
// inside the IMU's noise. A standstill is information instead: zero velocity, zero angular rate
// and one pose held over its duration (the zero-velocity update of pedestrian and vehicle
// navigation: Foxlin 2005; Skog et al., IEEE T-BME 2010; Groves §15.3).
//
// Detection, per interval between two consecutive states, needs every available sensor to agree:
//   - the IMU says nothing changes: the mean of each gyroscope and accelerometer axis over a
//     window of StandstillOptions::window_s equals that of the next window, within
//     mean_change_sigmas standard errors of the two means (or a floor), and the mean specific
//     force is gravity. A standing vehicle with its engine running, or a drone with spinning
//     rotors, vibrates by metres per second squared (EuRoC V1_01's standstill: up to 1.3 m/s² and
//     0.1 rad/s standard deviation in half a second), so the spread of the samples cannot tell a
//     standstill; their mean can. A body moving at constant velocity (or turning at a constant
//     rate) has constant means too, so the IMU alone does not decide where another sensor can:
//   - the image does not move (with a camera): the median displacement of the matched keypoints
//     between the two images is below max_image_motion_px;
//   - the GPS track does not move (with a GPS): speed below max_gps_speed.
// A standstill shorter than min_duration_s is not one (a vehicle changing direction passes
// through zero velocity for an instant).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <optional>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/slam/imu_preintegration.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

struct StandstillOptions {
  // Window of the IMU means, s.
  double window_s = 0.5;
  // Two consecutive windows agree when each axis's means differ by less than this many standard
  // errors of their difference, or less than the floor.
  double mean_change_sigmas = 3.0;
  double gyro_floor = 0.005;  // rad/s
  double accel_floor = 0.05;  // m/s²
  // The mean specific force's magnitude may differ from gravity (9.81) by this much, m/s².
  double max_gravity_error = 0.5;
  // Image motion between two consecutive images, px (median over the matched keypoints). The
  // vibration of a standing rig moves the image too: up to 0.74 px between EuRoC V1_01's
  // images (752×480, rotors spinning); a vehicle creeping at 5 cm/s moves a crop 1.5 m below a
  // 1280×960 camera at 7.5 Hz by about 4 px.
  double max_image_motion_px = 1.5;
  // GPS speed, m/s.
  double max_gps_speed = 0.05;
  // Shortest standstill, s.
  double min_duration_s = 1.0;
  // Constraints while still: velocity m/s, angular rate rad/s, and between consecutive poses
  // translation m and rotation rad.
  double sigma_velocity = 0.002;
  double sigma_rate = 0.001;
  double sigma_translation = 0.0002;
  double sigma_rotation = 0.00002;

  OptionCheck Check() const;
};

struct TimeInterval {
  Timestamp begin = 0;
  Timestamp end = 0;
  double seconds() const { return DurationSeconds(begin, end); }
};

// The intervals over which the IMU says nothing changes (samples sorted by time; pairs of
// consecutive windows of options.window_s, stepped by half a window; each agreeing pair makes
// the middle of its span quiet, from half a window after its start to half a window before its
// end), merged, each at least options.min_duration_s long. rate_hz: the nominal sample rate (a
// window with fewer than half its samples is an IMU gap, not a standstill).
std::vector<TimeInterval> QuietImuIntervals(const std::vector<ImuSample>& samples, double rate_hz,
                                            const StandstillOptions& options);

// What the other sensors say about the interval between state k and k + 1: the median image
// motion in px and the GPS speed in m/s (unset: that sensor has nothing to say there).
struct IntervalMotion {
  std::optional<double> image_motion_px;
  std::optional<double> gps_speed;
};

// Per interval between consecutive states (size times.size() − 1): true when the rig stands
// still over it — inside a quiet IMU interval and not contradicted by `motion` (empty, or one
// entry per interval). Runs of still intervals shorter than options.min_duration_s are dropped.
std::vector<bool> StillIntervals(const std::vector<Timestamp>& times,
                                 const std::vector<TimeInterval>& quiet_imu,
                                 const std::vector<IntervalMotion>& motion,
                                 const StandstillOptions& options);

// The runs of still intervals as time spans (for summaries and logs).
std::vector<TimeInterval> StillSpans(const std::vector<Timestamp>& times,
                                     const std::vector<bool>& still);

// Two consecutive poses of a standstill are one pose. Parameter blocks pose_i[7], pose_j[7]
// (state_layout.h):
//   r = [(p_j − p_i) / σ_t; Log(R_iᵀ R_j) / σ_r]
// Jacobians (R ← R Exp(δφ), p ← p + δp; E = R_iᵀ R_j, φ = Log E):
//   ∂r/∂δp_i = −I/σ_t, ∂r/∂δp_j = I/σ_t, ∂r/∂δφ_i = −Jr⁻¹(φ) Eᵀ/σ_r, ∂r/∂δφ_j = Jr⁻¹(φ)/σ_r.
class StandstillPoseFactor final : public ceres::SizedCostFunction<6, 7, 7> {
 public:
  StandstillPoseFactor(double sigma_translation, double sigma_rotation);
  static ceres::CostFunction* Create(double sigma_translation, double sigma_rotation);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double inv_sigma_translation_;
  double inv_sigma_rotation_;
};

}  // namespace crop4d::slam
