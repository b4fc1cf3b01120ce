#include "crop4d/sim/trajectory.h"

#include <fmt/format.h>

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"
#include "crop4d/sim/random.h"

namespace crop4d::sim {

namespace {

void Require(bool ok, const char* key, const std::string& what) {
  if (!ok) throw InputError(fmt::format("drive.{}: {}", key, what));
}

// Quintic "smootherstep" 6x⁵ − 15x⁴ + 10x³ on [0, 1] (C² at both ends), clamped outside.
double SmoothStep(double x) {
  if (x <= 0.0) return 0.0;
  if (x >= 1.0) return 1.0;
  return x * x * x * (x * (6.0 * x - 15.0) + 10.0);
}

constexpr int kSplineDegree = 5;
constexpr double kPathStep = 0.005;  // m, resolution of the time-of-arc-length table

}  // namespace

void TrajectoryOptions::Check() const {
  Require(lane == "row" || lane == "furrow", "lane",
          "must be \"row\" or \"furrow\", not \"" + lane + "\"");
  Require(std::isfinite(speed_mps) && speed_mps > 0.0, "speed_mps", "must be positive");
  Require(std::isfinite(turn_speed_mps) && turn_speed_mps > 0.0, "turn_speed_mps",
          "must be positive");
  Require(std::isfinite(turn_radius_m) && turn_radius_m > 0.0, "turn_radius_m", "must be positive");
  Require(std::isfinite(lead_m) && lead_m >= 0.0, "lead_m", "must be >= 0");
  Require(std::isfinite(speed_ramp_m) && speed_ramp_m > 0.0, "speed_ramp_m", "must be positive");
  Require(std::isfinite(lateral_offset_m) && lateral_offset_m >= 0.0, "lateral_offset_m",
          "must be >= 0");
  Require(std::isfinite(lateral_wobble_m) && lateral_wobble_m >= 0.0, "lateral_wobble_m",
          "must be >= 0");
  Require(std::isfinite(wobble_wavelength_m) && wobble_wavelength_m > 0.0, "wobble_wavelength_m",
          "must be positive");
  Require(std::isfinite(body_height_m) && body_height_m > 0.0, "body_height_m", "must be positive");
  Require(std::isfinite(wheelbase_m) && wheelbase_m > 0.0, "wheelbase_m", "must be positive");
  Require(std::isfinite(track_width_m) && track_width_m > 0.0, "track_width_m", "must be positive");
  Require(std::isfinite(knot_interval_s) && knot_interval_s >= 0.01 && knot_interval_s <= 1.0,
          "knot_interval_s", "must be in [0.01, 1]");
  Require(std::isfinite(max_duration_s) && max_duration_s >= 0.0, "max_duration_s",
          "must be >= 0 (0 = the whole field)");
  Require(std::isfinite(standstill_start_s) && standstill_start_s >= 0.0 &&
              standstill_start_s <= 3600.0,
          "standstill_start_s", "must be in [0, 3600]");
  Require(std::isfinite(stop_probability_row_end) && stop_probability_row_end >= 0.0 &&
              stop_probability_row_end <= 1.0,
          "stop_probability_row_end", "must be in [0, 1]");
  Require(std::isfinite(stop_probability_in_row) && stop_probability_in_row >= 0.0 &&
              stop_probability_in_row <= 1.0,
          "stop_probability_in_row", "must be in [0, 1]");
  Require(std::isfinite(stop_duration_s) && stop_duration_s >= 0.0 && stop_duration_s <= 3600.0,
          "stop_duration_s", "must be in [0, 3600]");
  Require(std::isfinite(stop_ramp_s) && stop_ramp_s >= 0.1 && stop_ramp_s <= 60.0, "stop_ramp_s",
          "must be in [0.1, 60]");
}

// ---- UniformBSpline -----------------------------------------------------------------------

UniformBSpline::UniformBSpline(int degree, double dt, std::vector<Eigen::VectorXd> control_points)
    : degree_(degree), dt_(dt) {
  CROP4D_CHECK(degree >= 1 && dt > 0.0);
  CROP4D_CHECK(static_cast<int>(control_points.size()) > degree);
  derivatives_.push_back(std::move(control_points));
  for (int k = 1; k <= degree; ++k) {
    const std::vector<Eigen::VectorXd>& c = derivatives_.back();
    std::vector<Eigen::VectorXd> d(c.size() - 1);
    for (size_t i = 0; i + 1 < c.size(); ++i) d[i] = (c[i + 1] - c[i]) / dt;
    derivatives_.push_back(std::move(d));
  }
}

double UniformBSpline::EndTime() const {
  return (static_cast<double>(derivatives_[0].size()) - degree_) * dt_;
}

Eigen::VectorXd UniformBSpline::Evaluate(double t, int derivative) const {
  CROP4D_CHECK(derivative >= 0);
  const int q = degree_ - derivative;
  if (q < 0) return Eigen::VectorXd::Zero(derivatives_[0][0].size());
  const std::vector<Eigen::VectorXd>& c = derivatives_[derivative];
  const int num_segments = static_cast<int>(derivatives_[0].size()) - degree_;
  const double x = std::clamp(t / dt_, 0.0, static_cast<double>(num_segments));
  const int i = std::min(static_cast<int>(std::floor(x)), num_segments - 1);
  const double local = x - i + q;  // position in the local knot numbering (knots at integers)
  // de Boor's algorithm on uniform integer knots: segment [q, q + 1], points c_i..c_{i+q}.
  Eigen::VectorXd d[kSplineDegree + 8];
  CROP4D_CHECK(q < kSplineDegree + 8);
  for (int j = 0; j <= q; ++j) d[j] = c[i + j];
  for (int r = 1; r <= q; ++r) {
    for (int j = q; j >= r; --j) {
      const double alpha = (local - j) / (q + 1 - r);
      d[j] = (1.0 - alpha) * d[j - 1] + alpha * d[j];
    }
  }
  return d[q];
}

// ---- Trajectory ---------------------------------------------------------------------------

double Trajectory::TurnReach(double lane_spacing_m, double turn_radius_m) {
  const double d = lane_spacing_m, r = turn_radius_m;
  if (d >= 2.0 * r) return r;
  const double alpha = std::acos((0.5 * d + r) / (2.0 * r));
  return 2.0 * r * std::sin(alpha) + r;
}

double Trajectory::LaneX(int lane) const {
  return lane_x0_ + lane * world_->options().row_spacing_m;
}

Trajectory::Trajectory(const World& world, const TrajectoryOptions& options, std::uint64_t seed)
    : world_(&world), options_(options) {
  options_.Check();
  const WorldOptions& w = world.options();
  const TrajectoryOptions& o = options_;
  if (o.lane == "row") {
    num_lanes_ = w.num_rows;
    lane_x0_ = 0.0;
  } else {
    Require(w.num_rows >= 2, "lane", "\"furrow\" needs at least 2 rows");
    num_lanes_ = w.num_rows - 1;
    lane_x0_ = 0.5 * w.row_spacing_m;
  }
  const double spacing = w.row_spacing_m;
  const double reach = TurnReach(spacing, o.turn_radius_m);
  Require(o.lead_m + reach <= w.headland_m + 1e-9, "turn_radius_m",
          fmt::format("the headland turns reach {:.2f} m beyond the rows (lead_m {} + turn {:.2f}) "
                      "but the headland is only {} m wide (rows.headland_m)",
                      o.lead_m + reach, o.lead_m, reach, w.headland_m));

  // ---- Plan the path: passes and turns.
  Random random(HashCombine(seed, 0x7a11u));
  const double y_south = -o.lead_m, y_north = w.row_length_m + o.lead_m;
  Eigen::Vector2d cursor(LaneX(0), y_south);
  double heading = 0.5 * M_PI;
  auto add = [&](double length, double curvature, bool is_pass) {
    Segment seg;
    seg.start = cursor;
    seg.heading = heading;
    seg.length = length;
    seg.curvature = curvature;
    seg.is_pass = is_pass;
    segments_.push_back(seg);
    cursor = seg.PositionAt(length);
    heading = seg.HeadingAt(length);
  };
  const double r = o.turn_radius_m;
  for (int lane = 0; lane < num_lanes_; ++lane) {
    add(y_north - y_south, 0.0, true);
    Segment& pass = segments_.back();
    pass.pass_index = lane;
    pass.offset = random.Normal(0.0, o.lateral_offset_m);
    pass.phase1 = random.Uniform(0.0, 2.0 * M_PI);
    pass.phase2 = random.Uniform(0.0, 2.0 * M_PI);
    if (lane + 1 == num_lanes_) break;
    // Northward passes turn right at the north end, southward passes left at the south end,
    // so that the next lane is always the one to the east.
    const double sign = (lane % 2 == 0) ? -1.0 : 1.0;
    if (spacing >= 2.0 * r) {
      // U of two quarter circles joined by a straight line.
      add(0.5 * M_PI * r, sign / r, false);
      if (spacing > 2.0 * r) add(spacing - 2.0 * r, 0.0, false);
      add(0.5 * M_PI * r, sign / r, false);
    } else {
      // Omega turn: away from the next lane by α, towards it by π + 2α, away by α, with
      // cos α = (d/2 + r) / (2r) so that the middle arc's centre lies midway between the lanes.
      const double alpha = std::acos((0.5 * spacing + r) / (2.0 * r));
      add(alpha * r, -sign / r, false);
      add((M_PI + 2.0 * alpha) * r, sign / r, false);
      add(alpha * r, -sign / r, false);
    }
    CROP4D_CHECK(
        (cursor - Eigen::Vector2d(LaneX(lane + 1), lane % 2 == 0 ? y_north : y_south)).norm() <
        1e-6);
  }
  double s = 0.0;
  for (const Segment& seg : segments_) {
    segment_start_s_.push_back(s);
    s += seg.length;
  }
  path_length_ = s;

  // ---- Time along the path: t(s) = ∫ ds / v(s) (trapezoid rule).
  const int steps = std::max(1, static_cast<int>(std::ceil(path_length_ / kPathStep)));
  const double ds = path_length_ / steps;
  std::vector<double> t_of_s(steps + 1, 0.0);
  double inv_prev = 1.0 / SpeedAt(0.0);
  for (int k = 1; k <= steps; ++k) {
    const double inv = 1.0 / SpeedAt(k * ds);
    t_of_s[k] = t_of_s[k - 1] + 0.5 * ds * (inv_prev + inv);
    inv_prev = inv;
  }
  const double full_duration = t_of_s.back();
  duration_ = o.max_duration_s > 0.0 ? std::min(o.max_duration_s, full_duration) : full_duration;
  auto s_of_t = [&](double t) {
    if (t <= 0.0) return t * SpeedAt(0.0);
    if (t >= full_duration) return path_length_ + (t - full_duration) * SpeedAt(path_length_);
    const auto it = std::upper_bound(t_of_s.begin(), t_of_s.end(), t);
    const int k = static_cast<int>(it - t_of_s.begin()) - 1;
    const double f = (t - t_of_s[k]) / (t_of_s[k + 1] - t_of_s[k]);
    return (k + f) * ds;
  };
  auto t_of = [&](double s_query) {
    const double x = std::clamp(s_query / ds, 0.0, static_cast<double>(steps));
    const int k = std::min(static_cast<int>(x), steps - 1);
    return t_of_s[k] + (x - k) * (t_of_s[k + 1] - t_of_s[k]);
  };

  // ---- Passes in time.
  for (size_t k = 0; k < segments_.size(); ++k) {
    const Segment& seg = segments_[k];
    if (!seg.is_pass) continue;
    Pass pass;
    pass.index = static_cast<int>(passes_.size());
    pass.lane = seg.pass_index;
    pass.lane_x = LaneX(seg.pass_index);
    pass.northward = std::sin(seg.heading) > 0.0;
    pass.t_begin = t_of(segment_start_s_[k]);
    pass.t_end = std::min(duration_, t_of(segment_start_s_[k] + seg.length));
    if (pass.t_begin >= duration_) break;
    passes_.push_back(pass);
  }

  // ---- Control points at the Greville abscissae: position on the path, heave, roll and pitch
  // from the terrain under the wheels.
  const double dt = o.knot_interval_s;
  const int num_segments = std::max(1, static_cast<int>(std::ceil(duration_ / dt)));
  const int n = num_segments + kSplineDegree;
  std::vector<Eigen::VectorXd> xyz(n), angles(n);
  for (int i = 0; i < n; ++i) {
    const double t = UniformBSpline::GrevilleTime(kSplineDegree, dt, i);
    const PlanarPose pose = PathAt(s_of_t(t));
    const Eigen::Vector2d forward(std::cos(pose.heading), std::sin(pose.heading));
    const Eigen::Vector2d left(-forward.y(), forward.x());
    const double half_base = 0.5 * o.wheelbase_m, half_track = 0.5 * o.track_width_m;
    auto height = [&](double f, double l) {
      const Eigen::Vector2d p = pose.xy + f * forward + l * left;
      return world.TerrainHeight(p.x(), p.y());
    };
    const double fl = height(half_base, half_track), fr = height(half_base, -half_track);
    const double rl = height(-half_base, half_track), rr = height(-half_base, -half_track);
    const double z = 0.25 * (fl + fr + rl + rr) + o.body_height_m;
    // Nose up (front higher) is a negative pitch about the left-pointing y axis; left side up
    // is a positive roll about the forward x axis.
    const double pitch = -std::atan2(0.5 * (fl + fr) - 0.5 * (rl + rr), o.wheelbase_m);
    const double roll = std::atan2(0.5 * (fl + rl) - 0.5 * (fr + rr), o.track_width_m);
    xyz[i] = Eigen::Vector3d(pose.xy.x(), pose.xy.y(), z);
    angles[i] = Eigen::Vector2d(roll, pitch);
  }
  xyz_ = UniformBSpline(kSplineDegree, dt, std::move(xyz));
  angles_ = UniformBSpline(kSplineDegree, dt, std::move(angles));

  wall_duration_ = duration_;
  PlanStandstills(seed);
}

// ---- Standstills ----------------------------------------------------------------------------

void Trajectory::PlanStandstills(std::uint64_t seed) {
  const TrajectoryOptions& o = options_;
  const bool any_stops = o.stop_probability_row_end > 0.0 || o.stop_probability_in_row > 0.0;
  if (o.standstill_start_s <= 0.0 && !any_stops) return;
  // The driving times at which the vehicle comes to rest (its own random stream: the path's
  // stream is untouched).
  Random random(HashCombine(seed, 0x5700u));
  const double ramp = o.stop_ramp_s;
  std::vector<double> stops;
  for (const Pass& pass : passes_) {
    const double row_part = pass.t_end - pass.t_begin - 2.0 * ramp;
    const double in_row = random.Uniform();
    const double where = random.Uniform();
    const double at_end = random.Uniform();
    if (o.stop_probability_in_row > 0.0 && in_row < o.stop_probability_in_row && row_part > 0) {
      stops.push_back(pass.t_begin + ramp + where * row_part);
    }
    if (o.stop_probability_row_end > 0.0 && at_end < o.stop_probability_row_end) {
      stops.push_back(pass.t_end);
    }
  }
  std::sort(stops.begin(), stops.end());
  // Braking takes ramp/2 of driving time: keep the stops that leave room for it after the
  // start (or the previous stop) and before the end.
  std::vector<double> kept;
  double earliest = o.standstill_start_s > 0.0 ? 0.5 * ramp : 0.0;
  for (const double tau : stops) {
    if (tau - 0.5 * ramp < earliest || tau + 0.5 * ramp > duration_) continue;
    kept.push_back(tau);
    earliest = tau + 0.5 * ramp;
  }

  // Pieces in session time.
  double t = 0.0, tau = 0.0;
  auto add = [&](WarpKind kind, double length, double driven) {
    warp_.push_back({kind, t, t + length, tau});
    t += length;
    tau += driven;
  };
  if (o.standstill_start_s > 0.0) {
    standstills_.push_back({0.0, o.standstill_start_s});
    add(WarpKind::kStill, o.standstill_start_s, 0.0);
    add(WarpKind::kAccelerate, ramp, 0.5 * ramp);
  }
  for (const double stop : kept) {
    add(WarpKind::kDrive, stop - 0.5 * ramp - tau, stop - 0.5 * ramp - tau);
    add(WarpKind::kBrake, ramp, 0.5 * ramp);
    standstills_.push_back({t, t + o.stop_duration_s});
    add(WarpKind::kStill, o.stop_duration_s, 0.0);
    add(WarpKind::kAccelerate, ramp, 0.5 * ramp);
  }
  add(WarpKind::kDrive, duration_ - tau, duration_ - tau);
  wall_duration_ = t;
  for (Pass& pass : passes_) {
    pass.t_begin = SessionTimeOf(pass.t_begin, false);
    pass.t_end = SessionTimeOf(pass.t_end, true);
  }
}

void Trajectory::Warp(double t, double* tau, double* sigma, double* sigma_rate) const {
  if (warp_.empty()) {
    *tau = t;
    *sigma = 1.0;
    *sigma_rate = 0.0;
    return;
  }
  t = std::clamp(t, 0.0, wall_duration_);
  auto it = std::upper_bound(warp_.begin(), warp_.end(), t,
                             [](double x, const WarpPiece& p) { return x < p.t_begin; });
  const WarpPiece& p = *std::prev(it);
  const double length = p.t_end - p.t_begin, dt = t - p.t_begin;
  const double u = length > 0.0 ? std::clamp(dt / length, 0.0, 1.0) : 0.0;
  switch (p.kind) {
    case WarpKind::kDrive:
      *tau = p.tau_begin + dt;
      *sigma = 1.0;
      *sigma_rate = 0.0;
      break;
    case WarpKind::kStill:
      *tau = p.tau_begin;
      *sigma = 0.0;
      *sigma_rate = 0.0;
      break;
    case WarpKind::kBrake:  // σ = (1 + cos πu) / 2
      *tau = p.tau_begin + 0.5 * length * (u + std::sin(M_PI * u) / M_PI);
      *sigma = 0.5 * (1.0 + std::cos(M_PI * u));
      *sigma_rate = -0.5 * M_PI * std::sin(M_PI * u) / length;
      break;
    case WarpKind::kAccelerate:  // σ = (1 − cos πu) / 2
      *tau = p.tau_begin + 0.5 * length * (u - std::sin(M_PI * u) / M_PI);
      *sigma = 0.5 * (1.0 - std::cos(M_PI * u));
      *sigma_rate = 0.5 * M_PI * std::sin(M_PI * u) / length;
      break;
  }
}

double Trajectory::SessionTimeOf(double tau, bool last) const {
  if (warp_.empty()) return tau;
  // τ(t) is non-decreasing: bisection for the first t with τ(t) >= tau (or the last with
  // τ(t) <= tau).
  double lo = 0.0, hi = wall_duration_;
  for (int k = 0; k < 100; ++k) {
    const double mid = 0.5 * (lo + hi);
    double x, sigma, rate;
    Warp(mid, &x, &sigma, &rate);
    if (last ? x <= tau : x < tau) {
      lo = mid;
    } else {
      hi = mid;
    }
  }
  return last ? lo : hi;
}

BodyState Trajectory::StateAt(double t) const {
  if (warp_.empty()) return DrivingStateAt(t);
  double tau, sigma, sigma_rate;
  Warp(t, &tau, &sigma, &sigma_rate);
  BodyState state = DrivingStateAt(tau);
  // d/dt = σ d/dτ: v = σ v_τ, a = σ² a_τ + σ' v_τ, and every rate (ω) scales with σ.
  state.acceleration_world =
      sigma * sigma * state.acceleration_world + sigma_rate * state.velocity_world;
  state.velocity_world *= sigma;
  state.angular_velocity_body *= sigma;
  return state;
}

double Trajectory::SpeedAt(double s) const {
  const TrajectoryOptions& o = options_;
  const auto it = std::upper_bound(segment_start_s_.begin(), segment_start_s_.end(), s);
  const int k = std::max(0, static_cast<int>(it - segment_start_s_.begin()) - 1);
  const Segment& seg = segments_[k];
  if (!seg.is_pass) return o.turn_speed_mps;
  const double u = s - segment_start_s_[k];
  // Ramps only next to turns: the session starts and ends at cruise speed.
  const bool turn_before = k > 0, turn_after = k + 1 < static_cast<int>(segments_.size());
  double f = 1.0;
  if (turn_before) f = std::min(f, SmoothStep(u / o.speed_ramp_m));
  if (turn_after) f = std::min(f, SmoothStep((seg.length - u) / o.speed_ramp_m));
  return o.turn_speed_mps + (o.speed_mps - o.turn_speed_mps) * f;
}

Trajectory::PlanarPose Trajectory::PathAt(double s) const {
  const auto it = std::upper_bound(segment_start_s_.begin(), segment_start_s_.end(), s);
  const int k = std::max(0, static_cast<int>(it - segment_start_s_.begin()) - 1);
  const Segment& seg = segments_[k];
  const double u = s - segment_start_s_[k];  // may run past either end of the first/last pass
  PlanarPose pose{seg.PositionAt(u), seg.HeadingAt(u)};
  if (seg.is_pass) {
    const TrajectoryOptions& o = options_;
    const double window_m = std::max(o.lead_m, 0.5);
    const double window = SmoothStep(u / window_m) * SmoothStep((seg.length - u) / window_m);
    const double lambda = o.wobble_wavelength_m;
    const double wobble = 0.7 * std::sin(2.0 * M_PI * u / lambda + seg.phase1) +
                          0.3 * std::sin(2.0 * M_PI * u / (0.41 * lambda) + seg.phase2);
    const double lateral = window * (seg.offset + o.lateral_wobble_m * wobble);
    pose.xy += lateral * Eigen::Vector2d(-std::sin(pose.heading), std::cos(pose.heading));
  }
  return pose;
}

BodyState Trajectory::DrivingStateAt(double t) const {
  const Eigen::VectorXd p = xyz_.Evaluate(t, 0);
  const Eigen::VectorXd v = xyz_.Evaluate(t, 1);
  const Eigen::VectorXd a = xyz_.Evaluate(t, 2);
  const Eigen::VectorXd ang = angles_.Evaluate(t, 0);
  const Eigen::VectorXd ang_rate = angles_.Evaluate(t, 1);
  BodyState state;
  state.yaw = std::atan2(v.y(), v.x());
  const double yaw_rate = (v.x() * a.y() - v.y() * a.x()) / (v.x() * v.x() + v.y() * v.y());
  state.roll = ang[0];
  state.pitch = ang[1];
  const double roll_rate = ang_rate[0], pitch_rate = ang_rate[1];
  const double sr = std::sin(state.roll), cr = std::cos(state.roll);
  const double sp = std::sin(state.pitch), cp = std::cos(state.pitch);
  const Eigen::Quaterniond rotation = Eigen::AngleAxisd(state.yaw, Eigen::Vector3d::UnitZ()) *
                                      Eigen::AngleAxisd(state.pitch, Eigen::Vector3d::UnitY()) *
                                      Eigen::AngleAxisd(state.roll, Eigen::Vector3d::UnitX());
  state.world_from_body = geometry::Rigid3(rotation, p.head<3>());
  state.velocity_world = v.head<3>();
  state.acceleration_world = a.head<3>();
  state.angular_velocity_body =
      Eigen::Vector3d(roll_rate - yaw_rate * sp, pitch_rate * cr + yaw_rate * cp * sr,
                      -pitch_rate * sr + yaw_rate * cp * cr);
  return state;
}

}  // namespace crop4d::sim
