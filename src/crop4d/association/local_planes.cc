#include "crop4d/association/local_planes.h"

#include <Eigen/Eigenvalues>
#include <cmath>
#include <cstdint>
#include <nanoflann.hpp>

#include "crop4d/core/error.h"

namespace crop4d::association {

// nanoflann's dataset interface over the finite points.
struct LocalPlanes::Index {
  struct Cloud {
    std::vector<Eigen::Vector3d> points;
    std::size_t kdtree_get_point_count() const { return points.size(); }
    double kdtree_get_pt(std::size_t i, std::size_t dim) const { return points[i][dim]; }
    template <class BBox>
    bool kdtree_get_bbox(BBox&) const {
      return false;
    }
  };
  using Tree = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, Cloud>,
                                                   Cloud, 3, std::uint32_t>;

  Cloud cloud;
  std::unique_ptr<Tree> tree;
};

namespace {

// Total-least-squares plane of points (PCA), with the checks of the options.
LocalPlane FitPlane(const std::vector<Eigen::Vector3d>& neighbors,
                    const LocalPlanes::Options& options) {
  LocalPlane plane;
  plane.num_neighbors = static_cast<int>(neighbors.size());
  if (plane.num_neighbors < std::max(options.min_neighbors, 3)) return plane;
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& p : neighbors) mean += p;
  mean /= static_cast<double>(neighbors.size());
  Eigen::Matrix3d covariance = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& p : neighbors) covariance += (p - mean) * (p - mean).transpose();
  covariance /= static_cast<double>(neighbors.size());
  // Ascending eigenvalues λ0 ≤ λ1 ≤ λ2.
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(covariance);
  if (solver.info() != Eigen::Success) return plane;
  const Eigen::Vector3d lambda = solver.eigenvalues().cwiseMax(0.0);
  const double total = lambda.sum();
  if (!(total > 0)) return plane;
  plane.normal = solver.eigenvectors().col(0).normalized();
  plane.centroid = mean;
  plane.surface_variation = lambda(0) / total;
  plane.valid = plane.surface_variation <= options.max_surface_variation &&
                lambda(1) >= options.min_spread_ratio * lambda(2);
  return plane;
}

}  // namespace

OptionCheck LocalPlanes::Options::Check() const {
  OptionChecker c;
  c.AtLeast("num_neighbors", num_neighbors, 3)
      .AtLeast("min_neighbors", min_neighbors, 3)
      .Require(min_neighbors <= num_neighbors, "min_neighbors", "must be <= num_neighbors",
               min_neighbors)
      .Greater("max_neighbor_distance_m", max_neighbor_distance_m, 0.0)
      .AtLeast("max_surface_variation", max_surface_variation, 0.0)
      .AtLeast("min_spread_ratio", min_spread_ratio, 0.0);
  return c.Result();
}

LocalPlanes::LocalPlanes(std::vector<Eigen::Vector3d> points)
    : LocalPlanes(std::move(points), Options()) {}

LocalPlanes::LocalPlanes(std::vector<Eigen::Vector3d> points, Options options)
    : options_(options), points_(std::move(points)), index_(std::make_unique<Index>()) {
  CROP4D_CHECK_OPTIONS(options_, "LocalPlanes::Options");
  index_->cloud.points.reserve(points_.size());
  for (const Eigen::Vector3d& p : points_) {
    if (p.allFinite()) index_->cloud.points.push_back(p);
  }
  index_->tree = std::make_unique<Index::Tree>(3, index_->cloud,
                                               nanoflann::KDTreeSingleIndexAdaptorParams(10));
  planes_.resize(points_.size());
  for (std::size_t i = 0; i < points_.size(); ++i) {
    if (points_[i].allFinite()) planes_[i] = FitAt(points_[i]);
  }
}

LocalPlanes::~LocalPlanes() = default;

LocalPlane LocalPlanes::FitAt(const Eigen::Vector3d& position) const {
  if (index_->cloud.points.empty() || !position.allFinite()) return LocalPlane();
  const std::size_t k = std::min<std::size_t>(options_.num_neighbors, index_->cloud.points.size());
  std::vector<std::uint32_t> indices(k);
  std::vector<double> squared_distances(k);
  const std::size_t found =
      index_->tree->knnSearch(position.data(), k, indices.data(), squared_distances.data());
  std::vector<Eigen::Vector3d> neighbors;
  neighbors.reserve(found);
  const double max_squared = options_.max_neighbor_distance_m * options_.max_neighbor_distance_m;
  for (std::size_t n = 0; n < found; ++n) {
    if (squared_distances[n] <= max_squared) neighbors.push_back(index_->cloud.points[indices[n]]);
  }
  return FitPlane(neighbors, options_);
}

LocalPlane LocalPlanes::PlaneFor(int index, const Eigen::Vector3d& position) const {
  if (index >= 0 && static_cast<std::size_t>(index) < points_.size() &&
      (points_[index] - position).squaredNorm() <= 1e-12) {
    return planes_[index];
  }
  return FitAt(position);
}

}  // namespace crop4d::association
