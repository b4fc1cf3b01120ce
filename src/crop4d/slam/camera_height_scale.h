#pragma once

// Scale from the camera's height above the ground, for passes without a precise receiver.
//
// With a metre-level receiver a pass's scale is known only to about 1 % (bench/RESULTS.md, "Row
// SLAM ablation": the fixes give a 20 m pass's speed to a few percent, and at constant speed on
// a straight row the IMU adds little). But the camera rides on a vehicle whose wheels stand on
// the ground, at a height the user can measure with a tape: the same for every pass. The soil
// landmarks of a pass lie that far below the camera where the camera passes over them, scaled
// by the pass's scale error, so their depth below the camera measures the scale (the technique
// of monocular visual odometry on cars, e.g. Song & Chandraker, CVPR 2014).
//
// Which soil: bed tops, furrows and tyre tracks differ by centimetres, and which of them a pass
// sees depends on the plants (late in the season only the furrows). A high quantile of the
// depths (the deepest soil near the track: furrows and tyre tracks, where the wheels run) varied
// least on the demo field: within −0.7 … +0.2 % of the true 1.5 m on every pass with RTK poses.
//
// SoilDepthBelowCamera measures that depth; PassLengthFactor then holds the pass at the scale it
// implies (row_optimiser.h).

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <optional>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::slam {

struct CameraHeightOptions {
  // A point is soil when its excess green (core/color.h) is below this.
  double max_excess_green = 0.05;
  // Soil within this distance of the camera's track, across it, m.
  double max_lateral_m = 1.0;
  // The depth below the camera taken: this quantile of the soil's depths (the deepest soil).
  double quantile = 0.9;
  // Fewer soil landmarks than this: no measurement.
  int min_points = 50;
  // Relative standard deviation of the scale the depth implies (PassLengthFactor's sigma is this
  // times the pass length).
  double sigma_relative = 0.005;
  // A scale change beyond this fraction is not applied (a warning instead): no receiver or IMU
  // leaves a pass that far off, so the soil's depth is what is wrong (a wrong height, a field
  // without visible soil).
  double max_scale_change = 0.1;
  // Triangulation of RowOptimiser::Input::depth_tracks from the solved poses (the checks of the
  // row-SLAM output cloud).
  TriangulationOptions triangulation;

  OptionCheck Check() const;
};

struct SoilDepth {
  // The quantile of the soil's depths below the camera, m.
  double depth_m = 0;
  // Soil landmarks that took part.
  int num_points = 0;
};

// The depth of the soil below the camera along a pass: for every soil landmark beside the track
// (`max_lateral_m`) and within its length, the camera's height where it passes the landmark
// (interpolated along the track) minus the landmark's; the `quantile` of those. Camera centres in
// travel order, at least two, world frame (z up); colours RGB. nullopt with too few points.
std::optional<SoilDepth> SoilDepthBelowCamera(
    const std::vector<Eigen::Vector3d>& camera_centres, const std::vector<Eigen::Vector3d>& points,
    const std::vector<std::array<std::uint8_t, 3>>& colors, const CameraHeightOptions& options);

// r = (‖p_b − p_a‖ − L) / σ on the positions of two pose blocks (state_layout.h): holds the
// distance between the first and the last state of a pass at L.
//   ∂r/∂δt_b = uᵀ / σ,   ∂r/∂δt_a = −uᵀ / σ,   ∂r/∂δφ = 0   (u = (p_b − p_a) / ‖p_b − p_a‖).
class PassLengthFactor final : public ceres::SizedCostFunction<1, 7, 7> {
 public:
  PassLengthFactor(double length_m, double sigma_m);
  static ceres::CostFunction* Create(double length_m, double sigma_m);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  double length_m_;
  double sigma_m_;
};

}  // namespace crop4d::slam
