#include "crop4d/workspace/pass_files.h"

#include <cmath>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/checksummed_file.h"
#include "crop4d/io/csv.h"

namespace crop4d::workspace {
namespace {

constexpr char kMagic[8] = {'C', '4', 'D', 'T', 'R', 'A', 'K', '\0'};
// Far above any real pass; a larger count means corruption (checked before allocating).
constexpr std::uint64_t kMaxCount = std::uint64_t{1} << 32;

void PutTracks(io::ByteBuffer* out, const std::vector<PassTrack>& tracks) {
  out->Put<std::uint64_t>(tracks.size());
  for (const PassTrack& t : tracks) {
    for (int k = 0; k < 3; ++k) out->Put<double>(t.position_world(k));
    out->PutBytes(t.color.data(), 3);
    out->Put<std::uint32_t>(static_cast<std::uint32_t>(t.observations.size()));
    for (const features::Observation& o : t.observations) {
      out->Put<std::int32_t>(o.image);
      out->Put<std::int32_t>(o.feature);
    }
  }
}

// Reads one value of the payload; the reader never reads into the checksum footer, so running
// out of payload means the file is truncated (or a count in it is wrong).
template <typename T>
T Get(const std::string& path, io::ChecksummedFileReader* reader) {
  T value;
  if (!reader->Get(&value)) throw InputError(path + ": truncated tracks file");
  return value;
}

// The checksum is only known once the whole payload is read, so every count is checked against
// the bytes left before it sizes an allocation.
void GetTracks(const std::string& path, io::ChecksummedFileReader* reader,
               std::vector<PassTrack>* tracks) {
  const auto count = Get<std::uint64_t>(path, reader);
  // Each track takes at least 31 bytes: a count larger than the bytes left is corrupt.
  if (count > kMaxCount || count * 31 > reader->remaining()) {
    throw InputError(path + ": corrupt tracks file (impossible track count)");
  }
  tracks->resize(count);
  for (PassTrack& t : *tracks) {
    for (int k = 0; k < 3; ++k) t.position_world(k) = Get<double>(path, reader);
    for (int k = 0; k < 3; ++k) t.color[k] = Get<std::uint8_t>(path, reader);
    const auto n = Get<std::uint32_t>(path, reader);
    if (std::uint64_t{n} * 8 > reader->remaining()) {
      throw InputError(path + ": corrupt tracks file (impossible observation count)");
    }
    t.observations.resize(n);
    for (features::Observation& o : t.observations) {
      o.image = Get<std::int32_t>(path, reader);
      o.feature = Get<std::int32_t>(path, reader);
      if (o.image < 0 || o.feature < 0) {
        throw InputError(path + ": corrupt tracks file (negative index)");
      }
    }
  }
}

constexpr int kStateColumns = 1 + 7 + 3 + 3 + 6;

}  // namespace

void WritePassTracks(const std::string& path, const PassTracks& tracks) {
  io::ByteBuffer bytes;
  PutTracks(&bytes, tracks.landmarks);
  PutTracks(&bytes, tracks.cloud);
  io::ChecksummedFileWriter writer(path, kMagic, kPassTracksVersion);
  writer.Write(bytes);
  writer.Commit();
}

PassTracks ReadPassTracks(const std::string& path) {
  io::ChecksummedFileReader reader(path, kMagic, kPassTracksVersion, "tracks file");
  switch (reader.status()) {
    case io::ChecksummedFileStatus::kOk:
      break;
    case io::ChecksummedFileStatus::kMissing:
      throw InputError(path + ": missing (rerun `crop4d slam` for this pass)");
    case io::ChecksummedFileStatus::kUnreadable:
      throw InputError(path + ": cannot be read (" + reader.detail() + ")");
    case io::ChecksummedFileStatus::kBadMagic:
      throw InputError(path + ": not a crop4d tracks file");
    case io::ChecksummedFileStatus::kWrongVersion:
      throw InputError(path + ": tracks file version " + std::to_string(reader.found_version()) +
                       ", expected " + std::to_string(kPassTracksVersion) +
                       " (rerun `crop4d slam --force`)");
    case io::ChecksummedFileStatus::kTruncated:
      throw InputError(path + ": truncated tracks file");
    case io::ChecksummedFileStatus::kCorrupt:
      throw InputError(path + ": corrupt tracks file (" + reader.detail() + ")");
  }
  PassTracks tracks;
  GetTracks(path, &reader, &tracks.landmarks);
  GetTracks(path, &reader, &tracks.cloud);
  switch (reader.Finish("the cloud")) {
    case io::ChecksummedFileStatus::kOk:
      return tracks;
    case io::ChecksummedFileStatus::kTruncated:
      throw InputError(path + ": truncated tracks file");
    default:
      // "checksum mismatch" or "<n> unexpected bytes after the cloud".
      throw InputError(path + ": corrupt tracks file (" + reader.detail() + ")");
  }
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

}  // namespace crop4d::workspace
