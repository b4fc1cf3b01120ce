#include "crop4d/fusion/pass_alignment.h"

#include <cmath>
#include <random>
#include <stdexcept>

namespace crop4d::fusion {
namespace {

// b = Rz(yaw) a + t.
geometry::Rigid3 Transform(double yaw, const Eigen::Vector3d& t) {
  return geometry::Rigid3(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix(), t);
}

// Least-squares yaw and translation of the selected correspondences.
geometry::Rigid3 Refit(const std::vector<Eigen::Vector3d>& a, const std::vector<Eigen::Vector3d>& b,
                       const std::vector<int>& use) {
  Eigen::Vector3d ca = Eigen::Vector3d::Zero(), cb = Eigen::Vector3d::Zero();
  for (int i : use) {
    ca += a[i];
    cb += b[i];
  }
  ca /= use.size();
  cb /= use.size();
  double dot = 0, cross = 0;
  for (int i : use) {
    const Eigen::Vector2d p = (a[i] - ca).head<2>(), q = (b[i] - cb).head<2>();
    dot += p.dot(q);
    cross += p.x() * q.y() - p.y() * q.x();
  }
  const double yaw = std::atan2(cross, dot);
  const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return geometry::Rigid3(R, cb - R * ca);
}

std::vector<int> Inliers(const std::vector<Eigen::Vector3d>& a,
                         const std::vector<Eigen::Vector3d>& b, const geometry::Rigid3& b_from_a,
                         double threshold) {
  std::vector<int> inliers;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if ((b_from_a * a[i] - b[i]).norm() < threshold) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

}  // namespace

OptionCheck PassAlignmentOptions::Check() const {
  OptionChecker c;
  c.Greater("inlier_threshold_m", inlier_threshold_m, 0)
      .Greater("ransac_iterations", ransac_iterations, 0)
      .AtLeast("min_inliers", min_inliers, 2)
      .AtLeast("min_sample_distance_m", min_sample_distance_m, 0);
  return c.Result();
}

PassAlignment AlignPasses4Dof(const std::vector<Eigen::Vector3d>& points_a,
                              const std::vector<Eigen::Vector3d>& points_b,
                              const PassAlignmentOptions& options) {
  PassAlignment result;
  const int n = static_cast<int>(std::min(points_a.size(), points_b.size()));
  if (n < std::max(2, options.min_inliers)) return result;
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  std::vector<int> best;
  for (int it = 0; it < options.ransac_iterations; ++it) {
    const int i = pick(rng), j = pick(rng);
    const Eigen::Vector2d da = (points_a[j] - points_a[i]).head<2>();
    const Eigen::Vector2d db = (points_b[j] - points_b[i]).head<2>();
    if (i == j || da.norm() < options.min_sample_distance_m ||
        db.norm() < options.min_sample_distance_m) {
      continue;
    }
    const double yaw = std::atan2(da.x() * db.y() - da.y() * db.x(), da.dot(db));
    const Eigen::Matrix3d R = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const Eigen::Vector3d t = 0.5 * (points_b[i] + points_b[j] - R * (points_a[i] + points_a[j]));
    std::vector<int> inliers =
        Inliers(points_a, points_b, Transform(yaw, t), options.inlier_threshold_m);
    if (inliers.size() > best.size()) best = std::move(inliers);
  }
  if (static_cast<int>(best.size()) < options.min_inliers) return result;
  // Refit on the inliers, and once more on the inliers of the refit.
  geometry::Rigid3 model = Refit(points_a, points_b, best);
  for (int round = 0; round < 2; ++round) {
    std::vector<int> inliers = Inliers(points_a, points_b, model, options.inlier_threshold_m);
    if (static_cast<int>(inliers.size()) < options.min_inliers) return result;
    best = std::move(inliers);
    model = Refit(points_a, points_b, best);
  }
  double sum_sq = 0;
  for (int i : best) sum_sq += (model * points_a[i] - points_b[i]).squaredNorm();
  result.ok = true;
  result.b_from_a = model;
  result.num_inliers = static_cast<int>(best.size());
  result.rms_m = std::sqrt(sum_sq / best.size());
  return result;
}

PassAlignment AlignPasses4DofNear(const std::vector<ObservedPoint>& a,
                                  const std::vector<ObservedPoint>& b, double max_range_m,
                                  const PassAlignmentOptions& options) {
  if (a.size() != b.size()) {
    throw std::invalid_argument("AlignPasses4DofNear: the two passes' point lists differ in size");
  }
  std::vector<Eigen::Vector3d> points_a, points_b;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if ((a[i].point - a[i].camera).norm() > max_range_m ||
        (b[i].point - b[i].camera).norm() > max_range_m) {
      continue;
    }
    points_a.push_back(a[i].point);
    points_b.push_back(b[i].point);
  }
  return AlignPasses4Dof(points_a, points_b, options);
}

}  // namespace crop4d::fusion
