#include "crop4d/slam/track_profile.h"

#include <algorithm>
#include <stdexcept>

namespace crop4d::slam {

TrackProfile::TrackProfile(const std::vector<Eigen::Vector3d>& camera_centres,
                           const Eigen::Vector2d& origin, const Eigen::Vector2d& along)
    : origin_(origin) {
  if (camera_centres.empty()) throw std::invalid_argument("TrackProfile: no camera");
  if (!(along.norm() > 0)) throw std::invalid_argument("TrackProfile: zero direction");
  along_ = along.normalized();
  across_ = Eigen::Vector2d(-along_.y(), along_.x());
  for (const Eigen::Vector3d& c : camera_centres) samples_.push_back({Along(c), Across(c), c.z()});
  std::sort(samples_.begin(), samples_.end(), [](const Sample& a, const Sample& b) {
    return a.s != b.s ? a.s < b.s : a.z != b.z ? a.z < b.z : a.l < b.l;
  });
}

TrackProfile::Position TrackProfile::At(double s) const {
  const auto next = std::lower_bound(samples_.begin(), samples_.end(), s,
                                     [](const Sample& e, double value) { return e.s < value; });
  if (next == samples_.end()) return {samples_.back().l, samples_.back().z};
  if (next == samples_.begin() || !(next->s > s)) return {next->l, next->z};
  const auto prev = next - 1;
  const double w = (s - prev->s) / (next->s - prev->s);
  return {prev->l + w * (next->l - prev->l), prev->z + w * (next->z - prev->z)};
}

}  // namespace crop4d::slam
