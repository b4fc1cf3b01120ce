#pragma once

// Test support (library crop4d_rosbag_test_writer, built with the tests only): writes a session
// folder of our dataset format (docs/format.md; a sample or simulated session) into a ROS 1 bag,
// as a robot's recorder would, so that tests can import it back with `crop4d import --bag`
// (bag_import.h) and compare: the importer's round trip (bag_import_test.cc) and `crop4d run` on
// an imported session against the original (pipeline/bag_run_test.cc).
//
// Every sensor folder of the session is written, on these topics:
//
//   cam<N> -> /cam<N>/image_raw            sensor_msgs/Image (mono8, bgr8 or mono16, as decoded)
//             /cam<N>/image_raw/compressed sensor_msgs/CompressedImage (the file's bytes)
//   imu<N> -> /imu<N>/data                 sensor_msgs/Imu
//   gps<N> -> /gps<N>/fix                  sensor_msgs/NavSatFix (fix -> status, sigmas ->
//                                          diagonal covariance)
//   mag<N> -> /mag<N>/mag                  sensor_msgs/MagneticField (µT -> T)
//
// Header stamps are the samples' times; record times are later by a fixed receive delay.
//
//   SessionBagOptions options;
//   options.compression = BagCompression::kLz4;
//   BagImportOptions import;
//   import.topics = WriteSessionBag(session_folder, "session.bag", options);
//   UseSessionCalibration(session_folder, &import);   // as --sensor-yaml would give it
//
// What does not come back exactly (the bag's messages cannot say it): a GPS fix 5 (RTK float)
// comes back as 4 (NavSatFix has one GBAS_FIX status for both), and magnetometer values are
// rounded to 1e-9 µT by the importer (tesla -> microtesla).

#include <cstdint>
#include <map>
#include <opencv2/core.hpp>
#include <string>

#include "crop4d/core/timestamp.h"
#include "crop4d/io/rosbag/bag_import.h"
#include "crop4d/io/rosbag/ros_bag.h"

namespace crop4d::io::testing {

// How camera images go into the bag.
enum class ImageMode {
  kRaw,         // sensor_msgs/Image on /<cam>/image_raw: the decoded pixels
  kCompressed,  // sensor_msgs/CompressedImage on /<cam>/image_raw/compressed: the file's bytes
};

struct SessionBagOptions {
  BagCompression compression = BagCompression::kNone;
  ImageMode images = ImageMode::kRaw;
  BagTime receive_delay_ns = 2000000;  // record time = header stamp + this
};

// A sensor_msgs/Image of `image` stamped `t`: the rows copied into a buffer of `step` = row
// bytes + `padding` (padding bytes 0xAB), little-endian.
RosImage ImageMessage(const cv::Mat& image, Timestamp t, const std::string& encoding,
                      std::uint32_t padding = 0, const std::string& frame_id = "cam0");

// The topic that WriteSessionBag writes the sensor folder `sensor` ("cam0", "gps1") on.
std::string SessionBagTopic(const std::string& sensor, ImageMode images = ImageMode::kRaw);

// Writes every sensor of the session folder into a new bag at `bag_path` (see above) and
// returns sensor folder -> topic, for BagImportOptions::topics. Throws std::runtime_error for
// an image it cannot read or encode.
std::map<std::string, std::string> WriteSessionBag(const std::string& session_folder,
                                                   const std::string& bag_path,
                                                   const SessionBagOptions& options);

// Gives `options` the calibration of every sensor of the session folder, as --sensor-yaml would
// (the structs and, in sensor_yaml_files, the sensor.yaml files to copy as they are).
void UseSessionCalibration(const std::string& session_folder, BagImportOptions* options);

}  // namespace crop4d::io::testing
