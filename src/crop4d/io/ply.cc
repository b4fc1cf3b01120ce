#include "crop4d/io/ply.h"

#include <fmt/format.h>

#include <algorithm>
#include <bit>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstring>
#include <fstream>
#include <iterator>
#include <limits>
#include <set>
#include <sstream>
#include <string_view>

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
  std::set<std::string> names;
  for (const PlyScalarField& field : scalars) {
    if (field.name.empty()) return fail("a scalar field without a name");
    for (char c : field.name) {
      if (std::isspace(static_cast<unsigned char>(c)) ||
          !std::isprint(static_cast<unsigned char>(c))) {
        return fail("scalar field name \"" + field.name + "\" is not a single printable word");
      }
    }
    if (kReserved.count(field.name) > 0) {
      return fail("scalar field name \"" + field.name + "\" is reserved");
    }
    if (!names.insert(field.name).second) {
      return fail("two scalar fields named \"" + field.name + "\"");
    }
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
  const bool binary = options.format == PlyFormat::kBinaryLittleEndian;
  const bool has_normals = !cloud.normals.empty();
  const bool has_colors = !cloud.colors.empty();

  std::string text = "ply\n";
  text += binary ? "format binary_little_endian 1.0\n" : "format ascii 1.0\n";
  std::istringstream comment(options.comment);
  for (std::string line; std::getline(comment, line);) {
    if (!line.empty() && line.back() == '\r') line.pop_back();
    text += "comment " + line + "\n";
  }
  text += fmt::format("element vertex {}\n", cloud.size());
  text += "property double x\nproperty double y\nproperty double z\n";
  if (has_normals) text += "property float nx\nproperty float ny\nproperty float nz\n";
  if (has_colors) text += "property uchar red\nproperty uchar green\nproperty uchar blue\n";
  for (const PlyScalarField& field : cloud.scalars) {
    text += fmt::format("property {} {}\n", PlyTypeName(field.type), field.name);
  }
  text += "end_header\n";

  AtomicFile file(path);
  std::ofstream& out = file.stream();
  out.write(text.data(), static_cast<std::streamsize>(text.size()));
  for (std::size_t start = 0; start < cloud.size(); start += kWriteChunk) {
    text.clear();
    const std::size_t stop = std::min(cloud.size(), start + kWriteChunk);
    for (std::size_t i = start; i < stop; ++i) {
      const Eigen::Vector3d& p = cloud.points[i];
      if (binary) {
        for (int k = 0; k < 3; ++k) AppendLittleEndian(p[k], &text);
        if (has_normals) {
          for (int k = 0; k < 3; ++k) AppendLittleEndian(cloud.normals[i][k], &text);
        }
        if (has_colors) {
          for (int k = 0; k < 3; ++k) AppendLittleEndian(cloud.colors[i][k], &text);
        }
        for (const PlyScalarField& field : cloud.scalars) {
          AppendBinary(field.values[i], field.type, field.name, &text);
        }
      } else {
        fmt::format_to(std::back_inserter(text), "{} {} {}", p.x(), p.y(), p.z());
        if (has_normals) {
          const Eigen::Vector3f& n = cloud.normals[i];
          fmt::format_to(std::back_inserter(text), " {} {} {}", n.x(), n.y(), n.z());
        }
        if (has_colors) {
          const auto& c = cloud.colors[i];
          fmt::format_to(std::back_inserter(text), " {} {} {}", int{c[0]}, int{c[1]}, int{c[2]});
        }
        for (const PlyScalarField& field : cloud.scalars) {
          text += ' ';
          AppendAscii(field.values[i], field.type, field.name, &text);
        }
        text += '\n';
      }
    }
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  file.Commit();
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

}  // namespace crop4d::io
