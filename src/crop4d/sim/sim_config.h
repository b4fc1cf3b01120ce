#pragma once

// The configuration of a simulation (`crop4d simulate`): the field, the sessions, the camera,
// the drive, the sensors and the ground truth, with three presets (tiny, demo, paper). It is
// printed as commented YAML (--print-config) and read back from such a file (--config): the
// keys of a file override the preset's values one by one, so print → edit → load round-trips.
// docs/simulator.md lists every key.

#include <cstdint>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/sim/imperfections.h"
#include "crop4d/sim/sensor_models.h"
#include "crop4d/sim/trajectory.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

// One recording session.
struct SessionSpec {
  // Date of the session, "YYYY-MM-DD" (also its folder name).
  std::string date;
  // It rained since the previous session: the soil looks different (new fine texture).
  bool rain_before = false;
};

// The camera and where it sits on the vehicle.
struct CameraRigOptions {
  // Image size, pixels.
  int width = 1280;
  int height = 960;
  // Pinhole intrinsics, pixels.
  double fx = 560.0, fy = 560.0, cx = 643.2, cy = 476.8;
  // Radial-tangential distortion (OpenCV k1 k2 p1 p2 k3), applied by the renderer.
  double k1 = -0.12, k2 = 0.02, p1 = 4.0e-4, p2 = -3.0e-4, k3 = 0.0;
  // Frame rate, Hz.
  double rate_hz = 7.5;
  // Height of the optical centre above the ground, m.
  double height_m = 1.5;
  // Downward tilt of the optical axis below the horizontal, degrees.
  double pitch_deg = 35.0;
  // Position of the optical centre ahead of / left of the IMU, m.
  double forward_m = 0.6;
  double lateral_m = 0.05;
  // Multisample anti-aliasing samples of the renderer (1, 2, 4 or 8).
  int msaa_samples = 4;
  // When the camera records: "continuous" (the whole drive, headland turns included) or
  // "passes" (only along the row passes, their straight lead beyond the row ends included: a
  // rig whose camera is triggered over the plots). The IMU, magnetometer and GPS record the
  // whole drive either way.
  std::string trigger = "continuous";

  geometry::PinholeRadTan Intrinsics() const;
  // body_from_camera for a body origin `body_height_m` above the ground: optical axis along
  // body x tilted down by pitch_deg, image x to the body's right (OpenCV camera frame).
  geometry::Rigid3 BodyFromCamera(double body_height_m) const;
};

// When and under what light the sessions are recorded.
struct RecordingOptions {
  // Start of each session, hours after midnight UTC.
  double start_utc_h = 14.0;
  // Each session starts up to this many hours later (seeded), for varied sun positions.
  double start_jitter_h = 2.0;
  // Exposure varies by up to ± this fraction between sessions (seeded).
  double brightness_jitter = 0.1;
  // Leaves sway in the wind between frames: a session's sway amplitude is this × a seeded
  // factor in [0.3, 1], m (0 = still air).
  double wind_sway_m = 0.0;
  // Period of the gusts, s.
  double wind_period_s = 2.0;
};

struct GroundTruthOptions {
  // Measurement sites per row, spread evenly along it (written to field.yaml).
  int sites_per_row = 3;
  // Radius of each site, m.
  double site_radius_m = 0.4;
  // Std-dev of a person's ruler reading in site_measurements.csv, m.
  double measurement_noise_m = 0.01;
  // Spacing of the terrain grid in ground_truth/terrain.csv, m.
  double terrain_grid_m = 0.25;
  // Also write a depth map per image (16-bit PNG, millimetres; --depth).
  bool depth = false;
};

struct SimConfig {
  // Master seed: every random choice derives from it.
  std::uint64_t seed = 1;
  // Field name and the WGS84 origin of its ENU frame.
  std::string name = "demo";
  geometry::GeodeticPoint origin{31.47, -83.53, 100.0};
  // Layout, terrain and growth of the field. world.seed and world.sowing_date are derived
  // (from seed and sowing_date) by MakeWorldOptions().
  WorldOptions world;
  // Sowing date "YYYY-MM-DD".
  std::string sowing_date = "2016-05-10";
  std::vector<SessionSpec> sessions;
  RecordingOptions recording;
  CameraRigOptions camera;
  TrajectoryOptions drive;
  ImuOptions imu;
  MagOptions mag;
  GpsOptions gps0, gps1;
  GroundTruthOptions ground_truth;
  // The imperfections of real rigs (imperfections.h), all off in the ideal world: the errors
  // of the calibration written to the dataset, and the camera's sensor effects (keys under
  // "camera."). IMU and GPS imperfections are in imu and gps0/gps1, standstills in drive.
  // `realism` names the level they were last set to as a whole (ApplyRealism).
  std::string realism = "ideal";
  CalibrationErrorOptions calibration_error;
  ImageEffectsOptions image;
  // How the soil changes between sessions without rain (textures.h).
  SoilChangeOptions soil_change;

  // Throws InputError "<key>: <what is wrong>" for the first bad value.
  void Check() const;
  // The session dates as midnight UTC (valid after Check()).
  std::vector<Timestamp> SessionDates() const;
  WorldOptions MakeWorldOptions() const;
};

// "tiny" (unit tests: 2 rows × 8 m, 2 sessions, 320×240), "demo" (`make demo`: 4 rows ×
// 20 m, 4 sessions over 6 weeks, 640×480, rain before the third) and "paper" (the scale of
// Dong et al. 2017: 21 rows × 150 m, 23 sessions over 89 days, 1280×960). Throws InputError for
// another name.
SimConfig PresetConfig(const std::string& preset);
std::vector<std::string> PresetNames();

// Sets every imperfection to the magnitudes of `level`: "ideal" (all off, the default of every
// preset) or "real" (realistic values for a rig like the paper's: see docs/simulator.md;
// pixel magnitudes scale with camera.width / 1280). Throws InputError for another level.
void ApplyRealism(const std::string& level, SimConfig* config);
std::vector<std::string> RealismLevels();

// The configuration as YAML with a comment on every key; `preset` is named in the header.
std::string SimConfigToYaml(const SimConfig& config, const std::string& preset = "");

// Applies the keys of YAML `text` over `config` and checks the result. `file` names the text
// in messages; every error is an InputError with file and line ("unknown key", a value of the
// wrong type, a bad value from Check()).
void ApplySimConfigYaml(const std::string& file, const std::string& text, SimConfig* config);
// Reads `path` and applies it (InputError when it cannot be read).
void LoadSimConfigFile(const std::string& path, SimConfig* config);

}  // namespace crop4d::sim
