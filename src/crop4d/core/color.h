#pragma once

// Colour indices shared by the stages that run before the crop analysis (row SLAM, densify),
// which must not depend on it. analysis/vegetation.h has the analysis's own family of indices.

#include <array>
#include <cstdint>

namespace crop4d {

// Excess green 2g − r − b of an RGB colour in chromatic coordinates (0 for black): ≈ 0 on bare
// soil, 0.27–0.34 on the simulator's leaves. The index of analysis::Greenness(kExG), in double
// precision.
inline double ExcessGreen(const std::array<std::uint8_t, 3>& rgb) {
  const double sum = static_cast<double>(rgb[0]) + rgb[1] + rgb[2];
  return sum > 0 ? (2.0 * rgb[1] - rgb[0] - rgb[2]) / sum : 0.0;
}

}  // namespace crop4d
