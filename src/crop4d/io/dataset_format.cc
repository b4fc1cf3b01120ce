#include "crop4d/io/dataset_format.h"

#include <cctype>

namespace crop4d::io {

const char* SensorKindName(SensorKind kind) {
  switch (kind) {
    case SensorKind::kCamera:
      return "camera";
    case SensorKind::kImu:
      return "imu";
    case SensorKind::kMag:
      return "magnetometer";
    case SensorKind::kGps:
      return "gps";
  }
  return "?";
}

const char* SensorFolderPrefix(SensorKind kind) {
  switch (kind) {
    case SensorKind::kCamera:
      return "cam";
    case SensorKind::kImu:
      return "imu";
    case SensorKind::kMag:
      return "mag";
    case SensorKind::kGps:
      return "gps";
  }
  return "?";
}

std::optional<SensorKind> SensorKindFromFolder(std::string_view folder) {
  for (SensorKind kind :
       {SensorKind::kCamera, SensorKind::kImu, SensorKind::kMag, SensorKind::kGps}) {
    const std::string_view prefix = SensorFolderPrefix(kind);
    if (folder.size() <= prefix.size() || folder.substr(0, prefix.size()) != prefix) continue;
    bool digits = true;
    for (char c : folder.substr(prefix.size())) {
      digits = digits && std::isdigit(static_cast<unsigned char>(c));
    }
    if (digits) return kind;
  }
  return std::nullopt;
}

std::optional<SensorKind> SensorKindFromType(std::string_view sensor_type) {
  if (sensor_type == "camera") return SensorKind::kCamera;
  if (sensor_type == "imu") return SensorKind::kImu;
  if (sensor_type == "magnetometer" || sensor_type == "mag") return SensorKind::kMag;
  if (sensor_type == "gps" || sensor_type == "gnss") return SensorKind::kGps;
  return std::nullopt;
}

const char* GpsKindName(GpsKind kind) { return kind == GpsKind::kRtk ? "rtk" : "standard"; }

std::optional<GpsKind> ParseGpsKind(std::string_view text) {
  if (text == "rtk") return GpsKind::kRtk;
  if (text == "standard") return GpsKind::kStandard;
  return std::nullopt;
}

const char* GpsFixName(int code) {
  switch (code) {
    case 0:
      return "none";
    case 1:
      return "single";
    case 2:
      return "dgps";
    case 3:
      return "pps";
    case 4:
      return "rtk-fixed";
    case 5:
      return "rtk-float";
    case 6:
      return "dead-reckoning";
    case 7:
      return "manual";
    case 8:
      return "simulation";
    default:
      return "unknown";
  }
}

bool IsGpsFixUsed(int code) {
  return code == 0 || code == 1 || code == 2 || code == 4 || code == 5;
}

}  // namespace crop4d::io
