#pragma once

// PLY point clouds with colour (DESIGN.md §5; read by CloudCompare, MeshLab, Open3D), after
// Paul Bourke's description of the format ("PLY - Polygon File Format",
// paulbourke.net/dataformats/ply). crop4d writes one `vertex` element with
//   property double x, y, z               (ENU metres: double keeps 0.1 mm at any field size)
//   property float nx, ny, nz             (when the cloud has normals)
//   property uchar red, green, blue       (when the cloud has colours)
//   property <type> <name>                (one per extra scalar field, in the given order)
// in binary little-endian (default) or ASCII, written atomically.
//
// The reader takes what the writer writes and the usual variants: ASCII or binary
// little-endian, x y z of any numeric type (float or double in practice), with or without
// colours and normals, extra vertex properties (returned as scalar fields; list properties are
// skipped), other elements (faces, edges: skipped), comment and obj_info lines, CRLF header
// lines. It throws InputError naming the file (and the line for the header and ASCII data)
// for anything else: a missing "ply" magic, big-endian or unknown formats, a malformed header,
// a vertex element without x, y or z, truncated data, values that do not parse, and data that
// does not match the element counts of the header.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace crop4d::io {

enum class PlyFormat { kBinaryLittleEndian, kAscii };

// The scalar types of the PLY format (char/int8 ... double/float64).
enum class PlyType { kInt8, kUint8, kInt16, kUint16, kInt32, kUint32, kFloat32, kFloat64 };

// The name the writer uses in the header ("char", "uchar", "short", ..., "float", "double").
const char* PlyTypeName(PlyType type);

// An extra per-vertex property, e.g. {"track_length", kInt32} or {"reprojection_error",
// kFloat32}. Values are held as double, which represents every PLY scalar type exactly.
struct PlyScalarField {
  std::string name;
  PlyType type = PlyType::kFloat32;
  std::vector<double> values;  // One per point.
};

struct PlyPointCloud {
  std::vector<Eigen::Vector3d> points;              // e.g. point_world (ENU metres)
  std::vector<std::array<std::uint8_t, 3>> colors;  // RGB; empty or one per point
  std::vector<Eigen::Vector3f> normals;             // empty or one per point
  std::vector<PlyScalarField> scalars;              // extra properties, written in this order

  std::size_t size() const { return points.size(); }
  // The scalar field called `name`, or nullptr.
  const PlyScalarField* FindScalar(const std::string& name) const;
  // Consistent sizes, and scalar names that are single words (no whitespace), unique, and none
  // of x y z nx ny nz red green blue. On failure, `why` (if not null) says what is wrong.
  bool Check(std::string* why = nullptr) const;
};

struct PlyWriteOptions {
  // Binary little-endian (compact, exact) or ASCII (readable; still exact: shortest
  // round-trip decimal representation of each value).
  PlyFormat format = PlyFormat::kBinaryLittleEndian;
  // Written as "comment" lines in the header (may hold several lines).
  std::string comment;
};

// Writes `cloud` atomically (io::AtomicFile). The cloud must pass Check() (CHECK). Scalar
// values of integer types are rounded to the nearest integer and must lie in the range of
// the type (CHECK). Throws InputError when the file cannot be written.
void WritePly(const std::string& path, const PlyPointCloud& cloud,
              const PlyWriteOptions& options = {});

// Reads the `vertex` element of a PLY file (see the header comment for what is accepted).
// Colours of an integer type are taken as 0..255 (clamped), of a floating type as 0..1
// (scaled by 255, rounded, clamped); "diffuse_red/green/blue" are read as colours too. Any
// other vertex property that is not a list (e.g. "alpha", "intensity", "track_length") comes
// back as a scalar field with its type, in file order.
PlyPointCloud ReadPly(const std::string& path);

}  // namespace crop4d::io
