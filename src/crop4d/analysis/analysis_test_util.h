#pragma once

// Hand-built ground for the analysis tests: a tilted field with raised beds.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <cstdint>
#include <random>
#include <vector>

namespace crop4d::analysis::testing_util {

// Ground height: a tilt of 5 % east and 2 % north plus 6 cm raised beds every 0.91 m (crests
// at x = 0, 0.91, 1.82, ...).
inline double BedHeight(double x, double y) {
  return 0.05 * x + 0.02 * y + 0.03 * (1.0 + std::cos(2.0 * M_PI * x / 0.91));
}

// Appends ground points uniformly over `box` (`per_m2` points per square metre) with Gaussian
// height noise, flagged as not vegetation.
inline void SampleGround(const Eigen::AlignedBox2d& box, double per_m2, double noise_m,
                         std::mt19937_64* rng, std::vector<Eigen::Vector3d>* points,
                         std::vector<std::uint8_t>* is_vegetation) {
  std::uniform_real_distribution<double> ux(box.min().x(), box.max().x());
  std::uniform_real_distribution<double> uy(box.min().y(), box.max().y());
  std::normal_distribution<double> noise(0.0, noise_m);
  const int n = static_cast<int>(per_m2 * box.volume());
  for (int i = 0; i < n; ++i) {
    const double x = ux(*rng), y = uy(*rng);
    points->emplace_back(x, y, BedHeight(x, y) + noise(*rng));
    is_vegetation->push_back(0);
  }
}

}  // namespace crop4d::analysis::testing_util
