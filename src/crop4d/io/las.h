#pragma once

// LAS 1.4 point clouds (uncompressed), written and read by hand after the ASPRS specification
// ("LAS Specification 1.4 – R15", ASPRS 2019, github.com/ASPRSorg/LAS), for `crop4d export`
// (docs/export.md): QGIS, CloudCompare, PDAL, LAStools and every GIS read them, and unlike PLY
// they carry their coordinate reference system.
//
// The subset written (and read back):
//  - the 375-byte public header block of LAS 1.4: signature "LASF", version 1.4, bounds, the
//    64-bit point counts (§2.4: the legacy 32-bit counts must be 0 with point data record
//    formats 6–10, which do not keep legacy compatibility), global encoding with the WKT bit
//    (bit 4, required for formats 6–10) and the GPS time type bit (bit 0: the points' GPS time
//    is "adjusted standard GPS time", GPS seconds since 1980-01-06 minus 10⁹; see
//    AdjustedStandardGpsTime);
//  - variable length records (54-byte headers), in particular the OGC coordinate system WKT
//    (user id "LASF_Projection", record id 2112, a NUL-terminated string); extended variable
//    length records (60-byte headers, after the points) are read too;
//  - point data record format 7 (36 bytes): X Y Z int32 (coordinate = integer · scale + offset),
//    intensity, return number / number of returns (4 bits each), classification flags, scanner
//    channel, scan direction and edge of flight line bits, classification (ASPRS classes, Table
//    17: kAsprsGround ...), user data, scan angle (int16, 0.006° units), point source id, GPS time
//    (double), red green blue (uint16).
//
// All fields are little-endian. Writes are atomic (io/atomic_file.h).
//
// The coordinates of a crop4d cloud (field ENU metres) become easting, northing in the field's
// UTM zone and the WGS 84 ellipsoidal height with LasPointsFromEnu.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/enu.h"

namespace crop4d::io {

struct PlyPointCloud;

// One point of record format 7.
struct LasPoint {
  // Coordinates in the file's CRS (e.g. UTM easting, northing, ellipsoidal height), metres.
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  std::uint16_t intensity = 0;
  std::uint8_t return_number = 1;      // 1..15
  std::uint8_t number_of_returns = 1;  // 1..15
  std::uint8_t classification = 0;     // ASPRS class (0: created, never classified; kAsprs*)
  std::uint8_t user_data = 0;
  std::int16_t scan_angle = 0;  // 0.006° units
  std::uint16_t point_source_id = 0;
  double gps_time = 0.0;  // adjusted standard GPS time, s (global encoding bit 0; see above)
  std::array<std::uint16_t, 3> rgb = {0, 0, 0};  // 16-bit red, green, blue

  bool operator==(const LasPoint&) const = default;
};

// A variable length record (VLR, before the points) or extended one (EVLR, after them).
struct LasVlr {
  std::string user_id;  // at most 16 characters, e.g. "LASF_Projection"
  std::uint16_t record_id = 0;
  std::string description;  // at most 32 characters
  std::string data;         // the payload (a VLR holds at most 65535 bytes)
};

// The fields of the public header block that the writer sets and the reader returns.
struct LasHeader {
  std::uint16_t file_source_id = 0;
  // Bit 0 (kLasGpsTimeAdjustedStandard): GPS time is adjusted standard GPS time (else GPS week
  // time); bit 4 (kLasCrsIsWkt): the CRS is WKT.
  std::uint16_t global_encoding = 0;
  std::uint8_t version_major = 1;
  std::uint8_t version_minor = 4;
  std::string system_identifier;    // ≤ 32 characters
  std::string generating_software;  // ≤ 32 characters
  std::uint16_t creation_day_of_year = 0;
  std::uint16_t creation_year = 0;
  std::uint16_t header_size = 375;
  std::uint32_t offset_to_point_data = 0;
  std::uint32_t number_of_vlrs = 0;
  std::uint8_t point_format = 7;
  std::uint16_t point_record_length = 36;
  std::uint32_t legacy_point_count = 0;
  std::array<std::uint32_t, 5> legacy_points_by_return = {0, 0, 0, 0, 0};
  Eigen::Vector3d scale = Eigen::Vector3d::Constant(0.001);
  Eigen::Vector3d offset = Eigen::Vector3d::Zero();
  Eigen::Vector3d min = Eigen::Vector3d::Zero();
  Eigen::Vector3d max = Eigen::Vector3d::Zero();
  std::uint64_t start_of_waveform_data = 0;
  std::uint64_t start_of_first_evlr = 0;
  std::uint32_t number_of_evlrs = 0;
  std::uint64_t point_count = 0;
  std::array<std::uint64_t, 15> points_by_return = {};
};

// The size of the LAS 1.4 public header block, of a format-7 point record, and of a VLR and an
// EVLR header.
inline constexpr int kLasHeaderSize = 375;
inline constexpr int kLasPointFormat7Length = 36;
inline constexpr int kLasVlrHeaderSize = 54;
inline constexpr int kLasEvlrHeaderSize = 60;
// The OGC coordinate system WKT record (LAS 1.4 §2.5 "Coordinate Reference System").
inline constexpr const char* kLasProjectionUserId = "LASF_Projection";
inline constexpr std::uint16_t kLasOgcWktRecordId = 2112;
// Bits of the global encoding (LAS 1.4 R15 Table 4).
inline constexpr std::uint16_t kLasGpsTimeAdjustedStandard = 1 << 0;
inline constexpr std::uint16_t kLasCrsIsWkt = 1 << 4;

// ASPRS standard point classes (LAS 1.4 R15 Table 17) that crop4d writes.
inline constexpr std::uint8_t kAsprsCreatedNeverClassified = 0;
inline constexpr std::uint8_t kAsprsUnclassified = 1;
inline constexpr std::uint8_t kAsprsGround = 2;
inline constexpr std::uint8_t kAsprsLowVegetation = 3;
inline constexpr std::uint8_t kAsprsMediumVegetation = 4;
inline constexpr std::uint8_t kAsprsHighVegetation = 5;

// The class of a point of vegetation (canopy) this high above the terrain, metres. The
// specification leaves the limits of low, medium and high vegetation to the producer; crop4d
// uses below 0.5 m: low (3), 0.5 m to below 2 m: medium (4), 2 m and above: high (5), so that a
// row crop is low vegetation early in the season and medium or high (maize) later.
std::uint8_t AsprsVegetationClass(double height_above_ground_m);

// Seconds that GPS time is ahead of UTC at a UTC instant (the leap seconds since the GPS epoch
// 1980-01-06: 0 before 1981-07-01, 17 from 2015-07-01, 18 from 2017-01-01). From a table of
// every leap second up to 2017-01-01 (the last announced as of 2026); later instants get 18.
int GpsMinusUtcSeconds(Timestamp utc);

// The LAS "adjusted standard GPS time" of a UTC instant: GPS seconds since the GPS epoch
// (1980-01-06 00:00:00 UTC, with the leap seconds of GpsMinusUtcSeconds) minus 10⁹, e.g.
// 167264018 for 2017-01-01 00:00:00 UTC. A double keeps it to ~30 ns in this century.
double AdjustedStandardGpsTime(Timestamp utc);

// The inverse: the UTC instant (ns, rounded) of an adjusted standard GPS time.
Timestamp UtcFromAdjustedStandardGpsTime(double gps_time);

struct LasWriteOptions {
  // The CRS as an EPSG code (0: none). With a code, its OGC WKT (UtmWkt) is written as a VLR.
  int epsg = 0;
  // Scale of the integer coordinates, metres (0.001: millimetres).
  Eigen::Vector3d scale = Eigen::Vector3d::Constant(0.001);
  // Written into the header (truncated to 32 characters).
  std::string system_identifier = "crop4d export";
  std::string generating_software = "crop4d";
  // Creation date of the header; 0: today (UTC).
  int creation_year = 0;
  int creation_day_of_year = 0;
  // Further VLRs written after the CRS (e.g. a description of the data).
  std::vector<LasVlr> extra_vlrs;
  // Sets bit 0 of the global encoding: the points' gps_time is adjusted standard GPS time
  // (AdjustedStandardGpsTime). false: GPS week time (seconds of the GPS week).
  bool adjusted_standard_gps_time = true;
};

// Writes `points` as an uncompressed LAS 1.4 file with point data record format 7, atomically;
// the global encoding has the WKT bit and, with options.adjusted_standard_gps_time, the GPS
// time type bit.
// Offsets are chosen near the data (the centre of its bounds, rounded to whole metres) and the
// header bounds are those of the stored (quantised) coordinates. Throws InputError naming `path`
// for non-finite coordinates, a cloud whose extent does not fit the int32 coordinates at
// `scale` (±2147 km at 1 mm), a return number / count outside 1..15, a VLR that is too long, an
// EPSG code GDAL does not know, or a file that cannot be written.
void WriteLas(const std::string& path, const std::vector<LasPoint>& points,
              const LasWriteOptions& options = {});

struct LasFile {
  LasHeader header;
  std::vector<LasVlr> vlrs;
  std::vector<LasVlr> evlrs;
  std::vector<LasPoint> points;  // coordinates already scaled and offset

  // The OGC WKT of the CRS record (LASF_Projection 2112, VLR or EVLR, without the trailing NUL),
  // or "" when there is none.
  std::string Wkt() const;
};

// Reads a LAS 1.4 file of point data record format 7 (records longer than 36 bytes are
// accepted, their extra bytes skipped). Throws InputError naming `path` for a missing file,
// a wrong signature or version, another point format, a header, VLR, point block or EVLR that
// is truncated or points outside the file, and counts that disagree with the file size.
LasFile ReadLas(const std::string& path);

// The OGC WKT (WKT1, as LAS 1.4 asks) of an EPSG coordinate system, from GDAL/PROJ, e.g.
// PROJCS["WGS 84 / UTM zone 17N",...] for 32617. Throws InputError for an unknown code.
std::string EpsgWkt(int epsg);

// The points of a crop4d cloud (field ENU metres, io/ply.h) in the field's UTM zone `epsg`:
// x, y = easting, northing of the point, converted exactly (geometry::LocalEnu → geodetic →
// geometry::UtmFromGeodetic, as io::FieldUtm::UtmFromEnu), z = origin.alt_m + up: the WGS 84
// ellipsoidal height in the convention of the terrain model WS/analysis/dtm.tif (docs/analysis.md),
// so that clouds and rasters line up. It differs from the point's exact geodetic height by the
// Earth's curvature, d²/2R: 0.8 mm at 100 m from the origin, 2 cm at 500 m. Colours become 16-bit
// (c · 257); `point_source_id` (e.g. the row pass of a merged cloud) and `gps_time` (e.g.
// AdjustedStandardGpsTime of the session's date) are stored in every point; the classification
// is left 0 (never classified) for the caller. Parallel (oneTBB).
std::vector<LasPoint> LasPointsFromEnu(const PlyPointCloud& cloud,
                                       const geometry::GeodeticPoint& origin, int epsg,
                                       std::uint16_t point_source_id = 0, double gps_time = 0.0);

}  // namespace crop4d::io
