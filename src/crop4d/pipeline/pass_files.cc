#include "crop4d/pipeline/pass_files.h"

#include <bit>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/features/hash.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"

namespace crop4d::pipeline {
namespace {

static_assert(std::endian::native == std::endian::little,
              "tracks.bin is written in the machine's byte order, assumed little-endian");

constexpr char kMagic[8] = {'C', '4', 'D', 'T', 'R', 'A', 'K', '\0'};
// Far above any real pass; a larger count means corruption (checked before allocating).
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 32;

template <typename T>
void Put(std::string* out, const T& value) {
  static_assert(std::is_trivially_copyable_v<T>);
  out->append(reinterpret_cast<const char*>(&value), sizeof(T));
}

void PutTracks(std::string* out, const std::vector<PassTrack>& tracks) {
  Put<std::uint64_t>(out, tracks.size());
  for (const PassTrack& t : tracks) {
    for (int k = 0; k < 3; ++k) Put<double>(out, t.position_world(k));
    out->append(reinterpret_cast<const char*>(t.color.data()), 3);
    Put<std::uint32_t>(out, static_cast<std::uint32_t>(t.observations.size()));
    for (const features::Observation& o : t.observations) {
      Put<std::int32_t>(out, o.image);
      Put<std::int32_t>(out, o.feature);
    }
  }
}

// Reads little-endian values from a byte range; any read past the end throws "truncated".
class Reader {
 public:
  Reader(const std::string& path, const std::string& bytes, std::size_t end)
      : path_(path), bytes_(bytes), end_(end) {}
  template <typename T>
  T Get() {
    if (pos_ + sizeof(T) > end_) throw InputError(path_ + ": truncated tracks file");
    T value;
    std::memcpy(&value, bytes_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  void GetTracks(std::vector<PassTrack>* tracks) {
    const auto count = Get<std::uint64_t>();
    // Each track takes at least 31 bytes: a count larger than the bytes left is corrupt.
    if (count > kMaxCount || count * 31 > end_ - pos_) {
      throw InputError(path_ + ": corrupt tracks file (impossible track count)");
    }
    tracks->resize(count);
    for (PassTrack& t : *tracks) {
      for (int k = 0; k < 3; ++k) t.position_world(k) = Get<double>();
      for (int k = 0; k < 3; ++k) t.color[k] = Get<std::uint8_t>();
      const auto n = Get<std::uint32_t>();
      if (std::uint64_t{n} * 8 > end_ - pos_) {
        throw InputError(path_ + ": corrupt tracks file (impossible observation count)");
      }
      t.observations.resize(n);
      for (features::Observation& o : t.observations) {
        o.image = Get<std::int32_t>();
        o.feature = Get<std::int32_t>();
        if (o.image < 0 || o.feature < 0) {
          throw InputError(path_ + ": corrupt tracks file (negative index)");
        }
      }
    }
  }
  std::size_t pos() const { return pos_; }

 private:
  const std::string& path_;
  const std::string& bytes_;
  std::size_t end_;
  std::size_t pos_ = 0;
};

constexpr int kStateColumns = 1 + 7 + 3 + 3 + 6;

}  // namespace

void WritePassTracks(const std::string& path, const PassTracks& tracks) {
  std::string bytes(kMagic, sizeof(kMagic));
  Put<std::uint32_t>(&bytes, kPassTracksVersion);
  PutTracks(&bytes, tracks.landmarks);
  PutTracks(&bytes, tracks.cloud);
  features::Fnv1aHasher hasher;
  hasher.AddBytes(bytes.data(), bytes.size());
  Put<std::uint64_t>(&bytes, hasher.hash());
  io::WriteFileAtomic(path, bytes);
}

PassTracks ReadPassTracks(const std::string& path) {
  if (!std::filesystem::exists(path)) {
    throw InputError(path + ": missing (rerun `crop4d slam` for this pass)");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path + ": cannot be read");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (bytes.size() < sizeof(kMagic) + 4 + 8 ||
      std::memcmp(bytes.data(), kMagic, sizeof(kMagic)) != 0) {
    throw InputError(path + ": not a crop4d tracks file");
  }
  std::uint32_t version = 0;
  std::memcpy(&version, bytes.data() + sizeof(kMagic), 4);
  if (version != kPassTracksVersion) {
    throw InputError(path + ": tracks file version " + std::to_string(version) + ", expected " +
                     std::to_string(kPassTracksVersion) + " (rerun `crop4d slam --force`)");
  }
  const std::size_t end = bytes.size() - 8;
  std::uint64_t stored = 0;
  std::memcpy(&stored, bytes.data() + end, 8);
  features::Fnv1aHasher hasher;
  hasher.AddBytes(bytes.data(), end);
  Reader reader(path, bytes, end);
  reader.Get<std::uint64_t>();  // magic
  reader.Get<std::uint32_t>();  // version
  PassTracks tracks;
  try {
    reader.GetTracks(&tracks.landmarks);
    reader.GetTracks(&tracks.cloud);
  } catch (const InputError&) {
    if (hasher.hash() != stored) throw InputError(path + ": corrupt tracks file (checksum)");
    throw;
  }
  if (hasher.hash() != stored) throw InputError(path + ": corrupt tracks file (checksum)");
  if (reader.pos() != end) throw InputError(path + ": corrupt tracks file (trailing bytes)");
  return tracks;
}

void WritePassStates(const std::string& path, const std::vector<slam::RowState>& states) {
  std::ostringstream out;
  out << "# t [ns],px,py,pz,qx,qy,qz,qw,vx,vy,vz,wx,wy,wz,bgx,bgy,bgz,bax,bay,baz"
         " (world_from_body, world velocity m/s, body angular rate rad/s, gyro bias rad/s,"
         " accel bias m/s^2)\n";
  out.precision(17);
  for (const slam::RowState& s : states) {
    const Eigen::Vector3d& p = s.nav.world_from_body.translation();
    const Eigen::Quaterniond& q = s.nav.world_from_body.rotation();
    out << s.t << ',' << p.x() << ',' << p.y() << ',' << p.z() << ',' << q.x() << ',' << q.y()
        << ',' << q.z() << ',' << q.w();
    for (int k = 0; k < 3; ++k) out << ',' << s.nav.vel_world(k);
    for (int k = 0; k < 3; ++k) out << ',' << s.nav.rate_body(k);
    for (int k = 0; k < 6; ++k) out << ',' << s.bias(k);
    out << '\n';
  }
  io::WriteFileAtomic(path, out.str());
}

std::vector<slam::RowState> ReadPassStates(const std::string& path) {
  io::CsvReader reader(path);
  io::CsvRecord record;
  std::vector<slam::RowState> states;
  while (reader.Next(&record)) {
    if (record.fields.size() != kStateColumns) {
      throw InputError(path, record.line,
                       "expected " + std::to_string(kStateColumns) + " values, found " +
                           std::to_string(record.fields.size()));
    }
    slam::RowState s;
    double v[kStateColumns - 1];
    if (!io::ParseInt64(record.fields[0], &s.t)) {
      throw InputError(path, record.line, "bad timestamp");
    }
    for (int k = 1; k < kStateColumns; ++k) {
      if (!io::ParseDouble(record.fields[k], &v[k - 1])) {
        throw InputError(path, record.line, "bad number in column " + std::to_string(k + 1));
      }
    }
    const Eigen::Quaterniond q(v[6], v[3], v[4], v[5]);
    if (std::abs(q.norm() - 1.0) > 1e-6) {
      throw InputError(path, record.line, "rotation quaternion is not unit length");
    }
    s.nav.world_from_body = geometry::Rigid3(q.normalized(), Eigen::Vector3d(v[0], v[1], v[2]));
    s.nav.vel_world = Eigen::Vector3d(v[7], v[8], v[9]);
    s.nav.rate_body = Eigen::Vector3d(v[10], v[11], v[12]);
    for (int k = 0; k < 6; ++k) s.bias(k) = v[13 + k];
    if (!states.empty() && s.t <= states.back().t) {
      throw InputError(path, record.line, "state times not increasing");
    }
    states.push_back(s);
  }
  return states;
}

}  // namespace crop4d::pipeline
