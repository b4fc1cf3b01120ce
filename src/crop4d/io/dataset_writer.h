#pragma once

// Writers for the dataset format (docs/format.md). Every file is written atomically. Numbers
// are written with enough digits to round-trip (timestamps as integers, lat/lon with 1e-10 deg).
// Used by the simulator and by `crop4d import`.

#include <string>
#include <vector>

#include "crop4d/io/dataset.h"

namespace crop4d::io {

void WriteFieldYaml(const std::string& path, const FieldInfo& field);
void WriteSessionYaml(const std::string& path, const SessionInfo& session);

// sensor.yaml in the EuRoC/Kalibr key layout (sensor_type, comment, T_BS, rate_hz, ...).
void WriteCameraSensorYaml(const std::string& path, const CameraSensor& sensor);
void WriteImuSensorYaml(const std::string& path, const ImuSensor& sensor);
void WriteMagSensorYaml(const std::string& path, const MagSensor& sensor);
void WriteGpsSensorYaml(const std::string& path, const GpsSensor& sensor);

// data.csv files with their "#timestamp [ns],..." header lines.
void WriteImageCsv(const std::string& path, const std::vector<ImageEntry>& images);
void WriteImuCsv(const std::string& path, const std::vector<ImuSample>& samples);
void WriteMagCsv(const std::string& path, const std::vector<MagSample>& samples);
void WriteGpsCsv(const std::string& path, const std::vector<GpsSample>& samples);

}  // namespace crop4d::io
