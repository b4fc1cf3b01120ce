#include "crop4d/slam/initialisation.h"

#include <spdlog/spdlog.h>

#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {
namespace {

// Index of the first fix at or after t.
std::size_t LowerFix(const std::vector<GpsFixWorld>& fixes, Timestamp t) {
  return std::lower_bound(fixes.begin(), fixes.end(), t,
                          [](const GpsFixWorld& f, Timestamp x) { return f.t < x; }) -
         fixes.begin();
}

// Gyro-only rotation from t_a to t_b (b may precede a: then the inverse), zero bias.
Eigen::Matrix3d GyroRotation(const std::vector<ImuSample>& samples, Timestamp t_a, Timestamp t_b) {
  if (samples.empty() || t_a == t_b) return Eigen::Matrix3d::Identity();
  ImuPreintegration pre(ImuPreintegration::Options(), Vector6d::Zero());
  if (t_b > t_a) {
    pre.Integrate(samples, t_a, t_b);
    return pre.delta_rotation();
  }
  pre.Integrate(samples, t_b, t_a);
  return pre.delta_rotation().transpose();
}

Eigen::Vector3d Horizontal(const Eigen::Vector3d& v) { return Eigen::Vector3d(v.x(), v.y(), 0); }

}  // namespace

std::optional<GpsTrackSample> FitGpsTrack(const std::vector<GpsFixWorld>& fixes, Timestamp t,
                                          double half_window_s) {
  const Timestamp half = SecondsToTimestamp(half_window_s);
  std::size_t begin = LowerFix(fixes, t - half);
  std::size_t end = LowerFix(fixes, t + half + 1);
  if (end - begin < 2) return std::nullopt;
  const double span = DurationSeconds(fixes[begin].t, fixes[end - 1].t);
  if (span < half_window_s) return std::nullopt;
  // Least-squares line in time (centred at t) with the inverse horizontal variance as weight.
  double sw = 0, st = 0, stt = 0;
  Eigen::Vector3d sp = Eigen::Vector3d::Zero(), stp = Eigen::Vector3d::Zero();
  for (std::size_t k = begin; k < end; ++k) {
    const double w = 1.0 / std::max(fixes[k].sigma_h * fixes[k].sigma_h, 1e-8);
    const double dt = DurationSeconds(t, fixes[k].t);
    sw += w;
    st += w * dt;
    stt += w * dt * dt;
    sp += w * fixes[k].position_world;
    stp += w * dt * fixes[k].position_world;
  }
  const double det = sw * stt - st * st;
  if (det <= 1e-12 * sw * sw) return std::nullopt;
  GpsTrackSample sample;
  sample.position_world = (stt * sp - st * stp) / det;
  sample.velocity_world = (sw * stp - st * sp) / det;
  return sample;
}

OptionCheck StateInitialiser::Options::Check() const {
  OptionChecker c;
  c.Greater("gps_half_window_s", gps_half_window_s, 0.0)
      .Greater("gravity_half_window_s", gravity_half_window_s, 0.0)
      .Greater("min_speed_for_course", min_speed_for_course, 0.0)
      .Require(alignment_window_s > alignment_step_s, "alignment_window_s",
               "must be > alignment_step_s", alignment_window_s)
      .Greater("alignment_step_s", alignment_step_s, 0.0)
      .Greater("alignment_min_horizontal_change", alignment_min_horizontal_change, 0.0)
      .Greater("gravity", gravity, 0.0);
  return c.Result();
}

StateInitialiser::StateInitialiser(Options options, const ImuStream& imu, const GpsStream* gps)
    : options_(options), imu_(imu), gps_(gps) {
  if (const OptionCheck why = options_.Check(); !why.empty()) {
    throw std::invalid_argument("StateInitialiser: " + why);
  }
}

Eigen::Vector3d StateInitialiser::Rate(Timestamp t) const {
  return has_imu() ? InterpolateImu(imu_.samples, t).gyro_body : Eigen::Vector3d::Zero();
}

Eigen::Matrix3d StateInitialiser::Turn(Timestamp from, Timestamp to) const {
  return has_imu() ? GyroRotation(imu_.samples, from, to) : Eigen::Matrix3d::Identity();
}

void StateInitialiser::set_forward_axis(const Eigen::Vector3d& forward_axis_body) {
  forward_axis_body_ = forward_axis_body.normalized();
}

Eigen::Vector3d StateInitialiser::UpInBody(Timestamp t) const {
  if (!has_imu()) return Eigen::Vector3d::UnitZ();
  const std::vector<ImuSample>& s = imu_.samples;
  const Timestamp half = SecondsToTimestamp(options_.gravity_half_window_s);
  auto lo = std::lower_bound(s.begin(), s.end(), t - half,
                             [](const ImuSample& a, Timestamp x) { return a.timestamp < x; });
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  int n = 0;
  for (auto it = lo; it != s.end() && it->timestamp <= t + half; ++it, ++n) sum += it->accel_body;
  if (n == 0) sum = InterpolateImu(s, t).accel_body;
  if (sum.norm() < 1e-9) return Eigen::Vector3d::UnitZ();
  return sum.normalized();
}

Eigen::Matrix3d StateInitialiser::AttitudeFromCourse(const Eigen::Vector3d& up_body,
                                                     const Eigen::Vector3d& course_world) const {
  Eigen::Vector3d forward = forward_axis_body_ - forward_axis_body_.dot(up_body) * up_body;
  if (forward.norm() < 1e-6) {
    // The forward axis is vertical: any horizontal body axis will do.
    forward = up_body.unitOrthogonal();
  }
  forward.normalize();
  Eigen::Matrix3d body_basis, world_basis;
  body_basis << forward, up_body.cross(forward), up_body;
  const Eigen::Vector3d c = Horizontal(course_world).normalized();
  world_basis << c, Eigen::Vector3d::UnitZ().cross(c), Eigen::Vector3d::UnitZ();
  return world_basis * body_basis.transpose();
}

Eigen::Vector3d StateInitialiser::EstimateForwardAxis(const Eigen::Vector3d& p_body_antenna,
                                                      Summary* summary) {
  Summary local;
  Summary& out = summary != nullptr ? *summary : local;
  out.num_alignment_windows = 0;
  out.forward_axis_fallback = true;
  forward_axis_body_ = Eigen::Vector3d::UnitX();
  if (gps_ == nullptr || gps_->fixes.size() < 4 || !has_imu()) {
    out.forward_axis_body = forward_axis_body_;
    return forward_axis_body_;
  }
  const std::vector<ImuSample>& samples = imu_.samples;
  const Timestamp t_first = std::max(samples.front().timestamp, gps_->fixes.front().t);
  const Timestamp t_last = std::min(samples.back().timestamp, gps_->fixes.back().t);
  const Timestamp window = SecondsToTimestamp(options_.alignment_window_s);
  const Timestamp step = SecondsToTimestamp(options_.alignment_step_s);
  const Eigen::Vector3d g_world(0, 0, -options_.gravity);
  Eigen::Vector3d axis_sum = Eigen::Vector3d::Zero();
  for (Timestamp t0 = t_first; t0 + window <= t_last; t0 += window / 2) {
    // At the sub-interval boundaries b_k: the antenna velocity from GPS, and the gyro rotation,
    // integrated specific force and rate from the IMU (relative to the body at t0).
    struct Boundary {
      Timestamp t;
      Eigen::Vector3d vel_antenna, dv, rate;
      Eigen::Matrix3d dR;
    };
    std::vector<Boundary> boundaries;
    ImuPreintegration pre(ImuPreintegration::Options(), Vector6d::Zero());
    bool ok = true;
    for (Timestamp b = t0; b <= t0 + window; b += step) {
      if (b > t0) pre.Integrate(samples, b - step, b);
      const std::optional<GpsTrackSample> fit =
          FitGpsTrack(gps_->fixes, b, options_.gps_half_window_s);
      if (!fit) {
        ok = false;
        break;
      }
      boundaries.push_back({b, fit->velocity_world, pre.delta_velocity(),
                            InterpolateImu(samples, b).gyro_body, pre.delta_rotation()});
    }
    if (!ok || boundaries.size() < 3) continue;
    double horizontal_change = 0;
    for (std::size_t k = 1; k < boundaries.size(); ++k) {
      horizontal_change +=
          Horizontal(boundaries[k].vel_antenna - boundaries[k - 1].vel_antenna).norm();
    }
    if (horizontal_change < options_.alignment_min_horizontal_change) continue;
    // Wahba's problem by SVD (Markley 1988): R₀ = U diag(1, 1, det(U V)) Vᵀ, for
    // d_k = v(b_k+1) − v(b_k) − g Δt and u_k the specific force integrated between them. The
    // body velocity is v_antenna − R (ω × p_B): solved once with the antenna velocity, then
    // again with the body velocity from the first R₀.
    Eigen::Matrix3d world_from_body_t0 = Eigen::Matrix3d::Identity();
    for (int iteration = 0; iteration < 2; ++iteration) {
      auto body_velocity = [&](const Boundary& b) -> Eigen::Vector3d {
        if (iteration == 0) return b.vel_antenna;
        return b.vel_antenna - world_from_body_t0 * b.dR * b.rate.cross(p_body_antenna);
      };
      Eigen::Matrix3d B = Eigen::Matrix3d::Zero();
      for (std::size_t k = 1; k < boundaries.size(); ++k) {
        const Eigen::Vector3d d = body_velocity(boundaries[k]) - body_velocity(boundaries[k - 1]) -
                                  g_world * DurationSeconds(boundaries[k - 1].t, boundaries[k].t);
        B += d * (boundaries[k].dv - boundaries[k - 1].dv).transpose();
      }
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(B, Eigen::ComputeFullU | Eigen::ComputeFullV);
      Eigen::Matrix3d D = Eigen::Matrix3d::Identity();
      D(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() > 0 ? 1.0 : -1.0;
      world_from_body_t0 = svd.matrixU() * D * svd.matrixV().transpose();
    }
    // The forward axis at the middle boundary.
    const Boundary& mid = boundaries[boundaries.size() / 2];
    const Eigen::Matrix3d world_from_body_mid = world_from_body_t0 * mid.dR;
    const Eigen::Vector3d vel_body_world =
        mid.vel_antenna - world_from_body_mid * mid.rate.cross(p_body_antenna);
    if (Horizontal(vel_body_world).norm() < options_.min_speed_for_course) continue;
    const Eigen::Vector3d course = Horizontal(vel_body_world).normalized();
    axis_sum += world_from_body_mid.transpose() * course;
    ++out.num_alignment_windows;
  }
  if (out.num_alignment_windows > 0 && axis_sum.norm() > 0.5 * out.num_alignment_windows) {
    forward_axis_body_ = axis_sum.normalized();
    out.forward_axis_fallback = false;
  }
  out.forward_axis_body = forward_axis_body_;
  return forward_axis_body_;
}

std::vector<RowState> StateInitialiser::Initialise(const std::vector<Timestamp>& times,
                                                   const Eigen::Vector3d& p_body_antenna,
                                                   Summary* summary) const {
  std::vector<RowState> states(times.size());
  std::vector<bool> has_course(times.size(), false), has_gps(times.size(), false);
  std::vector<GpsTrackSample> track(times.size());
  for (std::size_t k = 0; k < times.size(); ++k) {
    states[k].t = times[k];
    if (gps_ == nullptr) continue;
    std::optional<GpsTrackSample> fit =
        FitGpsTrack(gps_->fixes, times[k], options_.gps_half_window_s);
    if (!fit) fit = FitGpsTrack(gps_->fixes, times[k], 3 * options_.gps_half_window_s);
    if (!fit) continue;
    track[k] = *fit;
    has_gps[k] = true;
    has_course[k] = Horizontal(fit->velocity_world).norm() >= options_.min_speed_for_course;
  }
  // The antenna's velocity includes the turn rate about the lever arm: v_antenna = v_body +
  // R (ω × p_B). A first attitude from the uncorrected course gives R, then the course is
  // recomputed from v_body.
  for (std::size_t k = 0; k < times.size(); ++k) {
    if (!has_course[k]) continue;
    const Eigen::Vector3d up = UpInBody(times[k]);
    const Eigen::Matrix3d R = AttitudeFromCourse(up, track[k].velocity_world);
    const Eigen::Vector3d rate = Rate(times[k]);
    const Eigen::Vector3d corrected = track[k].velocity_world - R * rate.cross(p_body_antenna);
    if (Horizontal(corrected).norm() < options_.min_speed_for_course) {
      has_course[k] = false;
      continue;
    }
    track[k].velocity_world = corrected;
  }
  const auto first_course = std::find(has_course.begin(), has_course.end(), true);
  if (first_course == has_course.end()) {
    throw std::runtime_error(
        "initialisation: no GPS course in this pass (the vehicle did not move, or no GPS)");
  }
  // Attitudes: from the course where there is one; elsewhere carried by the gyro from the
  // nearest state that has one (forward, then backward from the first).
  const std::size_t k0 = first_course - has_course.begin();
  int from_gyro = 0;
  for (std::size_t k = k0; k < times.size(); ++k) {
    const Eigen::Vector3d up = UpInBody(times[k]);
    if (has_course[k]) {
      states[k].nav.world_from_body =
          geometry::Rigid3(Eigen::Quaterniond(AttitudeFromCourse(up, track[k].velocity_world)),
                           Eigen::Vector3d::Zero());
    } else {
      const Eigen::Matrix3d R =
          states[k - 1].nav.world_from_body.RotationMatrix() * Turn(times[k - 1], times[k]);
      states[k].nav.world_from_body =
          geometry::Rigid3(Eigen::Quaterniond(R).normalized(), Eigen::Vector3d::Zero());
      ++from_gyro;
    }
  }
  for (std::size_t k = k0; k-- > 0;) {
    const Eigen::Matrix3d R =
        states[k + 1].nav.world_from_body.RotationMatrix() * Turn(times[k + 1], times[k]);
    states[k].nav.world_from_body =
        geometry::Rigid3(Eigen::Quaterniond(R).normalized(), Eigen::Vector3d::Zero());
    ++from_gyro;
  }
  // Positions and velocities: the GPS track; without GPS nearby, constant velocity from the
  // previous state (or back from the next).
  int without_gps = 0;
  const auto first_gps = std::find(has_gps.begin(), has_gps.end(), true) - has_gps.begin();
  auto set_from_gps = [&](std::size_t k) {
    const Eigen::Matrix3d R = states[k].nav.world_from_body.RotationMatrix();
    states[k].nav.world_from_body = geometry::Rigid3(states[k].nav.world_from_body.rotation(),
                                                     track[k].position_world - R * p_body_antenna);
    states[k].nav.vel_world = track[k].velocity_world;
  };
  for (std::size_t k = first_gps; k < times.size(); ++k) {
    if (has_gps[k]) {
      set_from_gps(k);
      continue;
    }
    ++without_gps;
    const double dt = DurationSeconds(times[k - 1], times[k]);
    states[k].nav.vel_world = states[k - 1].nav.vel_world;
    states[k].nav.world_from_body = geometry::Rigid3(
        states[k].nav.world_from_body.rotation(),
        states[k - 1].nav.world_from_body.translation() + dt * states[k].nav.vel_world);
  }
  for (std::size_t k = first_gps; k-- > 0;) {
    ++without_gps;
    const double dt = DurationSeconds(times[k + 1], times[k]);
    states[k].nav.vel_world = states[k + 1].nav.vel_world;
    states[k].nav.world_from_body = geometry::Rigid3(
        states[k].nav.world_from_body.rotation(),
        states[k + 1].nav.world_from_body.translation() + dt * states[k].nav.vel_world);
  }
  for (std::size_t k = 0; k < times.size(); ++k) {
    states[k].nav.rate_body = Rate(times[k]);
  }
  if (summary != nullptr) {
    summary->forward_axis_body = forward_axis_body_;
    summary->num_states_heading_from_gyro = from_gyro;
    summary->num_states_without_gps = without_gps;
  }
  return states;
}

RowState StateInitialiser::LocalLevelState(Timestamp t) const {
  RowState s;
  s.t = t;
  s.nav.world_from_body = geometry::Rigid3(
      Eigen::Quaterniond(AttitudeFromCourse(UpInBody(t), Eigen::Vector3d::UnitX())),
      Eigen::Vector3d::Zero());
  s.nav.rate_body = Rate(t);
  return s;
}

std::vector<RowState> StateInitialiser::InitialiseFromAnchor(
    const RowState& anchor, const std::vector<Timestamp>& times) const {
  std::vector<RowState> states(times.size());
  auto fill = [&](std::size_t k, const Eigen::Matrix3d& R) {
    RowState& s = states[k];
    s.t = times[k];
    const double dt = DurationSeconds(anchor.t, times[k]);
    s.nav.world_from_body =
        geometry::Rigid3(Eigen::Quaterniond(R).normalized(),
                         anchor.nav.world_from_body.translation() + dt * anchor.nav.vel_world);
    s.nav.vel_world = anchor.nav.vel_world;
    s.nav.rate_body = Rate(times[k]);
    s.bias = anchor.bias;
  };
  // The gyro is integrated outward from the anchor, one interval at a time (each sample once).
  const std::size_t first_after =
      std::lower_bound(times.begin(), times.end(), anchor.t) - times.begin();
  Eigen::Matrix3d R = anchor.nav.world_from_body.RotationMatrix();
  Timestamp t = anchor.t;
  for (std::size_t k = first_after; k < times.size(); ++k) {
    R = R * Turn(t, times[k]);
    t = times[k];
    fill(k, R);
  }
  R = anchor.nav.world_from_body.RotationMatrix();
  t = anchor.t;
  for (std::size_t k = first_after; k-- > 0;) {
    R = R * Turn(t, times[k]);
    t = times[k];
    fill(k, R);
  }
  return states;
}

}  // namespace crop4d::slam
