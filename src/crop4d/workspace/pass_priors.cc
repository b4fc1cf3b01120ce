#include "crop4d/workspace/pass_priors.h"

#include <algorithm>

#include "crop4d/core/error.h"

namespace crop4d::workspace {
namespace {

using json = nlohmann::json;

json VectorOrNull(const std::optional<Eigen::Vector3d>& v) {
  return v ? json::array({v->x(), v->y(), v->z()}) : json();
}

std::vector<double> Values(const Eigen::Matrix<double, 6, 1>& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

[[noreturn]] void Malformed(const std::string& where, const std::string& what) {
  throw InputError(where, 0, "\"problem\": " + what + " (rerun `crop4d slam --force`)");
}

template <int N>
Eigen::Matrix<double, N, 1> Fixed(const json& j, const std::string& where, const char* key) {
  if (!j.is_array() || j.size() != N) {
    Malformed(where, std::string(key) + " is not " + std::to_string(N) + " numbers");
  }
  Eigen::Matrix<double, N, 1> v;
  for (int k = 0; k < N; ++k) v(k) = j.at(k).get<double>();
  return v;
}

}  // namespace

json ToJson(const PassPriors& p) {
  json problem;
  problem["camera"] = p.camera;
  problem["imu"] = p.imu;
  problem["use_imu"] = p.use_imu;
  problem["level_up_body"] = VectorOrNull(p.level_up_body);
  problem["gps"] = p.gps;
  json outages = json::array();
  for (const auto& [start, duration] : p.gps_outages) outages.push_back({start, duration});
  problem["gps_outages"] = outages;
  problem["imu_noise_factor"] = p.imu_noise_factor;
  problem["anchor_state"] = p.anchor_state;
  problem["anchor_sigma_velocity"] =
      p.anchor_sigma_velocity ? json(*p.anchor_sigma_velocity) : json();
  json still = json::array();
  for (const auto& [first, last] : p.still_intervals) still.push_back({first, last});
  problem["still_intervals"] = still;
  problem["forward_axis_body"] = VectorOrNull(p.forward_axis_body);
  problem["bias_prior_mean"] = Values(p.bias_prior_mean);
  problem["bias_prior_sigma"] = p.bias_prior_sigma ? json(Values(*p.bias_prior_sigma)) : json();
  problem["length_prior"] = p.length_prior ? json{{"length_m", p.length_prior->first},
                                                  {"sigma_m", p.length_prior->second}}
                                           : json();
  return problem;
}

PassPriors PassPriorsFromJson(const json& problem, const std::string& where) {
  if (!problem.is_object()) Malformed(where, "missing");
  PassPriors p;
  try {
    p.camera = problem.at("camera").get<std::string>();
    p.imu = problem.value("imu", "");
    p.use_imu = problem.value("use_imu", true);
    p.gps = problem.value("gps", "");
    for (const json& o : problem.at("gps_outages")) {
      p.gps_outages.emplace_back(o.at(0).get<double>(), o.at(1).get<double>());
    }
    p.imu_noise_factor = problem.value("imu_noise_factor", 1.0);
    if (!(p.imu_noise_factor > 0)) Malformed(where, "an IMU noise factor that is not positive");
    if (problem.contains("level_up_body") && !problem.at("level_up_body").is_null()) {
      p.level_up_body = Fixed<3>(problem.at("level_up_body"), where, "level_up_body");
    }
    if (!problem.at("forward_axis_body").is_null()) {
      p.forward_axis_body = Fixed<3>(problem.at("forward_axis_body"), where, "forward_axis_body");
    }
    p.anchor_state = problem.value("anchor_state", 0);
    if (problem.contains("anchor_sigma_velocity") &&
        !problem.at("anchor_sigma_velocity").is_null()) {
      p.anchor_sigma_velocity = problem.at("anchor_sigma_velocity").get<double>();
    }
    if (problem.contains("still_intervals")) {
      for (const json& range : problem.at("still_intervals")) {
        p.still_intervals.emplace_back(range.at(0).get<std::size_t>(),
                                       range.at(1).get<std::size_t>());
      }
    }
    if (problem.contains("length_prior") && !problem.at("length_prior").is_null()) {
      const json& prior = problem.at("length_prior");
      p.length_prior =
          std::make_pair(prior.at("length_m").get<double>(), prior.at("sigma_m").get<double>());
      if (!(p.length_prior->first > 0) || !(p.length_prior->second > 0)) {
        Malformed(where, "a length prior that is not positive");
      }
    }
    p.bias_prior_mean = Fixed<6>(problem.at("bias_prior_mean"), where, "bias_prior_mean");
    if (!problem.at("bias_prior_sigma").is_null()) {
      p.bias_prior_sigma = Fixed<6>(problem.at("bias_prior_sigma"), where, "bias_prior_sigma");
    }
  } catch (const json::exception& e) {
    Malformed(where, std::string("a missing or mistyped field (") + e.what() + ")");
  }
  return p;
}

std::vector<std::pair<std::size_t, std::size_t>> StillRanges(const std::vector<bool>& still) {
  std::vector<std::pair<std::size_t, std::size_t>> ranges;
  for (std::size_t k = 0; k < still.size(); ++k) {
    if (!still[k]) continue;
    if (!ranges.empty() && ranges.back().second == k) {
      ranges.back().second = k + 1;
    } else {
      ranges.emplace_back(k, k + 1);
    }
  }
  return ranges;
}

std::vector<bool> StillFlags(const std::vector<std::pair<std::size_t, std::size_t>>& ranges,
                             std::size_t num_states, const std::string& where) {
  std::vector<bool> still;
  for (const auto& [first, last] : ranges) {
    if (first >= last || last >= num_states) {
      throw InputError(where, 0,
                       "a standstill outside the pass's states (rerun `crop4d slam --force`)");
    }
    if (still.empty()) still.assign(num_states - 1, false);
    std::fill(still.begin() + static_cast<std::ptrdiff_t>(first),
              still.begin() + static_cast<std::ptrdiff_t>(last), true);
  }
  return still;
}

}  // namespace crop4d::workspace
