#pragma once

// The vehicle's true trajectory over one session: it drives every lane of the field
// boustrophedon (lane 0 northward, lane 1 southward, ...) with headland U-turns between lanes,
// a small random lateral offset and wobble within each pass, and roll, pitch and heave from
// the terrain under its four wheels.
//
// The body frame B is the IMU frame (DESIGN.md §3): x forward, y left, z up, origin at the
// IMU, `body_height_m` above the ground. The trajectory is a smooth function of time so that
// the IMU signals are exact derivatives of the poses:
//   - position p(t) = (x, y, z) and the terrain angles roll φ(t), pitch θ(t) are uniform
//     quintic B-splines (C⁴) whose control points are samples of the planned path at the
//     Greville abscissae (a uniform B-spline reproduces straight lines at constant speed
//     exactly and smooths the corners; de Boor, "A Practical Guide to Splines", 2001, ch. IX);
//   - heading ψ(t) = atan2(ẏ, ẋ): a ground vehicle points where it goes (no side slip);
//   - world_from_body rotation R = Rz(ψ) Ry(θ) Rx(φ) (yaw-pitch-roll, ZYX);
//   - angular velocity in B from the ZYX Euler rates (Diebel, "Representing Attitude", 2006;
//     checked numerically in the tests),
//       ω = Rx(φ)ᵀ Ry(θ)ᵀ (0, 0, ψ̇) + Rx(φ)ᵀ (0, θ̇, 0) + (φ̇, 0, 0)
//         = [φ̇ − ψ̇ sin θ,  θ̇ cos φ + ψ̇ cos θ sin φ,  −θ̇ sin φ + ψ̇ cos θ cos φ],
//     with ψ̇ = (ẋ ÿ − ẏ ẍ) / (ẋ² + ẏ²);
//   - acceleration a = p̈ from the spline.
//
// Lanes: with lane = "row" (default) the vehicle is centred over row r (it straddles it, its
// wheels in the tyre tracks midway between rows, track width = row spacing) for r = 0..N−1; with
// lane = "furrow" it is centred over the furrow between rows r and r+1 for r = 0..N−2. Either
// way a pass is a straight north–south segment at x = lane x (± a few cm), so the pass index is
// recovered from a GPS track by round((x − x₀) / row_spacing).

#include <Eigen/Core>
#include <string>
#include <vector>

#include "crop4d/geometry/rigid.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

struct TrajectoryOptions {
  // "row": centred over each row (straddling it); "furrow": centred between adjacent rows.
  std::string lane = "row";
  // Cruise speed along the rows, m/s.
  double speed_mps = 1.5;
  // Speed in the headland turns, m/s.
  double turn_speed_mps = 1.0;
  // Radius of the arcs of the U-turns, m.
  double turn_radius_m = 1.8;
  // Straight run beyond each end of the rows before a turn begins, m.
  double lead_m = 1.0;
  // Distance over which the speed changes between cruise and turn speed, m.
  double speed_ramp_m = 1.5;
  // Std-dev of the constant lateral offset of each pass from the lane centre, m.
  double lateral_offset_m = 0.03;
  // Amplitude of the smooth lateral wobble within a pass (the heading wobble follows), m.
  double lateral_wobble_m = 0.02;
  // Main wavelength of that wobble along the pass, m.
  double wobble_wavelength_m = 6.0;
  // Height of the body (IMU) origin above the ground, m.
  double body_height_m = 0.8;
  // Distance between front and rear axles (pitch from the terrain), m.
  double wheelbase_m = 1.6;
  // Distance between left and right wheels (roll from the terrain), m.
  double track_width_m = 0.91;
  // Knot interval of the trajectory splines; larger is smoother, s.
  double knot_interval_s = 0.1;
  // Stop the session after this many seconds of driving (standstills not counted); 0 drives
  // the whole field.
  double max_duration_s = 0.0;
  // Standstills (real drivers stop; every sensor keeps recording): the vehicle stands still
  // for this long at the start of the session, s (0 = none) ...
  double standstill_start_s = 0.0;
  // ... stops at the end of a pass (beyond the row end) with this probability ...
  double stop_probability_row_end = 0.0;
  // ... and at a random place within a pass with this probability ...
  double stop_probability_in_row = 0.0;
  // ... for this long, s ...
  double stop_duration_s = 3.0;
  // ... braking to and accelerating from the stop over this long each (raised-cosine speed
  // profile), s.
  double stop_ramp_s = 1.5;

  // Throws InputError naming the bad option (prefix "drive.").
  void Check() const;
};

// The true state of the body at one instant.
struct BodyState {
  geometry::Rigid3 world_from_body;
  Eigen::Vector3d velocity_world = Eigen::Vector3d::Zero();         // m/s, ENU
  Eigen::Vector3d acceleration_world = Eigen::Vector3d::Zero();     // m/s², ENU (no gravity)
  Eigen::Vector3d angular_velocity_body = Eigen::Vector3d::Zero();  // rad/s, frame B
  double roll = 0.0, pitch = 0.0, yaw = 0.0;                        // rad, R = Rz Ry Rx
};

// An interval in which the vehicle stands exactly still, seconds since the session start.
struct Standstill {
  double t_begin = 0.0;
  double t_end = 0.0;
};

// One straight pass along a lane, lead-in and lead-out included.
struct Pass {
  int index = 0;          // 0, 1, ... in driving order
  int lane = 0;           // lane index (= row index with lane "row")
  double lane_x = 0.0;    // nominal x of the lane centre, m
  bool northward = true;  // direction of travel
  double t_begin = 0.0;   // seconds since the session start
  double t_end = 0.0;
};

// Uniform B-spline of any degree in time: control points c_0..c_{n-1}, knot interval dt, valid
// on [0, (n − degree) dt]. Segment i uses c_i..c_{i+degree}; evaluation by de Boor's algorithm,
// derivatives by differencing the control points (de Boor 2001, ch. X).
class UniformBSpline {
 public:
  UniformBSpline() = default;
  UniformBSpline(int degree, double dt, std::vector<Eigen::VectorXd> control_points);

  // Time of control point i's Greville abscissa: (i − (degree − 1) / 2) dt.
  static double GrevilleTime(int degree, double dt, int i) { return (i - 0.5 * (degree - 1)) * dt; }
  double EndTime() const;
  // The `derivative`-th time derivative at t (clamped to the valid interval).
  Eigen::VectorXd Evaluate(double t, int derivative = 0) const;

 private:
  int degree_ = 0;
  double dt_ = 1.0;
  // derivatives_[k]: control points of the k-th derivative (degree − k).
  std::vector<std::vector<Eigen::VectorXd>> derivatives_;
};

class Trajectory {
 public:
  // Plans the drive over `world`. `seed` draws the per-pass offsets and wobble.
  Trajectory(const World& world, const TrajectoryOptions& options, std::uint64_t seed);

  const TrajectoryOptions& options() const { return options_; }
  // Seconds from the start to the end of the session (max_duration_s and standstills applied).
  double Duration() const { return wall_duration_; }
  // The intervals in which the vehicle stands still, in time order.
  const std::vector<Standstill>& standstills() const { return standstills_; }
  // The state at `t` seconds since the session start, t in [0, Duration()].
  BodyState StateAt(double t) const;
  geometry::Rigid3 WorldFromBody(double t) const { return StateAt(t).world_from_body; }

  // The passes in driving order (cut at Duration()).
  const std::vector<Pass>& passes() const { return passes_; }
  int num_lanes() const { return num_lanes_; }
  double LaneX(int lane) const;
  // Total planned path length in the plane, m.
  double PathLength() const { return path_length_; }

  // How far the turn reaches beyond the end of a lane (lead_m excluded), for the headland
  // check: an omega turn when 2 r > lane spacing, else a U of two quarter circles.
  static double TurnReach(double lane_spacing_m, double turn_radius_m);

 private:
  // A piece of the planned path in the plane: constant curvature (0 for a straight line).
  struct Segment {
    Eigen::Vector2d start = Eigen::Vector2d::Zero();
    double heading = 0.0;    // at the start, rad, counter-clockwise from east
    double length = 0.0;     // m
    double curvature = 0.0;  // 1/m, positive = turning left
    bool is_pass = false;
    int pass_index = -1;
    // Lateral offset of a pass: offset + wobble·(0.7 sin(2πu/λ + φ1) + 0.3 sin(2πu/(0.41λ) + φ2)).
    double offset = 0.0;
    double phase1 = 0.0, phase2 = 0.0;

    Eigen::Vector2d PositionAt(double u) const {
      if (curvature == 0.0) {
        return start + u * Eigen::Vector2d(std::cos(heading), std::sin(heading));
      }
      const double r = 1.0 / curvature;
      const Eigen::Vector2d center =
          start + r * Eigen::Vector2d(-std::sin(heading), std::cos(heading));
      const double h = heading + curvature * u;
      return center + r * Eigen::Vector2d(std::sin(h), -std::cos(h));
    }
    double HeadingAt(double u) const { return heading + curvature * u; }
  };
  struct PlanarPose {
    Eigen::Vector2d xy;
    double heading;
  };
  PlanarPose PathAt(double s) const;  // along the planned path, lateral offset included
  double SpeedAt(double s) const;
  // The state at `tau` seconds of driving time (standstills removed).
  BodyState DrivingStateAt(double tau) const;

  // Standstills warp time: the session's time t maps to the driving time τ(t) with
  // dτ/dt = σ(t) ∈ [0, 1], 1 while driving, 0 standing still, raised-cosine ramps between.
  // Pieces of the warp in session time, contiguous from t = 0.
  enum class WarpKind { kDrive, kBrake, kStill, kAccelerate };
  struct WarpPiece {
    WarpKind kind = WarpKind::kDrive;
    double t_begin = 0.0, t_end = 0.0;  // session time
    double tau_begin = 0.0;             // driving time at t_begin
  };
  // τ, σ = dτ/dt and dσ/dt at session time t.
  void Warp(double t, double* tau, double* sigma, double* sigma_rate) const;
  // The session time at which the driving time reaches `tau` (the first such time, or the
  // last with `last`).
  double SessionTimeOf(double tau, bool last) const;
  void PlanStandstills(std::uint64_t seed);

  const World* world_;
  TrajectoryOptions options_;
  int num_lanes_ = 0;
  double lane_x0_ = 0.0;
  std::vector<Segment> segments_;
  std::vector<double> segment_start_s_;
  double path_length_ = 0.0;
  double duration_ = 0.0;        // driving time
  double wall_duration_ = 0.0;   // session time
  std::vector<WarpPiece> warp_;  // empty: no standstills, t = τ
  std::vector<Standstill> standstills_;
  std::vector<Pass> passes_;
  UniformBSpline xyz_;     // x, y, z
  UniformBSpline angles_;  // roll, pitch
};

}  // namespace crop4d::sim
