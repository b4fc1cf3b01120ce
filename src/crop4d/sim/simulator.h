#pragma once

// The synthetic recording: drives the rig over the World once per session, simulates every
// sensor with its own clock, renders the camera images and writes a field folder in the
// dataset format (DESIGN.md §4) plus its ground truth (docs/simulator.md lists every file).
//
//   SimConfig config = PresetConfig("tiny");
//   Simulator simulator(config);
//   Simulator::Summary summary = simulator.Write("/tmp/field");

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/dataset.h"
#include "crop4d/sim/imperfections.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/trajectory.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

// Everything of one session except the images.
struct SessionRecord {
  int index = 0;
  io::SessionInfo info;          // id (= date), date, notes, rain_before
  SessionConditions conditions;  // light and soil for the renderer
  Timestamp start = 0;           // the trajectory's t = 0
  std::shared_ptr<const Trajectory> trajectory;

  // Image timestamps as written (on the camera's clock, calibration_error applied) and the
  // true capture times (mid-exposure, the trajectory's clock) they stand for.
  std::vector<Timestamp> image_times;
  std::vector<Timestamp> image_capture_times;
  std::vector<io::ImuSample> imu;
  std::vector<Eigen::Vector3d> gyro_bias, accel_bias;  // true biases at each IMU sample
  std::vector<io::MagSample> mag;
  // gps[0] = gps0 (RTK), gps[1] = gps1 (standard).
  std::array<std::vector<io::GpsSample>, 2> gps;
  std::array<std::vector<Eigen::Vector3d>, 2> gps_true_enu;      // true antenna position
  std::array<std::vector<Eigen::Vector3d>, 2> gps_measured_enu;  // what was converted to lat/lon
  std::array<std::vector<Eigen::Vector3d>, 2> gps_bias;          // true bias (ENU)
  std::array<std::vector<GpsFault>, 2> gps_faults;               // outlier / float of each sample

  // Seconds since `start`.
  double Seconds(Timestamp t) const { return DurationSeconds(start, t); }
};

class Simulator {
 public:
  struct Summary {
    int sessions = 0;
    std::int64_t images = 0;
    std::int64_t imu_samples = 0;
    std::int64_t mag_samples = 0;
    std::int64_t gps_samples = 0;
    double setup_seconds = 0.0;   // renderer start-up and Renderer::SetSession per session
    double render_seconds = 0.0;  // time spent in Renderer::Render
    double images_seconds = 0.0;  // rendering, encoding and writing the images
    double total_seconds = 0.0;   // the whole Write()
    // Images rendered, encoded and written per second (the image pipeline's throughput).
    double FramesPerSecond() const { return images_seconds > 0 ? images / images_seconds : 0.0; }
  };

  // Checks the configuration (InputError) and builds the World.
  explicit Simulator(const SimConfig& config);

  const SimConfig& config() const { return config_; }
  const World& world() const { return *world_; }

  // Session i's conditions, trajectory and every non-camera measurement, with the truth.
  SessionRecord SimulateSession(int i) const;
  // When session i starts (its trajectory's t = 0): the date + recording.start_utc_h + jitter.
  Timestamp SessionStart(int i) const;
  // Light and soil of session i.
  SessionConditions ConditionsOf(int i) const;
  // The camera's mounting: body_from_camera (OpenCV camera frame).
  geometry::Rigid3 BodyFromCamera() const;
  // The errors of the calibration written to the dataset (all zero in the ideal world).
  const CalibrationErrors& calibration_errors() const { return calibration_errors_; }
  // The IMU's scale factors and axis misalignment (identity in the ideal world).
  const ImuAxisErrors& imu_axis_errors() const { return imu_axis_errors_; }
  // field.yaml's content: origin, rows, sites, sessions.
  io::FieldInfo MakeFieldInfo() const;

  // Writes the field folder `out_dir` (created if missing; must not hold a field already,
  // see PrepareOutputFolder). field.yaml is written last, so a folder without it is
  // incomplete.
  Summary Write(const std::string& out_dir);

 private:
  SimConfig config_;
  std::unique_ptr<World> world_;
  CalibrationErrors calibration_errors_;
  ImuAxisErrors imu_axis_errors_;
};

// Makes `out_dir` ready for a simulation: creates it when missing; an empty folder is fine.
// A non-empty folder is refused (InputError) unless `force`, which deletes field.yaml,
// sessions/ and ground_truth/ in it (and nothing else) when the folder looks like a field
// (it has field.yaml or sessions/), and refuses otherwise.
void PrepareOutputFolder(const std::string& out_dir, bool force);

// Direction of the sun (NOAA Global Monitoring Laboratory, "General Solar Position
// Calculations"; fractional-year approximation, ~0.5° accurate): elevation above the horizon
// and azimuth clockwise from north, radians.
void SunPosition(Timestamp t, double lat_deg, double lon_deg, double* elevation_rad,
                 double* azimuth_rad);

}  // namespace crop4d::sim
