#include "crop4d/sim/world.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/sim/random.h"

namespace crop4d::sim {
namespace {

constexpr double kNanosPerDay = 86400.0 * 1e9;

void Require(bool ok, const std::string& what) {
  if (!ok) throw InputError("world options: " + what);
}

// Cubic smoothstep 3t² − 2t³ on [0, 1] and its derivative: a C¹ ramp.
double SmoothStep(double t, double* derivative) {
  if (t <= 0.0) {
    *derivative = 0.0;
    return 0.0;
  }
  if (t >= 1.0) {
    *derivative = 0.0;
    return 1.0;
  }
  *derivative = 6.0 * t * (1.0 - t);
  return t * t * (3.0 - 2.0 * t);
}

// 1 inside [lo, hi], falling to 0 over `fade` outside, C¹; `derivative` = d/dv.
double Window(double v, double lo, double hi, double fade, double* derivative) {
  double d_rise = 0.0, d_fall = 0.0;
  const double rise = SmoothStep((v - (lo - fade)) / fade, &d_rise);
  const double fall = SmoothStep(((hi + fade) - v) / fade, &d_fall);
  *derivative = (d_rise * fall - rise * d_fall) / fade;
  return rise * fall;
}

// Logistic growth rescaled to start at `start` at emergence and tend to `final`:
//   L(d) = 1 / (1 + exp(−k (d − m))),
//   v(d) = start + (final − start) (L(d) − L(d_e)) / (1 − L(d_e)),
// the logistic model of crop growth (e.g. Yin et al., "A flexible sigmoid function of
// determinate growth", Ann. Bot. 91, 2003), shifted so that v(d_e) = start.
double RescaledLogistic(double days, double emergence_days, double start, double final_value,
                        double midpoint, double rate) {
  auto logistic = [&](double d) { return 1.0 / (1.0 + std::exp(-rate * (d - midpoint))); };
  const double l_e = logistic(emergence_days);
  const double fraction = (logistic(days) - l_e) / (1.0 - l_e);
  return start + (final_value - start) * std::max(0.0, fraction);
}

}  // namespace

void WorldOptions::Check() const {
  Require(num_rows >= 1, "num_rows must be >= 1, got " + std::to_string(num_rows));
  Require(row_length_m > 0.0, "row_length_m must be > 0, got " + std::to_string(row_length_m));
  Require(row_spacing_m > 0.1, "row_spacing_m must be > 0.1, got " + std::to_string(row_spacing_m));
  Require(plant_spacing_m > 0.01,
          "plant_spacing_m must be > 0.01, got " + std::to_string(plant_spacing_m));
  Require(plant_spacing_jitter >= 0.0 && plant_spacing_jitter <= 1.0,
          "plant_spacing_jitter must be in [0, 1], got " + std::to_string(plant_spacing_jitter));
  Require(gap_probability >= 0.0 && gap_probability < 1.0,
          "gap_probability must be in [0, 1), got " + std::to_string(gap_probability));
  Require(double_probability >= 0.0 && double_probability <= 1.0,
          "double_probability must be in [0, 1], got " + std::to_string(double_probability));
  Require(headland_m >= 0.0, "headland_m must be >= 0, got " + std::to_string(headland_m));
  Require(
      undulation_amplitude_m >= 0.0 && undulation_amplitude_m < 5.0,
      "undulation_amplitude_m must be in [0, 5), got " + std::to_string(undulation_amplitude_m));
  Require(undulation_wavelength_m > 1.0,
          "undulation_wavelength_m must be > 1, got " + std::to_string(undulation_wavelength_m));
  Require(bed_height_m >= 0.0 && bed_height_m < 0.5,
          "bed_height_m must be in [0, 0.5), got " + std::to_string(bed_height_m));
  Require(tyre_track_depth_m >= 0.0 && tyre_track_depth_m < 0.3,
          "tyre_track_depth_m must be in [0, 0.3), got " + std::to_string(tyre_track_depth_m));
  Require(emergence_days >= 0.0, "emergence_days must be >= 0");
  Require(emergence_height_m > 0.0 && final_height_m > emergence_height_m,
          "need 0 < emergence_height_m < final_height_m");
  Require(emergence_canopy_radius_m > 0.0 && final_canopy_radius_m > emergence_canopy_radius_m,
          "need 0 < emergence_canopy_radius_m < final_canopy_radius_m");
  Require(height_rate_per_day > 0.0 && radius_rate_per_day > 0.0,
          "height_rate_per_day and radius_rate_per_day must be > 0");
  Require(plant_variation >= 0.0 && plant_variation < 0.5,
          "plant_variation must be in [0, 0.5), got " + std::to_string(plant_variation));
  weeds.Check();
  Require(2.0 * weeds.row_clearance_m < row_spacing_m || weeds.density_per_m2 == 0.0,
          "weeds.row_clearance_m must be less than half of row_spacing_m");
}

void WeedOptions::Check() const {
  Require(density_per_m2 >= 0.0 && density_per_m2 <= 100.0,
          "weeds.density_per_m2 must be in [0, 100], got " + std::to_string(density_per_m2));
  Require(row_clearance_m >= 0.0,
          "weeds.row_clearance_m must be >= 0, got " + std::to_string(row_clearance_m));
  Require(first_emergence_days >= 0.0 && emergence_span_days >= 0.0,
          "weeds.first_emergence_days and weeds.emergence_span_days must be >= 0");
  Require(final_height_m > 0.0 && final_height_m <= 2.0,
          "weeds.final_height_m must be in (0, 2], got " + std::to_string(final_height_m));
  Require(final_radius_m > 0.0 && final_radius_m <= 1.0,
          "weeds.final_radius_m must be in (0, 1], got " + std::to_string(final_radius_m));
  Require(half_size_days > 0.0,
          "weeds.half_size_days must be > 0, got " + std::to_string(half_size_days));
  Require(size_variation >= 0.0 && size_variation < 0.5,
          "weeds.size_variation must be in [0, 0.5), got " + std::to_string(size_variation));
}

World::World(const WorldOptions& options) : options_(options) {
  options_.Check();
  const WorldOptions& o = options_;

  // Relief: three plane waves with random directions and phases, total amplitude
  // `undulation_amplitude_m`, wavelengths around `undulation_wavelength_m`.
  Random terrain_random(HashCombine(o.seed, 0x7e44a1u));
  const double wavelength_factors[3] = {1.0, 0.63, 1.71};
  const double amplitude_shares[3] = {0.5, 0.2, 0.3};
  for (int i = 0; i < 3; ++i) {
    Wave w;
    const double angle = terrain_random.Uniform(0.0, 2.0 * M_PI);
    const double wavelength = o.undulation_wavelength_m * wavelength_factors[i];
    w.k = (2.0 * M_PI / wavelength) * Eigen::Vector2d(std::cos(angle), std::sin(angle));
    w.amplitude = o.undulation_amplitude_m * amplitude_shares[i];
    w.phase = terrain_random.Uniform(0.0, 2.0 * M_PI);
    waves_.push_back(w);
  }

  // Plants: planting positions along each row with jittered spacing; each position stays
  // empty (gap), holds one plant, or two (double).
  Random random(HashCombine(o.seed, 0x91a47u));
  row_begin_.reserve(o.num_rows + 1);
  for (int row = 0; row < o.num_rows; ++row) {
    row_begin_.push_back(static_cast<int>(plants_.size()));
    const double x_row = RowX(row);
    double y = random.Uniform(0.1, 0.6) * o.plant_spacing_m;
    while (y <= o.row_length_m) {
      if (!random.Bernoulli(o.gap_probability)) {
        const int count = random.Bernoulli(o.double_probability) ? 2 : 1;
        for (int k = 0; k < count; ++k) {
          Plant p;
          p.id = static_cast<int>(plants_.size());
          p.row = row;
          const double dx = std::clamp(random.Normal(0.0, 0.012), -0.04, 0.04);
          double dy = 0.0;
          if (count == 2) dy = (k == 0 ? -1.0 : 1.0) * random.Uniform(0.015, 0.03);
          p.xy = Eigen::Vector2d(x_row + dx + (count == 2 ? (k == 0 ? -0.01 : 0.01) : 0.0),
                                 std::clamp(y + dy, 0.0, o.row_length_m));
          const double v = o.plant_variation;
          const double vigour = random.Normal();
          p.height_scale = std::clamp(1.0 + v * vigour, 1.0 - 3.0 * v, 1.0 + 3.0 * v);
          p.radius_scale = std::clamp(1.0 + v * (0.6 * vigour + 0.8 * random.Normal()),
                                      1.0 - 3.0 * v, 1.0 + 3.0 * v);
          // Timing spread: std-dev plant_variation × midpoint / 3 (≈ 1.8 days by default).
          const double delay_sigma = v * o.height_midpoint_days / 3.0;
          p.delay_days =
              std::clamp(random.Normal(0.0, delay_sigma), -3.0 * delay_sigma, 3.0 * delay_sigma);
          if (count == 2) {  // the second seed of a double emerges late and stays smaller
            p.delay_days += k * random.Uniform(0.0, 3.0);
            p.height_scale *= 1.0 - 0.1 * k;
          }
          p.yaw_rad = random.Uniform(0.0, 2.0 * M_PI);
          p.seed = HashCombine(o.seed, 0x5eedu, static_cast<std::uint64_t>(p.id));
          plants_.push_back(p);
        }
      }
      y += o.plant_spacing_m * std::max(0.25, 1.0 + o.plant_spacing_jitter * random.Normal());
    }
    std::sort(plants_.begin() + row_begin_.back(), plants_.end(),
              [](const Plant& a, const Plant& b) { return a.xy.y() < b.xy.y(); });
  }
  row_begin_.push_back(static_cast<int>(plants_.size()));
  for (int i = 0; i < static_cast<int>(plants_.size()); ++i) {
    plants_[i].id = i;
    plants_[i].seed = HashCombine(o.seed, 0x5eedu, static_cast<std::uint64_t>(i));
  }
  PlaceWeeds();
}

void World::PlaceWeeds() {
  // Strip k of soil lies left of row k, between the clear bands of rows k − 1 and k; strips 0
  // and num_rows reach to the edge of the cultivated area, half a spacing beyond the outer
  // rows. density × area weeds per strip (rounded at random, so the mean is exact), uniform
  // over it.
  const WorldOptions& o = options_;
  const WeedOptions& w = o.weeds;
  const double half = 0.5 * o.row_spacing_m;
  Random random(HashCombine(o.seed, 0x3eedu));
  for (int strip = 0; strip <= o.num_rows; ++strip) {
    strip_begin_.push_back(static_cast<int>(weeds_.size()));
    const double lo = strip == 0 ? -half : RowX(strip - 1) + w.row_clearance_m;
    const double hi =
        strip == o.num_rows ? RowX(strip - 1) + half : RowX(strip) - w.row_clearance_m;
    if (w.density_per_m2 <= 0.0 || hi <= lo) continue;
    const int count = static_cast<int>(
        std::floor(w.density_per_m2 * (hi - lo) * o.row_length_m + random.Uniform()));
    for (int i = 0; i < count; ++i) {
      Weed weed;
      weed.strip = strip;
      weed.xy = Eigen::Vector2d(random.Uniform(lo, hi), random.Uniform(0.0, o.row_length_m));
      weed.emergence_days = w.first_emergence_days + random.Uniform(0.0, w.emergence_span_days);
      weed.size_scale = std::clamp(1.0 + w.size_variation * random.Normal(), 0.3, 2.0);
      weed.yaw_rad = random.Uniform(0.0, 2.0 * M_PI);
      weeds_.push_back(weed);
    }
    std::sort(weeds_.begin() + strip_begin_.back(), weeds_.end(),
              [](const Weed& a, const Weed& b) { return a.xy.y() < b.xy.y(); });
  }
  strip_begin_.push_back(static_cast<int>(weeds_.size()));
  for (int i = 0; i < static_cast<int>(weeds_.size()); ++i) {
    weeds_[i].id = i;
    weeds_[i].seed = HashCombine(o.seed, 0x3eedu, static_cast<std::uint64_t>(i));
  }
}

double World::TerrainHeightAndGradient(double x, double y, Eigen::Vector2d* gradient) const {
  const WorldOptions& o = options_;
  double h = 0.0;
  Eigen::Vector2d g = Eigen::Vector2d::Zero();
  const Eigen::Vector2d p(x, y);
  for (const Wave& w : waves_) {
    const double arg = w.k.dot(p) + w.phase;
    h += w.amplitude * std::sin(arg);
    g += w.amplitude * std::cos(arg) * w.k;
  }

  // Beds and furrows: a raised cosine across the rows, highest on the row centre lines,
  //   bed(x) = b (1 + cos(2π x / s)) / 2;
  // tyre tracks midway between rows: a periodic bump cos²ⁿ(θ/2) with θ = 2π(x/s − 1/2),
  // ≈ a Gaussian of σ = s/(2π) √(2/n) (≈ 6 cm for n = 12).
  // Both fade out smoothly (C¹) outside the cultivated area.
  const double s = o.row_spacing_m;
  const double theta = 2.0 * M_PI * x / s;
  const double bed = 0.5 * o.bed_height_m * (1.0 + std::cos(theta));
  const double d_bed = -0.5 * o.bed_height_m * std::sin(theta) * 2.0 * M_PI / s;
  constexpr int kTrackPower = 12;
  const double c = 0.5 * (1.0 - std::cos(theta));  // cos²((θ − π)/2), 1 midway between rows
  const double track = -o.tyre_track_depth_m * std::pow(c, kTrackPower);
  const double d_track = -o.tyre_track_depth_m * kTrackPower * std::pow(c, kTrackPower - 1) * 0.5 *
                         std::sin(theta) * 2.0 * M_PI / s;
  double dwx = 0.0, dwy = 0.0;
  const double wx = Window(x, -0.5 * s, (o.num_rows - 0.5) * s, 0.6, &dwx);
  const double wy = Window(y, -1.0, o.row_length_m + 1.0, 1.5, &dwy);
  const double profile = bed + track;
  const double d_profile = d_bed + d_track;
  h += wx * wy * profile;
  g.x() += (dwx * profile + wx * d_profile) * wy;
  g.y() += wx * dwy * profile;
  if (gradient) *gradient = g;
  return h;
}

double World::TerrainHeight(double x, double y) const {
  return TerrainHeightAndGradient(x, y, nullptr);
}

Eigen::Vector3d World::TerrainNormal(double x, double y) const {
  Eigen::Vector2d g;
  TerrainHeightAndGradient(x, y, &g);
  return Eigen::Vector3d(-g.x(), -g.y(), 1.0).normalized();
}

Eigen::Vector3d World::RowStart(int row) const {
  const double x = RowX(row);
  return Eigen::Vector3d(x, 0.0, TerrainHeight(x, 0.0));
}

Eigen::Vector3d World::RowEnd(int row) const {
  const double x = RowX(row);
  const double y = options_.row_length_m;
  return Eigen::Vector3d(x, y, TerrainHeight(x, y));
}

Eigen::AlignedBox2d World::Bounds() const {
  const WorldOptions& o = options_;
  const double half = 0.5 * o.row_spacing_m;
  return Eigen::AlignedBox2d(
      Eigen::Vector2d(-half - o.headland_m, -o.headland_m),
      Eigen::Vector2d(RowX(o.num_rows - 1) + half + o.headland_m, o.row_length_m + o.headland_m));
}

double World::DaysAfterSowing(Timestamp date) const {
  return static_cast<double>(date - options_.sowing_date) / kNanosPerDay;
}

PlantState World::NominalStateAt(double days) const {
  const WorldOptions& o = options_;
  PlantState state;
  if (days < o.emergence_days) return state;
  state.emerged = true;
  state.height_m = RescaledLogistic(days, o.emergence_days, o.emergence_height_m, o.final_height_m,
                                    o.height_midpoint_days, o.height_rate_per_day);
  state.canopy_radius_m =
      RescaledLogistic(days, o.emergence_days, o.emergence_canopy_radius_m, o.final_canopy_radius_m,
                       o.radius_midpoint_days, o.radius_rate_per_day);
  return state;
}

PlantState World::StateAt(const Plant& plant, Timestamp date) const {
  PlantState state = NominalStateAt(DaysAfterSowing(date) - plant.delay_days);
  state.height_m *= plant.height_scale;
  state.canopy_radius_m *= plant.radius_scale;
  return state;
}

PlantState World::WeedStateAt(const Weed& weed, Timestamp date) const {
  // Logistic in the days since emergence: a fifth of the final size at emergence, half after
  // half_size_days.
  const WeedOptions& w = options_.weeds;
  PlantState state;
  const double days = DaysAfterSowing(date) - weed.emergence_days;
  if (days < 0.0) return state;
  const double rate = std::log(4.0) / w.half_size_days;  // L(0) = 1/5, L(half) = 1/2
  const double fraction = 1.0 / (1.0 + std::exp(-rate * (days - w.half_size_days)));
  state.emerged = true;
  state.height_m = weed.size_scale * w.final_height_m * fraction;
  state.canopy_radius_m = weed.size_scale * w.final_radius_m * fraction;
  return state;
}

std::pair<int, int> World::WeedStripRange(int strip) const {
  CROP4D_CHECK(strip >= 0 && strip <= options_.num_rows);
  return {strip_begin_[strip], strip_begin_[strip + 1]};
}

std::pair<int, int> World::RowPlantRange(int row) const {
  CROP4D_CHECK(row >= 0 && row < options_.num_rows);
  return {row_begin_[row], row_begin_[row + 1]};
}

double World::TrueCanopyHeight(const Eigen::Vector2d& center, double radius_m,
                               Timestamp date) const {
  const double s = options_.row_spacing_m;
  const int first_row = std::max(0, static_cast<int>(std::floor((center.x() - radius_m) / s)));
  const int last_row =
      std::min(options_.num_rows - 1, static_cast<int>(std::ceil((center.x() + radius_m) / s)));
  double sum = 0.0;
  int count = 0;
  for (int row = first_row; row <= last_row; ++row) {
    const auto [begin, end] = RowPlantRange(row);
    // Plants of a row are sorted by y: jump to the first one that can be inside.
    auto it =
        std::lower_bound(plants_.begin() + begin, plants_.begin() + end, center.y() - radius_m,
                         [](const Plant& p, double y) { return p.xy.y() < y; });
    for (; it != plants_.begin() + end && it->xy.y() <= center.y() + radius_m; ++it) {
      if ((it->xy - center).norm() > radius_m) continue;
      const PlantState state = StateAt(*it, date);
      if (!state.emerged) continue;
      sum += state.height_m;
      ++count;
    }
  }
  return count > 0 ? sum / count : 0.0;
}

}  // namespace crop4d::sim
