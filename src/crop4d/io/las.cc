#include "crop4d/io/las.h"

#include <cpl_conv.h>
#include <ogr_spatialref.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <bit>
#include <chrono>
#include <cmath>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <limits>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/ply.h"

namespace crop4d::io {
namespace {

static_assert(std::endian::native == std::endian::little,
              "the LAS writer assumes a little-endian machine");

// ---- little-endian byte buffers ---------------------------------------------------------------

class ByteWriter {
 public:
  explicit ByteWriter(std::string* out) : out_(out) {}
  template <typename T>
  void Put(T value) {
    char bytes[sizeof(T)];
    std::memcpy(bytes, &value, sizeof(T));
    out_->append(bytes, sizeof(T));
  }
  // A fixed-size character field, NUL-padded (and truncated to `size`).
  void PutText(const std::string& text, std::size_t size) {
    std::string field = text.substr(0, size);
    field.resize(size, '\0');
    out_->append(field);
  }
  void PutBytes(const std::string& bytes) { out_->append(bytes); }

 private:
  std::string* out_;
};

class ByteReader {
 public:
  explicit ByteReader(const char* data) : data_(data) {}
  template <typename T>
  T Get() {
    T value;
    std::memcpy(&value, data_ + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }
  // A fixed-size character field up to its first NUL.
  std::string GetText(std::size_t size) {
    std::string text(data_ + pos_, size);
    pos_ += size;
    const std::size_t nul = text.find('\0');
    if (nul != std::string::npos) text.resize(nul);
    return text;
  }
  std::size_t pos() const { return pos_; }

 private:
  const char* data_;
  std::size_t pos_ = 0;
};

// The (E)VLR whose header starts at bytes[*pos], which must end by `end`; moves *pos past it.
// An EVLR (`extended`) has a 64-bit length, a VLR a 16-bit one. Returns an error message
// (`label` names the record, `past_end` says what a record that does not fit does) or "".
std::string ReadVlr(const std::string& bytes, std::uint64_t* pos, std::uint64_t end, bool extended,
                    const std::string& label, const std::string& past_end, LasVlr* vlr) {
  const std::uint64_t header_size = extended ? kLasEvlrHeaderSize : kLasVlrHeaderSize;
  if (*pos > end || end - *pos < header_size) return label + " " + past_end;
  ByteReader v(bytes.data() + *pos);
  v.Get<std::uint16_t>();  // reserved
  vlr->user_id = v.GetText(16);
  vlr->record_id = v.Get<std::uint16_t>();
  const std::uint64_t length =
      extended ? v.Get<std::uint64_t>() : std::uint64_t{v.Get<std::uint16_t>()};
  vlr->description = v.GetText(32);
  *pos += header_size;
  if (length > end - *pos) return label + " ('" + vlr->user_id + "') " + past_end;
  vlr->data = bytes.substr(*pos, length);
  *pos += length;
  return "";
}

void PutVlrHeader(ByteWriter& w, const LasVlr& vlr, bool extended) {
  w.Put<std::uint16_t>(0);  // reserved
  w.PutText(vlr.user_id, 16);
  w.Put<std::uint16_t>(vlr.record_id);
  if (extended) {
    w.Put<std::uint64_t>(vlr.data.size());
  } else {
    w.Put<std::uint16_t>(static_cast<std::uint16_t>(vlr.data.size()));
  }
  w.PutText(vlr.description, 32);
}

// Today's date (UTC) as year and day of the year (1 = January 1st).
void Today(int* year, int* day_of_year) {
  const std::time_t now = std::chrono::system_clock::to_time_t(std::chrono::system_clock::now());
  std::tm utc{};
  gmtime_r(&now, &utc);
  *year = utc.tm_year + 1900;
  *day_of_year = utc.tm_yday + 1;
}

std::int32_t Quantise(double value, double offset, double scale, const std::string& path) {
  const double q = std::round((value - offset) / scale);
  if (!(q >= double(std::numeric_limits<std::int32_t>::min()) &&
        q <= double(std::numeric_limits<std::int32_t>::max()))) {
    throw InputError(path, 0,
                     "the point cloud's extent does not fit LAS int32 coordinates at scale " +
                         std::to_string(scale) + " m");
  }
  return static_cast<std::int32_t>(q);
}

// UTC instants (s since the Unix epoch) from which GPS time is one more second ahead of UTC:
// the leap seconds since the GPS epoch (IERS Bulletin C; none announced after 2017-01-01).
constexpr std::int64_t kLeapSecondsUnix[] = {
    362793600,   // 1981-07-01
    394329600,   // 1982-07-01
    425865600,   // 1983-07-01
    489024000,   // 1985-07-01
    567993600,   // 1988-01-01
    631152000,   // 1990-01-01
    662688000,   // 1991-01-01
    709948800,   // 1992-07-01
    741484800,   // 1993-07-01
    773020800,   // 1994-07-01
    820454400,   // 1996-01-01
    867715200,   // 1997-07-01
    915148800,   // 1999-01-01
    1136073600,  // 2006-01-01
    1230768000,  // 2009-01-01
    1341100800,  // 2012-07-01
    1435708800,  // 2015-07-01
    1483228800,  // 2017-01-01
};
// The GPS epoch, 1980-01-06 00:00:00 UTC, in Unix seconds; the LAS offset of adjusted standard
// GPS time.
constexpr std::int64_t kGpsEpochUnix = 315964800;
constexpr double kAdjustedGpsOffset = 1e9;

}  // namespace

std::uint8_t AsprsVegetationClass(double height_above_ground_m) {
  if (height_above_ground_m < 0.5) return kAsprsLowVegetation;
  if (height_above_ground_m < 2.0) return kAsprsMediumVegetation;
  return kAsprsHighVegetation;
}

int GpsMinusUtcSeconds(Timestamp utc) {
  // Floor division: instants before 1970 are before every leap second.
  const std::int64_t seconds =
      utc >= 0 ? utc / kNanosPerSecond : -((-utc + kNanosPerSecond - 1) / kNanosPerSecond);
  int leaps = 0;
  for (const std::int64_t leap : kLeapSecondsUnix) leaps += seconds >= leap ? 1 : 0;
  return leaps;
}

double AdjustedStandardGpsTime(Timestamp utc) {
  // Whole seconds and the fraction apart, so that the large part is exact.
  const Timestamp whole = (utc / kNanosPerSecond) * kNanosPerSecond;
  const std::int64_t gps_seconds =
      whole / kNanosPerSecond - kGpsEpochUnix + GpsMinusUtcSeconds(utc);
  return double(gps_seconds - std::int64_t(kAdjustedGpsOffset)) +
         double(utc - whole) / double(kNanosPerSecond);
}

Timestamp UtcFromAdjustedStandardGpsTime(double gps_time) {
  // GPS time as nanoseconds on the Unix scale, then the leap seconds at that instant (looked up
  // twice: near a leap second the first guess may be one second off).
  const double whole = std::floor(gps_time);
  const Timestamp gps_unix_ns =
      (static_cast<Timestamp>(whole) + static_cast<Timestamp>(kAdjustedGpsOffset) + kGpsEpochUnix) *
          kNanosPerSecond +
      static_cast<Timestamp>(std::llround((gps_time - whole) * 1e9));
  Timestamp utc = gps_unix_ns - Timestamp{GpsMinusUtcSeconds(gps_unix_ns)} * kNanosPerSecond;
  utc = gps_unix_ns - Timestamp{GpsMinusUtcSeconds(utc)} * kNanosPerSecond;
  return utc;
}

std::string EpsgWkt(int epsg) {
  OGRSpatialReference srs;
  if (epsg <= 0 || srs.importFromEPSG(epsg) != OGRERR_NONE) {
    throw InputError("EPSG:" + std::to_string(epsg), 0, "unknown coordinate reference system");
  }
  char* wkt = nullptr;
  // WKT1 (OGC 01-009), the form LAS 1.4 names ("OGC Coordinate Transformation Services").
  const char* const options[] = {"FORMAT=WKT1_GDAL", nullptr};
  if (srs.exportToWkt(&wkt, options) != OGRERR_NONE || wkt == nullptr) {
    CPLFree(wkt);
    throw InputError("EPSG:" + std::to_string(epsg), 0, "cannot export the CRS as WKT");
  }
  std::string text(wkt);
  CPLFree(wkt);
  return text;
}

void WriteLas(const std::string& path, const std::vector<LasPoint>& points,
              const LasWriteOptions& options) {
  CROP4D_CHECK(options.scale.allFinite() && (options.scale.array() > 0).all());
  // VLRs: the CRS first, then the caller's.
  std::vector<LasVlr> vlrs;
  if (options.epsg != 0) {
    LasVlr crs;
    crs.user_id = kLasProjectionUserId;
    crs.record_id = kLasOgcWktRecordId;
    crs.description = "OGC coordinate system WKT";
    crs.data = EpsgWkt(options.epsg);
    crs.data.push_back('\0');
    vlrs.push_back(std::move(crs));
  }
  vlrs.insert(vlrs.end(), options.extra_vlrs.begin(), options.extra_vlrs.end());
  std::size_t vlr_bytes = 0;
  for (const LasVlr& vlr : vlrs) {
    if (vlr.data.size() > std::numeric_limits<std::uint16_t>::max()) {
      throw InputError(path, 0, "VLR '" + vlr.user_id + "' is longer than 65535 bytes");
    }
    vlr_bytes += kLasVlrHeaderSize + vlr.data.size();
  }

  // Offsets at the centre of the bounds (whole metres), then quantise.
  Eigen::Vector3d lo = Eigen::Vector3d::Zero(), hi = Eigen::Vector3d::Zero();
  for (std::size_t i = 0; i < points.size(); ++i) {
    const LasPoint& p = points[i];
    if (!p.xyz.allFinite()) {
      throw InputError(path, 0, "point " + std::to_string(i) + " has non-finite coordinates");
    }
    if (p.return_number < 1 || p.return_number > 15 || p.number_of_returns < 1 ||
        p.number_of_returns > 15) {
      throw InputError(path, 0,
                       "point " + std::to_string(i) + ": return number or count outside 1..15");
    }
    lo = i == 0 ? p.xyz : lo.cwiseMin(p.xyz);
    hi = i == 0 ? p.xyz : hi.cwiseMax(p.xyz);
  }
  const Eigen::Vector3d offset = (0.5 * (lo + hi)).array().round();
  std::vector<std::array<std::int32_t, 3>> ints(points.size());
  Eigen::Vector3d qlo = Eigen::Vector3d::Zero(), qhi = Eigen::Vector3d::Zero();
  std::array<std::uint64_t, 15> by_return = {};
  for (std::size_t i = 0; i < points.size(); ++i) {
    Eigen::Vector3d stored;
    for (int k = 0; k < 3; ++k) {
      ints[i][k] = Quantise(points[i].xyz[k], offset[k], options.scale[k], path);
      stored[k] = ints[i][k] * options.scale[k] + offset[k];
    }
    qlo = i == 0 ? stored : qlo.cwiseMin(stored);
    qhi = i == 0 ? stored : qhi.cwiseMax(stored);
    ++by_return[points[i].return_number - 1];
  }

  int year = options.creation_year, day = options.creation_day_of_year;
  if (year == 0 || day == 0) Today(&year, &day);
  const std::uint64_t offset_to_points = kLasHeaderSize + vlr_bytes;
  CROP4D_CHECK(offset_to_points <= std::numeric_limits<std::uint32_t>::max());

  std::string head;
  head.reserve(offset_to_points);
  ByteWriter w(&head);
  // Public header block (LAS 1.4 R15 Table 3).
  w.PutText("LASF", 4);
  w.Put<std::uint16_t>(0);  // file source id
  // Global encoding: WKT CRS (bit 4), adjusted standard GPS time (bit 0).
  w.Put<std::uint16_t>(kLasCrsIsWkt |
                       (options.adjusted_standard_gps_time ? kLasGpsTimeAdjustedStandard : 0));
  w.Put<std::uint32_t>(0);  // project id (GUID), 16 bytes
  w.Put<std::uint16_t>(0);
  w.Put<std::uint16_t>(0);
  w.PutText("", 8);
  w.Put<std::uint8_t>(1);  // version 1.4
  w.Put<std::uint8_t>(4);
  w.PutText(options.system_identifier, 32);
  w.PutText(options.generating_software, 32);
  w.Put<std::uint16_t>(static_cast<std::uint16_t>(day));
  w.Put<std::uint16_t>(static_cast<std::uint16_t>(year));
  w.Put<std::uint16_t>(kLasHeaderSize);
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(offset_to_points));
  w.Put<std::uint32_t>(static_cast<std::uint32_t>(vlrs.size()));
  w.Put<std::uint8_t>(7);
  w.Put<std::uint16_t>(kLasPointFormat7Length);
  // Legacy counts: zero for point data record formats 6-10 (no legacy compatibility).
  w.Put<std::uint32_t>(0);
  for (int i = 0; i < 5; ++i) w.Put<std::uint32_t>(0);
  for (int k = 0; k < 3; ++k) w.Put<double>(options.scale[k]);
  for (int k = 0; k < 3; ++k) w.Put<double>(offset[k]);
  for (int k = 0; k < 3; ++k) {
    w.Put<double>(qhi[k]);
    w.Put<double>(qlo[k]);
  }
  w.Put<std::uint64_t>(0);  // start of waveform data packet record
  w.Put<std::uint64_t>(0);  // start of first EVLR
  w.Put<std::uint32_t>(0);  // number of EVLRs
  w.Put<std::uint64_t>(points.size());
  for (std::uint64_t n : by_return) w.Put<std::uint64_t>(n);
  CROP4D_CHECK(head.size() == std::size_t(kLasHeaderSize));
  for (const LasVlr& vlr : vlrs) {
    PutVlrHeader(w, vlr, /*extended=*/false);
    w.PutBytes(vlr.data);
  }
  CROP4D_CHECK(head.size() == offset_to_points);

  AtomicFile file(path);
  file.stream().write(head.data(), static_cast<std::streamsize>(head.size()));
  // Points, in blocks.
  constexpr std::size_t kBlock = 1 << 16;
  std::string block;
  for (std::size_t begin = 0; begin < points.size(); begin += kBlock) {
    block.clear();
    ByteWriter b(&block);
    const std::size_t end = std::min(points.size(), begin + kBlock);
    for (std::size_t i = begin; i < end; ++i) {
      const LasPoint& p = points[i];
      b.Put<std::int32_t>(ints[i][0]);
      b.Put<std::int32_t>(ints[i][1]);
      b.Put<std::int32_t>(ints[i][2]);
      b.Put<std::uint16_t>(p.intensity);
      b.Put<std::uint8_t>(
          static_cast<std::uint8_t>((p.return_number & 0x0F) | (p.number_of_returns << 4)));
      b.Put<std::uint8_t>(0);  // classification flags, scanner channel, scan direction, edge
      b.Put<std::uint8_t>(p.classification);
      b.Put<std::uint8_t>(p.user_data);
      b.Put<std::int16_t>(p.scan_angle);
      b.Put<std::uint16_t>(p.point_source_id);
      b.Put<double>(p.gps_time);
      for (int c = 0; c < 3; ++c) b.Put<std::uint16_t>(p.rgb[c]);
    }
    file.stream().write(block.data(), static_cast<std::streamsize>(block.size()));
  }
  file.Commit();
}

std::string LasFile::Wkt() const {
  for (const std::vector<LasVlr>* records : {&vlrs, &evlrs}) {
    for (const LasVlr& vlr : *records) {
      if (vlr.user_id == kLasProjectionUserId && vlr.record_id == kLasOgcWktRecordId) {
        std::string wkt = vlr.data;
        while (!wkt.empty() && wkt.back() == '\0') wkt.pop_back();
        return wkt;
      }
    }
  }
  return "";
}

LasFile ReadLas(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(path, 0, "no such LAS file");
  }
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open");
  const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, 0, "cannot read");
  auto fail = [&path](const std::string& what) { return InputError(path, 0, what); };

  if (bytes.size() < 4 || bytes.compare(0, 4, "LASF") != 0) {
    throw fail("not a LAS file (no \"LASF\" signature)");
  }
  if (bytes.size() < std::size_t(kLasHeaderSize)) {
    throw fail("truncated LAS header (" + std::to_string(bytes.size()) + " bytes, expected " +
               std::to_string(kLasHeaderSize) + ")");
  }
  LasFile las;
  LasHeader& h = las.header;
  ByteReader r(bytes.data());
  r.GetText(4);
  h.file_source_id = r.Get<std::uint16_t>();
  h.global_encoding = r.Get<std::uint16_t>();
  r.GetText(16);  // project id
  h.version_major = r.Get<std::uint8_t>();
  h.version_minor = r.Get<std::uint8_t>();
  if (h.version_major != 1 || h.version_minor != 4) {
    throw fail("LAS version " + std::to_string(h.version_major) + "." +
               std::to_string(h.version_minor) + " is not supported (1.4 only)");
  }
  h.system_identifier = r.GetText(32);
  h.generating_software = r.GetText(32);
  h.creation_day_of_year = r.Get<std::uint16_t>();
  h.creation_year = r.Get<std::uint16_t>();
  h.header_size = r.Get<std::uint16_t>();
  h.offset_to_point_data = r.Get<std::uint32_t>();
  h.number_of_vlrs = r.Get<std::uint32_t>();
  h.point_format = r.Get<std::uint8_t>();
  h.point_record_length = r.Get<std::uint16_t>();
  h.legacy_point_count = r.Get<std::uint32_t>();
  for (std::uint32_t& n : h.legacy_points_by_return) n = r.Get<std::uint32_t>();
  for (int k = 0; k < 3; ++k) h.scale[k] = r.Get<double>();
  for (int k = 0; k < 3; ++k) h.offset[k] = r.Get<double>();
  for (int k = 0; k < 3; ++k) {
    h.max[k] = r.Get<double>();
    h.min[k] = r.Get<double>();
  }
  h.start_of_waveform_data = r.Get<std::uint64_t>();
  h.start_of_first_evlr = r.Get<std::uint64_t>();
  h.number_of_evlrs = r.Get<std::uint32_t>();
  h.point_count = r.Get<std::uint64_t>();
  for (std::uint64_t& n : h.points_by_return) n = r.Get<std::uint64_t>();

  if (h.header_size < kLasHeaderSize) {
    throw fail("header size " + std::to_string(h.header_size) + " is below the " +
               std::to_string(kLasHeaderSize) + " bytes of LAS 1.4");
  }
  if (h.point_format != 7) {
    throw fail("point data record format " + std::to_string(h.point_format) +
               " is not supported (7 only)");
  }
  if (h.point_record_length < kLasPointFormat7Length) {
    throw fail("point data record length " + std::to_string(h.point_record_length) +
               " is below the 36 bytes of format 7");
  }
  if (!h.scale.allFinite() || (h.scale.array() == 0).any() || !h.offset.allFinite()) {
    throw fail("invalid scale or offset in the header");
  }
  if (h.offset_to_point_data < h.header_size || h.offset_to_point_data > bytes.size()) {
    throw fail("offset to point data " + std::to_string(h.offset_to_point_data) +
               " lies outside the file (" + std::to_string(bytes.size()) + " bytes)");
  }

  // VLRs between the header and the points.
  std::uint64_t pos = h.header_size;
  for (std::uint32_t i = 0; i < h.number_of_vlrs; ++i) {
    LasVlr vlr;
    const std::string error =
        ReadVlr(bytes, &pos, h.offset_to_point_data, false, "VLR " + std::to_string(i),
                "runs past the offset to point data", &vlr);
    if (!error.empty()) throw fail(error);
    las.vlrs.push_back(std::move(vlr));
  }

  // Points.
  const std::uint64_t count = h.point_count;
  const std::uint64_t available = (bytes.size() - h.offset_to_point_data) / h.point_record_length;
  if (count > available) {
    throw fail("truncated point data: the header counts " + std::to_string(count) +
               " points, the file holds " + std::to_string(available));
  }
  las.points.resize(count);
  for (std::uint64_t i = 0; i < count; ++i) {
    ByteReader p(bytes.data() + h.offset_to_point_data + i * h.point_record_length);
    LasPoint& q = las.points[i];
    for (int k = 0; k < 3; ++k) q.xyz[k] = p.Get<std::int32_t>() * h.scale[k] + h.offset[k];
    q.intensity = p.Get<std::uint16_t>();
    const std::uint8_t returns = p.Get<std::uint8_t>();
    q.return_number = returns & 0x0F;
    q.number_of_returns = returns >> 4;
    p.Get<std::uint8_t>();  // flags
    q.classification = p.Get<std::uint8_t>();
    q.user_data = p.Get<std::uint8_t>();
    q.scan_angle = p.Get<std::int16_t>();
    q.point_source_id = p.Get<std::uint16_t>();
    q.gps_time = p.Get<double>();
    for (int c = 0; c < 3; ++c) q.rgb[c] = p.Get<std::uint16_t>();
  }

  // EVLRs after the points.
  if (h.number_of_evlrs > 0) {
    const std::uint64_t points_end =
        std::uint64_t(h.offset_to_point_data) + count * h.point_record_length;
    if (h.start_of_first_evlr < points_end || h.start_of_first_evlr > bytes.size()) {
      throw fail("start of the first EVLR " + std::to_string(h.start_of_first_evlr) +
                 " lies outside the file or inside the point data");
    }
    std::uint64_t at = h.start_of_first_evlr;
    for (std::uint32_t i = 0; i < h.number_of_evlrs; ++i) {
      LasVlr vlr;
      const std::string error = ReadVlr(bytes, &at, bytes.size(), true, "EVLR " + std::to_string(i),
                                        "is truncated", &vlr);
      if (!error.empty()) throw fail(error);
      las.evlrs.push_back(std::move(vlr));
    }
  }
  return las;
}

std::vector<LasPoint> LasPointsFromEnu(const PlyPointCloud& cloud,
                                       const geometry::GeodeticPoint& origin, int epsg,
                                       std::uint16_t point_source_id, double gps_time) {
  CROP4D_CHECK(geometry::IsUtmEpsgCode(epsg));
  CROP4D_CHECK(cloud.colors.empty() || cloud.colors.size() == cloud.points.size());
  const geometry::LocalEnu enu(origin);
  std::vector<LasPoint> points(cloud.size());
  tbb::parallel_for(tbb::blocked_range<std::size_t>(0, cloud.size(), 4096),
                    [&](const tbb::blocked_range<std::size_t>& range) {
                      for (std::size_t i = range.begin(); i != range.end(); ++i) {
                        const geometry::GeodeticPoint g = enu.ToGeodetic(cloud.points[i]);
                        const Eigen::Vector2d en = geometry::UtmFromGeodetic(g, epsg);
                        LasPoint& p = points[i];
                        p.xyz = Eigen::Vector3d(en.x(), en.y(), origin.alt_m + cloud.points[i].z());
                        p.point_source_id = point_source_id;
                        p.gps_time = gps_time;
                        if (!cloud.colors.empty()) {
                          for (int c = 0; c < 3; ++c) {
                            p.rgb[c] = static_cast<std::uint16_t>(cloud.colors[i][c] * 257);
                          }
                        }
                      }
                    });
  return points;
}

}  // namespace crop4d::io
