#pragma once

// Procedural textures of the synthetic field, generated on the CPU and deterministic (a pure
// function of their options): the fine soil (clods, pebbles, grit, crop residue), its
// large-scale variation (moisture, organic matter), and the foliage of the distant tree line.
// All are periodic (they tile seamlessly); the renderer hides the soil's period by
// hex-tiling it with random offsets (see renderer.cc).

#include <cstdint>
#include <opencv2/core/mat.hpp>

#include "crop4d/core/option_check.h"

namespace crop4d::sim {

struct SoilTextureOptions {
  int size_px = 4096;             // texels per side; a power of two
  double extent_m = 4.0;          // side length of the texture on the ground
  std::uint64_t seed = 1;         // the field's seed
  int epoch = 0;                  // soil epoch: every rain re-randomises the surface
  double clod_density = 1.3;      // clod area per ground area (overlapping clods)
  double pebbles_per_m2 = 260.0;  // stones of 1.5–7 mm radius
  double grit_per_m2 = 2500.0;    // sand grains and crumbs of 0.4–1.2 mm radius
  double straws_per_m2 = 28.0;    // crop residue: straw and stalk fragments
  double litter_per_m2 = 60.0;    // small pieces of dead leaves
  // Clods flatten with every rain: relief = 1 / (1 + clod_smoothing_per_epoch × epoch),
  // at least min_relief.
  double clod_smoothing_per_epoch = 0.2;
  double min_relief = 0.45;
  // Renewed surface `change` sessions after the epoch began (0: the epoch's own surface): a
  // texture of the same kind from another seed, used by ApplySoilChange.
  int change = 0;
  OptionCheck Check() const;
};

// How the soil changes between two sessions without rain (SessionConditions): a seeded set of
// patches covering `fraction` of the ground is renewed at every session (weathering, residue
// moved by wind and irrigation, footprints and tracks, fallen leaves), and the surface dries
// and crusts, brightening by `drying` per session (at most 3 sessions' worth).
struct SoilChangeOptions {
  double fraction = 0.0;  // share of the area renewed per session, [0, 1]
  double patch_m = 0.15;  // typical size of a renewed patch, m
  double drying = 0.0;    // relative albedo increase per session without rain
};

// A periodic patch mask (CV_8U, 1 = renewed) of `size_px`² texels covering exactly
// round(fraction · size_px²) texels: the highest values of value noise of `patch_m` features.
cv::Mat SoilChangeMask(int size_px, double extent_m, double patch_m, double fraction,
                       std::uint64_t seed);

// The soil `level` sessions after its epoch began: the epoch's texture `base` (level 0) with the
// patches of sessions 1..level replaced by renewed surface, then the drying tone. RGBA8.
cv::Mat ApplySoilChange(const SoilTextureOptions& base_options, const cv::Mat& base, int level,
                        const SoilChangeOptions& change);

// RGBA8 (CV_8UC4, R first) soil albedo with the small-scale relief shading baked in.
cv::Mat GenerateSoilTexture(const SoilTextureOptions& options);

// RGBA8 texture of large-scale soil variation, `size_px`² and tiling: R,G,B multiply the soil
// colour (≈ 1 on average), A is a moisture / dark-patch weight in [0, 1].
cv::Mat GenerateSoilMacroTexture(std::uint64_t seed, int size_px = 256);

// RGBA8 foliage of the tree line: u along the tree line (tiles), v from the ground (0) to the
// crown top (1).
cv::Mat GenerateFoliageTexture(std::uint64_t seed, int width_px = 1024, int height_px = 256);

// Periodic value noise in [-1, 1]: `cells` random lattice values per side, interpolated
// bicubically to `size_px`² texels (size_px a multiple of cells). CV_32F.
cv::Mat PeriodicValueNoise(int size_px, int cells, std::uint64_t seed);

// Bilinear sample of an RGBA8 texture (CV_8UC4) at texture coordinates (u, v), wrapping as
// OpenGL's GL_REPEAT does and with its texel-centre convention (texel i covers [i, i + 1) / size
// and its centre is (i + 0.5) / size), rounded to 8 bits: the renderer samples the soil macro
// texture once per terrain vertex with it, as the GPU would have per pixel.
void SampleRepeat(const cv::Mat& rgba, double u, double v, std::uint8_t out[4]);

}  // namespace crop4d::sim
