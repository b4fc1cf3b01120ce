#pragma once

// Points binned by their ENU xy into square buckets, for the radius queries of the terrain and
// canopy models. A sorted bucket list is enough here (queries are a few decimetres wide, the
// clouds a few million points): simpler and faster to build than a k-d tree.

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

namespace crop4d::analysis {

class PointBuckets {
 public:
  PointBuckets(const std::vector<Eigen::Vector3d>& points, double bucket_m) : bucket_m_(bucket_m) {
    if (points.empty()) return;
    Eigen::Vector2d lo = points[0].head<2>(), hi = lo;
    for (const Eigen::Vector3d& p : points) {
      lo = lo.cwiseMin(p.head<2>());
      hi = hi.cwiseMax(p.head<2>());
    }
    origin_ = lo;
    width_ = static_cast<int>(std::floor((hi.x() - lo.x()) / bucket_m_)) + 1;
    height_ = static_cast<int>(std::floor((hi.y() - lo.y()) / bucket_m_)) + 1;
    start_.assign(static_cast<std::size_t>(width_) * height_ + 1, 0);
    std::vector<std::uint32_t> cell(points.size());
    for (std::size_t i = 0; i < points.size(); ++i) {
      cell[i] = static_cast<std::uint32_t>(Cell(points[i].x(), points[i].y()));
      ++start_[cell[i] + 1];
    }
    for (std::size_t c = 1; c < start_.size(); ++c) start_[c] += start_[c - 1];
    order_.resize(points.size());
    std::vector<std::uint32_t> next(start_.begin(), start_.end() - 1);
    for (std::size_t i = 0; i < points.size(); ++i) {
      order_[next[cell[i]]++] = static_cast<std::uint32_t>(i);
    }
  }

  // Appends to `out` the indices of the points within `radius` of `center` (horizontally).
  void Query(const Eigen::Vector2d& center, double radius,
             const std::vector<Eigen::Vector3d>& points, std::vector<std::uint32_t>* out) const {
    Visit(center, radius, points, [&](std::uint32_t i) {
      out->push_back(i);
      return true;
    });
  }

  // Whether any point lies within `radius` of `center`.
  bool Any(const Eigen::Vector2d& center, double radius,
           const std::vector<Eigen::Vector3d>& points) const {
    bool found = false;
    Visit(center, radius, points, [&](std::uint32_t) {
      found = true;
      return false;
    });
    return found;
  }

 private:
  int Cell(double x, double y) const {
    const int i =
        std::clamp(static_cast<int>(std::floor((x - origin_.x()) / bucket_m_)), 0, width_ - 1);
    const int j =
        std::clamp(static_cast<int>(std::floor((y - origin_.y()) / bucket_m_)), 0, height_ - 1);
    return j * width_ + i;
  }

  // Calls f(index) for the points within `radius`; f returns false to stop.
  template <typename F>
  void Visit(const Eigen::Vector2d& center, double radius,
             const std::vector<Eigen::Vector3d>& points, F&& f) const {
    if (order_.empty()) return;
    const int i0 = static_cast<int>(std::floor((center.x() - radius - origin_.x()) / bucket_m_));
    const int i1 = static_cast<int>(std::floor((center.x() + radius - origin_.x()) / bucket_m_));
    const int j0 = static_cast<int>(std::floor((center.y() - radius - origin_.y()) / bucket_m_));
    const int j1 = static_cast<int>(std::floor((center.y() + radius - origin_.y()) / bucket_m_));
    const double r2 = radius * radius;
    for (int j = std::max(j0, 0); j <= std::min(j1, height_ - 1); ++j) {
      for (int i = std::max(i0, 0); i <= std::min(i1, width_ - 1); ++i) {
        const int c = j * width_ + i;
        for (std::uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
          const std::uint32_t idx = order_[k];
          if ((points[idx].head<2>() - center).squaredNorm() <= r2 && !f(idx)) return;
        }
      }
    }
  }

  double bucket_m_;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  int width_ = 0, height_ = 0;
  std::vector<std::uint32_t> start_;  // bucket c holds order_[start_[c] .. start_[c+1])
  std::vector<std::uint32_t> order_;  // point indices sorted by bucket
};

}  // namespace crop4d::analysis
