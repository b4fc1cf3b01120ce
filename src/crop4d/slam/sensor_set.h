#pragma once

// The sensor sets of row SLAM (`crop4d slam --sensors`), so that each sensor's contribution can
// be measured: cam+imu+rtk, cam+imu+gps (the low-accuracy receiver), cam+imu, imu+rtk, and for
// rigs without an IMU cam+rtk and cam+gps (the Gaussian-process prior alone carries the motion
// between images, as in the paper's factor graph).

#include <optional>
#include <string>
#include <vector>

#include "crop4d/io/dataset.h"

namespace crop4d::slam {

enum class SensorSet { kCamImuRtk, kCamImuGps, kCamImu, kImuRtk, kCamRtk, kCamGps };

struct SensorSetInfo {
  bool camera = false;
  bool imu = true;
  // Whether GPS factors are used, and from which kind of receiver.
  bool gps = false;
  io::GpsKind gps_kind = io::GpsKind::kRtk;
};

SensorSetInfo Describe(SensorSet set);
// "cam+imu+rtk", ...
const char* ToString(SensorSet set);
// Parses a set name (as ToString writes it); nullopt for anything else.
std::optional<SensorSet> ParseSensorSet(const std::string& text);
std::vector<std::string> SensorSetNames();

}  // namespace crop4d::slam
