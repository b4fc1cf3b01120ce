#pragma once

// What row SLAM put into a pass's problem besides the sensors' data: the sensors it used, the GPS
// outages it applied, the IMU noise factor and the priors (gauge anchor, standstills, bias prior,
// length prior). Row SLAM writes it as the "problem" object of the pass's summary.json; the joint
// 4D problem rebuilds the pass's graph from it (fusion/joint_optimiser.h). A missing or malformed
// field throws InputError naming the file and saying to rerun `crop4d slam --force`.

#include <Eigen/Core>
#include <cstddef>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace crop4d::workspace {

struct PassPriors {
  std::string camera;  // the camera's name ("" without)
  std::string imu;     // the IMU's name ("" when not used)
  bool use_imu = true;
  std::string gps;  // the receiver the GPS factors used ("" without)
  // Dropped stretches of the receivers' fixes (start, duration) in s from each receiver's first
  // fix (the slam stage's --gps-outage).
  std::vector<std::pair<double, double>> gps_outages;
  double imu_noise_factor = 1.0;  // on sensor.yaml's noise (slam/session_solve.h)
  // Without an IMU: the body axis that points up when the rig is level.
  std::optional<Eigen::Vector3d> level_up_body;
  std::optional<Eigen::Vector3d> forward_axis_body;
  int anchor_state = 0;
  std::optional<double> anchor_sigma_velocity;
  // The standstills as [first, last) state index ranges.
  std::vector<std::pair<std::size_t, std::size_t>> still_intervals;
  Eigen::Matrix<double, 6, 1> bias_prior_mean = Eigen::Matrix<double, 6, 1>::Zero();
  std::optional<Eigen::Matrix<double, 6, 1>> bias_prior_sigma;
  // The length the camera-height step held the pass at, m, and its sigma (none: no prior).
  std::optional<std::pair<double, double>> length_prior;

  bool operator==(const PassPriors&) const = default;
};

nlohmann::json ToJson(const PassPriors& priors);
// `where` names the file in errors.
PassPriors PassPriorsFromJson(const nlohmann::json& problem, const std::string& where);

// Per-state standstill flags (true: the state and the next one stand still; one per interval
// between states) as [first, last) ranges, and back. StillFlags gives an empty vector without a
// range and throws InputError (naming `where`) for a range outside `num_states`.
std::vector<std::pair<std::size_t, std::size_t>> StillRanges(const std::vector<bool>& still);
std::vector<bool> StillFlags(const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                             std::size_t num_states, const std::string& where);

}  // namespace crop4d::workspace
