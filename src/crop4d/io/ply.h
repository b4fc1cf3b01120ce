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
#include <fstream>
#include <functional>
#include <string>
#include <utility>
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
  // Appends the points of `part` (which passes Check()) with their normals, colours and scalar
  // values. A cloud with no points and no scalar fields takes `part`'s fields; otherwise the
  // scalar fields must be the same, by name and type, and normals and colours present in both
  // or in neither (CHECK).
  void Append(const PlyPointCloud& part);
  // Appends vertex `i` of `part` (of this cloud's layout) with its normal, colour and scalars.
  void AppendVertex(const PlyPointCloud& part, std::size_t i);
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

// What the header of a PLY file says about its vertices, apart from their count: whether they
// have normals and colours, and the extra scalar fields (name and type) in file order. It is
// what every part given to a PlyStreamWriter must share.
struct PlyLayout {
  bool normals = false;
  bool colors = false;
  std::vector<std::pair<std::string, PlyType>> scalars;
};

bool operator==(const PlyLayout& a, const PlyLayout& b);

// The layout WritePly writes for `cloud`: normals and colours when their vectors are not empty
// (so never for a cloud of no points), and the names and types of its scalar fields.
PlyLayout LayoutOf(const PlyPointCloud& cloud);

// Writes a PLY file part by part, for a cloud too large to hold in memory at once (dense
// clouds; issue 28). The records of each part go to a hidden temporary "body" file next to
// `path` as they come; Finish() then writes `path` atomically (io::AtomicFile): the header,
// which needs the final vertex count, followed by a copy of the body, read in small blocks.
// Parts are encoded exactly as WritePly encodes a cloud, so appending a cloud in consecutive
// slices gives the same bytes as WritePly of the whole cloud.
//
// Until Finish() succeeds, `path` is left as it was. Destroying the writer without Finish()
// (an exception unwinding) removes the body file. A killed process leaves the body file
// behind; its name ends in ".tmp.<pid>.<n>" like AtomicFile's, so RemoveStaleTemporaryFiles
// removes it. Writing takes about twice the file size of free disk space until Finish()
// returns (body and result side by side).
//
//   PlyStreamWriter writer(path, layout);
//   for (...) writer.Append(part);  // Each part: layout == `layout`.
//   writer.Finish();
class PlyStreamWriter {
 public:
  // The layout's scalar names must be valid as in PlyPointCloud::Check (CHECK). Creates the
  // missing parent folders of `path` and opens the body file; throws InputError naming
  // `path` when that fails.
  PlyStreamWriter(const std::string& path, const PlyLayout& layout,
                  const PlyWriteOptions& options = {});
  // Removes the body file; without Finish(), leaves `path` as it was.
  ~PlyStreamWriter();
  PlyStreamWriter(const PlyStreamWriter&) = delete;
  PlyStreamWriter& operator=(const PlyStreamWriter&) = delete;

  // Encodes the points of `part` after those appended before. The part must pass Check() and
  // have this writer's layout, and its integer scalars must fit their types, as for WritePly
  // (CHECK). A part of no points is fine; as it cannot show normals or colours, only the names
  // and types of its scalar fields are compared with the layout. Not after Finish() (CHECK).
  // Throws InputError when the body file cannot be written (disk full).
  void Append(const PlyPointCloud& part);

  // Points appended so far.
  std::size_t size() const { return size_; }

  // Writes `path` (header, then the body) atomically and removes the body file. Once only,
  // and no Append() after it (CHECK). Throws InputError when a file cannot be written or
  // read; `path` is then left as it was.
  void Finish();

 private:
  std::string path_, body_path_;
  PlyLayout layout_;
  PlyWriteOptions options_;
  std::ofstream body_;
  std::size_t size_ = 0;
  bool finished_ = false;
};

// Reads the vertices of a PLY file a slice at a time, so that a cloud too large for memory can
// be read through (the analysis reads the dense clouds so). A binary little-endian file whose
// vertices are fixed-size records (no list property; what crop4d writes) is read by seeking to
// the slice; any other file that ReadPly accepts is read whole once and sliced. The constructor
// checks the header as ReadPly does and that the file holds every record the header announces;
// it throws InputError naming the file when not.
class PlyVertexReader {
 public:
  explicit PlyVertexReader(const std::string& path);

  // Vertices in the file.
  std::size_t size() const { return size_; }
  // Normals, colours and scalar fields of the vertices (those ReadPly returns).
  const PlyLayout& layout() const { return layout_; }
  // Vertices [start, start + count) (clamped to size()), as ReadPly returns them. Throws
  // InputError when the file cannot be read.
  PlyPointCloud Read(std::size_t start, std::size_t count);

 private:
  std::string path_;
  std::size_t size_ = 0;
  PlyLayout layout_;
  // Seeking: where the vertices start, their record size and each property's offset.
  std::ifstream in_;
  std::size_t data_offset_ = 0, record_size_ = 0;
  std::vector<int> slots_;
  std::vector<PlyType> types_;
  PlyPointCloud empty_;  // the layout, no points
  // Otherwise: the whole cloud.
  bool whole_ = false;
  PlyPointCloud cloud_;
};

// The vertices of a PLY file for which `keep(point)` is true, with their normals, colours and
// scalar fields: read a slice at a time (PlyVertexReader), so that only those kept are held.
PlyPointCloud ReadPlyWhere(const std::string& path,
                           const std::function<bool(const Eigen::Vector3d&)>& keep);

// Reads the `vertex` element of a PLY file (see the header comment for what is accepted).
// Colours of an integer type are taken as 0..255 (clamped), of a floating type as 0..1
// (scaled by 255, rounded, clamped); "diffuse_red/green/blue" are read as colours too. Any
// other vertex property that is not a list (e.g. "alpha", "intensity", "track_length") comes
// back as a scalar field with its type, in file order.
PlyPointCloud ReadPly(const std::string& path);

}  // namespace crop4d::io
