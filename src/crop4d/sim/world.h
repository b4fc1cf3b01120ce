#pragma once

// The static world of a synthetic field: terrain, rows and plants, and how each plant grows
// over the season. Everything is a deterministic function of WorldOptions (seed included), so
// the renderer, the sensor models and the ground-truth writers all see the same field.
//
// Frame: the field's ENU world frame (DESIGN.md §3). Rows run along +y (north); row r's centre
// line is x = r * row_spacing_m, from y = 0 to y = row_length_m. The ground is z =
// TerrainHeight(x, y), close to 0.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <utility>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/sim/textures.h"

namespace crop4d::sim {

// Weeds on the soil between the rows: low broadleaf rosettes that emerge one after another
// through the season and grow to a small final size (a field kept clean in the rows by
// cultivation and herbicide; the inter-row soil is not). None with the defaults.
struct WeedOptions {
  double density_per_m2 = 0.0;         // weeds per m² of inter-row soil once all have emerged
  double row_clearance_m = 0.2;        // no weed closer than this to a row's centre line
  double first_emergence_days = 10.0;  // days after sowing when the first weeds emerge
  double emergence_span_days = 50.0;   // emergence dates spread uniformly over this span
  double final_height_m = 0.08;        // top of a full-grown weed above the ground
  double final_radius_m = 0.10;        // horizontal reach of its leaves
  double half_size_days = 10.0;        // days from emergence to half the final size
  double size_variation = 0.3;         // per-weed relative std-dev of the final size

  // Throws InputError naming the bad value.
  void Check() const;
};

struct WorldOptions {
  // Layout.
  int num_rows = 4;                   // parallel crop rows
  double row_length_m = 20.0;         // length of every row
  double row_spacing_m = 0.91;        // distance between row centre lines
  double plant_spacing_m = 0.20;      // mean distance between plants along a row
  double plant_spacing_jitter = 0.3;  // std-dev of the spacing, as a fraction of the mean
  double gap_probability = 0.05;      // chance that a planting position stays empty
  double double_probability = 0.04;   // chance that a position holds two plants
  double headland_m = 6.0;            // bare soil around the rows (turning area)
  // Terrain.
  double undulation_amplitude_m = 0.12;  // gentle large-scale relief
  double undulation_wavelength_m = 25.0;
  double bed_height_m = 0.06;        // raised beds under the rows (furrows in between)
  double tyre_track_depth_m = 0.02;  // tyre tracks midway between rows
  // Growth (peanut-like defaults): logistic in days after sowing.
  Timestamp sowing_date = 0;                // date the crop was sown
  double emergence_days = 7.0;              // no plant before this
  double emergence_height_m = 0.05;         // height at emergence
  double final_height_m = 0.45;             // asymptotic height
  double height_midpoint_days = 45.0;       // days after sowing at half of the final height
  double height_rate_per_day = 0.09;        // logistic steepness
  double emergence_canopy_radius_m = 0.03;  // canopy radius at emergence
  double final_canopy_radius_m = 0.50;      // canopy radius at the end (rows close late)
  double radius_midpoint_days = 55.0;
  double radius_rate_per_day = 0.08;
  double plant_variation = 0.12;  // per-plant relative std-dev of size and timing
  WeedOptions weeds;
  std::uint64_t seed = 1;

  // Throws InputError naming the bad value.
  void Check() const;
};

struct Plant {
  int id = 0;
  int row = 0;
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // stem position on the ground
  double height_scale = 1.0;                     // multiplies the nominal height
  double radius_scale = 1.0;                     // multiplies the nominal canopy radius
  double delay_days = 0.0;                       // shifts the growth curve
  double yaw_rad = 0.0;                          // orientation of the plant
  std::uint64_t seed = 0;                        // for its procedural geometry
};

// A weed between the rows. Weeds come from their own random stream: adding them changes no
// crop plant.
struct Weed {
  int id = 0;
  int strip = 0;  // the soil left of row `strip` (num_rows: right of the last row)
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // centre of the rosette on the ground
  double emergence_days = 0.0;                   // days after sowing when it emerges
  double size_scale = 1.0;                       // multiplies the final height and radius
  double yaw_rad = 0.0;
  std::uint64_t seed = 0;  // for its procedural geometry
};

// A plant on one date.
struct PlantState {
  double height_m = 0.0;         // top of the canopy above the ground at the stem
  double canopy_radius_m = 0.0;  // horizontal radius of the canopy
  bool emerged = false;
};

// Conditions of one session (light, weather) that change how the field looks.
struct SessionConditions {
  Timestamp date = 0;
  double sun_elevation_rad = 0.9;
  double sun_azimuth_rad = 2.5;  // clockwise from north
  double brightness = 1.0;       // overall exposure factor
  bool rain_before = false;      // rain since the previous session
  int soil_epoch = 0;            // increments at every rain: re-randomises the fine soil texture
  std::uint64_t wind_seed = 0;   // small per-session leaf perturbation
  // Sessions since the last rain (0 in the first session and right after rain), and how the
  // soil changes at each of them (textures.h; nothing with the defaults).
  int soil_change_level = 0;
  SoilChangeOptions soil_change;
  // Leaves sway in the wind within the session: amplitude of a leaf's displacement (m; 0 =
  // still) and the period of the gusts (s); phases from wind_seed. Renderer::SetTime.
  double wind_sway_m = 0.0;
  double wind_period_s = 2.0;
};

class World {
 public:
  explicit World(const WorldOptions& options);

  const WorldOptions& options() const { return options_; }
  const std::vector<Plant>& plants() const { return plants_; }

  // Ground height and unit normal at (x, y); smooth (C¹) everywhere.
  double TerrainHeight(double x, double y) const;
  Eigen::Vector3d TerrainNormal(double x, double y) const;

  // Row centre line end points (z on the terrain).
  Eigen::Vector3d RowStart(int row) const;
  Eigen::Vector3d RowEnd(int row) const;
  // The area that is rendered and driven: rows plus headland.
  Eigen::AlignedBox2d Bounds() const;

  PlantState StateAt(const Plant& plant, Timestamp date) const;

  // Weeds, sorted by strip and then by y; WeedStripRange gives one strip's [first, second).
  const std::vector<Weed>& weeds() const { return weeds_; }
  std::pair<int, int> WeedStripRange(int strip) const;
  // Height (top of the rosette above the ground) and radius of a weed on a date.
  PlantState WeedStateAt(const Weed& weed, Timestamp date) const;

  // Days since `options().sowing_date` (fractional).
  double DaysAfterSowing(Timestamp date) const;
  // Height and canopy radius of a nominal plant (scales 1, no delay) `days` after sowing.
  PlantState NominalStateAt(double days) const;

  // Plants of one row are contiguous in plants() and sorted by y: [first, second).
  std::pair<int, int> RowPlantRange(int row) const;
  // Centre line x of a row.
  double RowX(int row) const { return row * options_.row_spacing_m; }

  // True canopy height at a site on a date: the mean height of the emerged plants whose stems
  // lie within `radius_m` of `center` (0 when there are none).
  double TrueCanopyHeight(const Eigen::Vector2d& center, double radius_m, Timestamp date) const;

 private:
  // Draws the weeds of options_.weeds (from their own random stream).
  void PlaceWeeds();
  // Height and its gradient (dh/dx, dh/dy).
  double TerrainHeightAndGradient(double x, double y, Eigen::Vector2d* gradient) const;

  WorldOptions options_;
  std::vector<Plant> plants_;
  std::vector<int> row_begin_;  // index of the first plant of each row, plus the end
  std::vector<Weed> weeds_;
  std::vector<int> strip_begin_;  // index of the first weed of each strip, plus the end
  // Undulation: directions, wavelengths and phases of the relief waves (from the seed).
  struct Wave {
    Eigen::Vector2d k = Eigen::Vector2d::Zero();  // wave vector (rad/m)
    double amplitude = 0.0;
    double phase = 0.0;
  };
  std::vector<Wave> waves_;
};

}  // namespace crop4d::sim
