#pragma once

// Local planes of a sparse landmark cloud, for the plane-induced homography of the robust data
// association (DESIGN.md §2.3; Dong et al., IROS 2017: the plane normal of the homography is
// estimated from the landmark's neighbours). The plane at a landmark is the total-least-squares
// plane of its k nearest landmarks (principal component analysis: the normal is the eigenvector of
// the neighbours' covariance with the smallest eigenvalue; Hoppe et al., "Surface Reconstruction
// from Unorganized Points", SIGGRAPH 1992). A fit is rejected when the neighbours are too few or
// too far, nearly collinear (no plane is defined), or too thick to be a surface: the surface
// variation λ0 / (λ0 + λ1 + λ2) (Pauly, Gross & Kobbelt, "Efficient Simplification of
// Point-Sampled Surfaces", VIS 2002) above a threshold.
//
// The cloud is fitted once per row pass and shared, read-only, by every image pair of that pass
// (thread-safe).

#include <Eigen/Core>
#include <memory>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::association {

struct LocalPlane {
  // Whether the fit passed the checks; when false, normal and centroid are unspecified.
  bool valid = false;
  // Unit normal in the world frame (sign arbitrary) and the neighbours' centroid.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  // Surface variation λ0 / (λ0 + λ1 + λ2), and neighbours used.
  double surface_variation = 0;
  int num_neighbors = 0;
};

class LocalPlanes {
 public:
  struct Options {
    // Neighbours of a fit, the landmark itself included.
    int num_neighbors = 10;
    // Fewer neighbours within max_neighbor_distance_m than this: no fit.
    int min_neighbors = 6;
    // Neighbours farther than this from the landmark are left out, metres.
    double max_neighbor_distance_m = 0.5;
    // Largest surface variation λ0 / (λ0 + λ1 + λ2) of a plane (0 for a perfect plane, 1/3
    // for an isotropic blob).
    double max_surface_variation = 0.08;
    // Smallest λ1 / λ2: below it the neighbours lie along a line and no plane is defined.
    double min_spread_ratio = 0.02;

    OptionCheck Check() const;
  };

  // Builds a k-d tree over the finite points (non-finite ones, e.g. untriangulated tracks, are
  // skipped) and fits the plane of every point. `points[i]` is landmark i: planes are indexed
  // like the points.
  LocalPlanes(std::vector<Eigen::Vector3d> points, Options options);
  explicit LocalPlanes(std::vector<Eigen::Vector3d> points);
  ~LocalPlanes();
  LocalPlanes(const LocalPlanes&) = delete;
  LocalPlanes& operator=(const LocalPlanes&) = delete;

  std::size_t size() const { return points_.size(); }
  const Eigen::Vector3d& point(std::size_t i) const { return points_[i]; }
  // The plane fitted at point i.
  const LocalPlane& plane(std::size_t i) const { return planes_[i]; }
  // The plane of the neighbours of an arbitrary position.
  LocalPlane FitAt(const Eigen::Vector3d& position) const;
  // The plane at landmark `index` when `position` is that point (the usual case: the cloud was
  // built from the same landmarks), a fit at `position` otherwise.
  LocalPlane PlaneFor(int index, const Eigen::Vector3d& position) const;

  const Options& options() const { return options_; }

  struct Index;  // local_planes.cc

 private:
  Options options_;
  std::vector<Eigen::Vector3d> points_;
  std::vector<LocalPlane> planes_;
  std::unique_ptr<Index> index_;
};

}  // namespace crop4d::association
