#pragma once

// A small, valid field folder written with the dataset writers: a few seconds of every sensor
// and tiny PNG images. Tests break one thing in it at a time; docs/format.md shows its files.

#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"

namespace crop4d::io {

struct SampleFieldOptions {
  // Session folder names; each is the session's date.
  std::vector<std::string> sessions = {"2016-05-25"};
  // Seconds of data per session.
  double duration_s = 2.0;
  // Size of the generated images (pixels).
  int image_width = 32;
  int image_height = 24;
  // Sensor rates (Hz), written into sensor.yaml and used for the timestamps.
  double camera_rate_hz = 7.5;
  double imu_rate_hz = 167.0;
  double mag_rate_hz = 110.0;
  double gps_rate_hz = 5.0;
  // Write mag0/ (magnetometer).
  bool with_mag = true;
  // Seconds after midnight UTC of the session date at which recording starts.
  double start_of_day_s = 14.0 * 3600.0;
};

// Writes the field into `folder` (created if needed). Throws InputError on I/O failure.
void WriteSampleField(const std::string& folder,
                      const SampleFieldOptions& options = SampleFieldOptions());

}  // namespace crop4d::io
