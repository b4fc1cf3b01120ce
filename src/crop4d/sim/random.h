#pragma once

// Seeded random numbers for the synthetic world: a small wrapper around std::mt19937_64 whose
// output sequence the C++ standard fixes, with Gaussian samples by the Marsaglia polar method
// (std::normal_distribution is implementation-defined), so a seed gives the same field with
// every standard library. Seeds of independent streams come from HashCombine.

#include <cmath>
#include <cstdint>
#include <initializer_list>
#include <random>

namespace crop4d::sim {

// SplitMix64 finaliser (Steele, Lea & Flood, OOPSLA 2014).
inline std::uint64_t SplitMix64(std::uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// A seed derived from several values (order matters).
template <typename... T>
std::uint64_t HashCombine(std::uint64_t first, T... rest) {
  std::uint64_t h = SplitMix64(first);
  for (const std::uint64_t v :
       std::initializer_list<std::uint64_t>{static_cast<std::uint64_t>(rest)...}) {
    h = SplitMix64(h ^ (v + 0x9e3779b97f4a7c15ULL + (h << 6) + (h >> 2)));
  }
  return h;
}

class Random {
 public:
  explicit Random(std::uint64_t seed) : engine_(seed) {}

  // Uniform in [0, 1) with 53 random bits.
  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  // Uniform integer in [0, n), n > 0.
  std::uint64_t UniformInt(std::uint64_t n) { return engine_() % n; }
  bool Bernoulli(double p) { return Uniform() < p; }

  // Standard normal (Marsaglia & Bray, SIAM Review 6(3), 1964); caches the second value.
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u, v, s;
    do {
      u = 2.0 * Uniform() - 1.0;
      v = 2.0 * Uniform() - 1.0;
      s = u * u + v * v;
    } while (s >= 1.0 || s == 0.0);
    const double f = std::sqrt(-2.0 * std::log(s) / s);
    spare_ = v * f;
    has_spare_ = true;
    return u * f;
  }
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }

  std::mt19937_64& engine() { return engine_; }

 private:
  std::mt19937_64 engine_;
  bool has_spare_ = false;
  double spare_ = 0.0;
};

}  // namespace crop4d::sim
