#include "crop4d/association/prealignment.h"

#include <tbb/parallel_for.h>

#include <algorithm>

#include "crop4d/association/robust_matcher.h"
#include "crop4d/core/error.h"

namespace crop4d::association {

OptionCheck PreAlignmentOptions::Check() const {
  OptionChecker c;
  c.AtLeast("stride", stride, 1)
      .Greater("radius_m", radius_m, 0.0)
      .Greater("max_landmark_distance_m", max_landmark_distance_m, 0.0)
      .Nested("naive", naive.Check())
      .Nested("alignment", alignment.Check());
  return c.Result();
}

std::vector<std::pair<int, int>> PreAlignmentImagePairs(
    const std::vector<geometry::Rigid3>& poses_a, const std::vector<geometry::Rigid3>& poses_b,
    const PreAlignmentOptions& options) {
  std::vector<std::pair<int, int>> image_pairs;
  const int step_a = std::max(1, options.stride);
  const int step_b = std::max(1, options.stride / kPassBSamplingFactor);
  for (int ia = 0; ia < static_cast<int>(poses_a.size()); ia += step_a) {
    const geometry::Rigid3& ca = poses_a[ia];
    for (int ib = 0; ib < static_cast<int>(poses_b.size()); ib += step_b) {
      const geometry::Rigid3& cb = poses_b[ib];
      const Eigen::Vector3d axis_a = ca.rotation() * Eigen::Vector3d::UnitZ();
      const Eigen::Vector3d axis_b = cb.rotation() * Eigen::Vector3d::UnitZ();
      if ((ca.translation() - cb.translation()).head<2>().norm() > options.radius_m ||
          axis_a.dot(axis_b) < 0) {
        continue;
      }
      image_pairs.emplace_back(ia, ib);
    }
  }
  return image_pairs;
}

fusion::PassAlignment PreAlignPasses(const PreAlignmentPass& a, const PreAlignmentPass& b,
                                     const PreAlignmentOptions& options) {
  const std::string invalid = options.Check();
  CROP4D_CHECK_MSG(invalid.empty(), "PreAlignPasses: " + invalid);
  const std::vector<std::pair<int, int>> image_pairs =
      PreAlignmentImagePairs(*a.poses, *b.poses, options);
  std::vector<AssociationResult> results(image_pairs.size());
  tbb::parallel_for(std::size_t{0}, image_pairs.size(), [&](std::size_t k) {
    const features::FeatureSet& fa = (*a.features)[image_pairs[k].first];
    const features::FeatureSet& fb = (*b.features)[image_pairs[k].second];
    if (fa.empty() || fb.empty()) return;
    results[k] = NaiveMatch(*a.camera, fa, *b.camera, fb, options.naive);
  });
  std::vector<fusion::ObservedPoint> points_a, points_b;
  for (std::size_t k = 0; k < image_pairs.size(); ++k) {
    const auto [ia, ib] = image_pairs[k];
    for (const LandmarkMatch& m : results[k].matches) {
      const std::optional<Eigen::Vector3d> pa = a.cloud_point(ia, m.feature_a);
      const std::optional<Eigen::Vector3d> pb = b.cloud_point(ib, m.feature_b);
      if (!pa || !pb) continue;
      points_a.push_back({*pa, (*a.poses)[ia].translation()});
      points_b.push_back({*pb, (*b.poses)[ib].translation()});
    }
  }
  return fusion::AlignPasses4DofNear(points_a, points_b, options.max_landmark_distance_m,
                                     options.alignment);
}

double GroundHeight(std::vector<double> cloud_heights, std::optional<double> first_camera_z) {
  if (!cloud_heights.empty()) {
    const auto q = static_cast<std::size_t>(cloud_heights.size() * kGroundQuantile);
    std::nth_element(cloud_heights.begin(), cloud_heights.begin() + q, cloud_heights.end());
    return cloud_heights[q];
  }
  return first_camera_z ? *first_camera_z - kFallbackCameraHeightM : 0.0;
}

}  // namespace crop4d::association
