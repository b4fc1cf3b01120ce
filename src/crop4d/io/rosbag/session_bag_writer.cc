#include "crop4d/io/rosbag/session_bag_writer.h"

#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"

namespace crop4d::io::testing {
namespace {

namespace fs = std::filesystem;

std::vector<std::uint8_t> ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw std::runtime_error("cannot read " + path);
  return std::vector<std::uint8_t>(std::istreambuf_iterator<char>(in),
                                   std::istreambuf_iterator<char>());
}

// The ROS encoding of a decoded image file (OpenCV's BGR channel order).
std::string EncodingOf(const cv::Mat& image, const std::string& path) {
  switch (image.type()) {
    case CV_8UC1:
      return "mono8";
    case CV_8UC3:
      return "bgr8";
    case CV_16UC1:
      return "mono16";
    default:
      throw std::runtime_error(path + ": no sensor_msgs/Image encoding for this pixel type");
  }
}

// NMEA fix -> NavSatStatus. ROS drivers report RTK fixed and float alike as GBAS_FIX.
std::int8_t StatusOf(GpsFix fix) {
  switch (fix) {
    case GpsFix::kNone:
      return RosNavSatFix::kStatusNoFix;
    case GpsFix::kSingle:
      return RosNavSatFix::kStatusFix;
    case GpsFix::kDgps:
      return RosNavSatFix::kStatusSbasFix;
    case GpsFix::kRtkFixed:
    case GpsFix::kRtkFloat:
      return RosNavSatFix::kStatusGbasFix;
  }
  return RosNavSatFix::kStatusNoFix;
}

}  // namespace

RosImage ImageMessage(const cv::Mat& image, Timestamp t, const std::string& encoding,
                      std::uint32_t padding, const std::string& frame_id) {
  RosImage m;
  m.stamp = t;
  m.frame_id = frame_id;
  m.width = static_cast<std::uint32_t>(image.cols);
  m.height = static_cast<std::uint32_t>(image.rows);
  m.encoding = encoding;
  const std::uint32_t row = static_cast<std::uint32_t>(image.cols * image.elemSize());
  m.step = row + padding;
  m.data.assign(static_cast<std::size_t>(m.step) * m.height, 0xAB);
  for (int r = 0; r < image.rows; ++r) {
    std::memcpy(m.data.data() + static_cast<std::size_t>(r) * m.step, image.ptr(r), row);
  }
  return m;
}

std::string SessionBagTopic(const std::string& sensor, ImageMode images) {
  const std::optional<SensorKind> kind = SensorKindFromFolder(sensor);
  if (!kind) throw std::runtime_error("'" + sensor + "' is not a sensor folder name");
  switch (*kind) {
    case SensorKind::kCamera:
      return "/" + sensor + (images == ImageMode::kRaw ? "/image_raw" : "/image_raw/compressed");
    case SensorKind::kImu:
      return "/" + sensor + "/data";
    case SensorKind::kGps:
      return "/" + sensor + "/fix";
    case SensorKind::kMag:
      return "/" + sensor + "/mag";
  }
  return "";
}

std::map<std::string, std::string> WriteSessionBag(const std::string& session_folder,
                                                   const std::string& bag_path,
                                                   const SessionBagOptions& options) {
  const Session session(session_folder);
  BagWriter bag(bag_path, options.compression);
  const BagTime delay = options.receive_delay_ns;
  std::map<std::string, std::string> topics;
  for (const CameraSensor& camera : session.cameras()) {
    const std::string topic = SessionBagTopic(camera.name, options.images);
    topics[camera.name] = topic;
    for (const ImageEntry& e : session.ReadImageList(camera.name)) {
      const std::string path = session.ImagePath(camera.name, e.filename);
      if (options.images == ImageMode::kRaw) {
        const cv::Mat image = cv::imread(path, cv::IMREAD_UNCHANGED);
        if (image.empty()) throw std::runtime_error("cannot decode " + path);
        bag.Write(topic, e.t + delay,
                  ImageMessage(image, e.t, EncodingOf(image, path), 0, camera.name));
      } else {
        RosCompressedImage m;
        m.stamp = e.t;
        m.frame_id = camera.name;
        m.format = fs::path(path).extension() == ".png" ? "png" : "jpeg";
        m.data = ReadBytes(path);
        bag.Write(topic, e.t + delay, m);
      }
    }
  }
  for (const ImuSensor& imu : session.imus()) {
    const std::string topic = SessionBagTopic(imu.name);
    topics[imu.name] = topic;
    for (const ImuSample& s : session.ReadImu(imu.name)) {
      RosImu m;
      m.stamp = s.t;
      m.frame_id = imu.name;
      m.angular_velocity = {s.gyro.x(), s.gyro.y(), s.gyro.z()};
      m.linear_acceleration = {s.accel.x(), s.accel.y(), s.accel.z()};
      bag.Write(topic, s.t + delay, m);
    }
  }
  for (const GpsSensor& gps : session.gps_receivers()) {
    const std::string topic = SessionBagTopic(gps.name);
    topics[gps.name] = topic;
    // ReadGps gives samples without sigmas the receiver's defaults: every message has them.
    for (const GpsSample& s : session.ReadGps(gps.name)) {
      RosNavSatFix m;
      m.stamp = s.t;
      m.frame_id = gps.name;
      m.latitude = s.position.lat_deg;
      m.longitude = s.position.lon_deg;
      m.altitude = s.position.alt_m;
      m.status = StatusOf(s.fix);
      // sqrt(sigma * sigma) == sigma in IEEE double: the importer gets the sigmas back exactly.
      m.position_covariance = {s.sigma_h * s.sigma_h, 0, 0, 0, s.sigma_h * s.sigma_h, 0, 0, 0,
                               s.sigma_v * s.sigma_v};
      m.position_covariance_type = RosNavSatFix::kCovarianceDiagonalKnown;
      bag.Write(topic, s.t + delay, m);
    }
  }
  for (const MagSensor& mag : session.mags()) {
    const std::string topic = SessionBagTopic(mag.name);
    topics[mag.name] = topic;
    for (const MagSample& s : session.ReadMag(mag.name)) {
      RosMagneticField m;
      m.stamp = s.t;
      m.frame_id = mag.name;
      m.magnetic_field = {s.field_ut.x() * 1e-6, s.field_ut.y() * 1e-6, s.field_ut.z() * 1e-6};
      bag.Write(topic, s.t + delay, m);
    }
  }
  bag.Close();
  return topics;
}

void UseSessionCalibration(const std::string& session_folder, BagImportOptions* o) {
  const fs::path folder(session_folder);
  for (const SensorFolder& sensor : ListSensorFolders(session_folder)) {
    const std::string yaml = (folder / sensor.name / kSensorYaml).string();
    switch (sensor.kind) {
      case SensorKind::kCamera:
        o->cameras[sensor.name] = ReadCameraSensorYaml(yaml);
        break;
      case SensorKind::kImu:
        o->imus[sensor.name] = ReadImuSensorYaml(yaml);
        break;
      case SensorKind::kGps:
        o->gps[sensor.name] = ReadGpsSensorYaml(yaml);
        break;
      case SensorKind::kMag:
        o->mags[sensor.name] = ReadMagSensorYaml(yaml);
        break;
    }
    o->sensor_yaml_files[sensor.name] = yaml;
  }
}

}  // namespace crop4d::io::testing
