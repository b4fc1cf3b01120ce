#include "crop4d/sim/textures.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/sim/random.h"

namespace crop4d::sim {
namespace {

using Rgb = std::array<float, 3>;

bool IsPowerOfTwo(int n) { return n > 0 && (n & (n - 1)) == 0; }

// Gaussian blur of a periodic image (OpenCV's filters do not wrap, so pad with copies).
cv::Mat PeriodicBlur(const cv::Mat& image, double sigma) {
  const int pad = static_cast<int>(std::ceil(3.0 * sigma)) + 1;
  cv::Mat padded;
  cv::copyMakeBorder(image, padded, pad, pad, pad, pad, cv::BORDER_WRAP);
  cv::GaussianBlur(padded, padded, cv::Size(0, 0), sigma);
  return padded(cv::Rect(pad, pad, image.cols, image.rows)).clone();
}

// A periodic (wrapping) RGB float canvas with splat helpers.
class Canvas {
 public:
  explicit Canvas(int size) : size_(size), mask_(size - 1), rgb_(size * size) {}
  int size() const { return size_; }
  int Index(int x, int y) const { return (y & mask_) * size_ + (x & mask_); }
  Rgb& at(int x, int y) { return rgb_[Index(x, y)]; }
  std::vector<Rgb>& data() { return rgb_; }

 private:
  int size_;
  int mask_;
  std::vector<Rgb> rgb_;
};

float Clamp01(float v) { return std::min(1.0f, std::max(0.0f, v)); }

Rgb Scale(const Rgb& c, float s) { return {c[0] * s, c[1] * s, c[2] * s}; }
Rgb Mix(const Rgb& a, const Rgb& b, float t) {
  return {a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t, a[2] + (b[2] - a[2]) * t};
}

cv::Mat ToRgba8(std::vector<Rgb>& rgb, int width, int height) {
  cv::Mat out(height, width, CV_8UC4);
  cv::parallel_for_(cv::Range(0, height), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      auto* row = out.ptr<cv::Vec4b>(y);
      for (int x = 0; x < width; ++x) {
        const Rgb& c = rgb[y * width + x];
        row[x] = cv::Vec4b(cv::saturate_cast<uchar>(255.0f * Clamp01(c[0]) + 0.5f),
                           cv::saturate_cast<uchar>(255.0f * Clamp01(c[1]) + 0.5f),
                           cv::saturate_cast<uchar>(255.0f * Clamp01(c[2]) + 0.5f), 255);
      }
    }
  });
  return out;
}

// Fixed light of the baked relief shading: from the upper left of the texture, high up (the
// renderer adds the real sun on top, so this only gives clods and stones their volume).
const float kLight[3] = {-0.38f, -0.42f, 0.82f};

}  // namespace

OptionCheck SoilTextureOptions::Check() const {
  OptionChecker c;
  c.Require(IsPowerOfTwo(size_px), "size_px", "must be a power of two", size_px)
      .AtLeast("size_px", size_px, 64)
      .Greater("extent_m", extent_m, 0.0)
      .AtLeast("epoch", epoch, 0)
      .AtLeast("change", change, 0)
      .AtLeast("clod_density", clod_density, 0.0)
      .AtLeast("pebbles_per_m2", pebbles_per_m2, 0.0)
      .AtLeast("grit_per_m2", grit_per_m2, 0.0)
      .AtLeast("straws_per_m2", straws_per_m2, 0.0)
      .AtLeast("litter_per_m2", litter_per_m2, 0.0)
      .AtLeast("clod_smoothing_per_epoch", clod_smoothing_per_epoch, 0.0)
      .Greater("min_relief", min_relief, 0.0)
      .AtMost("min_relief", min_relief, 1.0);
  return c.Result();
}

cv::Mat PeriodicValueNoise(int size_px, int cells, std::uint64_t seed) {
  CROP4D_CHECK(cells > 0 && size_px % cells == 0);
  Random random(seed);
  cv::Mat lattice(cells, cells, CV_32F);
  for (int y = 0; y < cells; ++y) {
    for (int x = 0; x < cells; ++x) lattice.at<float>(y, x) = random.Uniform(-1.0, 1.0);
  }
  const int k = size_px / cells;
  if (k == 1) return lattice;
  constexpr int kPad = 2;  // cells of wrap-around border for the bicubic kernel
  cv::Mat padded;
  cv::copyMakeBorder(lattice, padded, kPad, kPad, kPad, kPad, cv::BORDER_WRAP);
  cv::Mat up;
  cv::resize(padded, up, cv::Size((cells + 2 * kPad) * k, (cells + 2 * kPad) * k), 0, 0,
             cv::INTER_CUBIC);
  return up(cv::Rect(kPad * k, kPad * k, size_px, size_px)).clone();
}

cv::Mat GenerateSoilTexture(const SoilTextureOptions& o) {
  CROP4D_CHECK_OPTIONS(o, "GenerateSoilTexture");
  const int S = o.size_px;
  const int mask = S - 1;
  const float texel_m = static_cast<float>(o.extent_m / S);
  const float texels_per_m = 1.0f / texel_m;
  const double area_m2 = o.extent_m * o.extent_m;
  const std::uint64_t seed =
      o.change == 0 ? HashCombine(o.seed, 0x50117u, static_cast<std::uint64_t>(o.epoch))
                    : HashCombine(o.seed, 0x50117u, static_cast<std::uint64_t>(o.epoch),
                                  static_cast<std::uint64_t>(o.change));
  Random random(seed);
  const float relief = static_cast<float>(
      std::max(o.min_relief, 1.0 / (1.0 + o.clod_smoothing_per_epoch * o.epoch)));

  // Noise of the texture's own period at a few scales (lattice cells per side chosen from
  // the wanted feature size in metres).
  auto cells_for = [&](double feature_m) {
    int cells = 1;
    while (cells < S && o.extent_m / (2 * cells) >= feature_m) cells *= 2;
    return cells;
  };
  std::uint64_t noise_seed = HashCombine(seed, 1);
  auto noise = [&](double feature_m) {
    noise_seed = SplitMix64(noise_seed);
    return PeriodicValueNoise(S, cells_for(feature_m), noise_seed);
  };
  const cv::Mat n_crumb = noise(texel_m * 1.5);  // per-texel crumbs, also roughens clod edges
  const cv::Mat n_fine = noise(0.004);
  const cv::Mat n_mid = noise(0.03);
  const cv::Mat n_coarse = noise(0.25);
  const cv::Mat n_hue = noise(0.12);

  // 1. Relief: a crumbly base plus clods, lumps of soil that sit on each other (max).
  cv::Mat height(S, S, CV_32F);
  cv::Mat tone(S, S, CV_32F, cv::Scalar(1.0f));  // albedo factor of the clod on top
  for (int i = 0; i < S * S; ++i) {
    height.ptr<float>()[i] =
        relief * (0.0012f * n_fine.ptr<float>()[i] + 0.0005f * n_crumb.ptr<float>()[i]) +
        0.002f * n_mid.ptr<float>()[i];
  }
  {
    float* h = height.ptr<float>();
    float* t = tone.ptr<float>();
    const float* rough = n_crumb.ptr<float>();
    const float* rough2 = n_fine.ptr<float>();
    const double r_min = 0.0022, r_max = 0.028;
    double covered = 0.0;
    const double target = o.clod_density * area_m2;
    while (covered < target) {
      const float cx = random.Uniform(0, S), cy = random.Uniform(0, S);
      const double r_m = r_min * std::pow(r_max / r_min, std::pow(random.Uniform(), 1.8));
      const float aspect = random.Uniform(0.6, 1.0);
      const float angle = random.Uniform(0, M_PI);
      const float amp = relief * static_cast<float>(r_m * random.Uniform(0.3, 0.75));
      const float clod_tone = random.Uniform(0.8, 1.2);
      covered += M_PI * r_m * r_m * aspect;
      const float r = static_cast<float>(r_m) * texels_per_m;
      const float c = std::cos(angle), s = std::sin(angle);
      const int R = static_cast<int>(std::ceil(r * 1.25f)) + 1;
      const int x0 = static_cast<int>(cx), y0 = static_cast<int>(cy);
      for (int dy = -R; dy <= R; ++dy) {
        for (int dx = -R; dx <= R; ++dx) {
          const float lx = x0 + dx - cx, ly = y0 + dy - cy;
          const float u = (lx * c + ly * s) / r;
          const float v = (-lx * s + ly * c) / (r * aspect);
          const int idx = ((y0 + dy) & mask) * S + ((x0 + dx) & mask);
          const float q = u * u + v * v + 0.08f * rough[idx] + 0.35f * rough2[idx];
          if (q >= 1.0f) continue;
          const float bump = amp * std::pow(1.0f - q, 0.6f);
          if (bump > h[idx]) {
            h[idx] = bump;
            t[idx] = clod_tone;
          }
        }
      }
    }
  }

  // 2. Albedo and baked relief shading: Lambert with the fixed light, darker crevices (the
  // relief minus its local mean, a cheap ambient-occlusion estimate).
  const cv::Mat height_mean = PeriodicBlur(height, 0.006 * texels_per_m);
  Canvas canvas(S);
  const Rgb soil_dry = {0.56f, 0.45f, 0.34f};
  const Rgb soil_red = {0.58f, 0.40f, 0.29f};
  const Rgb soil_grey = {0.47f, 0.43f, 0.38f};
  const float light_norm =
      std::sqrt(kLight[0] * kLight[0] + kLight[1] * kLight[1] + kLight[2] * kLight[2]);
  const float lx = kLight[0] / light_norm, ly = kLight[1] / light_norm, lz = kLight[2] / light_norm;
  cv::parallel_for_(cv::Range(0, S), [&](const cv::Range& range) {
    for (int y = range.start; y < range.end; ++y) {
      const float* hr = height.ptr<float>(y);
      const float* hu = height.ptr<float>((y - 1) & mask);
      const float* hd = height.ptr<float>((y + 1) & mask);
      for (int x = 0; x < S; ++x) {
        const int i = y * S + x;
        const float gx = (hr[(x + 1) & mask] - hr[(x - 1) & mask]) * 0.5f * texels_per_m;
        const float gy = (hd[x] - hu[x]) * 0.5f * texels_per_m;
        const float inv = 1.0f / std::sqrt(gx * gx + gy * gy + 1.0f);
        const float ndotl = (-gx * lx - gy * ly + lz) * inv;
        const float shade = std::clamp(ndotl / lz, 0.3f, 1.35f);
        const float cavity =
            std::clamp(1.0f + 90.0f * (hr[x] - height_mean.ptr<float>()[i]), 0.5f, 1.15f);
        const float hue = n_hue.ptr<float>()[i];
        Rgb base = Mix(soil_dry, hue > 0 ? soil_red : soil_grey, std::abs(hue) * 0.7f);
        const float albedo =
            tone.ptr<float>()[i] * (1.0f + 0.12f * n_coarse.ptr<float>()[i] +
                                    0.08f * n_mid.ptr<float>()[i] + 0.07f * n_fine.ptr<float>()[i]);
        canvas.data()[i] = Scale(base, albedo * shade * cavity);
      }
    }
  });

  // 3. Stones: pebbles with a domed, lit top and a contact shadow; then grit.
  const std::array<Rgb, 6> stone_palette = {{{0.66f, 0.64f, 0.60f},
                                             {0.74f, 0.66f, 0.54f},
                                             {0.57f, 0.41f, 0.32f},
                                             {0.36f, 0.34f, 0.31f},
                                             {0.84f, 0.82f, 0.78f},
                                             {0.50f, 0.47f, 0.40f}}};
  const int num_pebbles = static_cast<int>(o.pebbles_per_m2 * area_m2);
  for (int i = 0; i < num_pebbles; ++i) {
    const float cx = random.Uniform(0, S), cy = random.Uniform(0, S);
    const float r = static_cast<float>(
        0.0015 * std::pow(7.0 / 1.5, std::pow(random.Uniform(), 1.5)) * texels_per_m);
    const float aspect = random.Uniform(0.55, 1.0);
    const float angle = random.Uniform(0, M_PI);
    // One draw per statement: the order of function arguments is unspecified in C++ (gcc and
    // clang differ), and a seed must give the same texture whatever the compiler.
    const float shade = random.Uniform(0.85, 1.1);
    const Rgb color = Scale(stone_palette[random.UniformInt(6)], shade);
    const float c = std::cos(angle), s = std::sin(angle);
    const int R = static_cast<int>(std::ceil(r * 1.5f)) + 1;
    const int x0 = static_cast<int>(cx), y0 = static_cast<int>(cy);
    for (int dy = -R; dy <= R; ++dy) {
      for (int dx = -R; dx <= R; ++dx) {
        const float px = x0 + dx - cx, py = y0 + dy - cy;
        const float u = (px * c + py * s) / r;
        const float v = (-px * s + py * c) / (r * aspect);
        const float q = u * u + v * v;
        Rgb& out = canvas.at(x0 + dx, y0 + dy);
        if (q < 1.0f) {
          // Normal of an ellipsoidal dome, back in texture axes.
          const float nz = std::sqrt(1.0f - q);
          const float nu = u, nv = v;
          const float nx = nu * c - nv * s, ny = nu * s + nv * c;
          const float ndotl = std::max(0.0f, nx * lx + ny * ly + nz * lz);
          const float highlight = 0.25f * std::pow(ndotl, 24.0f);
          const float shade = 0.35f + 0.75f * ndotl;
          out = {color[0] * shade + highlight, color[1] * shade + highlight,
                 color[2] * shade + highlight};
        } else if (q < 2.0f) {
          // Contact shadow, stronger away from the light.
          const float away = std::max(0.0f, -(px * lx + py * ly)) / (r + 1e-3f);
          out = Scale(out, 1.0f - (0.3f + 0.3f * std::min(1.0f, away)) * (2.0f - q));
        }
      }
    }
  }
  const int num_grit = static_cast<int>(o.grit_per_m2 * area_m2);
  for (int i = 0; i < num_grit; ++i) {
    const float cx = random.Uniform(0, S), cy = random.Uniform(0, S);
    const float r = random.Uniform(0.0004, 0.0012) * texels_per_m;
    const float brightness =
        random.Bernoulli(0.6) ? random.Uniform(1.25, 1.6) : random.Uniform(0.45, 0.7);
    const int R = static_cast<int>(std::ceil(r)) + 1;
    const int x0 = static_cast<int>(cx), y0 = static_cast<int>(cy);
    for (int dy = -R; dy <= R; ++dy) {
      for (int dx = -R; dx <= R; ++dx) {
        const float px = x0 + dx - cx, py = y0 + dy - cy;
        const float q = (px * px + py * py) / (r * r);
        if (q >= 1.0f) continue;
        Rgb& out = canvas.at(x0 + dx, y0 + dy);
        out = Scale(out, 1.0f + (brightness - 1.0f) * (1.0f - q));
      }
    }
  }

  // 4. Crop residue: straw and stalk fragments (bent thin cylinders with a cast shadow) and
  // pieces of dead leaves.
  std::vector<int> stamp(static_cast<size_t>(S) * S, -1);
  const std::array<Rgb, 4> straw_palette = {
      {{0.80f, 0.72f, 0.52f}, {0.66f, 0.60f, 0.50f}, {0.52f, 0.48f, 0.42f}, {0.34f, 0.27f, 0.20f}}};
  const int num_straws = static_cast<int>(o.straws_per_m2 * area_m2);
  for (int i = 0; i < num_straws; ++i) {
    const float cx = random.Uniform(0, S), cy = random.Uniform(0, S);
    const float length = random.Uniform(0.02, 0.12) * texels_per_m;
    const float width = random.Uniform(0.0015, 0.0045) * texels_per_m;
    const float angle = random.Uniform(0, 2 * M_PI);
    const float bend = random.Uniform(-0.15, 0.15) * length;
    const float shade = random.Uniform(0.85, 1.1);  // before the index: see the stones
    const Rgb color = Scale(straw_palette[random.UniformInt(4)], shade);
    const float dx = std::cos(angle), dy = std::sin(angle);
    const float half_w = 0.5f * width;
    const int R = static_cast<int>(std::ceil(half_w)) + 1;
    const float shadow_dx = -lx * width * 0.9f / std::max(0.2f, lz) * 0.5f;
    const float shadow_dy = -ly * width * 0.9f / std::max(0.2f, lz) * 0.5f;
    for (int pass = 0; pass < 2; ++pass) {  // 0: shadow, 1: the straw itself
      const int stamp_id = 2 * i + pass;
      for (float t = 0.0f; t <= length; t += 0.5f) {
        const float a = 2.0f * t / length - 1.0f;  // -1 … 1 along the straw
        const float px = cx + dx * (t - 0.5f * length) - dy * bend * (1.0f - a * a) +
                         (pass == 0 ? shadow_dx : 0.0f);
        const float py = cy + dy * (t - 0.5f * length) + dx * bend * (1.0f - a * a) +
                         (pass == 0 ? shadow_dy : 0.0f);
        const int x0 = static_cast<int>(std::floor(px)), y0 = static_cast<int>(std::floor(py));
        for (int oy = -R; oy <= R; ++oy) {
          for (int ox = -R; ox <= R; ++ox) {
            const float qx = x0 + ox + 0.5f - px, qy = y0 + oy + 0.5f - py;
            const float across = (-dy * qx + dx * qy) / half_w;  // signed, −1 … 1
            if (std::abs(across) >= 1.0f || std::abs(dx * qx + dy * qy) > 0.5f) continue;
            const int idx = canvas.Index(x0 + ox, y0 + oy);
            if (stamp[idx] == stamp_id) continue;
            stamp[idx] = stamp_id;
            if (pass == 0) {
              canvas.data()[idx] = Scale(canvas.data()[idx], 0.55f);
            } else {
              const float round = std::sqrt(1.0f - across * across);
              const float shade = 0.65f + 0.4f * round - 0.12f * across;
              canvas.data()[idx] = Scale(color, shade);
            }
          }
        }
      }
    }
  }
  const int num_litter = static_cast<int>(o.litter_per_m2 * area_m2);
  const float* rough = n_fine.ptr<float>();
  for (int i = 0; i < num_litter; ++i) {
    const float cx = random.Uniform(0, S), cy = random.Uniform(0, S);
    const float r = random.Uniform(0.003, 0.009) * texels_per_m;
    const Rgb color = Scale({0.36f, 0.27f, 0.18f}, random.Uniform(0.7, 1.25));
    const int R = static_cast<int>(std::ceil(r * 1.4f)) + 1;
    const int x0 = static_cast<int>(cx), y0 = static_cast<int>(cy);
    for (int dy = -R; dy <= R; ++dy) {
      for (int dx = -R; dx <= R; ++dx) {
        const float px = x0 + dx - cx, py = y0 + dy - cy;
        const int idx = canvas.Index(x0 + dx, y0 + dy);
        const float q = (px * px + py * py) / (r * r) + 0.6f * rough[idx];
        if (q >= 1.0f) continue;
        canvas.data()[idx] = Mix(canvas.data()[idx], color, 0.85f);
      }
    }
  }
  return ToRgba8(canvas.data(), S, S);
}

cv::Mat GenerateSoilMacroTexture(std::uint64_t seed, int size_px) {
  CROP4D_CHECK(IsPowerOfTwo(size_px) && size_px >= 16);
  const std::uint64_t s = HashCombine(seed, 0x3ac40u);
  const cv::Mat a = PeriodicValueNoise(size_px, 4, HashCombine(s, 1));
  const cv::Mat b = PeriodicValueNoise(size_px, 16, HashCombine(s, 2));
  const cv::Mat c = PeriodicValueNoise(size_px, 64, HashCombine(s, 3));
  const cv::Mat m = PeriodicValueNoise(size_px, 8, HashCombine(s, 4));
  const cv::Mat h = PeriodicValueNoise(size_px, 8, HashCombine(s, 5));
  std::vector<Rgb> rgb(static_cast<size_t>(size_px) * size_px);
  cv::Mat out(size_px, size_px, CV_8UC4);
  for (int y = 0; y < size_px; ++y) {
    for (int x = 0; x < size_px; ++x) {
      const float brightness =
          1.0f + 0.10f * a.at<float>(y, x) + 0.06f * b.at<float>(y, x) + 0.03f * c.at<float>(y, x);
      const float hue = 0.05f * h.at<float>(y, x);
      const float moisture =
          Clamp01((m.at<float>(y, x) + 0.25f * b.at<float>(y, x) - 0.25f) * 2.0f);
      out.at<cv::Vec4b>(y, x) =
          cv::Vec4b(cv::saturate_cast<uchar>(200.0f * brightness * (1.0f + hue)),
                    cv::saturate_cast<uchar>(200.0f * brightness),
                    cv::saturate_cast<uchar>(200.0f * brightness * (1.0f - hue)),
                    cv::saturate_cast<uchar>(255.0f * moisture));
    }
  }
  return out;  // the shader multiplies by 255/200
}

cv::Mat GenerateFoliageTexture(std::uint64_t seed, int width_px, int height_px) {
  Random random(HashCombine(seed, 0xf011a6eu));
  const int W = width_px, H = height_px;
  std::vector<Rgb> rgb(static_cast<size_t>(W) * H);
  // Forest interior: dark, with vertical trunks at the bottom.
  for (int y = 0; y < H; ++y) {
    for (int x = 0; x < W; ++x) rgb[y * W + x] = {0.07f, 0.09f, 0.055f};
  }
  const int num_trunks = W / 12;
  for (int i = 0; i < num_trunks; ++i) {
    const int x0 = random.UniformInt(W);
    const int w = 1 + random.UniformInt(3);
    const float g = random.Uniform(0.14, 0.26);
    for (int y = 0; y < H * 0.35; ++y) {
      for (int dx = 0; dx < w; ++dx) rgb[y * W + (x0 + dx) % W] = {g, g * 0.9f, g * 0.75f};
    }
  }
  // Leaf clumps: many overlapping blobs, lit from above, larger higher up.
  const int num_clumps = W * H / 30;
  for (int i = 0; i < num_clumps; ++i) {
    const float cx = random.Uniform(0, W);
    const float cy = static_cast<float>(H * std::pow(random.Uniform(), 0.6) * 0.98 + H * 0.1);
    const float r = random.Uniform(2.0, 7.0);
    const float v = cy / H;
    const Rgb base = Mix({0.10f, 0.18f, 0.07f}, {0.22f, 0.33f, 0.13f}, random.Uniform());
    const int R = static_cast<int>(std::ceil(r)) + 1;
    for (int dy = -R; dy <= R; ++dy) {
      const int y = static_cast<int>(cy) + dy;
      if (y < 0 || y >= H) continue;
      for (int dx = -R; dx <= R; ++dx) {
        const float q = (dx * dx + dy * dy) / (r * r);
        if (q >= 1.0f) continue;
        const int x = ((static_cast<int>(cx) + dx) % W + W) % W;
        // Lit from above: the upper part of a clump is brighter.
        const float shade = (0.75f + 0.45f * (dy / r)) * (0.7f + 0.5f * v);
        rgb[y * W + x] = Scale(base, shade);
      }
    }
  }
  return ToRgba8(rgb, W, H);
}

void SampleRepeat(const cv::Mat& rgba, double u, double v, std::uint8_t out[4]) {
  const int w = rgba.cols, h = rgba.rows;
  const double x = u * w - 0.5, y = v * h - 0.5;
  const double fx = std::floor(x), fy = std::floor(y);
  const double ax = x - fx, ay = y - fy;
  auto wrap = [](double i, int n) {
    const long k = static_cast<long>(i) % n;
    return static_cast<int>(k < 0 ? k + n : k);
  };
  const int x0 = wrap(fx, w), x1 = wrap(fx + 1, w), y0 = wrap(fy, h), y1 = wrap(fy + 1, h);
  const cv::Vec4b& p00 = rgba.at<cv::Vec4b>(y0, x0);
  const cv::Vec4b& p10 = rgba.at<cv::Vec4b>(y0, x1);
  const cv::Vec4b& p01 = rgba.at<cv::Vec4b>(y1, x0);
  const cv::Vec4b& p11 = rgba.at<cv::Vec4b>(y1, x1);
  for (int c = 0; c < 4; ++c) {
    const double top = p00[c] * (1 - ax) + p10[c] * ax;
    const double bottom = p01[c] * (1 - ax) + p11[c] * ax;
    out[c] = static_cast<std::uint8_t>(std::lround(top * (1 - ay) + bottom * ay));
  }
}

}  // namespace crop4d::sim

namespace crop4d::sim {

cv::Mat SoilChangeMask(int size_px, double extent_m, double patch_m, double fraction,
                       std::uint64_t seed) {
  CROP4D_CHECK(IsPowerOfTwo(size_px) && extent_m > 0.0 && patch_m > 0.0);
  cv::Mat mask(size_px, size_px, CV_8U, cv::Scalar(0));
  const std::size_t n = static_cast<std::size_t>(size_px) * size_px;
  const std::size_t wanted =
      static_cast<std::size_t>(std::llround(std::clamp(fraction, 0.0, 1.0) * n));
  if (wanted == 0) return mask;
  // Lattice cells of about the patch size (a power of two dividing size_px); two octaves for
  // ragged patch edges.
  int cells = 1;
  while (cells < size_px && extent_m / (2 * cells) >= patch_m) cells *= 2;
  const cv::Mat coarse = PeriodicValueNoise(size_px, cells, HashCombine(seed, 1));
  const cv::Mat fine =
      PeriodicValueNoise(size_px, std::min(size_px, 4 * cells), HashCombine(seed, 2));
  std::vector<float> value(n);
  for (std::size_t i = 0; i < n; ++i) {
    value[i] = coarse.ptr<float>()[i] + 0.3f * fine.ptr<float>()[i];
  }
  std::vector<float> sorted = value;
  std::nth_element(sorted.begin(), sorted.begin() + (n - wanted), sorted.end());
  const float threshold = sorted[n - wanted];
  std::size_t count = 0;
  for (std::size_t i = 0; i < n && count < wanted; ++i) {
    if (value[i] > threshold) {
      mask.ptr<std::uint8_t>()[i] = 1;
      ++count;
    }
  }
  // Ties at the threshold fill the rest, in texel order.
  for (std::size_t i = 0; i < n && count < wanted; ++i) {
    if (value[i] == threshold && mask.ptr<std::uint8_t>()[i] == 0) {
      mask.ptr<std::uint8_t>()[i] = 1;
      ++count;
    }
  }
  return mask;
}

cv::Mat ApplySoilChange(const SoilTextureOptions& base_options, const cv::Mat& base, int level,
                        const SoilChangeOptions& change) {
  CROP4D_CHECK(base.type() == CV_8UC4 && base.rows == base_options.size_px);
  cv::Mat out = base.clone();
  for (int j = 1; j <= level && change.fraction > 0.0; ++j) {
    SoilTextureOptions renewed_options = base_options;
    renewed_options.change = j;
    const cv::Mat renewed = GenerateSoilTexture(renewed_options);
    const cv::Mat mask = SoilChangeMask(
        base_options.size_px, base_options.extent_m, change.patch_m, change.fraction,
        HashCombine(base_options.seed, 0x5c4a, static_cast<std::uint64_t>(base_options.epoch),
                    static_cast<std::uint64_t>(j)));
    renewed.copyTo(out, mask);
  }
  const double tone = 1.0 + change.drying * std::min(level, 3);
  if (tone != 1.0) {
    for (int r = 0; r < out.rows; ++r) {
      std::uint8_t* p = out.ptr<std::uint8_t>(r);
      for (int c = 0; c < out.cols; ++c) {
        for (int k = 0; k < 3; ++k) {
          p[4 * c + k] =
              static_cast<std::uint8_t>(std::min(255.0, std::round(p[4 * c + k] * tone)));
        }
      }
    }
  }
  return out;
}

}  // namespace crop4d::sim
