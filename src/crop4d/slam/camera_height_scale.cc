#include "crop4d/slam/camera_height_scale.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crop4d/core/color.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::slam {

bool CameraHeightOptions::Check() const {
  return std::isfinite(max_excess_green) && max_lateral_m > 0 && quantile >= 0 && quantile <= 1 &&
         min_points >= 1 && sigma_relative > 0 && max_scale_change > 0 && triangulation.Check();
}

std::optional<SoilDepth> SoilDepthBelowCamera(
    const std::vector<Eigen::Vector3d>& camera_centres, const std::vector<Eigen::Vector3d>& points,
    const std::vector<std::array<std::uint8_t, 3>>& colors, const CameraHeightOptions& options) {
  if (!options.Check()) throw std::invalid_argument("SoilDepthBelowCamera: invalid options");
  if (points.size() != colors.size()) {
    throw std::invalid_argument("SoilDepthBelowCamera: one colour per point");
  }
  if (camera_centres.size() < 2) return std::nullopt;
  // The track's horizontal direction, and each camera's coordinate along it.
  Eigen::Vector2d along = (camera_centres.back() - camera_centres.front()).head<2>();
  if (!(along.norm() > 0)) return std::nullopt;
  along.normalize();
  const Eigen::Vector2d across(-along.y(), along.x());
  const Eigen::Vector2d origin = camera_centres.front().head<2>();
  std::vector<std::pair<double, double>> track;  // (along, camera z), sorted by along
  for (const Eigen::Vector3d& c : camera_centres) {
    track.emplace_back(along.dot(c.head<2>() - origin), c.z());
  }
  std::sort(track.begin(), track.end());
  std::vector<double> depths;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!(ExcessGreen(colors[i]) < options.max_excess_green)) continue;
    const Eigen::Vector2d d = points[i].head<2>() - origin;
    if (std::abs(across.dot(d)) > options.max_lateral_m) continue;
    const double s = along.dot(d);
    if (s < track.front().first || s > track.back().first) continue;
    const auto next = std::lower_bound(
        track.begin(), track.end(), s,
        [](const std::pair<double, double>& e, double value) { return e.first < value; });
    double camera_z = next->second;
    if (next != track.begin() && next->first > s) {
      const auto prev = next - 1;
      const double w = (s - prev->first) / (next->first - prev->first);
      camera_z = prev->second + w * (next->second - prev->second);
    }
    depths.push_back(camera_z - points[i].z());
  }
  if (static_cast<int>(depths.size()) < options.min_points) return std::nullopt;
  const auto k = static_cast<std::size_t>(
      std::lround(options.quantile * static_cast<double>(depths.size() - 1)));
  std::nth_element(depths.begin(), depths.begin() + static_cast<std::ptrdiff_t>(k), depths.end());
  return SoilDepth{depths[k], static_cast<int>(depths.size())};
}

PassLengthFactor::PassLengthFactor(double length_m, double sigma_m)
    : length_m_(length_m), sigma_m_(sigma_m) {
  if (!(length_m > 0) || !(sigma_m > 0)) {
    throw std::invalid_argument("PassLengthFactor: length and sigma must be positive");
  }
}

ceres::CostFunction* PassLengthFactor::Create(double length_m, double sigma_m) {
  return new PassLengthFactor(length_m, sigma_m);
}

bool PassLengthFactor::Evaluate(double const* const* parameters, double* residuals,
                                double** jacobians) const {
  const Eigen::Map<const Eigen::Vector3d> p_a(parameters[0]);
  const Eigen::Map<const Eigen::Vector3d> p_b(parameters[1]);
  const Eigen::Vector3d delta = p_b - p_a;
  const double distance = delta.norm();
  if (!(distance > 0)) return false;
  residuals[0] = (distance - length_m_) / sigma_m_;
  if (jacobians == nullptr) return true;
  const Eigen::Vector3d u = delta / distance;
  for (int k = 0; k < 2; ++k) {
    if (jacobians[k] == nullptr) continue;
    Eigen::Matrix<double, 1, 6> tangent = Eigen::Matrix<double, 1, 6>::Zero();
    tangent.leftCols<3>() = (k == 0 ? -u : u).transpose() / sigma_m_;
    WritePoseJacobian<1>(tangent, parameters[k], jacobians[k]);
  }
  return true;
}

}  // namespace crop4d::slam
