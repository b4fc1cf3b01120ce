#include "crop4d/io/rosbag/bag_import.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>
#include <set>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_format.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/image_probe.h"
#include "crop4d/io/importer.h"
#include "crop4d/io/rosbag/ros_bag.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

std::string TopicList(const BagReader& bag) { return DescribeTopics(bag.topics()); }

// The message types that can feed a sensor of `kind`.
std::vector<std::string> TypesFor(SensorKind kind) {
  switch (kind) {
    case SensorKind::kCamera:
      return {kRosImageType, kRosCompressedImageType};
    case SensorKind::kImu:
      return {kRosImuType};
    case SensorKind::kGps:
      return {kRosNavSatFixType};
    case SensorKind::kMag:
      return {kRosMagneticFieldType};
  }
  return {};
}

bool TypeFits(SensorKind kind, const std::string& datatype) {
  const std::vector<std::string> types = TypesFor(kind);
  return std::find(types.begin(), types.end(), datatype) != types.end();
}

std::string JoinTypes(SensorKind kind) {
  std::string out;
  for (const std::string& type : TypesFor(kind)) out += (out.empty() ? "" : " or ") + type;
  return out;
}

// A rate for sensor.yaml: 4 significant digits (the validator compares the mean rate with it).
double RoundRate(double rate_hz) {
  if (!(rate_hz > 0) || !std::isfinite(rate_hz)) return 0.0;
  const double scale = std::pow(10.0, 3 - std::floor(std::log10(rate_hz)));
  return std::round(rate_hz * scale) / scale;
}

double MeanRateHz(std::size_t n, Timestamp first, Timestamp last) {
  if (n < 2 || last <= first) return 0.0;
  return static_cast<double>(n - 1) / DurationSeconds(first, last);
}

// Tesla to microtesla, rounded to 1e-9 µT (1 fT, far below any magnetometer's resolution) so
// that a value written as µT·1e-6 reads back as the same decimal number.
double TeslaToMicrotesla(double tesla) {
  const double ut = tesla * 1e6;
  if (!std::isfinite(ut) || std::abs(ut) > 1e6) return ut;
  return std::round(ut * 1e9) / 1e9;
}

// ---- raw images ----

// A sensor_msgs/Image as an 8- or 16-bit OpenCV image in OpenCV's channel order (BGR). Bayer
// mosaics are demosaiced (bilinear); OpenCV names a Bayer pattern by the second row's first two
// pixels, so ROS's rggb is OpenCV's BG (the mapping cv_bridge uses).
cv::Mat DecodeImage(const RosImage& m, const std::string& where) {
  struct Encoding {
    const char* name;
    int type;
    int bytes_per_pixel;
    int conversion;  // -1: none
  };
  static const Encoding kEncodings[] = {
      {"mono8", CV_8UC1, 1, -1},
      {"mono16", CV_16UC1, 2, -1},
      {"bgr8", CV_8UC3, 3, -1},
      {"rgb8", CV_8UC3, 3, cv::COLOR_RGB2BGR},
      {"bayer_rggb8", CV_8UC1, 1, cv::COLOR_BayerBG2BGR},
      {"bayer_bggr8", CV_8UC1, 1, cv::COLOR_BayerRG2BGR},
      {"bayer_gbrg8", CV_8UC1, 1, cv::COLOR_BayerGR2BGR},
      {"bayer_grbg8", CV_8UC1, 1, cv::COLOR_BayerGB2BGR},
  };
  const Encoding* encoding = nullptr;
  for (const Encoding& e : kEncodings) {
    if (m.encoding == e.name) encoding = &e;
  }
  if (encoding == nullptr) {
    throw InputError(where, 0,
                     "image encoding '" + m.encoding +
                         "' is not supported (mono8, mono16, rgb8, bgr8, bayer_rggb8, "
                         "bayer_bggr8, bayer_gbrg8, bayer_grbg8)");
  }
  const std::uint64_t row_bytes =
      static_cast<std::uint64_t>(m.width) * static_cast<std::uint64_t>(encoding->bytes_per_pixel);
  if (m.width == 0 || m.height == 0 || m.width > 65535 || m.height > 65535) {
    throw InputError(where, 0, fmt::format("image size {}x{} is not usable", m.width, m.height));
  }
  if (m.step < row_bytes ||
      static_cast<std::uint64_t>(m.step) * m.height > static_cast<std::uint64_t>(m.data.size())) {
    throw InputError(where, 0,
                     fmt::format("{}x{} {} image: step {} and {} data bytes do not fit", m.width,
                                 m.height, m.encoding, m.step, m.data.size()));
  }
  const bool bayer = encoding->conversion != -1 && encoding->type == CV_8UC1;
  if (bayer && (m.width < 2 || m.height < 2)) {
    throw InputError(where, 0, "a Bayer image must be at least 2x2 pixels");
  }
  try {
    cv::Mat image = cv::Mat(static_cast<int>(m.height), static_cast<int>(m.width), encoding->type,
                            const_cast<std::uint8_t*>(m.data.data()), m.step)
                        .clone();
    const bool host_big_endian = std::endian::native == std::endian::big;
    if (encoding->bytes_per_pixel == 2 && (m.is_bigendian != 0) != host_big_endian) {
      for (int r = 0; r < image.rows; ++r) {
        auto* row = image.ptr<std::uint16_t>(r);
        for (int c = 0; c < image.cols; ++c) {
          row[c] = static_cast<std::uint16_t>((row[c] >> 8) | (row[c] << 8));
        }
      }
    }
    if (encoding->conversion != -1) {
      cv::Mat converted;
      cv::cvtColor(image, converted, encoding->conversion);
      return converted;
    }
    return image;
  } catch (const cv::Exception& e) {
    throw InputError(where, 0, std::string("cannot convert the image: ") + e.what());
  }
}

// "png" or "jpeg" from the first bytes of a compressed image; "" for anything else.
std::string CompressedFormat(const std::vector<std::uint8_t>& data) {
  static const std::uint8_t kPng[] = {0x89, 'P', 'N', 'G', 0x0D, 0x0A, 0x1A, 0x0A};
  if (data.size() >= sizeof(kPng) && std::equal(kPng, kPng + sizeof(kPng), data.begin())) {
    return "png";
  }
  if (data.size() >= 3 && data[0] == 0xFF && data[1] == 0xD8 && data[2] == 0xFF) return "jpeg";
  return "";
}

void WriteBytes(const fs::path& path, const std::vector<std::uint8_t>& data) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data.data()), static_cast<std::streamsize>(data.size()));
  out.close();
  if (!out) throw InputError(path.string(), 0, "cannot write the image");
}

// ---- calibration ----

// A camera from sensor_msgs/CameraInfo: K, D (plumb_bob = OpenCV's k1 k2 p1 p2 k3), size. The
// bag says nothing about where the camera sits: T_BS is the identity.
CameraSensor CameraFromInfo(const RosCameraInfo& info, const std::string& name,
                            const std::string& where) {
  CameraSensor sensor;
  sensor.name = name;
  geometry::PinholeRadTan& c = sensor.camera;
  c.width = static_cast<int>(std::min<std::uint32_t>(info.width, 1 << 20));
  c.height = static_cast<int>(std::min<std::uint32_t>(info.height, 1 << 20));
  c.fx = info.K[0];
  c.fy = info.K[4];
  c.cx = info.K[2];
  c.cy = info.K[5];
  if ((info.binning_x > 1 || info.binning_y > 1) ||
      (info.roi_width != 0 && (info.roi_width != info.width || info.roi_height != info.height))) {
    throw InputError(where, 0,
                     "CameraInfo with binning or a region of interest is not supported: give the "
                     "calibration with --sensor-yaml");
  }
  const std::string& model = info.distortion_model;
  const bool radtan = model == "plumb_bob" || model == "rational_polynomial" || model.empty();
  if (!radtan) {
    throw InputError(where, 0,
                     "CameraInfo distortion model '" + model +
                         "' is not supported (plumb_bob): give the calibration with "
                         "--sensor-yaml");
  }
  // k1 k2 p1 p2 k3 [k4 k5 k6 ...]: coefficients beyond k3 must be 0 (not in crop4d's model).
  for (std::size_t i = 5; i < info.D.size(); ++i) {
    if (info.D[i] != 0.0) {
      throw InputError(where, 0,
                       "CameraInfo has rational-polynomial coefficients (k4..k6) that crop4d's "
                       "radial-tangential model cannot hold: give the calibration with "
                       "--sensor-yaml");
    }
  }
  double* coefficients[] = {&c.k1, &c.k2, &c.p1, &c.p2, &c.k3};
  for (std::size_t i = 0; i < info.D.size() && i < 5; ++i) *coefficients[i] = info.D[i];
  if (const std::string why = c.Check(); !why.empty()) {
    throw InputError(where, 0,
                     fmt::format("CameraInfo is not a usable calibration (size {}x{}, K [{}, {}, "
                                 "{}, {}]): {}",
                                 info.width, info.height, c.fx, c.fy, c.cx, c.cy, why));
  }
  if (info.K[1] != 0.0) {
    spdlog::warn("import: {}: CameraInfo skew K[0][1] = {} is left out (crop4d's model has none)",
                 where, info.K[1]);
  }
  return sensor;
}

// ---- per-sensor state while the bag is read ----

struct GpsRaw {
  Timestamp t = 0;
  geometry::GeodeticPoint position;
  double sigma_h = 0, sigma_v = 0;  // 0: no covariance; the receiver's defaults
  std::int8_t status = RosNavSatFix::kStatusNoFix;
};

struct Stream {
  std::string name;
  SensorKind kind = SensorKind::kCamera;
  std::string topic, datatype;
  std::string calibration;  // where sensor.yaml comes from (for the summary)
  std::int64_t reordered = 0, duplicates = 0, dropped = 0;
  std::optional<Timestamp> previous;  // the stamp of the previous message, for `reordered`
  // cameras
  std::optional<CameraSensor> camera;
  std::string info_topic;
  fs::path folder;  // staging/<name>
  std::vector<ImageEntry> images;
  std::set<Timestamp> image_stamps;
  // the others
  std::vector<ImuSample> imu;
  std::vector<GpsRaw> gps;
  std::vector<MagSample> mag;
};

// Sorts by time (stable: of equal stamps the first message stays) and drops repeated stamps.
template <typename T>
void SortUnique(std::vector<T>* samples, std::int64_t* duplicates) {
  std::stable_sort(samples->begin(), samples->end(),
                   [](const T& a, const T& b) { return a.t < b.t; });
  const auto end = std::unique(samples->begin(), samples->end(),
                               [](const T& a, const T& b) { return a.t == b.t; });
  *duplicates += static_cast<std::int64_t>(samples->end() - end);
  samples->erase(end, samples->end());
}

bool IsFinite(const std::array<double, 3>& v) {
  return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]);
}

// NavSatStatus -> NMEA fix. GBAS_FIX ("ground-based augmentation") is what ROS GNSS drivers
// report for RTK (fixed and float alike) and also for other ground-based corrections: it is RTK
// fixed on an RTK receiver and DGPS on a standard one.
GpsFix FixFromStatus(std::int8_t status, GpsKind kind) {
  switch (status) {
    case RosNavSatFix::kStatusFix:
      return GpsFix::kSingle;
    case RosNavSatFix::kStatusSbasFix:
      return GpsFix::kDgps;
    case RosNavSatFix::kStatusGbasFix:
      return kind == GpsKind::kRtk ? GpsFix::kRtkFixed : GpsFix::kDgps;
    default:
      return GpsFix::kNone;
  }
}

const std::regex& SensorNamePattern() {
  static const std::regex pattern("(cam|imu|gps|mag)[0-9]+");
  return pattern;
}

// Picks the topic of every sensor: the named ones, then one per kind that has none named when
// the bag has exactly one topic of that kind's types.
std::vector<Stream> SelectStreams(const BagReader& bag, const BagImportOptions& o) {
  const std::string where = o.bag_path;
  std::vector<Stream> streams;
  std::set<SensorKind> named_kinds;
  std::map<std::string, std::string> used_topics;  // topic -> sensor
  const auto check_topic = [&](const std::string& sensor, const std::string& topic) {
    const BagTopic* t = bag.FindTopic(topic);
    if (t == nullptr) {
      throw InputError(where, 0,
                       fmt::format("--topic {}={}: the bag has no such topic; {}", sensor, topic,
                                   TopicList(bag)));
    }
    if (t->messages == 0) {
      throw InputError(
          where, 0, fmt::format("{}: topic {} has no messages; {}", sensor, topic, TopicList(bag)));
    }
    if (const auto it = used_topics.find(topic); it != used_topics.end()) {
      throw InputError(
          where, 0, fmt::format("topic {} is given to both {} and {}", topic, it->second, sensor));
    }
    used_topics[topic] = sensor;
    return t;
  };
  for (const auto& [name, topic] : o.topics) {
    if (name.ends_with("_info")) continue;  // CameraInfo topics: resolved with their camera
    const SensorKind kind = *SensorKindFromFolder(name);
    const BagTopic* t = check_topic(name, topic);
    if (!TypeFits(kind, t->datatype)) {
      throw InputError(
          where, 0,
          fmt::format(
              "--topic {}={}: the topic's message type {} is {} (a {} needs {}); {}", name, topic,
              t->datatype,
              IsReadableRosType(t->datatype) ? "not one for this sensor" : "unknown to crop4d",
              SensorKindName(kind), JoinTypes(kind), TopicList(bag)));
    }
    Stream s;
    s.name = name;
    s.kind = kind;
    s.topic = topic;
    s.datatype = t->datatype;
    streams.push_back(std::move(s));
    named_kinds.insert(kind);
  }
  for (SensorKind kind :
       {SensorKind::kCamera, SensorKind::kImu, SensorKind::kGps, SensorKind::kMag}) {
    if (named_kinds.count(kind) > 0) continue;
    std::vector<const BagTopic*> candidates;
    for (const BagTopic& t : bag.topics()) {
      if (TypeFits(kind, t.datatype) && used_topics.count(t.topic) == 0) candidates.push_back(&t);
    }
    const std::string name = std::string(SensorFolderPrefix(kind)) + "0";
    if (candidates.size() > 1) {
      std::string list;
      for (const BagTopic* t : candidates) {
        list += fmt::format("{}{} ({})", list.empty() ? "" : ", ", t->topic, t->datatype);
      }
      throw InputError(
          where, 0,
          fmt::format("the bag has {} topics for a {} ({}): name the one to import "
                      "with --topic {}=TOPIC; {}",
                      candidates.size(), SensorKindName(kind), list, name, TopicList(bag)));
    }
    if (candidates.empty()) continue;
    const BagTopic* t = check_topic(name, candidates.front()->topic);
    Stream s;
    s.name = name;
    s.kind = kind;
    s.topic = t->topic;
    s.datatype = t->datatype;
    spdlog::info("import: {} <- {} ({}), the bag's only such topic", name, s.topic, s.datatype);
    streams.push_back(std::move(s));
  }
  if (streams.empty()) {
    throw InputError(where, 0,
                     "nothing to import: no topic of type sensor_msgs/Image, CompressedImage, "
                     "Imu, NavSatFix or MagneticField; " +
                         TopicList(bag));
  }
  std::sort(streams.begin(), streams.end(),
            [](const Stream& a, const Stream& b) { return a.name < b.name; });
  return streams;
}

// The CameraInfo topic of a camera with no calibration given: --topic camN_info, else
// <namespace>/camera_info next to the image topic (image_transport's layout), else the bag's only
// CameraInfo topic when there is one camera. "" when there is none.
std::string FindInfoTopic(const BagReader& bag, const BagImportOptions& o, const Stream& camera,
                          int camera_count) {
  if (const auto it = o.topics.find(camera.name + "_info"); it != o.topics.end()) {
    const BagTopic* t = bag.FindTopic(it->second);
    if (t == nullptr || t->datatype != kRosCameraInfoType || t->messages == 0) {
      throw InputError(o.bag_path, 0,
                       fmt::format("--topic {}_info={}: not a {} topic with messages; {}",
                                   camera.name, it->second, kRosCameraInfoType, TopicList(bag)));
    }
    return t->topic;
  }
  std::string base = camera.topic;
  if (camera.datatype == kRosCompressedImageType && base.ends_with("/compressed")) {
    base.resize(base.size() - std::string("/compressed").size());
  }
  const std::size_t slash = base.rfind('/');
  const std::string sibling =
      (slash == std::string::npos ? std::string() : base.substr(0, slash)) + "/camera_info";
  if (const BagTopic* t = bag.FindTopic(sibling);
      t != nullptr && t->datatype == kRosCameraInfoType && t->messages > 0) {
    return sibling;
  }
  std::vector<const BagTopic*> infos;
  for (const BagTopic& t : bag.topics()) {
    if (t.datatype == kRosCameraInfoType && t.messages > 0) infos.push_back(&t);
  }
  if (infos.size() == 1 && camera_count == 1) return infos.front()->topic;
  return "";
}

// Fills the calibration of every camera before the images are read: Options::cameras, else the
// first message of its CameraInfo topic.
void ResolveCameras(const BagReader& bag, const BagImportOptions& o, std::vector<Stream>* streams) {
  int camera_count = 0;
  for (const Stream& s : *streams) camera_count += s.kind == SensorKind::kCamera ? 1 : 0;
  std::map<std::string, std::optional<RosCameraInfo>> infos;
  for (Stream& s : *streams) {
    if (s.kind != SensorKind::kCamera) continue;
    if (const auto it = o.cameras.find(s.name); it != o.cameras.end()) {
      s.camera = it->second;
      s.camera->name = s.name;
      s.calibration =
          o.sensor_yaml_files.count(s.name) > 0 ? "--sensor-yaml" : "given by the caller (Kalibr)";
      continue;
    }
    s.info_topic = FindInfoTopic(bag, o, s, camera_count);
    if (s.info_topic.empty()) {
      throw InputError(o.bag_path, 0,
                       fmt::format("{} ({}): a bag holds no camera calibration and this one has "
                                   "no sensor_msgs/CameraInfo for it: pass --sensor-yaml "
                                   "{}=FILE (a crop4d sensor.yaml) or --kalibr-camchain FILE, or "
                                   "--topic {}_info=TOPIC; {}",
                                   s.name, s.topic, s.name, s.name, TopicList(bag)));
    }
    infos[s.info_topic];
  }
  if (infos.empty()) return;
  std::vector<std::string> topics;
  for (const auto& [topic, info] : infos) topics.push_back(topic);
  std::size_t found = 0;
  bag.Read(topics, [&](const BagMessage& m) {
    std::optional<RosCameraInfo>& slot = infos[m.topic];
    if (!slot) {
      slot = std::get<RosCameraInfo>(m.payload);
      ++found;
    }
    return found < infos.size();
  });
  for (Stream& s : *streams) {
    if (s.kind != SensorKind::kCamera || s.camera) continue;
    s.camera = CameraFromInfo(*infos[s.info_topic], s.name, o.bag_path + ": " + s.info_topic);
    s.calibration = "CameraInfo " + s.info_topic + " (T_BS identity)";
    spdlog::warn(
        "import: {}: intrinsics from {}; the bag does not say where the camera sits on the rig, "
        "so T_BS (body_from_camera) is the identity: give it with --sensor-yaml {}=FILE or "
        "--kalibr-camchain before running slam",
        s.name, s.info_topic, s.name);
  }
}

// Takes one message into its stream (images are written to the staging folder right away).
void TakeMessage(const BagImportOptions& o, const BagMessage& m, Stream* s) {
  const std::string where = o.bag_path + ": " + m.topic;
  const Timestamp header_stamp = std::visit([](const auto& p) { return p.stamp; }, m.payload);
  Timestamp t = m.receive_time;
  if (o.stamp == BagStamp::kHeader) {
    if (header_stamp == 0) {
      throw InputError(where, 0,
                       "a message has no header stamp (0): the driver did not set it; import "
                       "with --stamp receive (the bag's record times)");
    }
    t = header_stamp;
  }
  if (const auto shift = o.camera_time_shift_ns.find(s->name);
      shift != o.camera_time_shift_ns.end()) {
    t += shift->second;
  }
  if (s->previous && t < *s->previous) ++s->reordered;
  s->previous = t;

  if (const auto* image = std::get_if<RosImage>(&m.payload)) {
    if (!s->image_stamps.insert(t).second) {
      ++s->duplicates;
      return;
    }
    const std::string what = fmt::format("{} (image stamped {})", where, t);
    const cv::Mat decoded = DecodeImage(*image, what);
    const geometry::PinholeRadTan& c = s->camera->camera;
    if (decoded.cols != c.width || decoded.rows != c.height) {
      throw InputError(what, 0,
                       fmt::format("the image is {}x{}, the calibration of {} is for {}x{}",
                                   decoded.cols, decoded.rows, s->name, c.width, c.height));
    }
    ImageEntry entry;
    entry.t = t;
    entry.filename = std::to_string(t) + ".png";
    const fs::path path = s->folder / kImageFolder / entry.filename;
    bool written = false;
    try {
      written = cv::imwrite(path.string(), decoded);
    } catch (const cv::Exception&) {
      written = false;
    }
    if (!written) throw InputError(path.string(), 0, "cannot write the image");
    s->images.push_back(entry);
  } else if (const auto* compressed = std::get_if<RosCompressedImage>(&m.payload)) {
    if (!s->image_stamps.insert(t).second) {
      ++s->duplicates;
      return;
    }
    const std::string what = fmt::format("{} (image stamped {})", where, t);
    const std::string format = CompressedFormat(compressed->data);
    if (format.empty()) {
      throw InputError(
          what, 0,
          "the compressed image (format '" + compressed->format + "') is neither PNG nor JPEG");
    }
    ImageEntry entry;
    entry.t = t;
    entry.filename = std::to_string(t) + (format == "png" ? ".png" : ".jpg");
    const fs::path path = s->folder / kImageFolder / entry.filename;
    WriteBytes(path, compressed->data);
    const ImageProbe probe = ProbeImage(path.string());
    if (!probe.ok) throw InputError(what, 0, "not a readable image: " + probe.problem);
    const geometry::PinholeRadTan& c = s->camera->camera;
    if (probe.width != c.width || probe.height != c.height) {
      throw InputError(what, 0,
                       fmt::format("the image is {}x{}, the calibration of {} is for {}x{}",
                                   probe.width, probe.height, s->name, c.width, c.height));
    }
    s->images.push_back(entry);
  } else if (const auto* imu = std::get_if<RosImu>(&m.payload)) {
    if (imu->angular_velocity_covariance[0] == -1.0 ||
        imu->linear_acceleration_covariance[0] == -1.0) {
      throw InputError(where, 0,
                       "the IMU messages lack angular velocity or linear acceleration "
                       "(covariance[0] = -1): crop4d needs both");
    }
    if (!IsFinite(imu->angular_velocity) || !IsFinite(imu->linear_acceleration)) {
      ++s->dropped;
      return;
    }
    ImuSample sample;
    sample.t = t;
    sample.gyro = Eigen::Vector3d(imu->angular_velocity.data());
    sample.accel = Eigen::Vector3d(imu->linear_acceleration.data());
    s->imu.push_back(sample);
  } else if (const auto* fix = std::get_if<RosNavSatFix>(&m.payload)) {
    if (!std::isfinite(fix->latitude) || !std::isfinite(fix->longitude) ||
        !std::isfinite(fix->altitude) || std::abs(fix->latitude) > 90.0 ||
        std::abs(fix->longitude) > 180.0) {
      ++s->dropped;  // STATUS_NO_FIX messages often carry NaN: no position at all
      return;
    }
    GpsRaw raw;
    raw.t = t;
    raw.position = {fix->latitude, fix->longitude, fix->altitude};
    raw.status = fix->status;
    const auto& c = fix->position_covariance;
    if (fix->position_covariance_type != RosNavSatFix::kCovarianceUnknown && c[0] >= 0 &&
        c[4] >= 0 && c[8] >= 0 && std::isfinite(c[0] + c[4] + c[8])) {
      raw.sigma_h = std::sqrt((c[0] + c[4]) / 2.0);
      raw.sigma_v = std::sqrt(c[8]);
    }
    s->gps.push_back(raw);
  } else if (const auto* field = std::get_if<RosMagneticField>(&m.payload)) {
    MagSample sample;
    sample.t = t;
    sample.field_ut = Eigen::Vector3d(TeslaToMicrotesla(field->magnetic_field[0]),
                                      TeslaToMicrotesla(field->magnetic_field[1]),
                                      TeslaToMicrotesla(field->magnetic_field[2]));
    if (!sample.field_ut.allFinite()) {
      ++s->dropped;
      return;
    }
    s->mag.push_back(sample);
  }
}

// Writes sensor.yaml with `write`, or copies the file the calibration was read from.
template <typename Sensor, typename WriteFunction>
void WriteSensorYaml(const BagImportOptions& o, const std::string& name, bool given,
                     const std::string& path, const Sensor& sensor, WriteFunction write) {
  const auto file = o.sensor_yaml_files.find(name);
  if (given && file != o.sensor_yaml_files.end()) {
    std::error_code ec;
    fs::copy_file(file->second, path, fs::copy_options::overwrite_existing, ec);
    if (ec) throw InputError(file->second, 0, "cannot copy the sensor.yaml: " + ec.message());
    return;
  }
  write(path, sensor);
}

// Writes sensor.yaml and data.csv of one stream into the staging folder.
void WriteStream(const BagImportOptions& o, Stream* s, BagImportSummary* summary) {
  BagImportSummary::Sensor out;
  out.name = s->name;
  out.topic = s->topic;
  out.datatype = s->datatype;
  const std::string yaml = (s->folder / kSensorYaml).string();
  const std::string csv = (s->folder / kDataCsv).string();
  const auto fill_times = [&](auto& samples) {
    SortUnique(&samples, &s->duplicates);
    if (samples.empty()) {
      throw InputError(o.bag_path, 0,
                       fmt::format("{}: topic {} has no usable message ({} without a value)",
                                   s->name, s->topic, s->dropped));
    }
    out.samples = static_cast<std::int64_t>(samples.size());
    out.first_t = samples.front().t;
    out.last_t = samples.back().t;
    return RoundRate(MeanRateHz(samples.size(), out.first_t, out.last_t));
  };
  fs::create_directories(s->folder);
  switch (s->kind) {
    case SensorKind::kCamera: {
      const double rate = fill_times(s->images);
      // The rate of the data, unless sensor.yaml is copied from a file as it is.
      if (o.sensor_yaml_files.count(s->name) == 0 && rate > 0) s->camera->rate_hz = rate;
      WriteSensorYaml(o, s->name, o.cameras.count(s->name) > 0, yaml, *s->camera,
                      WriteCameraSensorYaml);
      WriteImageCsv(csv, s->images);
      break;
    }
    case SensorKind::kImu: {
      const double rate = fill_times(s->imu);
      ImuSensor sensor;
      if (const auto it = o.imus.find(s->name); it != o.imus.end()) {
        sensor = it->second;
        if (o.sensor_yaml_files.count(s->name) == 0 && rate > 0) sensor.rate_hz = rate;
        s->calibration = o.sensor_yaml_files.count(s->name) > 0 ? "--sensor-yaml"
                                                                : "given by the caller (Kalibr)";
      } else {
        sensor.rate_hz = rate > 0 ? rate : 100.0;
        sensor.gyroscope_noise_density = o.gyroscope_noise_density;
        sensor.gyroscope_random_walk = o.gyroscope_random_walk;
        sensor.accelerometer_noise_density = o.accelerometer_noise_density;
        sensor.accelerometer_random_walk = o.accelerometer_random_walk;
        s->calibration = "defaults (noise from the options, T_BS identity)";
      }
      sensor.name = s->name;
      WriteSensorYaml(o, s->name, o.imus.count(s->name) > 0, yaml, sensor, WriteImuSensorYaml);
      WriteImuCsv(csv, s->imu);
      break;
    }
    case SensorKind::kGps: {
      std::vector<GpsRaw>& raw = s->gps;
      const double rate = fill_times(raw);
      GpsSensor sensor;
      if (const auto it = o.gps.find(s->name); it != o.gps.end()) {
        sensor = it->second;
        s->calibration = o.sensor_yaml_files.count(s->name) > 0 ? "--sensor-yaml"
                                                                : "given by the caller (Kalibr)";
      } else {
        const bool any_gbas = std::any_of(raw.begin(), raw.end(), [](const GpsRaw& r) {
          return r.status == RosNavSatFix::kStatusGbasFix;
        });
        sensor.kind = o.gps_kind ? *o.gps_kind : (any_gbas ? GpsKind::kRtk : GpsKind::kStandard);
        sensor.rate_hz = rate > 0 ? rate : 5.0;
        sensor.antenna_in_body = o.antenna_in_body;
        sensor.default_sigma_h = sensor.kind == GpsKind::kRtk ? 0.02 : 2.5;
        sensor.default_sigma_v = sensor.kind == GpsKind::kRtk ? 0.04 : 5.0;
        s->calibration = fmt::format("defaults (kind {}{})", GpsKindName(sensor.kind),
                                     o.gps_kind ? "" : ", auto");
      }
      sensor.name = s->name;
      std::vector<GpsSample> samples;
      samples.reserve(raw.size());
      for (const GpsRaw& r : raw) {
        GpsSample g;
        g.t = r.t;
        g.position = r.position;
        const bool has_sigma = r.sigma_h > 0 || r.sigma_v > 0;
        g.sigma_h = has_sigma ? r.sigma_h : sensor.default_sigma_h;
        g.sigma_v = has_sigma ? r.sigma_v : sensor.default_sigma_v;
        g.fix = FixFromStatus(r.status, sensor.kind);
        ++summary->fix_counts[static_cast<int>(g.fix)];
        samples.push_back(g);
      }
      // The summary shows the kind of the first receiver (streams are sorted by name).
      if (std::none_of(
              summary->sensors.begin(), summary->sensors.end(),
              [](const BagImportSummary::Sensor& x) { return x.name.starts_with("gps"); })) {
        summary->gps_kind = sensor.kind;
      }
      WriteSensorYaml(o, s->name, o.gps.count(s->name) > 0, yaml, sensor, WriteGpsSensorYaml);
      WriteGpsCsv(csv, samples);
      break;
    }
    case SensorKind::kMag: {
      const double rate = fill_times(s->mag);
      MagSensor sensor;
      if (const auto it = o.mags.find(s->name); it != o.mags.end()) {
        sensor = it->second;
        s->calibration = o.sensor_yaml_files.count(s->name) > 0 ? "--sensor-yaml"
                                                                : "given by the caller (Kalibr)";
      } else {
        sensor.rate_hz = rate > 0 ? rate : 110.0;
        s->calibration = "defaults (T_BS identity)";
      }
      sensor.name = s->name;
      WriteSensorYaml(o, s->name, o.mags.count(s->name) > 0, yaml, sensor, WriteMagSensorYaml);
      WriteMagCsv(csv, s->mag);
      break;
    }
  }
  out.calibration = s->calibration;
  out.reordered = s->reordered;
  out.duplicates = s->duplicates;
  out.dropped = s->dropped;
  if (s->duplicates > 0 || s->dropped > 0) {
    spdlog::warn(
        "import: {} ({}): {} message(s) with a repeated stamp and {} without a usable "
        "value left out",
        s->name, s->topic, s->duplicates, s->dropped);
  }
  summary->sensors.push_back(out);
}

}  // namespace

void BagImportOptions::Check() const {
  if (bag_path.empty()) throw InputError("--bag", 0, "the bag file is required");
  if (field_folder.empty()) throw InputError("--out", 0, "the field folder is required");
  if (origin && (std::abs(origin->lat_deg) > 90 || std::abs(origin->lon_deg) > 180)) {
    throw InputError("--origin", 0, "latitude beyond ±90° or longitude beyond ±180°");
  }
  for (const auto& [name, topic] : topics) {
    const std::string sensor = name.ends_with("_info") ? name.substr(0, name.size() - 5) : name;
    const bool info_ok = sensor == name || sensor.starts_with("cam");
    if (!std::regex_match(sensor, SensorNamePattern()) || !info_ok || topic.empty()) {
      throw InputError("--topic", 0,
                       "'" + name + "=" + topic +
                           "': expected SENSOR=TOPIC with SENSOR cam<N>, imu<N>, gps<N>, "
                           "mag<N> or cam<N>_info (a CameraInfo topic)");
    }
  }
  const auto check_names = [](const auto& map, SensorKind kind, const char* what) {
    for (const auto& [name, sensor] : map) {
      if (!std::regex_match(name, SensorNamePattern()) || SensorKindFromFolder(name) != kind) {
        throw InputError("--sensor-yaml", 0,
                         "'" + name + "' is not a " + what + " folder name (" +
                             SensorFolderPrefix(kind) + "<N>)");
      }
    }
  };
  check_names(cameras, SensorKind::kCamera, "camera");
  check_names(imus, SensorKind::kImu, "IMU");
  check_names(gps, SensorKind::kGps, "GPS");
  check_names(mags, SensorKind::kMag, "magnetometer");
  const double noise[] = {gyroscope_noise_density, gyroscope_random_walk,
                          accelerometer_noise_density, accelerometer_random_walk};
  for (double value : noise) {
    if (!(value >= 0) || !std::isfinite(value)) {
      throw InputError("crop4d import: IMU noise values must be finite and not negative");
    }
  }
  if (!antenna_in_body.allFinite()) throw InputError("--antenna", 0, "must be finite");
}

BagImportSummary ImportBag(const BagImportOptions& o) {
  o.Check();
  BagImportSummary summary;
  summary.bag_path = o.bag_path;
  summary.stamp = o.stamp;
  const fs::path field_folder(o.field_folder);
  std::error_code ec;
  if (fs::exists(field_folder, ec) && !fs::is_directory(field_folder, ec)) {
    throw InputError(o.field_folder, 0, "exists and is not a folder");
  }
  // Checked before the bag is read when the id is given; else once the first stamp names it.
  if (!o.session_id.empty()) NewSessionFolder(o.field_folder, o.session_id, o.overwrite);
  std::optional<FieldInfo> field = ExistingField(o.field_folder);

  // ---- what to read: topics and cameras' calibration ----
  const BagReader bag(o.bag_path);
  std::vector<Stream> streams = SelectStreams(bag, o);
  for (const auto& camera : o.cameras) {
    const std::string& name = camera.first;
    if (std::none_of(streams.begin(), streams.end(),
                     [&](const Stream& s) { return s.name == name; })) {
      spdlog::warn("import: a calibration is given for {}, but no topic feeds it", name);
    }
  }
  ResolveCameras(bag, o, &streams);

  // ---- read the bag once, writing images as they come, into a hidden folder ----
  const fs::path staging =
      field_folder / kSessionsFolder / fmt::format(".bag-import-{}", ::getpid());
  fs::remove_all(staging, ec);
  try {
    std::map<std::string, Stream*> by_topic;
    std::vector<std::string> topics;
    for (Stream& s : streams) {
      s.folder = staging / s.name;
      if (s.kind == SensorKind::kCamera) fs::create_directories(s.folder / kImageFolder);
      by_topic[s.topic] = &s;
      topics.push_back(s.topic);
    }
    bag.Read(topics, [&](const BagMessage& m) {
      TakeMessage(o, m, by_topic.at(m.topic));
      return true;
    });
    for (Stream& s : streams) WriteStream(o, &s, &summary);

    // ---- session id, date, origin ----
    Timestamp first_t = summary.sensors.front().first_t;
    for (const BagImportSummary::Sensor& s : summary.sensors)
      first_t = std::min(first_t, s.first_t);
    summary.date = DayOf(first_t);
    const std::string id = o.session_id.empty() ? FormatDate(summary.date) : o.session_id;
    const fs::path session_folder = NewSessionFolder(o.field_folder, id, o.overwrite);
    summary.session_folder = session_folder.string();

    std::string sources;
    for (const BagImportSummary::Sensor& s : summary.sensors) {
      sources +=
          fmt::format("{}{} <- {} ({})", sources.empty() ? "" : ", ", s.name, s.topic, s.datatype);
    }
    SessionInfo session;
    session.id = id;
    session.date = summary.date;
    session.notes = o.notes;
    if (!session.notes.empty()) session.notes += ". ";
    session.notes +=
        fmt::format("Imported by crop4d import --bag from {} (ROS 1 bag; {}, UTC): {}.",
                    fs::absolute(o.bag_path).lexically_normal().string(),
                    o.stamp == BagStamp::kHeader ? "header stamps" : "record times", sources);
    WriteSessionYaml((staging / kSessionYaml).string(), session);

    if (field) {
      summary.origin = field->origin;
    } else if (o.origin) {
      summary.origin = *o.origin;
    } else {
      // The first GPS sample with a fix, in time order, of the first receiver.
      bool found = false;
      for (const Stream& s : streams) {
        if (s.kind != SensorKind::kGps || found) continue;
        for (const GpsRaw& r : s.gps) {
          if (r.status >= RosNavSatFix::kStatusFix && r.status <= RosNavSatFix::kStatusGbasFix) {
            summary.origin = r.position;
            found = true;
            break;
          }
        }
        if (!found && !s.gps.empty()) {
          summary.origin = s.gps.front().position;
          found = true;
        }
      }
      if (!found) {
        summary.origin = geometry::GeodeticPoint{0, 0, 0};
        summary.origin_by_convention = true;
      }
    }
    MoveIntoPlace(staging.string(), session_folder.string());
    AddSessionToField(o.field_folder, std::move(field), o.field_name, summary.origin, id,
                      &summary.field_created, &summary.field_sessions_updated);
  } catch (...) {
    fs::remove_all(staging, ec);
    throw;
  }
  return summary;
}

std::string FormatBagImportSummary(const BagImportSummary& s) {
  std::string out =
      fmt::format("session {} ({}) from {}, {} (UTC)\n", s.session_folder, FormatDate(s.date),
                  s.bag_path, s.stamp == BagStamp::kHeader ? "header stamps" : "record times");
  for (const BagImportSummary::Sensor& sensor : s.sensors) {
    out += fmt::format("  {:<6} {:>8} {}  {} .. {}  <- {} ({})\n", sensor.name, sensor.samples,
                       sensor.name.starts_with("cam") ? "images " : "samples",
                       FormatTimestamp(sensor.first_t), FormatTimestamp(sensor.last_t),
                       sensor.topic, sensor.datatype);
    out += fmt::format("         calibration: {}", sensor.calibration);
    if (sensor.reordered > 0) out += fmt::format("; {} out of order (sorted)", sensor.reordered);
    if (sensor.duplicates > 0) {
      out += fmt::format("; {} repeated stamps (dropped)", sensor.duplicates);
    }
    if (sensor.dropped > 0) out += fmt::format("; {} without a usable value", sensor.dropped);
    out += "\n";
  }
  if (!s.fix_counts.empty()) {
    std::string fixes;
    for (const auto& [code, count] : s.fix_counts) {
      fixes += fmt::format("{}{} {}", fixes.empty() ? "" : ", ", count, GpsFixName(code));
    }
    out += fmt::format("  gps fixes: {} (receiver kind {})\n", fixes, GpsKindName(s.gps_kind));
  }
  out += fmt::format("  field origin {:.9f}, {:.9f}, {:.3f} m{}{}\n", s.origin.lat_deg,
                     s.origin.lon_deg, s.origin.alt_m,
                     s.origin_by_convention ? " (by convention: no GPS and no --origin)" : "",
                     s.field_created ? " (new field.yaml, no rows)" : "");
  return out;
}

}  // namespace crop4d::io
