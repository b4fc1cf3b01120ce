#pragma once

// The sensor streams of one session as the row SLAM back end uses them (DESIGN.md §2.1): the
// image list of the camera, the IMU samples rotated into the body frame, and every GPS receiver's
// fixes converted to the field's local ENU world frame (GeographicLib, geometry/enu.h).

#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/slam/imu_preintegration.h"

namespace crop4d::slam {

// One GPS fix in the world frame.
struct GpsFixWorld {
  Timestamp t = 0;
  // Antenna position, ENU, m.
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  // 1-sigma horizontal / vertical, m (the receiver's defaults when the sample had none).
  double sigma_h = 0.02;
  double sigma_v = 0.04;
  io::GpsFix fix = io::GpsFix::kNone;
};

struct GpsStream {
  io::GpsSensor sensor;
  // Fixes with a position (fix quality other than kNone), in time order.
  std::vector<GpsFixWorld> fixes;
};

struct ImuStream {
  io::ImuSensor sensor;
  // Samples rotated into the body frame (B = IMU frame; T_BS is usually the identity).
  std::vector<ImuSample> samples;
};

struct CameraStream {
  io::CameraSensor sensor;
  std::vector<io::ImageEntry> images;
};

struct SessionStreams {
  std::string session_id;
  std::optional<CameraStream> camera;
  std::optional<ImuStream> imu;
  std::vector<GpsStream> gps;

  // The first receiver of the given kind, or nullptr.
  const GpsStream* FindGps(io::GpsKind kind) const;
  // The receiver with the smallest median horizontal sigma (the best track for segmenting the
  // session into row passes), or nullptr when there is no fix at all.
  const GpsStream* BestGps() const;
};

// Reads the session's streams: the named camera and IMU (the first of each when the name is
// empty; absent sensors are left empty with a logged warning) and every GPS receiver. Bad data
// lines are skipped with warnings by the reader (io/dataset_reader.h).
SessionStreams LoadSessionStreams(const io::Field& field, const io::Session& session,
                                  const std::string& camera_name = "",
                                  const std::string& imu_name = "");

}  // namespace crop4d::slam
