#include "crop4d/io/ply.h"

#include <fmt/format.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <bit>
#include <cctype>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>
#include <string_view>
#include <system_error>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"

namespace crop4d::io {
namespace {

// Points written per chunk, so that a large cloud is not held twice in memory.
constexpr std::size_t kWriteChunk = 1 << 16;

// Slots of the vertex properties the reader understands; scalar field j has slot kScalar + j.
enum Slot : int { kSkip = -1, kX, kY, kZ, kNx, kNy, kNz, kRed, kGreen, kBlue, kScalar };

int TypeSize(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
    case PlyType::kUint8:
      return 1;
    case PlyType::kInt16:
    case PlyType::kUint16:
      return 2;
    case PlyType::kInt32:
    case PlyType::kUint32:
    case PlyType::kFloat32:
      return 4;
    case PlyType::kFloat64:
      return 8;
  }
  return 0;
}

bool IsFloating(PlyType type) { return type == PlyType::kFloat32 || type == PlyType::kFloat64; }

// Range of an integer type.
void IntegerRange(PlyType type, double* lo, double* hi) {
  switch (type) {
    case PlyType::kInt8:
      *lo = -128, *hi = 127;
      return;
    case PlyType::kUint8:
      *lo = 0, *hi = 255;
      return;
    case PlyType::kInt16:
      *lo = -32768, *hi = 32767;
      return;
    case PlyType::kUint16:
      *lo = 0, *hi = 65535;
      return;
    case PlyType::kInt32:
      *lo = -2147483648.0, *hi = 2147483647.0;
      return;
    case PlyType::kUint32:
      *lo = 0, *hi = 4294967295.0;
      return;
    default:
      *lo = -std::numeric_limits<double>::infinity();
      *hi = std::numeric_limits<double>::infinity();
  }
}

// Type names of the PLY specification and their sized aliases (PLY 1.0 as written by VTK,
// Open3D, PCL).
bool ParseTypeName(const std::string& name, PlyType* type) {
  static const std::pair<const char*, PlyType> kNames[] = {
      {"char", PlyType::kInt8},      {"int8", PlyType::kInt8},       {"uchar", PlyType::kUint8},
      {"uint8", PlyType::kUint8},    {"short", PlyType::kInt16},     {"int16", PlyType::kInt16},
      {"ushort", PlyType::kUint16},  {"uint16", PlyType::kUint16},   {"int", PlyType::kInt32},
      {"int32", PlyType::kInt32},    {"uint", PlyType::kUint32},     {"uint32", PlyType::kUint32},
      {"float", PlyType::kFloat32},  {"float32", PlyType::kFloat32}, {"double", PlyType::kFloat64},
      {"float64", PlyType::kFloat64}};
  for (const auto& [text, value] : kNames) {
    if (name == text) {
      *type = value;
      return true;
    }
  }
  return false;
}

// ---- writing ----

template <typename T>
void AppendLittleEndian(T value, std::string* out) {
  using Bits = std::conditional_t<
      sizeof(T) == 1, std::uint8_t,
      std::conditional_t<sizeof(T) == 2, std::uint16_t,
                         std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
  Bits bits = std::bit_cast<Bits>(value);
  for (std::size_t i = 0; i < sizeof(T); ++i) {
    out->push_back(static_cast<char>(bits & 0xff));
    if constexpr (sizeof(T) > 1) bits >>= 8;
  }
}

// An integer value of `type`: rounded, and CHECKed to lie in the range of the type.
std::int64_t ToInteger(double value, PlyType type, const std::string& name) {
  double lo = 0, hi = 0;
  IntegerRange(type, &lo, &hi);
  const double rounded = std::round(value);
  CROP4D_CHECK_MSG(
      rounded >= lo && rounded <= hi,
      fmt::format("PLY scalar '{}' value {} does not fit a {}", name, value, PlyTypeName(type)));
  return static_cast<std::int64_t>(rounded);
}

void AppendBinary(double value, PlyType type, const std::string& name, std::string* out) {
  switch (type) {
    case PlyType::kInt8:
      return AppendLittleEndian(static_cast<std::int8_t>(ToInteger(value, type, name)), out);
    case PlyType::kUint8:
      return AppendLittleEndian(static_cast<std::uint8_t>(ToInteger(value, type, name)), out);
    case PlyType::kInt16:
      return AppendLittleEndian(static_cast<std::int16_t>(ToInteger(value, type, name)), out);
    case PlyType::kUint16:
      return AppendLittleEndian(static_cast<std::uint16_t>(ToInteger(value, type, name)), out);
    case PlyType::kInt32:
      return AppendLittleEndian(static_cast<std::int32_t>(ToInteger(value, type, name)), out);
    case PlyType::kUint32:
      return AppendLittleEndian(static_cast<std::uint32_t>(ToInteger(value, type, name)), out);
    case PlyType::kFloat32:
      return AppendLittleEndian(static_cast<float>(value), out);
    case PlyType::kFloat64:
      return AppendLittleEndian(value, out);
  }
}

// ASCII: the shortest decimal text that reads back to the same value (fmt's "{}").
void AppendAscii(double value, PlyType type, const std::string& name, std::string* out) {
  if (type == PlyType::kFloat64) {
    fmt::format_to(std::back_inserter(*out), "{}", value);
  } else if (type == PlyType::kFloat32) {
    fmt::format_to(std::back_inserter(*out), "{}", static_cast<float>(value));
  } else {
    fmt::format_to(std::back_inserter(*out), "{}", ToInteger(value, type, name));
  }
}

// The header WritePly writes for `count` vertices of `layout`.
std::string PlyHeader(const PlyLayout& layout, std::size_t count, const PlyWriteOptions& options) {
  std::string text = "ply\n";
  text += options.format == PlyFormat::kBinaryLittleEndian ? "format binary_little_endian 1.0\n"
                                                           : "format ascii 1.0\n";
  std::istringstream comment(options.comment);
  for (std::string line; std::getline(comment, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    text += "comment " + line + "\n";
  }
  text += fmt::format("element vertex {}\n", count);
  text += "property double x\nproperty double y\nproperty double z\n";
  if (layout.normals) text += "property float nx\nproperty float ny\nproperty float nz\n";
  if (layout.colors) text += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const auto& [name, type] : layout.scalars) {
    text += fmt::format("property {} {}\n", PlyTypeName(type), name);
  }
  text += "end_header\n";
  return text;
}

// Appends the records of points [start, stop) of `cloud` (which passes Check()) to `out`, in
// the layout of LayoutOf(cloud): the one encoder of WritePly and PlyStreamWriter.
void AppendRecords(const PlyPointCloud& cloud, std::size_t start, std::size_t stop,
                   PlyFormat format, std::string* out) {
  const bool binary = format == PlyFormat::kBinaryLittleEndian;
  const bool has_normals = !cloud.normals.empty();
  const bool has_colors = !cloud.colors.empty();
  for (std::size_t i = start; i < stop; ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    if (binary) {
      for (int k = 0; k < 3; ++k) AppendLittleEndian(p[k], out);
      if (has_normals) {
        for (int k = 0; k < 3; ++k) AppendLittleEndian(cloud.normals[i][k], out);
      }
      if (has_colors) {
        for (int k = 0; k < 3; ++k) AppendLittleEndian(cloud.colors[i][k], out);
      }
      for (const PlyScalarField& field : cloud.scalars) {
        AppendBinary(field.values[i], field.type, field.name, out);
      }
    } else {
      fmt::format_to(std::back_inserter(*out), "{} {} {}", p.x(), p.y(), p.z());
      if (has_normals) {
        const Eigen::Vector3f& n = cloud.normals[i];
        fmt::format_to(std::back_inserter(*out), " {} {} {}", n.x(), n.y(), n.z());
      }
      if (has_colors) {
        const auto& c = cloud.colors[i];
        fmt::format_to(std::back_inserter(*out), " {} {} {}", int{c[0]}, int{c[1]}, int{c[2]});
      }
      for (const PlyScalarField& field : cloud.scalars) {
        *out += ' ';
        AppendAscii(field.values[i], field.type, field.name, out);
      }
      *out += '\n';
    }
  }
}

// Encodes all the points of `cloud` (which passes Check()) into `out`, kWriteChunk points at a
// time. Returns false as soon as `out` fails.
bool WriteRecords(const PlyPointCloud& cloud, PlyFormat format, std::ostream& out) {
  std::string text;
  for (std::size_t start = 0; start < cloud.size() && out; start += kWriteChunk) {
    text.clear();
    AppendRecords(cloud, start, std::min(cloud.size(), start + kWriteChunk), format, &text);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  return static_cast<bool>(out);
}

// Why `name` cannot name a scalar field (empty when it can); `seen` holds the names of the
// fields before it and receives `name`.
std::string ScalarNameProblem(const std::string& name, std::set<std::string>* seen) {
  static const std::set<std::string> kReserved = {"x",
                                                  "y",
                                                  "z",
                                                  "nx",
                                                  "ny",
                                                  "nz",
                                                  "red",
                                                  "green",
                                                  "blue",
                                                  "diffuse_red",
                                                  "diffuse_green",
                                                  "diffuse_blue"};
  if (name.empty()) return "a scalar field without a name";
  for (char c : name) {
    if (std::isspace(static_cast<unsigned char>(c)) ||
        !std::isprint(static_cast<unsigned char>(c))) {
      return "scalar field name \"" + name + "\" is not a single printable word";
    }
  }
  if (kReserved.count(name) > 0) return "scalar field name \"" + name + "\" is reserved";
  if (!seen->insert(name).second) return "two scalar fields named \"" + name + "\"";
  return "";
}

// How the layout of a part differs from the writer's (empty when it does not).
std::string LayoutDifference(const PlyLayout& writer, const PlyLayout& part) {
  auto differ = [](const char* what, bool in_part, bool in_writer) {
    return fmt::format("the part has {}{}, the writer's layout has {}", in_part ? "" : "no ", what,
                       in_writer ? "them" : "none");
  };
  if (part.normals != writer.normals) return differ("normals", part.normals, writer.normals);
  if (part.colors != writer.colors) return differ("colours", part.colors, writer.colors);
  for (std::size_t k = 0; k < std::max(part.scalars.size(), writer.scalars.size()); ++k) {
    auto describe = [k](const std::vector<std::pair<std::string, PlyType>>& scalars) {
      return k < scalars.size()
                 ? fmt::format("\"{}\" ({})", scalars[k].first, PlyTypeName(scalars[k].second))
                 : std::string("none");
    };
    if (k >= part.scalars.size() || k >= writer.scalars.size() ||
        part.scalars[k] != writer.scalars[k]) {
      return fmt::format("scalar field {} of the part is {}, of the writer's layout {}", k + 1,
                         describe(part.scalars), describe(writer.scalars));
    }
  }
  return "";
}

// The body file of a PlyStreamWriter for `path`: hidden, next to it, unique to this process
// and writer, ending like AtomicFile's temporary names (so RemoveStaleTemporaryFiles takes it).
std::string BodyPath(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  const std::filesystem::path p(path);
  const std::string name =
      fmt::format(".{}.body.tmp.{}.{}", p.filename().string(), ::getpid(), counter++);
  return (p.parent_path() / name).string();
}

// ---- reading ----

struct Property {
  std::string name;
  PlyType type = PlyType::kFloat32;
  bool is_list = false;
  PlyType count_type = PlyType::kUint8;  // For lists; `type` is then the item type.
};

struct Element {
  std::string name;
  std::int64_t count = 0;
  std::vector<Property> properties;
  int line = 0;  // Header line of the element.
};

struct Header {
  PlyFormat format = PlyFormat::kAscii;
  std::vector<Element> elements;
  std::size_t data_offset = 0;  // First byte after "end_header\n".
  int line_count = 0;           // Lines in the header, "ply" and "end_header" included.
};

std::vector<std::string> SplitWords(std::string_view line) {
  std::vector<std::string> words;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) words.emplace_back(line.substr(start, i - start));
  }
  return words;
}

// The line starting at `*offset` without its "\n" or "\r\n"; advances `*offset` past it.
// Returns false at the end of the data or when the line has no '\n' (`*terminated` = false).
bool NextLine(std::string_view data, std::size_t* offset, std::string_view* line,
              bool* terminated) {
  if (*offset >= data.size()) return false;
  const std::size_t end = data.find('\n', *offset);
  *terminated = end != std::string_view::npos;
  const std::size_t stop = *terminated ? end : data.size();
  *line = data.substr(*offset, stop - *offset);
  if (!line->empty() && line->back() == '\r') line->remove_suffix(1);
  *offset = *terminated ? end + 1 : data.size();
  return true;
}

Header ParseHeader(const std::string& path, std::string_view data) {
  Header header;
  std::size_t offset = 0;
  std::string_view line;
  bool terminated = false;
  int line_number = 0;
  bool has_format = false;
  auto fail = [&](const std::string& what) { throw InputError(path, line_number, what); };

  if (!NextLine(data, &offset, &line, &terminated) || line != "ply" || !terminated) {
    throw InputError(path, 1, "not a PLY file: the first line is not \"ply\"");
  }
  line_number = 1;
  while (true) {
    if (!NextLine(data, &offset, &line, &terminated)) {
      throw InputError(path, line_number, "the PLY header ends without \"end_header\"");
    }
    ++line_number;
    const std::vector<std::string> words = SplitWords(line);
    if (words.empty()) continue;
    const std::string& keyword = words[0];
    if (keyword == "comment" || keyword == "obj_info") continue;
    if (keyword == "end_header") {
      if (words.size() != 1) fail("unexpected text after \"end_header\"");
      if (!terminated) fail("\"end_header\" is not followed by a newline");
      break;
    }
    if (keyword == "format") {
      if (has_format) fail("a second \"format\" line");
      if (words.size() != 3) fail("expected \"format <ascii|binary_little_endian> 1.0\"");
      if (words[2] != "1.0") fail("unsupported PLY version \"" + words[2] + "\" (expected 1.0)");
      if (words[1] == "ascii") {
        header.format = PlyFormat::kAscii;
      } else if (words[1] == "binary_little_endian") {
        header.format = PlyFormat::kBinaryLittleEndian;
      } else if (words[1] == "binary_big_endian") {
        fail("unsupported format binary_big_endian (crop4d reads ascii and binary_little_endian)");
      } else {
        fail("unknown format \"" + words[1] + "\"");
      }
      has_format = true;
    } else if (keyword == "element") {
      if (!has_format) fail("\"element\" before the \"format\" line");
      if (words.size() != 3) fail("expected \"element <name> <count>\"");
      Element element;
      element.name = words[1];
      element.line = line_number;
      const std::string& count = words[2];
      const auto [end, ec] =
          std::from_chars(count.data(), count.data() + count.size(), element.count);
      if (ec != std::errc() || end != count.data() + count.size() || element.count < 0) {
        fail("element count \"" + count + "\" is not a non-negative integer");
      }
      for (const Element& other : header.elements) {
        if (other.name == element.name) fail("a second element \"" + element.name + "\"");
      }
      header.elements.push_back(std::move(element));
    } else if (keyword == "property") {
      if (header.elements.empty()) fail("\"property\" before any \"element\"");
      Property property;
      if (words.size() == 5 && words[1] == "list") {
        property.is_list = true;
        if (!ParseTypeName(words[2], &property.count_type) ||
            !ParseTypeName(words[3], &property.type)) {
          fail("unknown type in list property \"" + words[4] + "\"");
        }
        if (IsFloating(property.count_type)) fail("list count of a floating-point type");
        property.name = words[4];
      } else if (words.size() == 3 && words[1] != "list") {
        if (!ParseTypeName(words[1], &property.type)) fail("unknown type \"" + words[1] + "\"");
        property.name = words[2];
      } else {
        fail("expected \"property <type> <name>\" or \"property list <type> <type> <name>\"");
      }
      std::vector<Property>& properties = header.elements.back().properties;
      for (const Property& other : properties) {
        if (other.name == property.name) fail("a second property \"" + property.name + "\"");
      }
      properties.push_back(std::move(property));
    } else {
      fail("unknown header line \"" + std::string(line) + "\"");
    }
  }
  if (!has_format) throw InputError(path, 0, "the PLY header has no \"format\" line");
  header.data_offset = offset;
  header.line_count = line_number;
  return header;
}

// Where each vertex property goes, and the scalar fields of the result (names and types).
struct VertexLayout {
  std::vector<int> slots;  // One per property.
  bool has_normals = false;
  bool has_colors = false;
};

VertexLayout MakeLayout(const std::string& path, const Element& vertex, PlyPointCloud* cloud) {
  VertexLayout layout;
  const char* const kFixed[] = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue"};
  bool found[kScalar] = {};
  for (const Property& property : vertex.properties) {
    int slot = kSkip;
    if (!property.is_list) {
      std::string name = property.name;
      if (name.rfind("diffuse_", 0) == 0 && name != "diffuse_") name = name.substr(8);
      for (int i = 0; i < kScalar; ++i) {
        if (name == kFixed[i] && (i >= kRed || name == property.name)) slot = i;
      }
      if (slot != kSkip && found[slot]) {
        throw InputError(path, vertex.line,
                         "vertex element has both \"" + name + "\" and \"diffuse_" + name + "\"");
      }
      if (slot == kSkip) {
        slot = kScalar + static_cast<int>(cloud->scalars.size());
        cloud->scalars.push_back({property.name, property.type, {}});
      } else {
        found[slot] = true;
      }
    } else if (property.name == "x" || property.name == "y" || property.name == "z") {
      throw InputError(path, vertex.line, "vertex property \"" + property.name + "\" is a list");
    }
    layout.slots.push_back(slot);
  }
  for (int i = kX; i <= kZ; ++i) {
    if (!found[i]) {
      throw InputError(path, vertex.line,
                       fmt::format("vertex element has no \"{}\" property", kFixed[i]));
    }
  }
  const int normals = found[kNx] + found[kNy] + found[kNz];
  const int colors = found[kRed] + found[kGreen] + found[kBlue];
  if (normals != 0 && normals != 3) {
    throw InputError(path, vertex.line, "vertex element has some of nx, ny, nz but not all");
  }
  if (colors != 0 && colors != 3) {
    throw InputError(path, vertex.line, "vertex element has some of red, green, blue but not all");
  }
  layout.has_normals = normals == 3;
  layout.has_colors = colors == 3;
  return layout;
}

std::uint8_t ToColor(double value, PlyType type) {
  const double scaled = IsFloating(type) ? value * 255.0 : value;
  if (!(scaled > 0.0)) return 0;  // Also NaN.
  return static_cast<std::uint8_t>(std::min(255.0, std::round(scaled)));
}

// Stores one property value of vertex `index`.
void Store(int slot, PlyType type, double value, std::size_t index, PlyPointCloud* cloud) {
  if (slot >= kScalar) {
    cloud->scalars[slot - kScalar].values[index] = value;
  } else if (slot >= kRed) {
    cloud->colors[index][slot - kRed] = ToColor(value, type);
  } else if (slot >= kNx) {
    cloud->normals[index][slot - kNx] = static_cast<float>(value);
  } else if (slot >= kX) {
    cloud->points[index][slot] = value;
  }
}

void Resize(const VertexLayout& layout, std::size_t n, PlyPointCloud* cloud) {
  cloud->points.assign(n, Eigen::Vector3d::Zero());
  if (layout.has_normals) cloud->normals.assign(n, Eigen::Vector3f::Zero());
  if (layout.has_colors) cloud->colors.assign(n, {0, 0, 0});
  for (PlyScalarField& field : cloud->scalars) field.values.assign(n, 0.0);
}

template <typename T>
T LoadLittleEndian(const char* bytes) {
  using Bits = std::conditional_t<
      sizeof(T) == 1, std::uint8_t,
      std::conditional_t<sizeof(T) == 2, std::uint16_t,
                         std::conditional_t<sizeof(T) == 4, std::uint32_t, std::uint64_t>>>;
  Bits bits = 0;
  for (std::size_t i = sizeof(T); i-- > 0;) {
    bits = static_cast<Bits>((static_cast<std::uint64_t>(bits) << 8) |
                             static_cast<std::uint8_t>(bytes[i]));
  }
  return std::bit_cast<T>(bits);
}

double LoadBinary(const char* bytes, PlyType type) {
  switch (type) {
    case PlyType::kInt8:
      return LoadLittleEndian<std::int8_t>(bytes);
    case PlyType::kUint8:
      return LoadLittleEndian<std::uint8_t>(bytes);
    case PlyType::kInt16:
      return LoadLittleEndian<std::int16_t>(bytes);
    case PlyType::kUint16:
      return LoadLittleEndian<std::uint16_t>(bytes);
    case PlyType::kInt32:
      return LoadLittleEndian<std::int32_t>(bytes);
    case PlyType::kUint32:
      return LoadLittleEndian<std::uint32_t>(bytes);
    case PlyType::kFloat32:
      return LoadLittleEndian<float>(bytes);
    case PlyType::kFloat64:
      return LoadLittleEndian<double>(bytes);
  }
  return 0.0;
}

void ReadBinary(const std::string& path, const Header& header, const VertexLayout& layout,
                std::string_view data, PlyPointCloud* cloud) {
  std::size_t offset = header.data_offset;
  auto truncated = [&](const Element& element, std::int64_t record) {
    return InputError(path, 0,
                      fmt::format("truncated data: element \"{}\" record {} of {} ends past the "
                                  "end of the file",
                                  element.name, record + 1, element.count));
  };
  for (const Element& element : header.elements) {
    const bool is_vertex = element.name == "vertex";
    // Minimum record size, to reject a count the file cannot hold before allocating for it.
    std::size_t min_record = 0;
    bool has_list = false;
    for (const Property& p : element.properties) {
      min_record += TypeSize(p.is_list ? p.count_type : p.type);
      has_list = has_list || p.is_list;
    }
    const std::size_t remaining = data.size() - offset;
    if (min_record > 0 && static_cast<std::uint64_t>(element.count) > remaining / min_record) {
      throw truncated(element, static_cast<std::int64_t>(remaining / min_record));
    }
    if (!is_vertex && !has_list) {
      offset += static_cast<std::size_t>(element.count) * min_record;
      continue;
    }
    if (is_vertex) Resize(layout, static_cast<std::size_t>(element.count), cloud);
    for (std::int64_t i = 0; i < element.count; ++i) {
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const Property& p = element.properties[k];
        if (p.is_list) {
          const int count_size = TypeSize(p.count_type);
          if (data.size() - offset < static_cast<std::size_t>(count_size)) {
            throw truncated(element, i);
          }
          const double count = LoadBinary(data.data() + offset, p.count_type);
          offset += count_size;
          if (count < 0) {
            throw InputError(path, 0,
                             fmt::format("element \"{}\" record {}: negative list length {}",
                                         element.name, i + 1, count));
          }
          const std::uint64_t bytes = static_cast<std::uint64_t>(count) * TypeSize(p.type);
          if (data.size() - offset < bytes) throw truncated(element, i);
          offset += bytes;
        } else {
          const int size = TypeSize(p.type);
          if (data.size() - offset < static_cast<std::size_t>(size)) throw truncated(element, i);
          if (is_vertex) {
            Store(layout.slots[k], p.type, LoadBinary(data.data() + offset, p.type),
                  static_cast<std::size_t>(i), cloud);
          }
          offset += size;
        }
      }
    }
  }
  if (offset != data.size()) {
    throw InputError(path, 0,
                     fmt::format("{} bytes after the last element: the data does not match the "
                                 "element counts of the header",
                                 data.size() - offset));
  }
}

// Parses an ASCII value of `type`; integers must be whole and in range.
bool ParseAscii(const std::string& word, PlyType type, double* value) {
  const char* begin = word.data();
  const char* end = word.data() + word.size();
  if (begin != end && *begin == '+') ++begin;
  if (!IsFloating(type)) {
    std::int64_t integer = 0;
    auto [ptr, ec] = std::from_chars(begin, end, integer);
    if (ec == std::errc() && ptr == end) {
      *value = static_cast<double>(integer);
    } else {
      // Some writers print integer properties as "255.0".
      auto [ptr2, ec2] = std::from_chars(begin, end, *value);
      if (ec2 != std::errc() || ptr2 != end || *value != std::round(*value)) return false;
    }
    double lo = 0, hi = 0;
    IntegerRange(type, &lo, &hi);
    return *value >= lo && *value <= hi;
  }
  auto [ptr, ec] = std::from_chars(begin, end, *value);
  // Out-of-range values (ec == result_out_of_range) are rejected as well.
  if (ec != std::errc() || ptr != end) return false;
  if (type == PlyType::kFloat32) *value = static_cast<float>(*value);
  return true;
}

void ReadAscii(const std::string& path, const Header& header, const VertexLayout& layout,
               std::string_view data, PlyPointCloud* cloud) {
  std::size_t offset = header.data_offset;
  int line_number = header.line_count;
  std::string_view line;
  bool terminated = false;
  // The next line that is not blank, or false at the end of the file.
  auto next = [&](std::vector<std::string>* words) {
    while (NextLine(data, &offset, &line, &terminated)) {
      ++line_number;
      *words = SplitWords(line);
      if (!words->empty()) return true;
    }
    return false;
  };
  std::vector<std::string> words;
  for (const Element& element : header.elements) {
    const bool is_vertex = element.name == "vertex";
    if (is_vertex) {
      // A record takes at least two bytes ("0\n") per property: bounds the allocation.
      const std::size_t bound = (data.size() - offset) / 2 + 1;
      if (static_cast<std::uint64_t>(element.count) > bound) {
        throw InputError(path, 0,
                         fmt::format("truncated data: the file is too short for {} \"vertex\" "
                                     "records",
                                     element.count));
      }
      Resize(layout, static_cast<std::size_t>(element.count), cloud);
    }
    for (std::int64_t i = 0; i < element.count; ++i) {
      if (!next(&words)) {
        throw InputError(path, line_number,
                         fmt::format("truncated data: element \"{}\" has {} records of the {} "
                                     "the header declares",
                                     element.name, i, element.count));
      }
      std::size_t w = 0;
      for (std::size_t k = 0; k < element.properties.size(); ++k) {
        const Property& p = element.properties[k];
        if (w >= words.size()) {
          throw InputError(path, line_number,
                           fmt::format("element \"{}\": too few values on the line (no value "
                                       "for \"{}\")",
                                       element.name, p.name));
        }
        double value = 0.0;
        if (!ParseAscii(words[w], p.is_list ? p.count_type : p.type, &value)) {
          throw InputError(path, line_number,
                           fmt::format("\"{}\" is not a valid {} value for \"{}\"", words[w],
                                       PlyTypeName(p.is_list ? p.count_type : p.type), p.name));
        }
        ++w;
        if (p.is_list) {
          if (value < 0 || value > static_cast<double>(words.size() - w)) {
            throw InputError(
                path, line_number,
                fmt::format("list \"{}\" of length {} does not fit the line", p.name, value));
          }
          w += static_cast<std::size_t>(value);
        } else if (is_vertex) {
          Store(layout.slots[k], p.type, value, static_cast<std::size_t>(i), cloud);
        }
      }
      if (w != words.size()) {
        throw InputError(path, line_number,
                         fmt::format("element \"{}\": {} values on the line, expected {}",
                                     element.name, words.size(), w));
      }
    }
  }
  if (next(&words)) {
    throw InputError(path, line_number,
                     "data after the last element: the data does not match the element counts "
                     "of the header");
  }
}

}  // namespace

const char* PlyTypeName(PlyType type) {
  switch (type) {
    case PlyType::kInt8:
      return "char";
    case PlyType::kUint8:
      return "uchar";
    case PlyType::kInt16:
      return "short";
    case PlyType::kUint16:
      return "ushort";
    case PlyType::kInt32:
      return "int";
    case PlyType::kUint32:
      return "uint";
    case PlyType::kFloat32:
      return "float";
    case PlyType::kFloat64:
      return "double";
  }
  return "?";
}

const PlyScalarField* PlyPointCloud::FindScalar(const std::string& name) const {
  for (const PlyScalarField& field : scalars) {
    if (field.name == name) return &field;
  }
  return nullptr;
}

void PlyPointCloud::Append(const PlyPointCloud& part) {
  std::string why;
  CROP4D_CHECK_MSG(part.Check(&why), why);
  if (points.empty() && scalars.empty()) {
    for (const PlyScalarField& field : part.scalars)
      scalars.push_back({field.name, field.type, {}});
  }
  CROP4D_CHECK_MSG(scalars.size() == part.scalars.size(),
                   "appending a cloud of other scalar fields");
  if (!points.empty() && !part.points.empty()) {
    CROP4D_CHECK_MSG(
        normals.empty() == part.normals.empty() && colors.empty() == part.colors.empty(),
        "appending a cloud with other normals or colours");
  }
  points.insert(points.end(), part.points.begin(), part.points.end());
  normals.insert(normals.end(), part.normals.begin(), part.normals.end());
  colors.insert(colors.end(), part.colors.begin(), part.colors.end());
  for (std::size_t k = 0; k < scalars.size(); ++k) {
    CROP4D_CHECK_MSG(
        scalars[k].name == part.scalars[k].name && scalars[k].type == part.scalars[k].type,
        "appending a cloud of other scalar fields");
    scalars[k].values.insert(scalars[k].values.end(), part.scalars[k].values.begin(),
                             part.scalars[k].values.end());
  }
}

bool PlyPointCloud::Check(std::string* why) const {
  auto fail = [&](const std::string& what) {
    if (why != nullptr) *why = what;
    return false;
  };
  const std::size_t n = points.size();
  if (!colors.empty() && colors.size() != n) {
    return fail(fmt::format("{} colours for {} points", colors.size(), n));
  }
  if (!normals.empty() && normals.size() != n) {
    return fail(fmt::format("{} normals for {} points", normals.size(), n));
  }
  std::set<std::string> names;
  for (const PlyScalarField& field : scalars) {
    const std::string problem = ScalarNameProblem(field.name, &names);
    if (!problem.empty()) return fail(problem);
    if (field.values.size() != n) {
      return fail(fmt::format("scalar field \"{}\" has {} values for {} points", field.name,
                              field.values.size(), n));
    }
  }
  return true;
}

void WritePly(const std::string& path, const PlyPointCloud& cloud, const PlyWriteOptions& options) {
  std::string why;
  CROP4D_CHECK_MSG(cloud.Check(&why), why);
  const std::string header = PlyHeader(LayoutOf(cloud), cloud.size(), options);
  AtomicFile file(path);
  file.stream().write(header.data(), static_cast<std::streamsize>(header.size()));
  WriteRecords(cloud, options.format, file.stream());
  file.Commit();  // Throws when a write failed.
}

bool operator==(const PlyLayout& a, const PlyLayout& b) {
  return a.normals == b.normals && a.colors == b.colors && a.scalars == b.scalars;
}

PlyLayout LayoutOf(const PlyPointCloud& cloud) {
  PlyLayout layout;
  layout.normals = !cloud.normals.empty();
  layout.colors = !cloud.colors.empty();
  for (const PlyScalarField& field : cloud.scalars)
    layout.scalars.emplace_back(field.name, field.type);
  return layout;
}

PlyStreamWriter::PlyStreamWriter(const std::string& path, const PlyLayout& layout,
                                 const PlyWriteOptions& options)
    : path_(path), layout_(layout), options_(options) {
  std::set<std::string> names;
  for (const auto& [name, type] : layout_.scalars) {
    const std::string problem = ScalarNameProblem(name, &names);
    CROP4D_CHECK_MSG(problem.empty(), problem);
  }
  const std::filesystem::path parent = std::filesystem::path(path_).parent_path();
  std::error_code ec;
  if (!parent.empty()) {
    std::filesystem::create_directories(parent, ec);
    if (ec) {
      throw InputError(path_, 0, "cannot create folder " + parent.string() + ": " + ec.message());
    }
  }
  if (std::filesystem::is_directory(path_, ec)) {
    throw InputError(path_, 0, "cannot write: it is a folder");
  }
  body_path_ = BodyPath(path_);
  body_.open(body_path_, std::ios::binary | std::ios::trunc);
  if (!body_) {
    throw InputError(
        path_, 0, "cannot create the temporary file " + body_path_ + ": " + std::strerror(errno));
  }
}

PlyStreamWriter::~PlyStreamWriter() {
  if (body_path_.empty()) return;
  body_.close();
  std::error_code ec;
  std::filesystem::remove(body_path_, ec);
}

void PlyStreamWriter::Append(const PlyPointCloud& part) {
  CROP4D_CHECK_MSG(!finished_, "PlyStreamWriter::Append after Finish");
  std::string why;
  CROP4D_CHECK_MSG(part.Check(&why), why);
  PlyLayout part_layout = LayoutOf(part);
  if (part.size() == 0) {  // Its normals and colours cannot show: only the scalars count.
    part_layout.normals = layout_.normals;
    part_layout.colors = layout_.colors;
  }
  const std::string difference = LayoutDifference(layout_, part_layout);
  CROP4D_CHECK_MSG(difference.empty(), difference);
  if (!WriteRecords(part, options_.format, body_)) {
    throw InputError(path_, 0, "cannot write the temporary file " + body_path_ + " (disk full?)");
  }
  size_ += part.size();
}

void PlyStreamWriter::Finish() {
  CROP4D_CHECK_MSG(!finished_, "PlyStreamWriter::Finish called twice");
  finished_ = true;
  body_.close();  // Flushes.
  if (body_.fail()) {
    throw InputError(path_, 0, "cannot write the temporary file " + body_path_ + " (disk full?)");
  }
  const std::string header = PlyHeader(layout_, size_, options_);
  AtomicFile file(path_);
  std::ofstream& out = file.stream();
  out.write(header.data(), static_cast<std::streamsize>(header.size()));
  AppendFileTo(body_path_, path_, out);  // In blocks: the body may be larger than memory.
  file.Commit();                         // Throws when a write failed.
  std::error_code ec;
  std::filesystem::remove(body_path_, ec);
  body_path_.clear();
}

PlyPointCloud ReadPly(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path, 0, "cannot open the PLY file");
  const std::string data((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (in.bad()) throw InputError(path, 0, "cannot read the PLY file");
  const Header header = ParseHeader(path, data);
  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) {
    throw InputError(path, 0, "the PLY file has no \"vertex\" element");
  }
  PlyPointCloud cloud;
  const VertexLayout layout = MakeLayout(path, *vertex, &cloud);
  if (header.format == PlyFormat::kBinaryLittleEndian) {
    ReadBinary(path, header, layout, data, &cloud);
  } else {
    ReadAscii(path, header, layout, data, &cloud);
  }
  return cloud;
}

PlyVertexReader::PlyVertexReader(const std::string& path) : path_(path) {
  in_.open(path, std::ios::binary);
  if (!in_) throw InputError(path, 0, "cannot open the PLY file");
  // The header: read until its end, a block at a time.
  std::string head;
  std::array<char, 1 << 16> block;
  constexpr std::size_t kMaxHeader = std::size_t{1} << 24;  // (not a PLY file)
  while (head.size() < kMaxHeader &&
         (head.find("end_header") == std::string::npos ||
          head.find('\n', head.find("end_header")) == std::string::npos)) {
    in_.read(block.data(), block.size());
    if (in_.gcount() <= 0) break;
    head.append(block.data(), static_cast<std::size_t>(in_.gcount()));
  }
  in_.clear();
  const Header header = ParseHeader(path, head);
  const auto vertex = std::find_if(header.elements.begin(), header.elements.end(),
                                   [](const Element& e) { return e.name == "vertex"; });
  if (vertex == header.elements.end()) {
    throw InputError(path, 0, "the PLY file has no \"vertex\" element");
  }
  const VertexLayout layout = MakeLayout(path, *vertex, &empty_);  // (its scalar fields)
  layout_ = LayoutOf(empty_);
  layout_.normals = layout.has_normals;
  layout_.colors = layout.has_colors;

  std::error_code ec;
  const std::uintmax_t file_size = std::filesystem::file_size(path, ec);
  if (ec) throw InputError(path, 0, "cannot read the PLY file: " + ec.message());
  const auto truncated = [&](const Element& e, std::uintmax_t held) {
    return InputError(path, 0,
                      fmt::format("truncated data: the file holds {} of the {} \"{}\" records "
                                  "its header announces",
                                  held, e.count, e.name));
  };

  // Seekable: binary, fixed-size records before and in the vertex element.
  bool seekable = header.format == PlyFormat::kBinaryLittleEndian;
  std::uintmax_t offset = header.data_offset;
  for (auto e = header.elements.begin(); seekable && e != vertex; ++e) {
    std::uintmax_t record = 0;
    for (const Property& p : e->properties) {
      seekable = seekable && !p.is_list;
      record += TypeSize(p.type);
    }
    const std::uintmax_t left = file_size > offset ? file_size - offset : 0;
    const std::uintmax_t held = record > 0 ? left / record : 0;
    if (seekable && record > 0 && static_cast<std::uintmax_t>(e->count) > held) {
      throw truncated(*e, held);
    }
    offset += static_cast<std::uintmax_t>(e->count) * record;
  }
  for (const Property& p : vertex->properties) {
    seekable = seekable && !p.is_list;
    record_size_ += TypeSize(p.type);
    types_.push_back(p.type);
  }
  if (!seekable) {
    cloud_ = ReadPly(path);
    size_ = cloud_.size();
    whole_ = true;
    return;
  }
  slots_ = layout.slots;
  data_offset_ = static_cast<std::size_t>(offset);
  size_ = static_cast<std::size_t>(vertex->count);
  const std::uintmax_t left = file_size > offset ? file_size - offset : 0;
  if (left / record_size_ < size_) throw truncated(*vertex, left / record_size_);
  const bool last = vertex + 1 == header.elements.end();
  if (last && left > size_ * record_size_) {
    throw InputError(path, 0,
                     fmt::format("{} bytes after the last element: the data does not match the "
                                 "element counts of the header",
                                 left - size_ * record_size_));
  }
}

PlyPointCloud PlyVertexReader::Read(std::size_t start, std::size_t count) {
  start = std::min(start, size_);
  count = std::min(count, size_ - start);
  PlyPointCloud part = empty_;
  if (whole_) {
    const auto from = static_cast<std::ptrdiff_t>(start);
    const auto to = static_cast<std::ptrdiff_t>(start + count);
    part.points.assign(cloud_.points.begin() + from, cloud_.points.begin() + to);
    if (!cloud_.normals.empty()) {
      part.normals.assign(cloud_.normals.begin() + from, cloud_.normals.begin() + to);
    }
    if (!cloud_.colors.empty()) {
      part.colors.assign(cloud_.colors.begin() + from, cloud_.colors.begin() + to);
    }
    for (std::size_t k = 0; k < part.scalars.size(); ++k) {
      const std::vector<double>& values = cloud_.scalars[k].values;
      part.scalars[k].values.assign(values.begin() + from, values.begin() + to);
    }
    return part;
  }
  VertexLayout layout;
  layout.slots = slots_;
  layout.has_normals = layout_.normals;
  layout.has_colors = layout_.colors;
  Resize(layout, count, &part);
  std::string bytes(count * record_size_, '\0');
  in_.seekg(static_cast<std::streamoff>(data_offset_ + start * record_size_));
  in_.read(bytes.data(), static_cast<std::streamsize>(bytes.size()));
  if (!in_ || static_cast<std::size_t>(in_.gcount()) != bytes.size()) {
    in_.clear();
    throw InputError(path_, 0,
                     fmt::format("cannot read vertices {} to {}", start + 1, start + count));
  }
  const char* record = bytes.data();
  for (std::size_t i = 0; i < count; ++i) {
    for (std::size_t k = 0; k < types_.size(); ++k) {
      Store(slots_[k], types_[k], LoadBinary(record, types_[k]), i, &part);
      record += TypeSize(types_[k]);
    }
  }
  return part;
}

void PlyPointCloud::AppendVertex(const PlyPointCloud& part, std::size_t i) {
  points.push_back(part.points[i]);
  if (!part.normals.empty()) normals.push_back(part.normals[i]);
  if (!part.colors.empty()) colors.push_back(part.colors[i]);
  for (std::size_t k = 0; k < part.scalars.size(); ++k) {
    scalars[k].values.push_back(part.scalars[k].values[i]);
  }
}

PlyPointCloud ReadPlyWhere(const std::string& path,
                           const std::function<bool(const Eigen::Vector3d&)>& keep) {
  constexpr std::size_t kSlice = std::size_t{1} << 18;
  PlyVertexReader reader(path);
  PlyPointCloud kept = reader.Read(0, 0);  // no point: the scalar fields' names and types
  for (std::size_t start = 0; start < reader.size(); start += kSlice) {
    const PlyPointCloud part = reader.Read(start, kSlice);
    for (std::size_t i = 0; i < part.size(); ++i) {
      if (!keep(part.points[i])) continue;
      kept.AppendVertex(part, i);
    }
  }
  return kept;
}

}  // namespace crop4d::io
