#include "crop4d/sim/sim_config.h"

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <variant>

#include "crop4d/core/error.h"
#include "crop4d/sim/random.h"

namespace crop4d::sim {
namespace {

// ---- The key table: one entry per configuration key, used to print and to load ------------

using ValueRef = std::variant<int*, double*, bool*, std::string*, std::uint64_t*, Eigen::Vector3d*>;

struct Key {
  std::string section;  // "" for top-level keys
  std::string name;
  ValueRef value;
  std::string comment;
};

struct Section {
  std::string name;
  std::string comment;
};

const std::vector<Section>& Sections() {
  static const std::vector<Section> sections = {
      {"", ""},
      {"field",
       "The field: its name and the WGS84 origin of its East-North-Up frame (the start of "
       "row 0)."},
      {"rows",
       "Layout: parallel rows along +y (north), row r at x = r * spacing_m, from y = 0 to "
       "y = length_m."},
      {"terrain", "Ground relief (heights in metres)."},
      {"growth",
       "Plant growth: logistic height and canopy radius in days after sowing "
       "(peanut-like defaults)."},
      {"weeds",
       "Weeds on the soil between the rows (the rows themselves are kept clean): low rosettes "
       "that emerge through the season and grow; the crop's truth (plants.csv, sites) leaves "
       "them out, ground_truth/<session>/weeds.csv lists them."},
      {"sessions", ""},  // printed separately
      {"recording", "When the sessions are recorded, and the light."},
      {"camera", "The camera (cam0): image, intrinsics, distortion, rate and mounting."},
      {"drive", "The vehicle's drive: boustrophedon over every lane with headland U-turns."},
      {"imu", "IMU (imu0 = the body frame): continuous-time noise in the Kalibr convention."},
      {"mag", "Magnetometer (mag0)."},
      {"gps0",
       "RTK GPS receiver (gps0). Noise is per axis; the reported sigma is "
       "sqrt(sigma^2 + bias_sigma^2)."},
      {"gps1",
       "Low-accuracy GPS receiver (gps1) with a slowly drifting bias (first-order "
       "Gauss-Markov)."},
      {"ground_truth", "Ground truth written to FIELD/ground_truth/."},
      {"soil_change",
       "How the soil changes between two sessions without rain (rain renews all of it): a "
       "seeded share of the ground is renewed at every session, and the surface dries."},
      {"calibration_error",
       "Errors of the calibration written to the dataset (sensor.yaml) while the renderer and "
       "the sensor models use the truth; the drawn errors are in "
       "ground_truth/calibration_truth.yaml. Each error has exactly this size, its sign or "
       "direction is seeded, the same in every session. 0 = exact."},
  };
  return sections;
}

std::vector<Key> Keys(SimConfig& c) {
  WorldOptions& w = c.world;
  CameraRigOptions& cam = c.camera;
  TrajectoryOptions& d = c.drive;
  std::vector<Key> k = {
      {"", "seed", &c.seed,
       "master seed: every random choice derives from it (same seed = byte-identical files)"},
      {"", "realism", &c.realism,
       "\"ideal\" or \"real\": the level every imperfection below was set to as a whole "
       "(in a --config file it is applied first, the file's other keys then override it)"},
      {"field", "name", &c.name, "field name, written to field.yaml"},
      {"field", "latitude_deg", &c.origin.lat_deg, "WGS84 latitude of the origin, degrees"},
      {"field", "longitude_deg", &c.origin.lon_deg, "WGS84 longitude of the origin, degrees"},
      {"field", "altitude_m", &c.origin.alt_m, "ellipsoidal height of the origin, m"},
      {"rows", "count", &w.num_rows, "number of crop rows (>= 1)"},
      {"rows", "length_m", &w.row_length_m, "length of every row, m"},
      {"rows", "spacing_m", &w.row_spacing_m, "distance between row centre lines, m"},
      {"rows", "plant_spacing_m", &w.plant_spacing_m, "mean distance between plants in a row, m"},
      {"rows", "plant_spacing_jitter", &w.plant_spacing_jitter,
       "std-dev of the plant spacing, fraction of the mean"},
      {"rows", "gap_probability", &w.gap_probability, "chance that a planting position is empty"},
      {"rows", "double_probability", &w.double_probability,
       "chance that a position holds two plants"},
      {"rows", "headland_m", &w.headland_m, "bare ground around the rows (turning area), m"},
      {"terrain", "undulation_amplitude_m", &w.undulation_amplitude_m,
       "amplitude of the gentle large-scale relief, m"},
      {"terrain", "undulation_wavelength_m", &w.undulation_wavelength_m,
       "wavelength of that relief, m"},
      {"terrain", "bed_height_m", &w.bed_height_m,
       "raised beds under the rows above the furrows, m"},
      {"terrain", "tyre_track_depth_m", &w.tyre_track_depth_m,
       "depth of the tyre tracks midway between rows, m"},
      {"growth", "sowing_date", &c.sowing_date, "date the crop was sown, YYYY-MM-DD"},
      {"growth", "emergence_days", &w.emergence_days, "days from sowing to emergence"},
      {"growth", "emergence_height_m", &w.emergence_height_m, "plant height at emergence, m"},
      {"growth", "emergence_canopy_radius_m", &w.emergence_canopy_radius_m,
       "canopy radius at emergence, m"},
      {"growth", "final_height_m", &w.final_height_m, "asymptotic plant height, m"},
      {"growth", "height_midpoint_days", &w.height_midpoint_days,
       "days after sowing at half the final height"},
      {"growth", "height_rate_per_day", &w.height_rate_per_day,
       "steepness of the logistic height curve, 1/day"},
      {"growth", "final_canopy_radius_m", &w.final_canopy_radius_m, "asymptotic canopy radius, m"},
      {"growth", "radius_midpoint_days", &w.radius_midpoint_days,
       "days after sowing at half the final radius"},
      {"growth", "radius_rate_per_day", &w.radius_rate_per_day,
       "steepness of the logistic radius curve, 1/day"},
      {"growth", "plant_variation", &w.plant_variation,
       "per-plant relative std-dev of size and timing"},
      {"weeds", "density_per_m2", &w.weeds.density_per_m2,
       "weeds per m2 of the soil between the rows once all have emerged (0 = none)"},
      {"weeds", "row_clearance_m", &w.weeds.row_clearance_m,
       "no weed closer than this to a row's centre line, m"},
      {"weeds", "first_emergence_days", &w.weeds.first_emergence_days,
       "days after sowing when the first weeds emerge"},
      {"weeds", "emergence_span_days", &w.weeds.emergence_span_days,
       "emergence dates spread uniformly over this many days"},
      {"weeds", "final_height_m", &w.weeds.final_height_m, "height of a full-grown weed, m"},
      {"weeds", "final_radius_m", &w.weeds.final_radius_m,
       "horizontal reach of a full-grown weed's leaves, m"},
      {"weeds", "half_size_days", &w.weeds.half_size_days,
       "days from emergence to half the final size"},
      {"weeds", "size_variation", &w.weeds.size_variation,
       "per-weed relative std-dev of the final size"},
      {"recording", "start_utc_h", &c.recording.start_utc_h,
       "start of each session, hours after midnight UTC"},
      {"recording", "start_jitter_h", &c.recording.start_jitter_h,
       "each session starts up to this many hours later (seeded)"},
      {"recording", "brightness_jitter", &c.recording.brightness_jitter,
       "exposure varies by up to +- this fraction between sessions"},
      {"recording", "wind_sway_m", &c.recording.wind_sway_m,
       "leaves sway in the wind between frames by up to this (x a seeded 0.3-1 per session), m"},
      {"recording", "wind_period_s", &c.recording.wind_period_s, "period of the gusts, s"},
      {"camera", "width", &cam.width, "image width, px"},
      {"camera", "height", &cam.height, "image height, px"},
      {"camera", "fx", &cam.fx, "focal length x, px"},
      {"camera", "fy", &cam.fy, "focal length y, px"},
      {"camera", "cx", &cam.cx, "principal point x, px"},
      {"camera", "cy", &cam.cy, "principal point y, px"},
      {"camera", "k1", &cam.k1, "radial distortion k1"},
      {"camera", "k2", &cam.k2, "radial distortion k2"},
      {"camera", "p1", &cam.p1, "tangential distortion p1"},
      {"camera", "p2", &cam.p2, "tangential distortion p2"},
      {"camera", "k3", &cam.k3, "radial distortion k3"},
      {"camera", "rate_hz", &cam.rate_hz, "frame rate, Hz"},
      {"camera", "height_m", &cam.height_m, "optical centre above the ground, m"},
      {"camera", "pitch_deg", &cam.pitch_deg,
       "downward tilt of the optical axis below horizontal, deg"},
      {"camera", "forward_m", &cam.forward_m, "optical centre ahead of the IMU, m"},
      {"camera", "lateral_m", &cam.lateral_m, "optical centre left of the IMU, m"},
      {"camera", "msaa_samples", &cam.msaa_samples, "renderer anti-aliasing samples (1, 2, 4, 8)"},
      {"camera", "trigger", &cam.trigger,
       "\"continuous\": the camera records the whole drive; \"passes\": only along the row passes"},
      {"camera", "exposure_s", &c.image.exposure_s,
       "exposure time: motion blur over it, s (0 = instant, no blur)"},
      {"camera", "electrons_per_dn", &c.image.electrons_per_dn,
       "shot noise: photo-electrons per grey level (0 = no shot noise)"},
      {"camera", "read_noise_dn", &c.image.read_noise_dn, "read noise std-dev, grey levels"},
      {"camera", "auto_exposure_jitter", &c.image.auto_exposure_jitter,
       "auto exposure (clouds): the gain varies by up to +- this fraction within a session"},
      {"camera", "auto_exposure_period_s", &c.image.auto_exposure_period_s,
       "time scale of those gain changes, s"},
      {"camera", "jpeg_quality", &c.image.jpeg_quality,
       "write JPEG images of this quality (1-100); 0 = PNG"},
      {"camera", "readout_s", &c.image.readout_s,
       "rolling shutter: rows exposed top to bottom over this time, s (0 = global shutter)"},
      {"drive", "lane", &d.lane,
       "\"row\": centred over each row (straddling it); \"furrow\": between rows"},
      {"drive", "speed_mps", &d.speed_mps, "cruise speed along the rows, m/s"},
      {"drive", "turn_speed_mps", &d.turn_speed_mps, "speed in the headland turns, m/s"},
      {"drive", "turn_radius_m", &d.turn_radius_m, "radius of the U-turn arcs, m"},
      {"drive", "lead_m", &d.lead_m, "straight run beyond each row end before a turn, m"},
      {"drive", "speed_ramp_m", &d.speed_ramp_m, "distance to change between the two speeds, m"},
      {"drive", "lateral_offset_m", &d.lateral_offset_m,
       "std-dev of each pass's constant offset from the lane centre, m"},
      {"drive", "lateral_wobble_m", &d.lateral_wobble_m,
       "amplitude of the smooth lateral (and heading) wobble, m"},
      {"drive", "wobble_wavelength_m", &d.wobble_wavelength_m, "main wavelength of the wobble, m"},
      {"drive", "body_height_m", &d.body_height_m, "IMU (body origin) above the ground, m"},
      {"drive", "wheelbase_m", &d.wheelbase_m, "front to rear axle (pitch from terrain), m"},
      {"drive", "track_width_m", &d.track_width_m, "left to right wheel (roll from terrain), m"},
      {"drive", "knot_interval_s", &d.knot_interval_s,
       "knot interval of the trajectory splines (smoothing), s"},
      {"drive", "max_duration_s", &d.max_duration_s,
       "stop each session after this many seconds of driving; 0 = drive the whole field"},
      {"drive", "standstill_start_s", &d.standstill_start_s,
       "the vehicle stands still this long at the start of each session, s"},
      {"drive", "stop_probability_row_end", &d.stop_probability_row_end,
       "chance of a stop at the end of each pass (beyond the row end)"},
      {"drive", "stop_probability_in_row", &d.stop_probability_in_row,
       "chance of a stop at a random place within each pass"},
      {"drive", "stop_duration_s", &d.stop_duration_s, "duration of such a stop, s"},
      {"drive", "stop_ramp_s", &d.stop_ramp_s,
       "braking to and accelerating from a standstill take this long each, s"},
      {"imu", "rate_hz", &c.imu.rate_hz, "sample rate, Hz"},
      {"imu", "gyroscope_noise_density", &c.imu.gyroscope_noise_density,
       "gyro white noise, rad/s/sqrt(Hz)"},
      {"imu", "gyroscope_random_walk", &c.imu.gyroscope_random_walk,
       "gyro bias random walk, rad/s^2/sqrt(Hz)"},
      {"imu", "accelerometer_noise_density", &c.imu.accelerometer_noise_density,
       "accelerometer white noise, m/s^2/sqrt(Hz)"},
      {"imu", "accelerometer_random_walk", &c.imu.accelerometer_random_walk,
       "accelerometer bias random walk, m/s^3/sqrt(Hz)"},
      {"imu", "gyroscope_bias_sigma", &c.imu.gyroscope_bias_sigma,
       "std-dev of the gyro bias at session start, rad/s"},
      {"imu", "accelerometer_bias_sigma", &c.imu.accelerometer_bias_sigma,
       "std-dev of the accelerometer bias at session start, m/s^2"},
      {"imu", "scale_factor_sigma", &c.imu.scale_factor_sigma,
       "std-dev of each axis's scale factor error (gyro and accelerometer), fraction"},
      {"imu", "misalignment_sigma_rad", &c.imu.misalignment_sigma_rad,
       "std-dev of each off-diagonal axis misalignment entry, rad"},
      {"mag", "rate_hz", &c.mag.rate_hz, "sample rate, Hz"},
      {"mag", "field_enu_ut", &c.mag.field_enu_ut, "Earth's magnetic field [E, N, U], uT"},
      {"mag", "noise_ut", &c.mag.noise_ut, "white noise std-dev per axis, uT"},
      {"mag", "position_in_body", &c.mag.position_in_body, "lever arm [x, y, z] in the body, m"},
  };
  for (auto [name, g] : {std::pair<const char*, GpsOptions*>{"gps0", &c.gps0}, {"gps1", &c.gps1}}) {
    std::vector<Key> gps = {
        {name, "kind", &g->kind, "\"rtk\" (fix 4) or \"standard\" (fix 1)"},
        {name, "rate_hz", &g->rate_hz, "sample rate, Hz"},
        {name, "sigma_h_m", &g->sigma_h_m, "white noise std-dev per horizontal axis, m"},
        {name, "sigma_v_m", &g->sigma_v_m, "white noise std-dev, vertical, m"},
        {name, "bias_sigma_h_m", &g->bias_sigma_h_m,
         "stationary std-dev of the drifting bias per horizontal axis, m"},
        {name, "bias_sigma_v_m", &g->bias_sigma_v_m, "same, vertical, m"},
        {name, "bias_time_constant_s", &g->bias_time_constant_s, "correlation time of the bias, s"},
        {name, "antenna_in_body", &g->antenna_in_body,
         "antenna lever arm [x, y, z] in the body, m"},
        {name, "outlier_probability", &g->faults.outlier_probability,
         "chance that a sample is a multipath outlier"},
        {name, "outlier_sigma_m", &g->faults.outlier_sigma_m,
         "std-dev of an outlier's offset per horizontal axis (vertical 1.5x), m"},
        {name, "float_rate_per_min", &g->faults.float_rate_per_min,
         "rtk only: rate of losing the fix (RTK float, fix 5), per minute"},
        {name, "float_duration_s", &g->faults.float_duration_s,
         "mean duration of an RTK float episode, s"},
        {name, "float_sigma_h_m", &g->faults.float_sigma_h_m,
         "noise std-dev (and reported sigma) in RTK float, horizontal, m"},
        {name, "float_sigma_v_m", &g->faults.float_sigma_v_m, "same, vertical, m"},
        {name, "dropout_rate_per_min", &g->faults.dropout_rate_per_min,
         "rate of dropouts beyond the row ends (near the tree line), per minute"},
        {name, "dropout_duration_s", &g->faults.dropout_duration_s, "duration of a dropout, s"},
    };
    k.insert(k.end(), gps.begin(), gps.end());
  }
  std::vector<Key> gt = {
      {"ground_truth", "sites_per_row", &c.ground_truth.sites_per_row,
       "measurement sites per row, spread along it (field.yaml)"},
      {"ground_truth", "site_radius_m", &c.ground_truth.site_radius_m, "radius of a site, m"},
      {"ground_truth", "measurement_noise_m", &c.ground_truth.measurement_noise_m,
       "std-dev of the ruler readings in site_measurements.csv, m"},
      {"ground_truth", "terrain_grid_m", &c.ground_truth.terrain_grid_m,
       "grid spacing of terrain.csv, m"},
      {"ground_truth", "depth", &c.ground_truth.depth,
       "write a 16-bit PNG depth map (mm) per image (--depth)"},
      {"soil_change", "fraction_per_session", &c.soil_change.fraction,
       "share of the ground whose fine texture and residue are renewed at every session"},
      {"soil_change", "patch_m", &c.soil_change.patch_m, "typical size of a renewed patch, m"},
      {"soil_change", "drying_per_session", &c.soil_change.drying,
       "the soil brightens (dries, crusts) by this fraction per session since the last rain"},
      {"calibration_error", "focal_px", &c.calibration_error.focal_px,
       "fx and fy each written off by +- this, px"},
      {"calibration_error", "principal_point_px", &c.calibration_error.principal_point_px,
       "principal point written off by this distance, px"},
      {"calibration_error", "radial_distortion", &c.calibration_error.radial_distortion,
       "k1 and k2 each written off by +- this"},
      {"calibration_error", "tangential_distortion", &c.calibration_error.tangential_distortion,
       "p1 and p2 each written off by +- this"},
      {"calibration_error", "lever_arm_m", &c.calibration_error.lever_arm_m,
       "every lever arm (camera, GPS antennas, magnetometer) written off by this distance, m"},
      {"calibration_error", "rotation_deg", &c.calibration_error.rotation_deg,
       "camera T_BS rotation written off by this angle, deg"},
      {"calibration_error", "camera_time_offset_s", &c.calibration_error.camera_time_offset_s,
       "image stamps = capture time on the IMU clock +- this, s"},
      {"calibration_error", "camera_clock_drift_ppm", &c.calibration_error.camera_clock_drift_ppm,
       "plus a camera clock drift of +- this, parts per million"},
  };
  k.insert(k.end(), gt.begin(), gt.end());
  return k;
}

// ---- Printing -----------------------------------------------------------------------------

std::string Quote(const std::string& text) {
  std::string out = "\"";
  for (const unsigned char ch : text) {
    if (ch == '"' || ch == '\\') {
      out += '\\';
      out += static_cast<char>(ch);
    } else if (ch < 0x20 || ch == 0x7f) {
      out += fmt::format("\\x{:02x}", ch);
    } else {
      out += static_cast<char>(ch);
    }
  }
  return out + "\"";
}

std::string Num(double x) { return fmt::format("{}", x); }

std::string ValueText(const ValueRef& value) {
  struct Visitor {
    std::string operator()(int* v) const { return std::to_string(*v); }
    std::string operator()(double* v) const { return Num(*v); }
    std::string operator()(bool* v) const { return *v ? "true" : "false"; }
    std::string operator()(std::string* v) const {
      // Dates print bare (they are validated); everything else quoted.
      Timestamp t;
      return ParseDate(*v, &t) ? *v : Quote(*v);
    }
    std::string operator()(std::uint64_t* v) const { return std::to_string(*v); }
    std::string operator()(Eigen::Vector3d* v) const {
      return fmt::format("[{}, {}, {}]", Num(v->x()), Num(v->y()), Num(v->z()));
    }
  };
  return std::visit(Visitor{}, value);
}

// Wraps `text` as "# ..." comment lines of at most 100 columns.
std::string CommentBlock(const std::string& text) {
  std::string out, line = "#";
  std::istringstream words(text);
  std::string word;
  while (words >> word) {
    if (line.size() + 1 + word.size() > 100) {
      out += line + "\n";
      line = "#";
    }
    line += " " + word;
  }
  return out + line + "\n";
}

// ---- Loading ------------------------------------------------------------------------------

std::int64_t LineOf(const YAML::Node& node) {
  const YAML::Mark mark = node.Mark();
  return mark.line >= 0 ? mark.line + 1 : 0;
}

std::string Scalar(const std::string& file, const YAML::Node& node, const std::string& key) {
  if (!node.IsScalar()) {
    throw InputError(file, LineOf(node), fmt::format("{}: expected a single value", key));
  }
  return node.Scalar();
}

void ParseValue(const std::string& file, const YAML::Node& node, const std::string& key,
                const ValueRef& value) {
  const std::int64_t line = LineOf(node);
  auto fail = [&](const char* what, const std::string& text) {
    throw InputError(file, line, fmt::format("{}: expected {}, got \"{}\"", key, what, text));
  };
  auto parse_double = [&](const std::string& text) {
    errno = 0;
    char* end = nullptr;
    const double x = std::strtod(text.c_str(), &end);
    if (text.empty() || end != text.c_str() + text.size() || errno != 0 || !std::isfinite(x)) {
      fail("a finite number", text);
    }
    return x;
  };
  struct Visitor {
    const std::string& file;
    const YAML::Node& node;
    const std::string& key;
    const decltype(fail)& fail_fn;
    const decltype(parse_double)& parse_double_fn;
    void operator()(int* v) const {
      const std::string text = Scalar(file, node, key);
      errno = 0;
      char* end = nullptr;
      const long long x = std::strtoll(text.c_str(), &end, 10);
      if (text.empty() || end != text.c_str() + text.size() || errno != 0 || x < -1000000000LL ||
          x > 1000000000LL) {
        fail_fn("an integer", text);
      }
      *v = static_cast<int>(x);
    }
    void operator()(double* v) const { *v = parse_double_fn(Scalar(file, node, key)); }
    void operator()(bool* v) const {
      const std::string text = Scalar(file, node, key);
      if (text == "true") {
        *v = true;
      } else if (text == "false") {
        *v = false;
      } else {
        fail_fn("true or false", text);
      }
    }
    void operator()(std::string* v) const { *v = Scalar(file, node, key); }
    void operator()(std::uint64_t* v) const {
      const std::string text = Scalar(file, node, key);
      errno = 0;
      char* end = nullptr;
      const unsigned long long x = std::strtoull(text.c_str(), &end, 10);
      if (text.empty() || text[0] == '-' || end != text.c_str() + text.size() || errno != 0) {
        fail_fn("a non-negative integer", text);
      }
      *v = x;
    }
    void operator()(Eigen::Vector3d* v) const {
      if (!node.IsSequence() || node.size() != 3) {
        throw InputError(file, LineOf(node),
                         fmt::format("{}: expected a list of 3 numbers [x, y, z]", key));
      }
      for (int i = 0; i < 3; ++i) (*v)[i] = parse_double_fn(Scalar(file, node[i], key));
    }
  };
  std::visit(Visitor{file, node, key, fail, parse_double}, value);
}

// ---- Checking -----------------------------------------------------------------------------

void Require(bool ok, const std::string& key, const std::string& what) {
  if (!ok) throw InputError(fmt::format("{}: {}", key, what));
}
bool In(double x, double lo, double hi) { return std::isfinite(x) && x >= lo && x <= hi; }
bool Positive(double x) { return std::isfinite(x) && x > 0.0; }
bool NonNegative(double x) { return std::isfinite(x) && x >= 0.0; }

// ---- Presets ------------------------------------------------------------------------------

void SetImage(SimConfig* c, int width, int height) {
  // The same lens at every resolution: fx = fy = 0.4375 width (≈ 97° horizontal field of view,
  // so that the far tree line and some sky show at the top with a 35° pitch).
  const double scale = width / 1280.0;
  c->camera.width = width;
  c->camera.height = height;
  c->camera.fx = c->camera.fy = 560.0 * scale;
  c->camera.cx = 643.2 * scale;
  c->camera.cy = 476.8 * scale;
}

SimConfig BaseConfig() {
  SimConfig c;
  c.gps0.kind = "rtk";
  c.gps0.sigma_h_m = 0.02;
  c.gps0.sigma_v_m = 0.04;
  c.gps0.antenna_in_body = Eigen::Vector3d(-0.30, 0.20, 1.20);
  c.gps1.kind = "standard";
  c.gps1.sigma_h_m = 1.5;
  c.gps1.sigma_v_m = 2.5;
  c.gps1.bias_sigma_h_m = 1.0;
  c.gps1.bias_sigma_v_m = 1.5;
  c.gps1.bias_time_constant_s = 600.0;
  c.gps1.antenna_in_body = Eigen::Vector3d(-0.25, -0.22, 1.10);
  return c;
}

}  // namespace

// ---- CameraRigOptions ---------------------------------------------------------------------

geometry::PinholeRadTan CameraRigOptions::Intrinsics() const {
  geometry::PinholeRadTan cam;
  cam.width = width;
  cam.height = height;
  cam.fx = fx;
  cam.fy = fy;
  cam.cx = cx;
  cam.cy = cy;
  cam.k1 = k1;
  cam.k2 = k2;
  cam.p1 = p1;
  cam.p2 = p2;
  cam.k3 = k3;
  return cam;
}

geometry::Rigid3 CameraRigOptions::BodyFromCamera(double body_height_m) const {
  const double p = pitch_deg * M_PI / 180.0;
  const double s = std::sin(p), c = std::cos(p);
  Eigen::Matrix3d body_from_camera;
  // Columns: the camera's x (right), y (down) and z (forward, tilted down) axes in the body.
  body_from_camera.col(0) = Eigen::Vector3d(0.0, -1.0, 0.0);
  body_from_camera.col(1) = Eigen::Vector3d(-s, 0.0, -c);
  body_from_camera.col(2) = Eigen::Vector3d(c, 0.0, -s);
  return geometry::Rigid3(body_from_camera,
                          Eigen::Vector3d(forward_m, lateral_m, height_m - body_height_m));
}

// ---- SimConfig ------------------------------------------------------------------------------

void SimConfig::Check() const {
  Require(!name.empty() && name.find_first_of("/\\\n\r\t") == std::string::npos, "field.name",
          "must be a non-empty name without slashes or control characters");
  Require(In(origin.lat_deg, -89.0, 89.0), "field.latitude_deg", "must be in [-89, 89]");
  Require(In(origin.lon_deg, -180.0, 180.0), "field.longitude_deg", "must be in [-180, 180]");
  Require(In(origin.alt_m, -1000.0, 10000.0), "field.altitude_m", "must be in [-1000, 10000]");

  const WorldOptions& w = world;
  Require(w.num_rows >= 1 && w.num_rows <= 1000, "rows.count", "must be in [1, 1000]");
  Require(In(w.row_length_m, 0.5, 10000.0) && w.row_length_m > 0.0, "rows.length_m",
          "must be in [0.5, 10000]");
  Require(In(w.row_spacing_m, 0.1, 10.0), "rows.spacing_m", "must be in [0.1, 10]");
  Require(In(w.plant_spacing_m, 0.01, 10.0), "rows.plant_spacing_m", "must be in [0.01, 10]");
  Require(In(w.plant_spacing_jitter, 0.0, 0.9), "rows.plant_spacing_jitter", "must be in [0, 0.9]");
  Require(In(w.gap_probability, 0.0, 1.0), "rows.gap_probability", "must be in [0, 1]");
  Require(In(w.double_probability, 0.0, 1.0), "rows.double_probability", "must be in [0, 1]");
  Require(In(w.headland_m, 0.0, 1000.0), "rows.headland_m", "must be in [0, 1000]");
  Require(NonNegative(w.undulation_amplitude_m), "terrain.undulation_amplitude_m", "must be >= 0");
  Require(Positive(w.undulation_wavelength_m), "terrain.undulation_wavelength_m",
          "must be positive");
  Require(NonNegative(w.bed_height_m), "terrain.bed_height_m", "must be >= 0");
  Require(NonNegative(w.tyre_track_depth_m), "terrain.tyre_track_depth_m", "must be >= 0");
  Timestamp sowing = 0;
  Require(ParseDate(sowing_date, &sowing), "growth.sowing_date",
          "must be a date YYYY-MM-DD, not \"" + sowing_date + "\"");
  Require(NonNegative(w.emergence_days), "growth.emergence_days", "must be >= 0");
  Require(Positive(w.final_height_m), "growth.final_height_m", "must be positive");
  Require(Positive(w.emergence_height_m) && w.emergence_height_m <= w.final_height_m,
          "growth.emergence_height_m", "must be positive and at most growth.final_height_m");
  Require(Positive(w.final_canopy_radius_m), "growth.final_canopy_radius_m", "must be positive");
  Require(Positive(w.emergence_canopy_radius_m) &&
              w.emergence_canopy_radius_m <= w.final_canopy_radius_m,
          "growth.emergence_canopy_radius_m",
          "must be positive and at most growth.final_canopy_radius_m");
  Require(Positive(w.height_midpoint_days), "growth.height_midpoint_days", "must be positive");
  Require(Positive(w.height_rate_per_day), "growth.height_rate_per_day", "must be positive");
  Require(Positive(w.radius_midpoint_days), "growth.radius_midpoint_days", "must be positive");
  Require(In(w.weeds.density_per_m2, 0.0, 100.0), "weeds.density_per_m2", "must be in [0, 100]");
  Require(In(w.weeds.row_clearance_m, 0.0, 0.5 * w.row_spacing_m) &&
              w.weeds.row_clearance_m < 0.5 * w.row_spacing_m,
          "weeds.row_clearance_m", "must be >= 0 and less than half of rows.spacing_m");
  Require(NonNegative(w.weeds.first_emergence_days), "weeds.first_emergence_days", "must be >= 0");
  Require(NonNegative(w.weeds.emergence_span_days), "weeds.emergence_span_days", "must be >= 0");
  Require(In(w.weeds.final_height_m, 0.001, 2.0), "weeds.final_height_m", "must be in [0.001, 2]");
  Require(In(w.weeds.final_radius_m, 0.001, 1.0), "weeds.final_radius_m", "must be in [0.001, 1]");
  Require(Positive(w.weeds.half_size_days), "weeds.half_size_days", "must be positive");
  Require(In(w.weeds.size_variation, 0.0, 0.49), "weeds.size_variation", "must be in [0, 0.49]");
  Require(Positive(w.radius_rate_per_day), "growth.radius_rate_per_day", "must be positive");
  Require(In(w.plant_variation, 0.0, 0.5), "growth.plant_variation", "must be in [0, 0.5]");

  Require(!sessions.empty(), "sessions", "at least one session is needed");
  Timestamp previous = 0;
  for (size_t i = 0; i < sessions.size(); ++i) {
    const std::string key = fmt::format("sessions[{}].date", i);
    Timestamp t = 0;
    Require(ParseDate(sessions[i].date, &t), key,
            "must be a date YYYY-MM-DD, not \"" + sessions[i].date + "\"");
    Require(i == 0 || t > previous, key,
            fmt::format("{} is not after the previous session's date {}: sessions must be in "
                        "date order, one per day",
                        sessions[i].date, sessions[i - (i > 0 ? 1 : 0)].date));
    previous = t;
  }

  Require(In(recording.start_utc_h, 0.0, 23.0), "recording.start_utc_h", "must be in [0, 23]");
  Require(In(recording.start_jitter_h, 0.0, 12.0) &&
              recording.start_utc_h + recording.start_jitter_h < 24.0,
          "recording.start_jitter_h", "must be >= 0 with start_utc_h + start_jitter_h < 24");
  Require(In(recording.brightness_jitter, 0.0, 0.5), "recording.brightness_jitter",
          "must be in [0, 0.5]");
  Require(In(recording.wind_sway_m, 0.0, 0.2), "recording.wind_sway_m", "must be in [0, 0.2]");
  Require(In(recording.wind_period_s, 0.1, 100.0), "recording.wind_period_s",
          "must be in [0.1, 100]");

  const CameraRigOptions& cam = camera;
  Require(cam.width >= 16 && cam.width <= 8192, "camera.width", "must be in [16, 8192]");
  Require(cam.height >= 16 && cam.height <= 8192, "camera.height", "must be in [16, 8192]");
  Require(Positive(cam.fx), "camera.fx", "must be positive");
  Require(Positive(cam.fy), "camera.fy", "must be positive");
  Require(In(cam.cx, 0.0, cam.width), "camera.cx", "must lie inside the image [0, width]");
  Require(In(cam.cy, 0.0, cam.height), "camera.cy", "must lie inside the image [0, height]");
  for (const auto& [key, value] : {std::pair<const char*, double>{"camera.k1", cam.k1},
                                   {"camera.k2", cam.k2},
                                   {"camera.p1", cam.p1},
                                   {"camera.p2", cam.p2},
                                   {"camera.k3", cam.k3}}) {
    Require(In(value, -10.0, 10.0), key, "must be in [-10, 10]");
  }
  Require(In(cam.rate_hz, 0.01, 1000.0), "camera.rate_hz", "must be in [0.01, 1000]");
  Require(In(cam.height_m, 0.05, 20.0), "camera.height_m", "must be in [0.05, 20]");
  Require(In(cam.pitch_deg, -10.0, 90.0), "camera.pitch_deg", "must be in [-10, 90]");
  Require(In(cam.forward_m, -10.0, 10.0), "camera.forward_m", "must be in [-10, 10]");
  Require(In(cam.lateral_m, -10.0, 10.0), "camera.lateral_m", "must be in [-10, 10]");
  Require(cam.trigger == "continuous" || cam.trigger == "passes", "camera.trigger",
          "must be \"continuous\" or \"passes\"");
  Require(cam.msaa_samples == 1 || cam.msaa_samples == 2 || cam.msaa_samples == 4 ||
              cam.msaa_samples == 8,
          "camera.msaa_samples", "must be 1, 2, 4 or 8");

  drive.Check();
  Require(drive.lane == "row" || w.num_rows >= 2, "drive.lane", "\"furrow\" needs at least 2 rows");
  const double reach = Trajectory::TurnReach(w.row_spacing_m, drive.turn_radius_m);
  Require(drive.lead_m + reach <= w.headland_m + 1e-9, "drive.turn_radius_m",
          fmt::format("the headland turns reach {:.2f} m beyond the rows (drive.lead_m {} + turn "
                      "{:.2f} m) but rows.headland_m is {} m: make the turns tighter or the "
                      "headland wider",
                      drive.lead_m + reach, drive.lead_m, reach, w.headland_m));
  imu.Check();
  mag.Check();
  gps0.Check("gps0");
  gps1.Check("gps1");

  Require(ground_truth.sites_per_row >= 0 && ground_truth.sites_per_row <= 1000,
          "ground_truth.sites_per_row", "must be in [0, 1000]");
  Require(In(ground_truth.site_radius_m, 0.01, 100.0), "ground_truth.site_radius_m",
          "must be in [0.01, 100]");
  Require(In(ground_truth.measurement_noise_m, 0.0, 1.0), "ground_truth.measurement_noise_m",
          "must be in [0, 1]");
  Require(In(ground_truth.terrain_grid_m, 0.01, 100.0), "ground_truth.terrain_grid_m",
          "must be in [0.01, 100]");
  const std::vector<std::string> levels = RealismLevels();
  Require(std::find(levels.begin(), levels.end(), realism) != levels.end(), "realism",
          "must be \"ideal\" or \"real\", not \"" + realism + "\"");
  calibration_error.Check();
  image.Check();
  Require(In(soil_change.fraction, 0.0, 1.0), "soil_change.fraction_per_session",
          "must be in [0, 1]");
  Require(In(soil_change.patch_m, 0.01, 2.0), "soil_change.patch_m", "must be in [0.01, 2]");
  Require(In(soil_change.drying, -0.2, 0.2), "soil_change.drying_per_session",
          "must be in [-0.2, 0.2]");

  MakeWorldOptions().Check();
}

std::vector<Timestamp> SimConfig::SessionDates() const {
  std::vector<Timestamp> dates;
  for (const SessionSpec& s : sessions) {
    Timestamp t = 0;
    CROP4D_CHECK_MSG(ParseDate(s.date, &t), s.date);
    dates.push_back(t);
  }
  return dates;
}

WorldOptions SimConfig::MakeWorldOptions() const {
  WorldOptions w = world;
  w.seed = HashCombine(seed, 0x3011du);
  Timestamp sowing = 0;
  if (ParseDate(sowing_date, &sowing)) w.sowing_date = sowing;
  return w;
}

// ---- Presets --------------------------------------------------------------------------------

std::vector<std::string> PresetNames() { return {"tiny", "demo", "paper"}; }

SimConfig PresetConfig(const std::string& preset) {
  SimConfig c = BaseConfig();
  c.name = preset;
  c.sowing_date = "2016-05-10";
  if (preset == "tiny") {
    c.world.num_rows = 2;
    c.world.row_length_m = 8.0;
    c.sessions = {{"2016-06-10", false}, {"2016-06-24", true}};
    SetImage(&c, 320, 240);
    c.ground_truth.sites_per_row = 2;
    c.ground_truth.terrain_grid_m = 0.5;
  } else if (preset == "demo") {
    c.world.num_rows = 4;
    c.world.row_length_m = 20.0;
    c.sessions = {
        {"2016-06-01", false}, {"2016-06-15", false}, {"2016-06-29", true}, {"2016-07-13", false}};
    SetImage(&c, 640, 480);
    // Images over the row passes only: no stage uses the 38 % of a continuous recording taken
    // in the headland turns, and rendering them took 85 s of `make demo` (bench/RESULTS.md,
    // "Whole season"). The tiny and paper presets record continuously.
    c.camera.trigger = "passes";
  } else if (preset == "paper") {
    // Dong et al. 2017: a peanut field recorded 23 times over 89 days, twice a week.
    c.world.num_rows = 21;
    c.world.row_length_m = 150.0;
    const int offsets[] = {0,  4,  7,  11, 15, 19, 23, 27, 31, 35, 39, 43,
                           47, 51, 55, 59, 63, 67, 71, 75, 79, 84, 89};
    const Timestamp first = FromDate(2016, 5, 25);
    for (const int day : offsets) {
      const bool rain = day == 11 || day == 31 || day == 47 || day == 63 || day == 79;
      c.sessions.push_back({FormatDate(first + day * 86400 * kNanosPerSecond), rain});
    }
    SetImage(&c, 1280, 960);
    c.ground_truth.terrain_grid_m = 0.5;
  } else {
    throw InputError(fmt::format("unknown preset \"{}\" (expected tiny, demo or paper)", preset));
  }
  c.Check();
  return c;
}

std::vector<std::string> RealismLevels() { return {"ideal", "real"}; }

void ApplyRealism(const std::string& level, SimConfig* c) {
  if (level != "ideal" && level != "real") {
    throw InputError(fmt::format("realism: must be \"ideal\" or \"real\", not \"{}\"", level));
  }
  c->realism = level;
  const SimConfig defaults;
  c->calibration_error = defaults.calibration_error;
  c->image = defaults.image;
  c->imu.scale_factor_sigma = defaults.imu.scale_factor_sigma;
  c->imu.misalignment_sigma_rad = defaults.imu.misalignment_sigma_rad;
  c->gps0.faults = c->gps1.faults = GpsFaultOptions();
  c->soil_change = defaults.soil_change;
  c->world.weeds = defaults.world.weeds;
  c->recording.wind_sway_m = defaults.recording.wind_sway_m;
  c->recording.wind_period_s = defaults.recording.wind_period_s;
  c->drive.standstill_start_s = defaults.drive.standstill_start_s;
  c->drive.stop_probability_row_end = defaults.drive.stop_probability_row_end;
  c->drive.stop_probability_in_row = defaults.drive.stop_probability_in_row;
  c->drive.stop_duration_s = defaults.drive.stop_duration_s;
  c->drive.stop_ramp_s = defaults.drive.stop_ramp_s;
  if (level == "ideal") return;

  // Between two visits without rain a fifth of the surface changes (weathering, residue moved,
  // footprints, tracks, fallen leaves) and it dries a little.
  c->soil_change.fraction = 0.2;
  c->soil_change.patch_m = 0.15;
  c->soil_change.drying = 0.02;

  // Weeds emerge between the rows from ten days after sowing over seven weeks: two per m² of
  // inter-row soil in the end, rosettes up to about 8 cm high and 10 cm across (a field with
  // pre-emergence herbicide; untreated fields have tens per m²).
  c->world.weeds.density_per_m2 = 2.0;

  // A breeze: leaves move by up to a centimetre between frames.
  c->recording.wind_sway_m = 0.01;
  c->recording.wind_period_s = 2.0;

  // The driver waits a few seconds before starting and stops now and then.
  c->drive.standstill_start_s = 5.0;
  c->drive.stop_probability_row_end = 0.25;
  c->drive.stop_probability_in_row = 0.15;
  c->drive.stop_duration_s = 3.0;
  c->drive.stop_ramp_s = 1.5;

  // A rig like the paper's: a machine-vision camera calibrated in the lab and mounted on the
  // vehicle afterwards, no hardware synchronisation, a consumer MEMS IMU, an RTK receiver and
  // a standard one, driven along a tree line.
  const double px = c->camera.width / 1280.0;  // pixel magnitudes are for 1280 px wide images
  CalibrationErrorOptions& e = c->calibration_error;
  e.focal_px = 3.0 * px;
  e.principal_point_px = 3.0 * px;
  e.radial_distortion = 0.005;
  e.tangential_distortion = 2.0e-4;
  e.lever_arm_m = 0.015;
  e.rotation_deg = 0.3;
  e.camera_time_offset_s = 0.025;
  e.camera_clock_drift_ppm = 20.0;

  ImageEffectsOptions& im = c->image;
  im.exposure_s = 0.004;
  im.electrons_per_dn = 12.0;  // ≈ 3.3 grey levels of shot noise at mid-grey
  im.read_noise_dn = 1.5;
  im.auto_exposure_jitter = 0.12;
  im.auto_exposure_period_s = 20.0;
  im.jpeg_quality = 0;  // JPEG stays an option

  // MPU-9250 class: scale factor tolerance ±3 % (datasheet), a third of it after the factory
  // trim; cross-axis sensitivity ±2 %.
  c->imu.scale_factor_sigma = 0.005;
  c->imu.misalignment_sigma_rad = 0.002;

  for (GpsOptions* g : {&c->gps0, &c->gps1}) {
    GpsFaultOptions& f = g->faults;
    const bool rtk = g->kind == "rtk";
    f.outlier_probability = rtk ? 0.005 : 0.01;
    f.outlier_sigma_m = rtk ? 0.3 : 5.0;
    f.float_rate_per_min = rtk ? 0.5 : 0.0;
    f.float_duration_s = 15.0;
    f.float_sigma_h_m = 0.15;
    f.float_sigma_v_m = 0.30;
    f.dropout_rate_per_min = 2.0;
    f.dropout_duration_s = 3.0;
  }
}

// ---- YAML -----------------------------------------------------------------------------------

std::string SimConfigToYaml(const SimConfig& config, const std::string& preset) {
  SimConfig copy = config;
  const std::vector<Key> keys = Keys(copy);
  std::string out = CommentBlock(
      fmt::format("crop4d simulate: the effective configuration{}. Give a file with any subset of "
                  "these keys to `crop4d simulate --config FILE`: its values override the "
                  "preset's key by key (a sessions list replaces the whole list); unknown keys "
                  "are errors. Units are in the key names: _m metres, _deg degrees, _hz hertz, "
                  "_s seconds, _h hours, _ut microtesla.",
                  preset.empty() ? "" : fmt::format(" (preset \"{}\")", preset)));
  constexpr size_t kCommentColumn = 40;
  auto line = [&](const std::string& text, const std::string& comment) {
    std::string l = text;
    l += std::string(l.size() < kCommentColumn ? kCommentColumn - l.size() : 1, ' ');
    return l + "# " + comment + "\n";
  };
  for (const Section& section : Sections()) {
    if (section.name == "sessions") {
      out += "\n" + CommentBlock(
                        "The recording sessions in date order, one drive over the whole field "
                        "each. date: YYYY-MM-DD, also the session's folder name; rain_before: it "
                        "rained since the previous session (the soil looks different).");
      out += "sessions:\n";
      for (const SessionSpec& s : config.sessions) {
        out += fmt::format("  - {{date: {}, rain_before: {}}}\n", s.date,
                           s.rain_before ? "true" : "false");
      }
      continue;
    }
    out += "\n";
    const std::string indent = section.name.empty() ? "" : "  ";
    if (!section.name.empty()) out += CommentBlock(section.comment) + section.name + ":\n";
    for (const Key& key : keys) {
      if (key.section != section.name) continue;
      out += line(indent + key.name + ": " + ValueText(key.value), key.comment);
    }
  }
  return out;
}

void ApplySimConfigYaml(const std::string& file, const std::string& text, SimConfig* config) {
  YAML::Node root;
  try {
    root = YAML::Load(text);
  } catch (const YAML::Exception& e) {
    throw InputError(file, e.mark.line >= 0 ? e.mark.line + 1 : 0, "not valid YAML: " + e.msg);
  }
  if (root.IsNull()) return;  // an empty file changes nothing
  if (!root.IsMap()) {
    throw InputError(file, LineOf(root), "expected a map of configuration keys");
  }
  std::vector<Key> keys = Keys(*config);
  std::map<std::string, std::int64_t> lines;  // key -> line, for errors from Check()
  auto find = [&](const std::string& section, const std::string& name) -> Key* {
    for (Key& key : keys) {
      if (key.section == section && key.name == name) return &key;
    }
    return nullptr;
  };
  auto known_section = [&](const std::string& name) {
    for (const Section& s : Sections()) {
      if (!s.name.empty() && s.name == name) return true;
    }
    return false;
  };
  const std::string hint = " (crop4d simulate --print-config lists every key)";
  // `realism` sets every imperfection at once, so it is applied before the file's other keys.
  if (const YAML::Node level = root["realism"]) {
    std::string text;
    ParseValue(file, level, "realism", &text);
    try {
      ApplyRealism(text, config);
    } catch (const InputError& e) {
      throw InputError(file, LineOf(level), e.message());
    }
    lines["realism"] = LineOf(level);
  }
  for (const auto& item : root) {
    const std::string top = item.first.Scalar();
    const YAML::Node& value = item.second;
    if (top == "sessions") {
      if (!value.IsSequence() || value.size() == 0) {
        throw InputError(file, LineOf(value),
                         "sessions: expected a non-empty list of "
                         "{date: YYYY-MM-DD, rain_before: false} entries");
      }
      lines["sessions"] = LineOf(item.first);
      std::vector<SessionSpec> sessions;
      for (size_t i = 0; i < value.size(); ++i) {
        const YAML::Node entry = value[i];
        const std::string prefix = fmt::format("sessions[{}]", i);
        if (!entry.IsMap()) {
          throw InputError(file, LineOf(entry),
                           prefix + ": expected {date: YYYY-MM-DD, rain_before: false}");
        }
        SessionSpec spec;
        bool has_date = false;
        for (const auto& field : entry) {
          const std::string name = field.first.Scalar();
          const std::string key = prefix + "." + name;
          if (name == "date") {
            ParseValue(file, field.second, key, &spec.date);
            has_date = true;
          } else if (name == "rain_before") {
            ParseValue(file, field.second, key, &spec.rain_before);
          } else {
            throw InputError(file, LineOf(field.first),
                             fmt::format("unknown key \"{}\" (a session has date and "
                                         "rain_before)",
                                         key));
          }
          lines[key] = LineOf(field.second);
        }
        if (!has_date) throw InputError(file, LineOf(entry), prefix + ": missing key \"date\"");
        sessions.push_back(spec);
      }
      config->sessions = sessions;
      continue;
    }
    if (Key* key = find("", top)) {
      ParseValue(file, value, top, key->value);
      lines[top] = LineOf(value);
      continue;
    }
    if (!known_section(top)) {
      throw InputError(file, LineOf(item.first), fmt::format("unknown key \"{}\"{}", top, hint));
    }
    if (value.IsNull()) continue;  // "camera:" with nothing under it
    if (!value.IsMap()) {
      throw InputError(file, LineOf(value), fmt::format("{}: expected a map of keys", top));
    }
    for (const auto& field : value) {
      const std::string name = field.first.Scalar();
      const std::string full = top + "." + name;
      Key* key = find(top, name);
      if (key == nullptr) {
        throw InputError(file, LineOf(field.first),
                         fmt::format("unknown key \"{}\"{}", full, hint));
      }
      ParseValue(file, field.second, full, key->value);
      lines[full] = LineOf(field.second);
    }
  }
  try {
    config->Check();
  } catch (const InputError& e) {
    // Messages are "<key>: <what>"; point at the key's line when the file set it.
    const std::string& message = e.message();
    const size_t colon = message.find(": ");
    std::int64_t line = 0;
    if (colon != std::string::npos) {
      const std::string key = message.substr(0, colon);
      auto it = lines.find(key);
      if (it == lines.end() && key.rfind("sessions", 0) == 0) it = lines.find("sessions");
      if (it != lines.end()) line = it->second;
    }
    throw InputError(file, line, message);
  }
}

void LoadSimConfigFile(const std::string& path, SimConfig* config) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the configuration file");
  std::ostringstream text;
  text << in.rdbuf();
  ApplySimConfigYaml(path, text.str(), config);
}

}  // namespace crop4d::sim
