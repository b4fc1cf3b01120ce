#pragma once

// The measurements row SLAM solved a pass with, persisted so that the later stages (associate,
// fuse, densify) never open the field's sensor files again (DESIGN.md §5,
// WS/sessions/<s>/rows/<pass>/measurements.bin). With the priors of the pass's summary.json
// (pass_priors.h) it is the whole problem: the joint 4D optimiser rebuilds the pass's graph from
// the two.
//
//   camera  the calibration (intrinsics, T_BS, rate) and the pass's images: timestamp and file
//           name, in the folder `image_folder` (relative to the field folder, so a field that
//           moves with its workspace still resolves); the pixels stay in the field.
//   imu     the sensor (noise densities as in sensor.yaml, T_BS, rate) and its samples, rotated
//           into the body frame, over the pass's states and a margin either side.
//   gps     the receiver the GPS factors used and its fixes in the world frame over the pass,
//           with the slam stage's GPS outages already applied.
//
// measurements.bin layout (little-endian, io/checksummed_file.h framing):
//   char[8] magic "C4DMEAS\0", u32 version (kPassMeasurementsVersion)
//   u8 parts (bit 0 camera, bit 1 IMU, bit 2 GPS)
//   camera: string name; i32 width, height; f64 fx, fy, cx, cy, k1, k2, p1, p2, k3; f64 rate;
//           pose T_BS; u8 has height, f64 height; string image folder;
//           u64 n; n × { i64 t; i64 data.csv line; string file name }
//   imu:    string name; f64 rate, gyro noise, gyro walk, accel noise, accel walk; pose T_BS;
//           u64 n; n × { i64 t; f64 gyro xyz; f64 accel xyz }
//   gps:    string name; u8 kind; f64 rate; f64 antenna xyz; f64 sigma h, sigma v;
//           u64 n; n × { i64 t; f64 x, y, z; f64 sigma h, sigma v; i32 fix quality }
//   u64 FNV-1a 64 checksum of every byte above
//   (string = u32 length + bytes; pose = f64 qx, qy, qz, qw, tx, ty, tz)
// Reading detects a missing, foreign, old, truncated or corrupt file and throws InputError
// naming the file and saying to rerun `crop4d slam`. Values round-trip bit for bit.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/image_sequence.h"
#include "crop4d/slam/session_streams.h"

namespace crop4d::workspace {

inline constexpr std::uint32_t kPassMeasurementsVersion = 1;

// The IMU samples kept either side of a pass's first and last state: the preintegration
// between two states and the gyro interpolation at a (time-shifted) capture instant need the
// samples that bracket them.
inline constexpr double kPassImuMarginSeconds = 1.0;

struct PassMeasurements {
  // Relative to the field folder ("sessions/<s>/<camera>/data"); empty without a camera.
  std::string image_folder;
  // The images of the pass only, in time order.
  std::optional<slam::CameraStream> camera;
  std::optional<slam::ImuStream> imu;
  std::optional<slam::GpsStream> gps;

  // The path of image i of the camera (field folder joined with image_folder and the name;
  // needs the camera).
  std::string ImagePath(const std::string& field_folder, std::size_t i) const;
  // The camera's images as a sequence to decode (needs the camera).
  io::ImageSequence Images(const std::string& field_folder) const;
};

// The images row SLAM used over every pass of `session` that has a camera (each once, in time
// order) with the camera's calibration: the views densify matches. Throws InputError when no
// pass of the session has a camera or when `camera` (empty: the passes' camera) is not the one
// row SLAM used.
io::ImageSequence SessionImages(const std::string& workspace, const std::string& session,
                                const std::string& field_folder, const std::string& camera);

// The part of the session's streams a pass used: the entries of `camera` at `image_times`, the
// samples of `imu` from `first` − kPassImuMarginSeconds to `last` + kPassImuMarginSeconds (at
// least one sample on each side of the states when the stream has one), and the fixes of `gps`
// (the receiver with the outages applied) from `first` to `last`. A null stream is left out.
// `image_folder` as in PassMeasurements.
PassMeasurements SelectPassMeasurements(const slam::CameraStream* camera,
                                        const slam::ImuStream* imu, const slam::GpsStream* gps,
                                        const std::vector<Timestamp>& image_times, Timestamp first,
                                        Timestamp last, std::string image_folder);

void WritePassMeasurements(const std::string& path, const PassMeasurements& measurements);
PassMeasurements ReadPassMeasurements(const std::string& path);

}  // namespace crop4d::workspace
