#pragma once

// ROS 1 bag files (format 2.0) through Debian's rosbag storage library (librosbag-storage-dev),
// behind an interface without ROS types. The ROS 1 message headers of Debian 12 do not compile
// as C++20 (they use std::allocator<void>::rebind), so ros_bag.cc alone is built as C++17 and
// everything the rest of crop4d sees is plain structs with the fields of the sensor_msgs
// messages that crop4d reads.
//
//   BagReader bag("drive.bag");                      // throws InputError when unreadable
//   for (const BagTopic& t : bag.topics()) ...       // topic, type, message count
//   bag.Read({"/imu/data"}, [](const BagMessage& m) {
//     if (const auto* imu = std::get_if<RosImu>(&m.payload)) ...
//     return true;                                   // false stops the iteration
//   });
//
// Messages are decoded one at a time in the bag's order (record time), so images are never all
// in memory. Every failure of the library (a truncated or corrupt file, a chunk that does not
// decompress, a message that does not deserialise) becomes an InputError naming the bag.
//
// BagWriter writes such messages (the tests make their bags with it; plain, bz2 or lz4 chunks).

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <variant>
#include <vector>

namespace crop4d::io {

// ROS time as nanoseconds since the Unix epoch (ros::Time is sec + nsec, both uint32).
using BagTime = std::int64_t;

// The message types crop4d reads (their ROS names in the comments).
inline constexpr const char* kRosImageType = "sensor_msgs/Image";
inline constexpr const char* kRosCompressedImageType = "sensor_msgs/CompressedImage";
inline constexpr const char* kRosImuType = "sensor_msgs/Imu";
inline constexpr const char* kRosNavSatFixType = "sensor_msgs/NavSatFix";
inline constexpr const char* kRosMagneticFieldType = "sensor_msgs/MagneticField";
inline constexpr const char* kRosCameraInfoType = "sensor_msgs/CameraInfo";

// sensor_msgs/Image.
struct RosImage {
  BagTime stamp = 0;  // header.stamp
  std::string frame_id;
  std::uint32_t height = 0, width = 0;
  std::string encoding;  // "mono8", "rgb8", "bayer_rggb8", ...
  std::uint8_t is_bigendian = 0;
  std::uint32_t step = 0;  // bytes per row
  std::vector<std::uint8_t> data;
};

// sensor_msgs/CompressedImage: `format` is "jpeg", "png" or image_transport's
// "<encoding>; jpeg compressed <encoding>".
struct RosCompressedImage {
  BagTime stamp = 0;
  std::string frame_id;
  std::string format;
  std::vector<std::uint8_t> data;
};

// sensor_msgs/Imu. A covariance whose element 0 is -1 means "this field is not given".
struct RosImu {
  BagTime stamp = 0;
  std::string frame_id;
  std::array<double, 4> orientation_xyzw = {0, 0, 0, 1};
  std::array<double, 9> orientation_covariance = {};
  std::array<double, 3> angular_velocity = {};  // rad/s
  std::array<double, 9> angular_velocity_covariance = {};
  std::array<double, 3> linear_acceleration = {};  // m/s², specific force
  std::array<double, 9> linear_acceleration_covariance = {};
};

// sensor_msgs/NavSatFix (with its NavSatStatus).
struct RosNavSatFix {
  // NavSatStatus.status values.
  static constexpr std::int8_t kStatusNoFix = -1, kStatusFix = 0, kStatusSbasFix = 1,
                               kStatusGbasFix = 2;
  // position_covariance_type values.
  static constexpr std::uint8_t kCovarianceUnknown = 0, kCovarianceApproximated = 1,
                                kCovarianceDiagonalKnown = 2, kCovarianceKnown = 3;
  BagTime stamp = 0;
  std::string frame_id;
  std::int8_t status = kStatusNoFix;
  std::uint16_t service = 0;
  double latitude = 0, longitude = 0, altitude = 0;  // degrees, degrees, m (WGS84 ellipsoid)
  std::array<double, 9> position_covariance = {};    // ENU, m², row-major
  std::uint8_t position_covariance_type = kCovarianceUnknown;
};

// sensor_msgs/MagneticField.
struct RosMagneticField {
  BagTime stamp = 0;
  std::string frame_id;
  std::array<double, 3> magnetic_field = {};  // tesla
  std::array<double, 9> magnetic_field_covariance = {};
};

// sensor_msgs/CameraInfo (binning and ROI are read but crop4d only accepts the full image).
struct RosCameraInfo {
  BagTime stamp = 0;
  std::string frame_id;
  std::uint32_t height = 0, width = 0;
  std::string distortion_model;  // "plumb_bob", "rational_polynomial", "equidistant", ...
  std::vector<double> D;
  std::array<double, 9> K = {};
  std::array<double, 9> R = {};
  std::array<double, 12> P = {};
  std::uint32_t binning_x = 0, binning_y = 0;
  std::uint32_t roi_x_offset = 0, roi_y_offset = 0, roi_height = 0, roi_width = 0;
};

using RosMessage = std::variant<RosImage, RosCompressedImage, RosImu, RosNavSatFix,
                                RosMagneticField, RosCameraInfo>;

// Whether `datatype` ("sensor_msgs/Imu") is one of the types above.
bool IsReadableRosType(const std::string& datatype);

// A topic of a bag: its name, message type and number of messages.
struct BagTopic {
  std::string topic;
  std::string datatype;
  std::int64_t messages = 0;
};

// "the bag's topics: /a (sensor_msgs/Imu, 200 messages), /b (...)", or "the bag has no topics":
// what error messages about topics end with, so that the user sees what --topic can name.
std::string DescribeTopics(const std::vector<BagTopic>& topics);

struct BagMessage {
  std::string topic;
  std::string datatype;
  BagTime receive_time = 0;  // the time the recorder wrote the message (bag record time)
  RosMessage payload;
};

class BagReader {
 public:
  // Opens the bag and reads its index. Throws InputError(path, 0, ...) when the file is missing,
  // not a bag, cut short (the index is at the end of a bag) or corrupt.
  explicit BagReader(const std::string& path);
  ~BagReader();
  BagReader(const BagReader&) = delete;
  BagReader& operator=(const BagReader&) = delete;

  const std::string& path() const { return path_; }
  // Every topic of the bag, sorted by name (a topic recorded over several connections once).
  const std::vector<BagTopic>& topics() const { return topics_; }
  // The topic called `name`, or nullptr.
  const BagTopic* FindTopic(const std::string& name) const;

  // Calls `visit` for each message on `topics`, in record-time order, until it returns false.
  // Every topic must have one of the readable types (IsReadableRosType). Throws InputError on a
  // message that cannot be read (corrupt chunk, truncated record, a message definition that
  // differs from sensor_msgs' (md5 sum)); an InputError thrown by `visit` passes through.
  void Read(const std::vector<std::string>& topics,
            const std::function<bool(const BagMessage&)>& visit) const;

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
  std::vector<BagTopic> topics_;
};

enum class BagCompression { kNone, kBz2, kLz4 };

class BagWriter {
 public:
  // Creates (truncates) the bag at `path`; chunks are compressed as asked.
  BagWriter(const std::string& path, BagCompression compression);
  ~BagWriter();  // closes the bag (writes its index)
  BagWriter(const BagWriter&) = delete;
  BagWriter& operator=(const BagWriter&) = delete;

  // Writes `message` on `topic` with record time `receive_time` (>= 0).
  void Write(const std::string& topic, BagTime receive_time, const RosMessage& message);
  // A std_msgs/String: a type crop4d does not read (for tests of that error).
  void WriteString(const std::string& topic, BagTime receive_time, const std::string& text);
  // Writes the index and closes the file; further writes are errors.
  void Close();

 private:
  struct Impl;
  std::string path_;
  std::unique_ptr<Impl> impl_;
};

}  // namespace crop4d::io
