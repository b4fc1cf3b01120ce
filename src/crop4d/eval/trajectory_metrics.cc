#include "crop4d/eval/trajectory_metrics.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

#include "crop4d/core/error.h"

namespace crop4d::eval {

using geometry::Rigid3;

AssociatedPoses AssociateByTime(const std::vector<io::StampedPose>& estimate,
                                const std::vector<io::StampedPose>& truth, Timestamp max_dt) {
  CROP4D_CHECK(max_dt >= 0);
  for (std::size_t k = 1; k < truth.size(); ++k)
    CROP4D_CHECK_MSG(truth[k - 1].t < truth[k].t, "truth timestamps must strictly increase");

  AssociatedPoses out;
  out.t.reserve(estimate.size());
  out.estimate.reserve(estimate.size());
  out.truth.reserve(estimate.size());
  const auto before = [](const io::StampedPose& p, Timestamp t) { return p.t < t; };
  for (const io::StampedPose& e : estimate) {
    if (truth.empty() || e.t < truth.front().t || e.t > truth.back().t) {
      ++out.dropped_out_of_span;
      continue;
    }
    // First truth pose at or after e.t; it exists since e.t <= truth.back().t.
    const auto after = std::lower_bound(truth.begin(), truth.end(), e.t, before);
    if (after->t == e.t) {
      out.t.push_back(e.t);
      out.estimate.push_back(e.pose);
      out.truth.push_back(after->pose);
      ++out.exact;
      continue;
    }
    // e.t > truth.front().t here, so `after` is not the first pose.
    const auto prior = after - 1;
    if (e.t - prior->t > max_dt || after->t - e.t > max_dt) {
      ++out.dropped_gap;
      continue;
    }
    const double alpha =
        static_cast<double>(e.t - prior->t) / static_cast<double>(after->t - prior->t);
    out.t.push_back(e.t);
    out.estimate.push_back(e.pose);
    out.truth.push_back(geometry::InterpolateSeparately(prior->pose, after->pose, alpha));
    ++out.interpolated;
  }
  return out;
}

ErrorStats ErrorStats::Of(const std::vector<double>& errors) {
  ErrorStats s;
  if (errors.empty()) return s;
  double sum = 0.0, sum_sq = 0.0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    s.max = std::max(s.max, e);
  }
  s.count = static_cast<int>(errors.size());
  s.mean = sum / s.count;
  s.rmse = std::sqrt(sum_sq / s.count);
  return s;
}

ErrorStats ErrorStats::Pool(const std::vector<ErrorStats>& parts) {
  ErrorStats s;
  double sum = 0.0, sum_sq = 0.0;
  for (const ErrorStats& p : parts) {
    if (p.count == 0) continue;
    s.count += p.count;
    sum += p.mean * p.count;
    sum_sq += p.rmse * p.rmse * p.count;
    s.max = std::max(s.max, p.max);
  }
  if (s.count == 0) return s;
  s.mean = sum / s.count;
  s.rmse = std::sqrt(sum_sq / s.count);
  return s;
}

OptionCheck TrajectoryMetricsOptions::Check() const {
  OptionChecker c;
  c.AtLeast("rpe_distance_m", rpe_distance_m, 0.0).Finite("rpe_distance_m", rpe_distance_m);
  return c.Result();
}

double RotationAngleDeg(const Eigen::Quaterniond& q) {
  // angle = 2 atan2(|v|, |w|): stable near 0 and 180 degrees, and q and −q give the same angle.
  const double angle = 2.0 * std::atan2(q.vec().norm(), std::abs(q.w()));
  return angle * 180.0 / M_PI;
}

Wander TrajectoryWander(const std::vector<Rigid3>& poses, const Eigen::Vector3d& axis) {
  Wander w;
  if (poses.empty()) return w;
  const auto heading = [&](const Rigid3& pose) {
    const Eigen::Vector3d a = pose.rotation() * axis;
    return std::atan2(a.y(), a.x());
  };
  const double h0 = heading(poses.front());
  for (const Rigid3& pose : poses) {
    const double change = std::abs(std::remainder(heading(pose) - h0, 2.0 * M_PI));
    w.max_heading_change_deg = std::max(w.max_heading_change_deg, change * 180.0 / M_PI);
    w.max_displacement_m =
        std::max(w.max_displacement_m, (pose.translation() - poses.front().translation()).norm());
  }
  return w;
}

double MaxTiltErrorDeg(const std::vector<Rigid3>& estimate, const std::vector<Rigid3>& truth) {
  CROP4D_CHECK(estimate.size() == truth.size());
  double worst = 0.0;
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    const Eigen::Vector3d up_estimate = estimate[k].rotation().inverse() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d up_truth = truth[k].rotation().inverse() * Eigen::Vector3d::UnitZ();
    // atan2 of sine and cosine: exact near 0, where acos of the dot product is not.
    const double angle = std::atan2(up_estimate.cross(up_truth).norm(), up_estimate.dot(up_truth));
    worst = std::max(worst, angle * 180.0 / M_PI);
  }
  return worst;
}

Rigid3 AlignSE3(const std::vector<Eigen::Vector3d>& src, const std::vector<Eigen::Vector3d>& dst) {
  CROP4D_CHECK(src.size() == dst.size());
  CROP4D_CHECK(src.size() >= 3);
  Eigen::Matrix3Xd a(3, src.size()), b(3, dst.size());
  for (std::size_t k = 0; k < src.size(); ++k) {
    a.col(static_cast<Eigen::Index>(k)) = src[k];
    b.col(static_cast<Eigen::Index>(k)) = dst[k];
  }
  // Umeyama (1991), eq. 39-41 with c = 1: R = U S Vᵀ of the cross-covariance, t = μ_dst − R μ_src.
  const Eigen::Matrix4d m = Eigen::umeyama(a, b, /*with_scaling=*/false);
  return Rigid3(Eigen::Matrix3d(m.topLeftCorner<3, 3>()),
                Eigen::Vector3d(m.topRightCorner<3, 1>()));
}

Rigid3 AlignYawTranslation(const std::vector<Rigid3>& estimate, const std::vector<Rigid3>& truth) {
  CROP4D_CHECK(estimate.size() == truth.size());
  CROP4D_CHECK(!estimate.empty());
  // max_θ Σ tr(Rz(θ)ᵀ M_k) over the horizontal block of M_k = R_truth R_estᵀ.
  double c = 0, s = 0;
  Eigen::Vector3d mean_estimate = Eigen::Vector3d::Zero(), mean_truth = Eigen::Vector3d::Zero();
  for (std::size_t k = 0; k < estimate.size(); ++k) {
    const Eigen::Matrix3d M = truth[k].RotationMatrix() * estimate[k].RotationMatrix().transpose();
    c += M(0, 0) + M(1, 1);
    s += M(1, 0) - M(0, 1);
    mean_estimate += estimate[k].translation();
    mean_truth += truth[k].translation();
  }
  mean_estimate /= static_cast<double>(estimate.size());
  mean_truth /= static_cast<double>(truth.size());
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(std::atan2(s, c), Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return Rigid3(R, Eigen::Vector3d(mean_truth - R * mean_estimate));
}

TrajectoryMetrics ComputeTrajectoryMetrics(const std::vector<Rigid3>& estimate,
                                           const std::vector<Rigid3>& truth,
                                           const TrajectoryMetricsOptions& options) {
  CROP4D_CHECK(estimate.size() == truth.size());
  CROP4D_CHECK_OPTIONS(options, "ComputeTrajectoryMetrics");
  const std::size_t n = estimate.size();
  TrajectoryMetrics m;
  m.num_poses = static_cast<int>(n);
  m.rpe_distance_m = options.rpe_distance_m;
  if (n == 0) return m;

  // Cumulative true path length.
  std::vector<double> s(n, 0.0);
  for (std::size_t k = 1; k < n; ++k)
    s[k] = s[k - 1] + (truth[k].translation() - truth[k - 1].translation()).norm();
  m.path_length_m = s.back();

  // ATE raw and rotation error.
  std::vector<double> raw(n), rot(n);
  std::vector<Eigen::Vector3d> p_est(n), p_truth(n);
  for (std::size_t k = 0; k < n; ++k) {
    p_est[k] = estimate[k].translation();
    p_truth[k] = truth[k].translation();
    raw[k] = (p_est[k] - p_truth[k]).norm();
    rot[k] = RotationAngleDeg(truth[k].rotation().conjugate() * estimate[k].rotation());
  }
  m.ate_raw_m = ErrorStats::Of(raw);
  m.rotation_deg = ErrorStats::Of(rot);

  // ATE after the SE(3) alignment.
  if (n >= 3) {
    m.truth_from_estimate = AlignSE3(p_est, p_truth);
    std::vector<double> aligned(n);
    for (std::size_t k = 0; k < n; ++k)
      aligned[k] = (m.truth_from_estimate * p_est[k] - p_truth[k]).norm();
    m.ate_aligned_m = ErrorStats::Of(aligned);
  }

  // RPE: pairs (i, j) over rpe_distance_m of true path, or first → last for 0.
  std::vector<double> rpe_t, rpe_r;
  const auto add_pair = [&](std::size_t i, std::size_t j) {
    const double d = s[j] - s[i];
    if (!(d > 0.0)) return;
    const Rigid3 e = estimate[i].Inverse() * estimate[j];
    const Rigid3 g = truth[i].Inverse() * truth[j];
    rpe_t.push_back(100.0 * (e.translation() - g.translation()).norm() / d);
    rpe_r.push_back(RotationAngleDeg(g.rotation().conjugate() * e.rotation()) / d);
  };
  if (options.rpe_distance_m <= 0.0) {
    if (n >= 2) add_pair(0, n - 1);
  } else {
    std::size_t j = 0;
    for (std::size_t i = 0; i < n; ++i) {
      // s is non-decreasing, so j only moves forward.
      j = std::max(j, i + 1);
      while (j < n && s[j] - s[i] < options.rpe_distance_m) ++j;
      if (j >= n) break;
      add_pair(i, j);
    }
  }
  m.rpe_translation_percent = ErrorStats::Of(rpe_t);
  m.rpe_rotation_deg_per_m = ErrorStats::Of(rpe_r);
  return m;
}

}  // namespace crop4d::eval
