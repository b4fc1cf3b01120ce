#include "crop4d/eval/gnss_check.h"

#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"

namespace crop4d::eval {
namespace {

Eigen::Vector3d Antenna(const io::StampedPose& pose, const Eigen::Vector3d& p_body_antenna) {
  return pose.pose * p_body_antenna;
}

// Finite-difference tangent of the antenna track at pose k (one-sided at the ends), m/s.
Eigen::Vector3d Tangent(const std::vector<io::StampedPose>& trajectory,
                        const Eigen::Vector3d& p_body_antenna, std::size_t k) {
  const std::size_t a = k > 0 ? k - 1 : k;
  const std::size_t b = k + 1 < trajectory.size() ? k + 1 : k;
  if (a == b) return Eigen::Vector3d::Zero();
  return (Antenna(trajectory[b], p_body_antenna) - Antenna(trajectory[a], p_body_antenna)) /
         DurationSeconds(trajectory[a].t, trajectory[b].t);
}

}  // namespace

std::optional<Eigen::Vector3d> AntennaPositionAt(const std::vector<io::StampedPose>& trajectory,
                                                 const Eigen::Vector3d& p_body_antenna, Timestamp t,
                                                 Timestamp max_gap) {
  if (trajectory.empty() || t < trajectory.front().t || t > trajectory.back().t) {
    return std::nullopt;
  }
  const auto after =
      std::lower_bound(trajectory.begin(), trajectory.end(), t,
                       [](const io::StampedPose& p, Timestamp x) { return p.t < x; });
  if (after->t == t) return Antenna(*after, p_body_antenna);
  const std::size_t j = after - trajectory.begin();
  const std::size_t i = j - 1;
  CROP4D_CHECK_MSG(trajectory[i].t < trajectory[j].t, "trajectory times must strictly increase");
  if (trajectory[j].t - trajectory[i].t > max_gap) return std::nullopt;
  // Cubic Hermite on [t_i, t_j], u in [0, 1].
  const double h = DurationSeconds(trajectory[i].t, trajectory[j].t);
  const double u = DurationSeconds(trajectory[i].t, t) / h;
  const double u2 = u * u, u3 = u2 * u;
  const double h00 = 2 * u3 - 3 * u2 + 1, h10 = u3 - 2 * u2 + u, h01 = -2 * u3 + 3 * u2,
               h11 = u3 - u2;
  return h00 * Antenna(trajectory[i], p_body_antenna) +
         h10 * h * Tangent(trajectory, p_body_antenna, i) +
         h01 * Antenna(trajectory[j], p_body_antenna) +
         h11 * h * Tangent(trajectory, p_body_antenna, j);
}

std::vector<GnssResidual> CompareWithFixes(const std::vector<io::StampedPose>& trajectory,
                                           const std::vector<GnssFix>& fixes,
                                           const Eigen::Vector3d& p_body_antenna,
                                           Timestamp max_gap) {
  std::vector<GnssResidual> out;
  out.reserve(fixes.size());
  for (const GnssFix& fix : fixes) {
    const std::optional<Eigen::Vector3d> p =
        AntennaPositionAt(trajectory, p_body_antenna, fix.t, max_gap);
    if (!p) continue;
    GnssResidual r;
    r.t = fix.t;
    r.error_world = *p - fix.position_world;
    r.sigma_h = fix.sigma_h;
    r.sigma_v = fix.sigma_v;
    out.push_back(r);
  }
  return out;
}

GnssResidualStats SummariseResiduals(const std::vector<GnssResidual>& residuals, Timestamp begin,
                                     Timestamp end) {
  GnssResidualStats s;
  std::vector<double> horizontal, error_3d;
  double sum_sq_h = 0.0, sum_sq_v = 0.0;
  int within[3] = {0, 0, 0};
  for (const GnssResidual& r : residuals) {
    if (r.t < begin || r.t >= end) continue;
    CROP4D_CHECK(r.sigma_h > 0 && r.sigma_v > 0);
    horizontal.push_back(r.horizontal());
    error_3d.push_back(r.norm());
    sum_sq_h += r.error_world.head<2>().squaredNorm() / (r.sigma_h * r.sigma_h);
    sum_sq_v += r.error_world.z() * r.error_world.z() / (r.sigma_v * r.sigma_v);
    for (int k = 0; k < 3; ++k) within[k] += r.horizontal() <= (k + 1) * r.sigma_h ? 1 : 0;
    if (s.count == 0 || r.t >= s.last.t) s.last = r;
    ++s.count;
  }
  if (s.count == 0) return s;
  s.horizontal_m = ErrorStats::Of(horizontal);
  s.error_3d_m = ErrorStats::Of(error_3d);
  s.normalised_rms = std::sqrt((sum_sq_h + sum_sq_v) / (3.0 * s.count));
  s.normalised_rms_horizontal = std::sqrt(sum_sq_h / (2.0 * s.count));
  for (int k = 0; k < 3; ++k) s.within_sigma[k] = static_cast<double>(within[k]) / s.count;
  return s;
}

}  // namespace crop4d::eval
