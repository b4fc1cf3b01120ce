#include "crop4d/association/surface_points.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "crop4d/core/error.h"

namespace crop4d::association {

OptionCheck SurfacePointOptions::Check() const {
  OptionChecker c;
  c.InRange("num_neighbors", num_neighbors, 1, 16)
      .Greater("max_pixel_distance_px", max_pixel_distance_px, 0.0)
      .Greater("min_sigma_m", min_sigma_m, 0.0)
      .Require(max_sigma_m >= min_sigma_m, "max_sigma_m", "must be >= min_sigma_m", max_sigma_m)
      .Greater("min_incidence_cos", min_incidence_cos, 0.0)
      .AtMost("min_incidence_cos", min_incidence_cos, 1.0)
      .Greater("max_range_m", max_range_m, 0.0);
  return c.Result();
}

std::vector<LandmarkObservation> SurfacePoints(const geometry::PinholeRadTan& camera,
                                               const geometry::Rigid3& world_from_camera,
                                               const features::FeatureSet& features,
                                               const std::vector<LandmarkObservation>& landmarks,
                                               const LocalPlanes& planes,
                                               const SurfacePointOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "SurfacePointOptions");
  std::vector<LandmarkObservation> out;
  if (landmarks.empty()) return out;
  std::vector<bool> has_landmark(features.size(), false);
  // The landmarks that can place a feature: those with a finite position.
  struct Anchor {
    Eigen::Vector2d pixel;
    const LandmarkObservation* landmark;
  };
  const Eigen::Vector3d center = world_from_camera.translation();
  const Eigen::Matrix3d world_from_camera_rotation = world_from_camera.RotationMatrix();
  std::vector<Anchor> anchors;
  anchors.reserve(landmarks.size());
  for (const LandmarkObservation& l : landmarks) {
    CROP4D_CHECK(l.feature >= 0 && static_cast<std::size_t>(l.feature) < features.size());
    has_landmark[l.feature] = true;
    if (!l.position_world.allFinite()) continue;
    anchors.push_back({features.Point(l.feature), &l});
  }
  const int k = std::min<int>(options.num_neighbors, static_cast<int>(anchors.size()));
  if (k == 0) return out;
  const double max_d2 = options.max_pixel_distance_px * options.max_pixel_distance_px;
  // The k nearest anchors by brute force: an image has about a thousand features and a few
  // hundred landmarks, so well under a million squared distances per image.
  std::array<std::pair<double, int>, 16> nearest;
  for (std::size_t f = 0; f < features.size(); ++f) {
    if (has_landmark[f]) continue;
    const Eigen::Vector2d pixel = features.Point(f);
    int count = 0;
    for (int a = 0; a < static_cast<int>(anchors.size()); ++a) {
      const double d2 = (anchors[a].pixel - pixel).squaredNorm();
      if (d2 > max_d2) continue;
      if (count < k) {
        nearest[count++] = {d2, a};
      } else if (d2 < nearest[k - 1].first) {
        nearest[k - 1] = {d2, a};
      } else {
        continue;
      }
      // Keep the k best sorted by distance (insertion step).
      for (int i = count - 1; i > 0 && nearest[i].first < nearest[i - 1].first; --i) {
        std::swap(nearest[i], nearest[i - 1]);
      }
    }
    if (count < k) continue;
    Eigen::Vector3d ray_camera;
    if (!camera.Unproject(pixel, &ray_camera)) continue;
    const Eigen::Vector3d ray = (world_from_camera_rotation * ray_camera).normalized();
    const LandmarkObservation& anchor = *anchors[nearest[0].second].landmark;
    const LocalPlane plane = planes.PlaneFor(anchor.landmark, anchor.position_world);
    // The plane through the anchor: its local fit, or the ground's orientation where the fit
    // failed (as RobustMatcher's kGroundNormal fallback).
    const Eigen::Vector3d normal = plane.valid ? plane.normal : Eigen::Vector3d::UnitZ();
    const double cos_incidence = normal.dot(ray);
    if (std::abs(cos_incidence) < options.min_incidence_cos) continue;
    // nᵀ(C + t·ray − X) = 0, X a point of the plane: the anchor for a fallback, the centroid of
    // the fit otherwise.
    const Eigen::Vector3d on_plane = plane.valid ? plane.centroid : anchor.position_world;
    const double range = normal.dot(on_plane - center) / cos_incidence;
    if (!(range > 0) || range > options.max_range_m) continue;
    // How far the neighbours lie off the plane, measured along the ray: a neighbour on the soil
    // under a leaf's plane (or on a leaf above the soil's) is far off it.
    double spread = 0;
    for (int i = 0; i < k; ++i) {
      const Eigen::Vector3d& x = anchors[nearest[i].second].landmark->position_world;
      spread = std::max(spread, std::abs(normal.dot(x - on_plane)) / std::abs(cos_incidence));
    }
    if (spread > options.max_sigma_m) continue;
    LandmarkObservation point;
    point.feature = static_cast<std::int32_t>(f);
    point.position_world = center + range * ray;
    point.landmark = -1;
    point.sigma_along_ray_m = std::max(options.min_sigma_m, spread);
    out.push_back(point);
  }
  return out;
}

}  // namespace crop4d::association
