#include "crop4d/slam/camera_height_scale.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crop4d/core/color.h"
#include "crop4d/slam/state_layout.h"
#include "crop4d/slam/track_profile.h"

namespace crop4d::slam {

OptionCheck CameraHeightOptions::Check() const {
  OptionChecker c;
  c.Finite("max_excess_green", max_excess_green)
      .Greater("max_lateral_m", max_lateral_m, 0.0)
      .InRange("quantile", quantile, 0.0, 1.0)
      .AtLeast("min_points", min_points, 1)
      .Greater("sigma_relative", sigma_relative, 0.0)
      .Greater("max_scale_change", max_scale_change, 0.0)
      .Nested("triangulation", triangulation.Check());
  return c.Result();
}

std::optional<SoilDepth> SoilDepthBelowCamera(
    const std::vector<Eigen::Vector3d>& camera_centres, const std::vector<Eigen::Vector3d>& points,
    const std::vector<std::array<std::uint8_t, 3>>& colors, const CameraHeightOptions& options) {
  if (const OptionCheck why = options.Check(); !why.empty()) {
    throw std::invalid_argument("SoilDepthBelowCamera: " + why);
  }
  if (points.size() != colors.size()) {
    throw std::invalid_argument("SoilDepthBelowCamera: one colour per point");
  }
  if (camera_centres.size() < 2) return std::nullopt;
  // The track's horizontal direction, from the first camera to the last.
  const Eigen::Vector2d along = (camera_centres.back() - camera_centres.front()).head<2>();
  if (!(along.norm() > 0)) return std::nullopt;
  const TrackProfile track(camera_centres, camera_centres.front().head<2>(), along);
  std::vector<double> depths;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!(ExcessGreen(colors[i]) < options.max_excess_green)) continue;
    if (std::abs(track.Across(points[i])) > options.max_lateral_m) continue;
    const double s = track.Along(points[i]);
    if (s < track.min_s() || s > track.max_s()) continue;
    depths.push_back(track.At(s).z - points[i].z());
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
