#include "crop4d/slam/sensor_set.h"

namespace crop4d::slam {
namespace {

constexpr SensorSet kAll[] = {SensorSet::kCamImuRtk, SensorSet::kCamImuGps, SensorSet::kCamImu,
                              SensorSet::kImuRtk,    SensorSet::kCamRtk,    SensorSet::kCamGps};

}  // namespace

SensorSetInfo Describe(SensorSet set) {
  SensorSetInfo info;
  switch (set) {
    case SensorSet::kCamImuRtk:
      info.camera = true;
      info.gps = true;
      info.gps_kind = io::GpsKind::kRtk;
      break;
    case SensorSet::kCamImuGps:
      info.camera = true;
      info.gps = true;
      info.gps_kind = io::GpsKind::kStandard;
      break;
    case SensorSet::kCamImu:
      info.camera = true;
      break;
    case SensorSet::kImuRtk:
      info.gps = true;
      info.gps_kind = io::GpsKind::kRtk;
      break;
    case SensorSet::kCamRtk:
      info.camera = true;
      info.imu = false;
      info.gps = true;
      info.gps_kind = io::GpsKind::kRtk;
      break;
    case SensorSet::kCamGps:
      info.camera = true;
      info.imu = false;
      info.gps = true;
      info.gps_kind = io::GpsKind::kStandard;
      break;
  }
  return info;
}

const char* ToString(SensorSet set) {
  switch (set) {
    case SensorSet::kCamImuRtk:
      return "cam+imu+rtk";
    case SensorSet::kCamImuGps:
      return "cam+imu+gps";
    case SensorSet::kCamImu:
      return "cam+imu";
    case SensorSet::kImuRtk:
      return "imu+rtk";
    case SensorSet::kCamRtk:
      return "cam+rtk";
    case SensorSet::kCamGps:
      return "cam+gps";
  }
  return "?";
}

std::optional<SensorSet> ParseSensorSet(const std::string& text) {
  for (SensorSet set : kAll) {
    if (text == ToString(set)) return set;
  }
  return std::nullopt;
}

std::vector<std::string> SensorSetNames() {
  std::vector<std::string> names;
  for (SensorSet set : kAll) names.emplace_back(ToString(set));
  return names;
}

}  // namespace crop4d::slam
