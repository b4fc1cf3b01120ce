// Built as C++17 (see ros_bag.h): the only file of crop4d that includes ROS headers.

#include "crop4d/io/rosbag/ros_bag.h"

#include <bzlib.h>
#include <console_bridge/console.h>
#include <rosbag/bag.h>
#include <rosbag/exceptions.h>
#include <rosbag/view.h>
#include <roslz4/lz4s.h>
#include <sensor_msgs/CameraInfo.h>
#include <sensor_msgs/CompressedImage.h>
#include <sensor_msgs/Image.h>
#include <sensor_msgs/Imu.h>
#include <sensor_msgs/MagneticField.h>
#include <sensor_msgs/NavSatFix.h>
#include <std_msgs/String.h>

#include <algorithm>
#include <cstring>
#include <fstream>
#include <map>
#include <new>
#include <set>
#include <stdexcept>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

constexpr BagTime kNanosPerSecond = 1000000000;

BagTime FromRosTime(const ros::Time& t) {
  return static_cast<BagTime>(t.sec) * kNanosPerSecond + static_cast<BagTime>(t.nsec);
}

ros::Time ToRosTime(BagTime t, const std::string& what) {
  if (t < 0 || t / kNanosPerSecond > static_cast<BagTime>(UINT32_MAX)) {
    throw InputError(what, 0, "a time before 1970 or after 2106 cannot be written to a ROS bag");
  }
  return ros::Time(static_cast<std::uint32_t>(t / kNanosPerSecond),
                   static_cast<std::uint32_t>(t % kNanosPerSecond));
}

template <typename To, typename From>
void CopyArray(const From& from, To* to) {
  std::copy(from.begin(), from.end(), to->begin());
}

// The library's messages are quiet: every failure reaches the user as an InputError instead.
void SilenceLibraryLog() { console_bridge::setLogLevel(console_bridge::CONSOLE_BRIDGE_LOG_NONE); }

// ---- ROS message -> plain struct ----

RosImage Convert(sensor_msgs::Image& m) {
  RosImage out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.height = m.height;
  out.width = m.width;
  out.encoding = std::move(m.encoding);
  out.is_bigendian = m.is_bigendian;
  out.step = m.step;
  out.data = std::move(m.data);
  return out;
}

RosCompressedImage Convert(sensor_msgs::CompressedImage& m) {
  RosCompressedImage out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.format = std::move(m.format);
  out.data = std::move(m.data);
  return out;
}

RosImu Convert(sensor_msgs::Imu& m) {
  RosImu out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.orientation_xyzw = {m.orientation.x, m.orientation.y, m.orientation.z, m.orientation.w};
  CopyArray(m.orientation_covariance, &out.orientation_covariance);
  out.angular_velocity = {m.angular_velocity.x, m.angular_velocity.y, m.angular_velocity.z};
  CopyArray(m.angular_velocity_covariance, &out.angular_velocity_covariance);
  out.linear_acceleration = {m.linear_acceleration.x, m.linear_acceleration.y,
                             m.linear_acceleration.z};
  CopyArray(m.linear_acceleration_covariance, &out.linear_acceleration_covariance);
  return out;
}

RosNavSatFix Convert(sensor_msgs::NavSatFix& m) {
  RosNavSatFix out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.status = m.status.status;
  out.service = m.status.service;
  out.latitude = m.latitude;
  out.longitude = m.longitude;
  out.altitude = m.altitude;
  CopyArray(m.position_covariance, &out.position_covariance);
  out.position_covariance_type = m.position_covariance_type;
  return out;
}

RosMagneticField Convert(sensor_msgs::MagneticField& m) {
  RosMagneticField out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.magnetic_field = {m.magnetic_field.x, m.magnetic_field.y, m.magnetic_field.z};
  CopyArray(m.magnetic_field_covariance, &out.magnetic_field_covariance);
  return out;
}

RosCameraInfo Convert(sensor_msgs::CameraInfo& m) {
  RosCameraInfo out;
  out.stamp = FromRosTime(m.header.stamp);
  out.frame_id = std::move(m.header.frame_id);
  out.height = m.height;
  out.width = m.width;
  out.distortion_model = std::move(m.distortion_model);
  out.D = std::move(m.D);
  CopyArray(m.K, &out.K);
  CopyArray(m.R, &out.R);
  CopyArray(m.P, &out.P);
  out.binning_x = m.binning_x;
  out.binning_y = m.binning_y;
  out.roi_x_offset = m.roi.x_offset;
  out.roi_y_offset = m.roi.y_offset;
  out.roi_height = m.roi.height;
  out.roi_width = m.roi.width;
  return out;
}

// Deserialises `instance` as T; unset when its definition differs from T's (md5 sum).
template <typename T>
bool Decode(const rosbag::MessageInstance& instance, RosMessage* out) {
  const boost::shared_ptr<T> message = instance.instantiate<T>();
  if (!message) return false;
  *out = Convert(*message);
  return true;
}

// ---- plain struct -> ROS message ----

std_msgs::Header Header(BagTime stamp, const std::string& frame_id) {
  std_msgs::Header header;
  header.stamp = ToRosTime(stamp, "header.stamp");
  header.frame_id = frame_id;
  return header;
}

template <typename To, typename From>
void CopyBoost(const From& from, To* to) {
  std::copy(from.begin(), from.end(), to->begin());
}

struct Writer {
  rosbag::Bag* bag;
  const std::string& topic;
  ros::Time time;

  void operator()(const RosImage& in) const {
    sensor_msgs::Image m;
    m.header = Header(in.stamp, in.frame_id);
    m.height = in.height;
    m.width = in.width;
    m.encoding = in.encoding;
    m.is_bigendian = in.is_bigendian;
    m.step = in.step;
    m.data = in.data;
    bag->write(topic, time, m);
  }
  void operator()(const RosCompressedImage& in) const {
    sensor_msgs::CompressedImage m;
    m.header = Header(in.stamp, in.frame_id);
    m.format = in.format;
    m.data = in.data;
    bag->write(topic, time, m);
  }
  void operator()(const RosImu& in) const {
    sensor_msgs::Imu m;
    m.header = Header(in.stamp, in.frame_id);
    m.orientation.x = in.orientation_xyzw[0];
    m.orientation.y = in.orientation_xyzw[1];
    m.orientation.z = in.orientation_xyzw[2];
    m.orientation.w = in.orientation_xyzw[3];
    CopyBoost(in.orientation_covariance, &m.orientation_covariance);
    m.angular_velocity.x = in.angular_velocity[0];
    m.angular_velocity.y = in.angular_velocity[1];
    m.angular_velocity.z = in.angular_velocity[2];
    CopyBoost(in.angular_velocity_covariance, &m.angular_velocity_covariance);
    m.linear_acceleration.x = in.linear_acceleration[0];
    m.linear_acceleration.y = in.linear_acceleration[1];
    m.linear_acceleration.z = in.linear_acceleration[2];
    CopyBoost(in.linear_acceleration_covariance, &m.linear_acceleration_covariance);
    bag->write(topic, time, m);
  }
  void operator()(const RosNavSatFix& in) const {
    sensor_msgs::NavSatFix m;
    m.header = Header(in.stamp, in.frame_id);
    m.status.status = in.status;
    m.status.service = in.service;
    m.latitude = in.latitude;
    m.longitude = in.longitude;
    m.altitude = in.altitude;
    CopyBoost(in.position_covariance, &m.position_covariance);
    m.position_covariance_type = in.position_covariance_type;
    bag->write(topic, time, m);
  }
  void operator()(const RosMagneticField& in) const {
    sensor_msgs::MagneticField m;
    m.header = Header(in.stamp, in.frame_id);
    m.magnetic_field.x = in.magnetic_field[0];
    m.magnetic_field.y = in.magnetic_field[1];
    m.magnetic_field.z = in.magnetic_field[2];
    CopyBoost(in.magnetic_field_covariance, &m.magnetic_field_covariance);
    bag->write(topic, time, m);
  }
  void operator()(const RosCameraInfo& in) const {
    sensor_msgs::CameraInfo m;
    m.header = Header(in.stamp, in.frame_id);
    m.height = in.height;
    m.width = in.width;
    m.distortion_model = in.distortion_model;
    m.D = in.D;
    CopyBoost(in.K, &m.K);
    CopyBoost(in.R, &m.R);
    CopyBoost(in.P, &m.P);
    m.binning_x = in.binning_x;
    m.binning_y = in.binning_y;
    m.roi.x_offset = in.roi_x_offset;
    m.roi.y_offset = in.roi_y_offset;
    m.roi.height = in.roi_height;
    m.roi.width = in.roi_width;
    bag->write(topic, time, m);
  }
};

// ---- record framing, checked before the library sees the file ----
//
// Debian's rosbag_storage trusts the lengths and offsets in a bag: ros::Header::parse reads a
// header field of any declared length past the end of its buffer, and the offsets of index
// records are used unchecked (found by fuzzing: heap-buffer-overflow). So the whole file is
// walked once first, chunk by chunk (decompressed one at a time, as the library does), and
// every length, field and offset that the library will follow is checked:
//   record  = uint32 header_len, header, uint32 data_len, data
//   header  = fields: uint32 field_len, "name=value"
//   op 0x03 bag header (index_pos -> a record), 0x05 chunk (compression, size; data = records),
//   0x04 index data (count entries of sec, nsec, offset -> a record of the chunk before it),
//   0x06 chunk info (chunk_pos -> a chunk record), 0x07 connection (data = a header),
//   0x02 message data (in chunks).

constexpr std::uint64_t kMaxHeaderBytes = 64u << 20;  // no real record header comes near this
constexpr std::uint64_t kMaxChunkBytes = 1u << 30;    // decompressed chunk

std::uint32_t Le32(const std::uint8_t* p) {
  return static_cast<std::uint32_t>(p[0]) | static_cast<std::uint32_t>(p[1]) << 8 |
         static_cast<std::uint32_t>(p[2]) << 16 | static_cast<std::uint32_t>(p[3]) << 24;
}

std::uint64_t Le64(const std::uint8_t* p) {
  return static_cast<std::uint64_t>(Le32(p)) | static_cast<std::uint64_t>(Le32(p + 4)) << 32;
}

using Fields = std::map<std::string, std::string>;

// Parses header fields as ros::Header::parse does, but within `size`; "" when well formed.
std::string ParseFields(const std::uint8_t* p, std::size_t size, Fields* fields) {
  std::size_t pos = 0;
  while (pos < size) {
    if (size - pos < 4) return "a header field's length is cut short";
    const std::uint32_t len = Le32(p + pos);
    pos += 4;
    if (len > size - pos) return "a header field runs past the end of its header";
    const char* field = reinterpret_cast<const char*>(p + pos);
    const void* eq = std::memchr(field, '=', len);
    if (eq == nullptr) return "a header field has no '='";
    const std::size_t name_len = static_cast<const char*>(eq) - field;
    (*fields)[std::string(field, name_len)] = std::string(field + name_len + 1, len - name_len - 1);
    pos += len;
  }
  return "";
}

// The value of a fixed-size field (op: 1 byte, uint32, uint64) or nullopt.
template <std::size_t N>
bool FieldBytes(const Fields& fields, const char* name, std::uint8_t (&out)[N]) {
  const auto it = fields.find(name);
  if (it == fields.end() || it->second.size() != N) return false;
  std::memcpy(out, it->second.data(), N);
  return true;
}

class FramingCheck {
 public:
  explicit FramingCheck(const std::string& path) : path_(path) {}

  void Run() {
    std::ifstream in(path_, std::ios::binary);
    if (!in) Fail(0, "cannot open the file");
    in.seekg(0, std::ios::end);
    const std::uint64_t size = static_cast<std::uint64_t>(in.tellg());
    in.seekg(0);
    static const char kMagic[] = "#ROSBAG V2.0\n";
    char magic[sizeof(kMagic) - 1] = {};
    in.read(magic, sizeof(magic));
    if (!in || std::memcmp(magic, kMagic, sizeof(magic)) != 0) {
      Fail(0, "not a ROS 1 bag of format 2.0 (no '#ROSBAG V2.0' at its start)");
    }
    CollectIndexTopics(in, size);
    in.seekg(static_cast<std::streamoff>(sizeof(magic)));
    std::uint64_t pos = sizeof(magic);
    std::vector<std::uint8_t> header, data;
    std::set<std::uint64_t> inner_starts;  // record starts within the last chunk
    bool after_chunk = false;
    while (pos < size) {
      const std::uint64_t start = pos;
      record_starts_.insert(start);
      const std::uint32_t header_len = ReadLength(in, &pos, size, "a record's header length");
      if (header_len > kMaxHeaderBytes || header_len > size - pos) {
        Fail(start, "a record header runs past the end of the file");
      }
      header.resize(header_len);
      ReadBytes(in, header.data(), header_len, &pos);
      Fields fields;
      if (const std::string problem = ParseFields(header.data(), header_len, &fields);
          !problem.empty()) {
        Fail(start, problem);
      }
      std::uint8_t op[1];
      if (!FieldBytes(fields, "op", op)) Fail(start, "a record without its op field");
      const std::uint32_t data_len = ReadLength(in, &pos, size, "a record's data length");
      if (data_len > size - pos) {
        // A bag cut short inside an uncompressed chunk: the records before the cut still name
        // topics (a connection record precedes each topic's first message).
        const auto compression = fields.find("compression");
        if (op[0] == 0x05 && compression != fields.end() && compression->second == "none" &&
            size - pos <= kMaxChunkBytes) {
          data.resize(size - pos);
          in.read(reinterpret_cast<char*>(data.data()), static_cast<std::streamsize>(data.size()));
          data.resize(static_cast<std::size_t>(std::max<std::streamsize>(in.gcount(), 0)));
          SalvageTopics(data);
        }
        Fail(start, "a record's data runs past the end of the file");
      }
      const bool keep = op[0] == 0x05 || op[0] == 0x07 || op[0] == 0x04 || op[0] == 0x06;
      if (keep) {
        data.resize(data_len);
        ReadBytes(in, data.data(), data_len, &pos);
      } else {
        in.seekg(static_cast<std::streamoff>(data_len), std::ios::cur);
        pos += data_len;
      }
      switch (op[0]) {
        case 0x03: {  // bag header
          std::uint8_t index_pos[8];
          if (!FieldBytes(fields, "index_pos", index_pos))
            Fail(start, "bag header without index_pos");
          index_pos_ = Le64(index_pos);
          break;
        }
        case 0x05:  // chunk
          inner_starts = CheckChunk(start, fields, data);
          chunk_starts_.insert(start);
          after_chunk = true;
          continue;
        case 0x04:  // index data: offsets into the chunk before it
          if (!after_chunk) Fail(start, "an index record that follows no chunk");
          CheckIndex(start, fields, data, inner_starts);
          continue;
        case 0x07: {  // connection: its data is a header
          Fields connection;
          if (const std::string problem = ParseFields(data.data(), data.size(), &connection);
              !problem.empty()) {
            Fail(start, "connection record: " + problem);
          }
          NoteConnection(fields, connection);
          break;
        }
        case 0x06: {  // chunk info
          std::uint8_t chunk_pos[8], count[4];
          if (!FieldBytes(fields, "chunk_pos", chunk_pos) || !FieldBytes(fields, "count", count) ||
              static_cast<std::uint64_t>(Le32(count)) * 8 != data.size()) {
            Fail(start, "a malformed chunk info record");
          }
          chunk_infos_.push_back({start, Le64(chunk_pos)});
          break;
        }
        default:
          break;
      }
      after_chunk = false;
    }
    // Positions the library seeks to must be records of the right kind.
    if (index_pos_ == 0 || record_starts_.count(index_pos_) == 0) {
      Fail(0,
           "the index position in the bag header points to no record (the index that lists "
           "a bag's topics is at its end: the file may be cut short)");
    }
    for (const auto& [at, chunk_pos] : chunk_infos_) {
      if (chunk_starts_.count(chunk_pos) == 0) Fail(at, "a chunk info points to no chunk");
    }
  }

 private:
  [[noreturn]] void Fail(std::uint64_t offset, const std::string& what) const {
    std::string topics;
    for (const auto& [topic, type] : topics_) {
      topics += (topics.empty() ? "" : ", ") + topic + " (" + type + ")";
    }
    throw InputError(path_, 0,
                     "not a readable ROS 1 bag (cut short or corrupt; the index that lists a "
                     "bag's topics is at its end): " +
                         what + (offset > 0 ? " (byte " + std::to_string(offset) + ")" : "") +
                         (topics.empty() ? "; no topic could be read"
                                         : "; topics that could be read: " + topics));
  }

  // Notes the topic (in the record header, and in the data of some writers) and the type (in
  // the data, a connection header) of a connection record.
  void NoteConnection(const Fields& record, const Fields& connection) {
    auto topic = connection.find("topic");
    if (topic == connection.end()) topic = record.find("topic");
    const auto type = connection.find("type");
    if (topic != record.end() && topic != connection.end() && type != connection.end()) {
      topics_[topic->second] = type->second;
    }
  }

  // Notes the connection records among the records of `chunk`, as far as they are whole.
  void SalvageTopics(const std::vector<std::uint8_t>& chunk) {
    std::size_t pos = 0;
    while (chunk.size() - pos >= 4) {
      const std::uint32_t header_len = Le32(chunk.data() + pos);
      if (header_len > chunk.size() - pos - 4 || chunk.size() - pos - 4 - header_len < 4) return;
      Fields record, connection;
      if (!ParseFields(chunk.data() + pos + 4, header_len, &record).empty()) return;
      pos += 4 + header_len;
      const std::uint32_t data_len = Le32(chunk.data() + pos);
      pos += 4;
      if (data_len > chunk.size() - pos) return;
      std::uint8_t op[1];
      if (FieldBytes(record, "op", op) && op[0] == 0x07 &&
          ParseFields(chunk.data() + pos, data_len, &connection).empty()) {
        NoteConnection(record, connection);
      }
      pos += data_len;
    }
  }

  // The topics of the index at the end of the bag, when it is there and readable, so that an
  // error further on can name them; any problem here just stops the collection.
  void CollectIndexTopics(std::ifstream& in, std::uint64_t size) {
    std::uint64_t pos = 13;  // after the magic line
    std::vector<std::uint8_t> bytes;
    const auto read_record = [&](Fields* header, Fields* data) {
      std::uint8_t len[4];
      if (size - pos < 4 ||
          !in.seekg(static_cast<std::streamoff>(pos)).read(reinterpret_cast<char*>(len), 4))
        return false;
      const std::uint32_t header_len = Le32(len);
      if (header_len > kMaxHeaderBytes || header_len + 8ull > size - pos) return false;
      bytes.resize(header_len);
      if (!in.read(reinterpret_cast<char*>(bytes.data()), header_len)) return false;
      if (!ParseFields(bytes.data(), header_len, header).empty()) return false;
      if (!in.read(reinterpret_cast<char*>(len), 4)) return false;
      const std::uint32_t data_len = Le32(len);
      if (data_len > size - pos - 8 - header_len) return false;
      std::uint8_t op[1];
      if (FieldBytes(*header, "op", op) && op[0] == 0x07 && data_len <= kMaxHeaderBytes) {
        bytes.resize(data_len);
        if (!in.read(reinterpret_cast<char*>(bytes.data()), data_len)) return false;
        if (!ParseFields(bytes.data(), data_len, data).empty()) return false;
      }
      pos += 8ull + header_len + data_len;
      return true;
    };
    Fields bag_header, unused;
    std::uint8_t index_pos[8];
    if (!read_record(&bag_header, &unused) || !FieldBytes(bag_header, "index_pos", index_pos)) {
      in.clear();
      return;
    }
    pos = Le64(index_pos);
    while (pos > 13 && pos < size) {
      Fields header, data;
      if (!read_record(&header, &data)) break;
      NoteConnection(header, data);
    }
    in.clear();
  }

  std::uint32_t ReadLength(std::ifstream& in, std::uint64_t* pos, std::uint64_t size,
                           const char* what) const {
    if (size - *pos < 4) Fail(*pos, std::string(what) + " is cut short");
    std::uint8_t bytes[4];
    ReadBytes(in, bytes, 4, pos);
    return Le32(bytes);
  }

  void ReadBytes(std::ifstream& in, std::uint8_t* out, std::size_t n, std::uint64_t* pos) const {
    in.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    if (static_cast<std::size_t>(in.gcount()) != n) Fail(*pos, "the file ends inside a record");
    *pos += n;
  }

  // Decompresses a chunk and checks the records in it; returns their start offsets.
  std::set<std::uint64_t> CheckChunk(std::uint64_t start, const Fields& fields,
                                     std::vector<std::uint8_t>& data) {
    std::uint8_t size_bytes[4];
    const auto compression = fields.find("compression");
    if (!FieldBytes(fields, "size", size_bytes) || compression == fields.end()) {
      Fail(start, "a chunk without its compression and size");
    }
    const std::uint32_t size = Le32(size_bytes);
    if (size > kMaxChunkBytes) Fail(start, "a chunk claims more than 1 GiB");
    std::vector<std::uint8_t> plain;
    if (compression->second == "none") {
      if (size != data.size()) Fail(start, "an uncompressed chunk of the wrong size");
      plain.swap(data);
    } else if (compression->second == "bz2" || compression->second == "lz4") {
      plain.resize(size);
      unsigned int out_size = size;
      const bool ok =
          compression->second == "bz2"
              ? BZ2_bzBuffToBuffDecompress(reinterpret_cast<char*>(plain.data()), &out_size,
                                           reinterpret_cast<char*>(data.data()),
                                           static_cast<unsigned int>(data.size()), 0, 0) == BZ_OK
              : roslz4_buffToBuffDecompress(
                    reinterpret_cast<char*>(data.data()), static_cast<unsigned int>(data.size()),
                    reinterpret_cast<char*>(plain.data()), &out_size) == ROSLZ4_OK;
      if (!ok || out_size != size)
        Fail(start, "a " + compression->second + " chunk does not decompress");
    } else {
      Fail(start, "a chunk with the unknown compression '" + compression->second + "'");
    }
    std::set<std::uint64_t> starts;
    std::size_t pos = 0;
    while (pos < plain.size()) {
      starts.insert(pos);
      const std::size_t left = plain.size() - pos;
      if (left < 4) Fail(start, "a record in a chunk is cut short");
      const std::uint32_t header_len = Le32(plain.data() + pos);
      if (header_len > left - 4) Fail(start, "a record header in a chunk runs past its end");
      Fields inner;
      if (const std::string problem = ParseFields(plain.data() + pos + 4, header_len, &inner);
          !problem.empty()) {
        Fail(start, "a record in a chunk: " + problem);
      }
      pos += 4 + header_len;
      if (plain.size() - pos < 4) Fail(start, "a record in a chunk is cut short");
      const std::uint32_t data_len = Le32(plain.data() + pos);
      pos += 4;
      if (data_len > plain.size() - pos)
        Fail(start, "a record's data in a chunk runs past its end");
      std::uint8_t op[1];
      if (!FieldBytes(inner, "op", op)) Fail(start, "a record in a chunk without its op field");
      if (op[0] == 0x07) {
        Fields connection;
        if (const std::string problem = ParseFields(plain.data() + pos, data_len, &connection);
            !problem.empty()) {
          Fail(start, "a connection record in a chunk: " + problem);
        }
        NoteConnection(inner, connection);
      }
      pos += data_len;
    }
    return starts;
  }

  // Index data (version 1): count entries of (sec, nsec, offset into the chunk).
  void CheckIndex(std::uint64_t start, const Fields& fields, const std::vector<std::uint8_t>& data,
                  const std::set<std::uint64_t>& inner_starts) const {
    std::uint8_t version[4], count[4];
    if (!FieldBytes(fields, "ver", version) || !FieldBytes(fields, "count", count) ||
        Le32(version) != 1 || static_cast<std::uint64_t>(Le32(count)) * 12 != data.size()) {
      Fail(start, "a malformed index record");
    }
    for (std::size_t i = 0; i < data.size(); i += 12) {
      if (inner_starts.count(Le32(data.data() + i + 8)) == 0) {
        Fail(start, "an index entry points to no message of its chunk");
      }
    }
  }

  std::string path_;
  std::uint64_t index_pos_ = 0;
  std::set<std::uint64_t> record_starts_, chunk_starts_;
  std::vector<std::pair<std::uint64_t, std::uint64_t>> chunk_infos_;  // record, chunk_pos
  std::map<std::string, std::string> topics_;                         // topic -> type, as read
};

}  // namespace

bool IsReadableRosType(const std::string& datatype) {
  for (const char* type : {kRosImageType, kRosCompressedImageType, kRosImuType, kRosNavSatFixType,
                           kRosMagneticFieldType, kRosCameraInfoType}) {
    if (datatype == type) return true;
  }
  return false;
}

std::string DescribeTopics(const std::vector<BagTopic>& topics) {
  if (topics.empty()) return "the bag has no topics";
  std::string out = "the bag's topics: ";
  for (std::size_t i = 0; i < topics.size(); ++i) {
    const BagTopic& t = topics[i];
    out += (i > 0 ? ", " : "") + t.topic + " (" + t.datatype + ", " + std::to_string(t.messages) +
           (t.messages == 1 ? " message)" : " messages)");
  }
  return out;
}

// ---- BagReader ----

struct BagReader::Impl {
  rosbag::Bag bag;
};

BagReader::BagReader(const std::string& path) : path_(path), impl_(std::make_unique<Impl>()) {
  SilenceLibraryLog();
  FramingCheck(path).Run();
  try {
    impl_->bag.open(path, rosbag::bagmode::Read);
    rosbag::View view(impl_->bag);
    std::map<std::string, BagTopic> by_name;
    for (const rosbag::ConnectionInfo* c : view.getConnections()) {
      BagTopic& topic = by_name[c->topic];
      if (topic.topic.empty()) {
        topic.topic = c->topic;
        topic.datatype = c->datatype;
      } else if (topic.datatype != c->datatype) {
        throw InputError(path, 0,
                         "topic " + c->topic + " is recorded with two message types (" +
                             topic.datatype + " and " + c->datatype + ")");
      }
    }
    // Message counts per topic, from the index (no message is read).
    for (auto& [name, topic] : by_name) {
      rosbag::View counted(impl_->bag, rosbag::TopicQuery(name));
      topic.messages = static_cast<std::int64_t>(counted.size());
      topics_.push_back(topic);
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(path, 0, "not a readable ROS 1 bag: a record claims more memory than exists");
  } catch (const std::exception& e) {
    throw InputError(path, 0,
                     std::string("not a readable ROS 1 bag (missing, cut short or corrupt; the "
                                 "index that lists a bag's topics is at its end): ") +
                         e.what());
  }
}

BagReader::~BagReader() = default;

const BagTopic* BagReader::FindTopic(const std::string& name) const {
  for (const BagTopic& topic : topics_) {
    if (topic.topic == name) return &topic;
  }
  return nullptr;
}

void BagReader::Read(const std::vector<std::string>& topics,
                     const std::function<bool(const BagMessage&)>& visit) const {
  for (const std::string& name : topics) {
    const BagTopic* topic = FindTopic(name);
    if (topic == nullptr) throw InputError(path_, 0, "no topic " + name + " in the bag");
    if (!IsReadableRosType(topic->datatype)) {
      throw InputError(
          path_, 0,
          "topic " + name + " has the type " + topic->datatype + ", which crop4d does not read");
    }
  }
  if (topics.empty()) return;
  try {
    rosbag::View view(impl_->bag, rosbag::TopicQuery(topics));
    BagMessage message;
    for (const rosbag::MessageInstance& instance : view) {
      message.topic = instance.getTopic();
      message.datatype = instance.getDataType();
      message.receive_time = FromRosTime(instance.getTime());
      bool decoded = false;
      if (message.datatype == kRosImageType) {
        decoded = Decode<sensor_msgs::Image>(instance, &message.payload);
      } else if (message.datatype == kRosCompressedImageType) {
        decoded = Decode<sensor_msgs::CompressedImage>(instance, &message.payload);
      } else if (message.datatype == kRosImuType) {
        decoded = Decode<sensor_msgs::Imu>(instance, &message.payload);
      } else if (message.datatype == kRosNavSatFixType) {
        decoded = Decode<sensor_msgs::NavSatFix>(instance, &message.payload);
      } else if (message.datatype == kRosMagneticFieldType) {
        decoded = Decode<sensor_msgs::MagneticField>(instance, &message.payload);
      } else if (message.datatype == kRosCameraInfoType) {
        decoded = Decode<sensor_msgs::CameraInfo>(instance, &message.payload);
      }
      if (!decoded) {
        throw InputError(path_, 0,
                         "a message on " + message.topic + " (" + message.datatype +
                             ") has a definition (md5 sum " + instance.getMD5Sum() +
                             ") that differs from that of sensor_msgs");
      }
      if (!visit(message)) break;
    }
  } catch (const InputError&) {
    throw;
  } catch (const std::bad_alloc&) {
    throw InputError(
        path_, 0,
        "corrupt ROS 1 bag: a record claims more memory than exists; " + DescribeTopics(topics_));
  } catch (const std::exception& e) {
    throw InputError(path_, 0,
                     std::string("corrupt ROS 1 bag (a chunk or message that cannot be read: ") +
                         e.what() + "); " + DescribeTopics(topics_));
  }
}

// ---- BagWriter ----

struct BagWriter::Impl {
  rosbag::Bag bag;
  bool open = false;
};

BagWriter::BagWriter(const std::string& path, BagCompression compression)
    : path_(path), impl_(std::make_unique<Impl>()) {
  SilenceLibraryLog();
  try {
    impl_->bag.open(path, rosbag::bagmode::Write);
    impl_->bag.setCompression(compression == BagCompression::kBz2 ? rosbag::compression::BZ2
                              : compression == BagCompression::kLz4
                                  ? rosbag::compression::LZ4
                                  : rosbag::compression::Uncompressed);
    impl_->open = true;
  } catch (const std::exception& e) {
    throw InputError(path, 0, std::string("cannot write the bag: ") + e.what());
  }
}

BagWriter::~BagWriter() {
  try {
    Close();
  } catch (...) {
    // A destructor does not throw; Close() reports the failure to callers that ask.
  }
}

void BagWriter::Write(const std::string& topic, BagTime receive_time, const RosMessage& message) {
  if (!impl_->open) throw InputError(path_, 0, "the bag is closed");
  try {
    std::visit(Writer{&impl_->bag, topic, ToRosTime(receive_time, path_)}, message);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path_, 0, std::string("cannot write to the bag: ") + e.what());
  }
}

void BagWriter::WriteString(const std::string& topic, BagTime receive_time,
                            const std::string& text) {
  if (!impl_->open) throw InputError(path_, 0, "the bag is closed");
  std_msgs::String m;
  m.data = text;
  try {
    impl_->bag.write(topic, ToRosTime(receive_time, path_), m);
  } catch (const InputError&) {
    throw;
  } catch (const std::exception& e) {
    throw InputError(path_, 0, std::string("cannot write to the bag: ") + e.what());
  }
}

void BagWriter::Close() {
  if (!impl_->open) return;
  impl_->open = false;
  try {
    impl_->bag.close();
  } catch (const std::exception& e) {
    throw InputError(path_, 0, std::string("cannot close the bag: ") + e.what());
  }
}

}  // namespace crop4d::io
