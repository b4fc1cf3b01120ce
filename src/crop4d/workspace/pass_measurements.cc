#include "crop4d/workspace/pass_measurements.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/io/checksummed_file.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_list.h"

namespace crop4d::workspace {
namespace {

constexpr char kMagic[8] = {'C', '4', 'D', 'M', 'E', 'A', 'S', '\0'};
// Names, folders and file names are far shorter; a longer string means corruption.
constexpr std::size_t kMaxStringLength = 4096;

enum PartBits : std::uint8_t { kCameraBit = 1, kImuBit = 2, kGpsBit = 4 };

// The bytes of one record of each list, at the least: a count above the bytes left is corrupt.
constexpr std::uint64_t kMinImageBytes = 8 + 8 + 4;
constexpr std::uint64_t kImuSampleBytes = 8 + 6 * 8;
constexpr std::uint64_t kGpsFixBytes = 8 + 5 * 8 + 4;

class Writer {
 public:
  void U8(std::uint8_t v) { out_.Put(v); }
  void I32(std::int32_t v) { out_.Put(v); }
  void I64(std::int64_t v) { out_.Put(v); }
  void U64(std::uint64_t v) { out_.Put(v); }
  void F64(double v) { out_.Put(v); }
  void Vec3(const Eigen::Vector3d& v) {
    for (int k = 0; k < 3; ++k) F64(v(k));
  }
  void String(const std::string& text) {
    out_.PutString(text, kMaxStringLength, "measurements.bin");
  }
  void Pose(const geometry::Rigid3& pose) {
    const Eigen::Quaterniond& q = pose.rotation();
    for (double v : {q.x(), q.y(), q.z(), q.w()}) F64(v);
    Vec3(pose.translation());
  }
  const io::ByteBuffer& bytes() const { return out_; }

 private:
  io::ByteBuffer out_;
};

// Reads the payload of measurements.bin; any shortfall or impossible value throws InputError naming
// the file.
class Reader {
 public:
  Reader(std::string path, io::ChecksummedFileReader* in) : path_(std::move(path)), in_(in) {}

  template <typename T>
  T Get() {
    T value;
    if (!in_->Get(&value)) Fail("truncated measurements file");
    return value;
  }
  std::uint8_t U8() { return Get<std::uint8_t>(); }
  std::int32_t I32() { return Get<std::int32_t>(); }
  std::int64_t I64() { return Get<std::int64_t>(); }
  double F64() { return Get<double>(); }
  Eigen::Vector3d Vec3() {
    Eigen::Vector3d v;
    for (int k = 0; k < 3; ++k) v(k) = F64();
    return v;
  }
  std::string String() {
    const auto length = Get<std::uint32_t>();
    if (length > kMaxStringLength) Fail("corrupt measurements file (impossible string length)");
    std::string text(length, '\0');
    if (!in_->Read(text.data(), length)) Fail("truncated measurements file");
    return text;
  }
  geometry::Rigid3 Pose() {
    double q[4];
    for (double& v : q) v = F64();
    const Eigen::Vector3d t = Vec3();
    const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    if (!(std::abs(rotation.norm() - 1.0) <= geometry::Rigid3::kUnitQuaternionTolerance)) {
      Fail("corrupt measurements file (a rotation is not a unit quaternion)");
    }
    return geometry::Rigid3::FromUnitQuaternion(rotation, t);
  }
  // A list's length, checked against the bytes left before the caller allocates for it.
  std::uint64_t Count(std::uint64_t min_record_bytes) {
    const auto count = Get<std::uint64_t>();
    if (count > in_->remaining() / min_record_bytes) {
      Fail("corrupt measurements file (impossible count " + std::to_string(count) + ")");
    }
    return count;
  }
  [[noreturn]] void Fail(const std::string& why) const { throw InputError(path_ + ": " + why); }

 private:
  std::string path_;
  io::ChecksummedFileReader* in_;
};

void PutCamera(const slam::CameraStream& camera, const std::string& image_folder, Writer* w) {
  const io::CameraSensor& s = camera.sensor;
  const geometry::PinholeRadTan& c = s.camera;
  w->String(s.name);
  w->I32(c.width);
  w->I32(c.height);
  for (double v : {c.fx, c.fy, c.cx, c.cy, c.k1, c.k2, c.p1, c.p2, c.k3}) w->F64(v);
  w->F64(s.rate_hz);
  w->Pose(s.body_from_sensor);
  w->U8(s.height_above_ground_m.has_value());
  w->F64(s.height_above_ground_m.value_or(0.0));
  w->String(image_folder);
  w->U64(camera.images.size());
  for (const io::ImageEntry& e : camera.images) {
    w->I64(e.t);
    w->I64(e.line);
    w->String(e.filename);
  }
}

slam::CameraStream GetCamera(Reader* r, std::string* image_folder) {
  slam::CameraStream camera;
  io::CameraSensor& s = camera.sensor;
  geometry::PinholeRadTan& c = s.camera;
  s.name = r->String();
  c.width = r->I32();
  c.height = r->I32();
  for (double* v : {&c.fx, &c.fy, &c.cx, &c.cy, &c.k1, &c.k2, &c.p1, &c.p2, &c.k3}) *v = r->F64();
  s.rate_hz = r->F64();
  s.body_from_sensor = r->Pose();
  const bool has_height = r->U8() != 0;
  const double height = r->F64();
  if (has_height) s.height_above_ground_m = height;
  *image_folder = r->String();
  camera.images.resize(r->Count(kMinImageBytes));
  for (io::ImageEntry& e : camera.images) {
    e.t = r->I64();
    e.line = r->I64();
    e.filename = r->String();
  }
  return camera;
}

void PutImu(const slam::ImuStream& imu, Writer* w) {
  const io::ImuSensor& s = imu.sensor;
  w->String(s.name);
  for (double v : {s.rate_hz, s.gyroscope_noise_density, s.gyroscope_random_walk,
                   s.accelerometer_noise_density, s.accelerometer_random_walk}) {
    w->F64(v);
  }
  w->Pose(s.body_from_sensor);
  w->U64(imu.samples.size());
  for (const slam::ImuSample& m : imu.samples) {
    w->I64(m.timestamp);
    w->Vec3(m.gyro_body);
    w->Vec3(m.accel_body);
  }
}

slam::ImuStream GetImu(Reader* r) {
  slam::ImuStream imu;
  io::ImuSensor& s = imu.sensor;
  s.name = r->String();
  for (double* v : {&s.rate_hz, &s.gyroscope_noise_density, &s.gyroscope_random_walk,
                    &s.accelerometer_noise_density, &s.accelerometer_random_walk}) {
    *v = r->F64();
  }
  s.body_from_sensor = r->Pose();
  imu.samples.resize(r->Count(kImuSampleBytes));
  for (slam::ImuSample& m : imu.samples) {
    m.timestamp = r->I64();
    m.gyro_body = r->Vec3();
    m.accel_body = r->Vec3();
  }
  return imu;
}

void PutGps(const slam::GpsStream& gps, Writer* w) {
  const io::GpsSensor& s = gps.sensor;
  w->String(s.name);
  w->U8(s.kind == io::GpsKind::kRtk ? 0 : 1);
  w->F64(s.rate_hz);
  w->Vec3(s.antenna_in_body);
  w->F64(s.default_sigma_h);
  w->F64(s.default_sigma_v);
  w->U64(gps.fixes.size());
  for (const slam::GpsFixWorld& f : gps.fixes) {
    w->I64(f.t);
    w->Vec3(f.position_world);
    w->F64(f.sigma_h);
    w->F64(f.sigma_v);
    w->I32(static_cast<std::int32_t>(f.fix));
  }
}

slam::GpsStream GetGps(Reader* r) {
  slam::GpsStream gps;
  io::GpsSensor& s = gps.sensor;
  s.name = r->String();
  const std::uint8_t kind = r->U8();
  if (kind > 1) r->Fail("corrupt measurements file (GPS kind " + std::to_string(kind) + ")");
  s.kind = kind == 0 ? io::GpsKind::kRtk : io::GpsKind::kStandard;
  s.rate_hz = r->F64();
  s.antenna_in_body = r->Vec3();
  s.default_sigma_h = r->F64();
  s.default_sigma_v = r->F64();
  gps.fixes.resize(r->Count(kGpsFixBytes));
  for (slam::GpsFixWorld& f : gps.fixes) {
    f.t = r->I64();
    f.position_world = r->Vec3();
    f.sigma_h = r->F64();
    f.sigma_v = r->F64();
    const std::int32_t fix = r->I32();
    f.fix = static_cast<io::GpsFix>(fix);
    if (f.fix != io::GpsFix::kNone && f.fix != io::GpsFix::kSingle && f.fix != io::GpsFix::kDgps &&
        f.fix != io::GpsFix::kRtkFixed && f.fix != io::GpsFix::kRtkFloat) {
      r->Fail("corrupt measurements file (GPS fix quality " + std::to_string(fix) + ")");
    }
  }
  return gps;
}

// Turns the container's verdict on the header or the end into the reader's error.
void ThrowOnStatus(const std::string& path, io::ChecksummedFileStatus status,
                   const io::ChecksummedFileReader& reader) {
  switch (status) {
    case io::ChecksummedFileStatus::kOk:
      return;
    case io::ChecksummedFileStatus::kMissing:
      throw InputError(path + ": missing (rerun `crop4d slam --force` for this pass)");
    case io::ChecksummedFileStatus::kUnreadable:
      throw InputError(path + ": cannot be read (" + reader.detail() + ")");
    case io::ChecksummedFileStatus::kBadMagic:
      throw InputError(path + ": not a crop4d pass measurements file");
    case io::ChecksummedFileStatus::kWrongVersion:
      throw InputError(path + ": measurements file version " +
                       std::to_string(reader.found_version()) + ", expected " +
                       std::to_string(kPassMeasurementsVersion) + " (rerun `crop4d slam --force`)");
    case io::ChecksummedFileStatus::kTruncated:
      throw InputError(path + ": truncated measurements file");
    case io::ChecksummedFileStatus::kCorrupt:
      throw InputError(path + ": corrupt measurements file (" + reader.detail() + ")");
  }
}

}  // namespace

std::string PassMeasurements::ImagePath(const std::string& field_folder, std::size_t i) const {
  return (std::filesystem::path(field_folder) / image_folder / camera->images.at(i).filename)
      .string();
}

io::ImageSequence PassMeasurements::Images(const std::string& field_folder) const {
  return io::ImageSequence(camera->sensor,
                           (std::filesystem::path(field_folder) / image_folder).string(),
                           camera->images);
}

io::ImageSequence SessionImages(const std::string& workspace, const std::string& session,
                                const std::string& field_folder, const std::string& camera) {
  const Layout layout(workspace);
  std::optional<PassMeasurements> merged;
  std::string first_pass;
  std::map<Timestamp, io::ImageEntry> entries;
  for (const slam::RowPass& pass : ReadPassList(workspace, session)) {
    const std::string path = layout.PassMeasurements(session, pass.id).string();
    PassMeasurements m = ReadPassMeasurements(path);
    if (!m.camera) continue;
    if (merged && (m.camera->sensor.name != merged->camera->sensor.name ||
                   m.image_folder != merged->image_folder)) {
      throw InputError(path + ": camera '" + m.camera->sensor.name + "', but pass " + first_pass +
                       " of the session used '" + merged->camera->sensor.name +
                       "' (rerun `crop4d slam --force`)");
    }
    for (const io::ImageEntry& e : m.camera->images) entries.emplace(e.t, e);
    if (!merged) {
      merged = std::move(m);
      first_pass = pass.id;
    }
  }
  if (!merged) {
    throw InputError(layout.PassList(session).string() + ": no pass of session " + session +
                     " has a camera (run `crop4d slam` with a camera)");
  }
  if (!camera.empty() && camera != merged->camera->sensor.name) {
    throw InputError("camera '" + camera + "': row SLAM of session " + session + " used camera '" +
                     merged->camera->sensor.name + "'");
  }
  merged->camera->images.clear();
  for (auto& [t, e] : entries) merged->camera->images.push_back(std::move(e));
  return merged->Images(field_folder);
}

PassMeasurements SelectPassMeasurements(const slam::CameraStream* camera,
                                        const slam::ImuStream* imu, const slam::GpsStream* gps,
                                        const std::vector<Timestamp>& image_times, Timestamp first,
                                        Timestamp last, std::string image_folder) {
  PassMeasurements m;
  if (camera != nullptr) {
    m.image_folder = std::move(image_folder);
    m.camera.emplace();
    m.camera->sensor = camera->sensor;
    const std::set<Timestamp> wanted(image_times.begin(), image_times.end());
    for (const io::ImageEntry& e : camera->images) {
      if (wanted.count(e.t) != 0) m.camera->images.push_back(e);
    }
  }
  if (imu != nullptr) {
    m.imu.emplace();
    m.imu->sensor = imu->sensor;
    const std::vector<slam::ImuSample>& samples = imu->samples;
    const Timestamp from = first - SecondsToTimestamp(kPassImuMarginSeconds);
    const Timestamp to = last + SecondsToTimestamp(kPassImuMarginSeconds);
    const auto by_time = [](const slam::ImuSample& s, Timestamp t) { return s.timestamp < t; };
    auto begin = std::lower_bound(samples.begin(), samples.end(), from, by_time);
    auto end = std::lower_bound(samples.begin(), samples.end(), to, by_time);
    // One sample at or before `first` and one at or after `last` even across a gap longer than
    // the margin.
    if (begin != samples.begin() && (begin == samples.end() || begin->timestamp > first)) --begin;
    if (end != samples.end() && (end == samples.begin() || std::prev(end)->timestamp < last)) ++end;
    m.imu->samples.assign(begin, end);
  }
  if (gps != nullptr) {
    m.gps.emplace();
    m.gps->sensor = gps->sensor;
    for (const slam::GpsFixWorld& f : gps->fixes) {
      if (f.t >= first && f.t <= last) m.gps->fixes.push_back(f);
    }
  }
  return m;
}

void WritePassMeasurements(const std::string& path, const PassMeasurements& m) {
  Writer w;
  w.U8((m.camera ? kCameraBit : 0) | (m.imu ? kImuBit : 0) | (m.gps ? kGpsBit : 0));
  if (m.camera) PutCamera(*m.camera, m.image_folder, &w);
  if (m.imu) PutImu(*m.imu, &w);
  if (m.gps) PutGps(*m.gps, &w);
  io::ChecksummedFileWriter writer(path, kMagic, kPassMeasurementsVersion);
  writer.Write(w.bytes());
  writer.Commit();
}

PassMeasurements ReadPassMeasurements(const std::string& path) {
  io::ChecksummedFileReader in(path, kMagic, kPassMeasurementsVersion, "pass measurements");
  ThrowOnStatus(path, in.status(), in);
  Reader r(path, &in);
  PassMeasurements m;
  const std::uint8_t parts = r.U8();
  if ((parts & ~(kCameraBit | kImuBit | kGpsBit)) != 0) {
    r.Fail("corrupt measurements file (unknown parts " + std::to_string(parts) + ")");
  }
  if (parts & kCameraBit) m.camera = GetCamera(&r, &m.image_folder);
  if (parts & kImuBit) m.imu = GetImu(&r);
  if (parts & kGpsBit) m.gps = GetGps(&r);
  ThrowOnStatus(path, in.Finish("the measurements"), in);
  return m;
}

}  // namespace crop4d::workspace
