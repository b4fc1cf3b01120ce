#pragma once

// A pass's camera track in a horizontal frame: each camera's coordinate s along a horizontal
// direction, and its coordinate l across it and its height z as piecewise-linear functions of
// s — "where was the camera when it passed this point". The camera-height step
// (camera_height_scale.h) and the ground ties (fusion/ground_ties.h) measure the soil beside a
// track with it.

#include <Eigen/Core>
#include <vector>

namespace crop4d::slam {

class TrackProfile {
 public:
  // `along` is a horizontal direction (normalised here), `origin` a horizontal point. At least
  // one camera centre (world frame, z up); throws std::invalid_argument otherwise or for a zero
  // direction.
  TrackProfile(const std::vector<Eigen::Vector3d>& camera_centres, const Eigen::Vector2d& origin,
               const Eigen::Vector2d& along);

  // A point's coordinates along and across the frame's direction (across = up × along).
  double Along(const Eigen::Vector3d& p) const { return along_.dot(p.head<2>() - origin_); }
  double Across(const Eigen::Vector3d& p) const { return across_.dot(p.head<2>() - origin_); }

  // The point at (s, l) of the frame, at height z.
  Eigen::Vector3d Point(double s, double l, double z) const {
    const Eigen::Vector2d xy = origin_ + s * along_ + l * across_;
    return {xy.x(), xy.y(), z};
  }

  double min_s() const { return samples_.front().s; }
  double max_s() const { return samples_.back().s; }

  // The camera's across coordinate and height where it passed s, linear between the two cameras
  // around s (the end camera's beyond the track's ends).
  struct Position {
    double l = 0;
    double z = 0;
  };
  Position At(double s) const;

  const Eigen::Vector2d& along() const { return along_; }
  const Eigen::Vector2d& across() const { return across_; }

 private:
  struct Sample {
    double s, l, z;
  };
  Eigen::Vector2d origin_, along_, across_;
  std::vector<Sample> samples_;  // sorted by s
};

}  // namespace crop4d::slam
