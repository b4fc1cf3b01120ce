#include "crop4d/io/colmap_text.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <memory>
#include <string_view>
#include <unordered_map>
#include <unordered_set>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"

namespace crop4d::io {
namespace {

// COLMAP puts the centre of the top-left pixel at (0.5, 0.5), crop4d (OpenCV) at (0, 0):
// colmap = crop4d + kPixelOffset.
constexpr double kPixelOffset = 0.5;

std::string Join(const std::string& folder, const char* file) {
  return (std::filesystem::path(folder) / file).string();
}

bool HasWhitespace(const std::string& text) {
  return text.find_first_of(" \t\r\n\v\f") != std::string::npos;
}

// The parameters COLMAP stores for `c` under ColmapCameraModelName(c), principal point shifted
// to COLMAP's pixel convention.
std::vector<double> ColmapParams(const geometry::PinholeRadTan& c) {
  std::vector<double> params = {c.fx, c.fy, c.cx + kPixelOffset, c.cy + kPixelOffset, c.k1, c.k2,
                                c.p1, c.p2};
  if (c.k3 != 0.0) params.insert(params.end(), {c.k3, 0.0, 0.0, 0.0});  // k3, k4, k5, k6
  return params;
}

// Buffers formatted text and hands it to an AtomicFile stream in large pieces.
class TextWriter {
 public:
  explicit TextWriter(const std::string& path) : path_(path), file_(path) {}

  template <typename... Args>
  void Print(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
    if (buffer_.size() > (1u << 20)) Flush();
  }
  void Commit() {
    Flush();
    file_.Commit();
  }
  // Appends the file at `from` (it may be larger than memory).
  void AppendFile(const std::string& from) {
    Flush();
    AppendFileTo(from, path_, file_.stream());
  }

 private:
  void Flush() {
    file_.stream().write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

  std::string path_;
  AtomicFile file_;
  fmt::memory_buffer buffer_;
};

// ---- reading --------------------------------------------------------------------------------

// Reads a text file line by line, counting lines, for messages "file:line: what".
class LineReader {
 public:
  explicit LineReader(std::string path) : path_(std::move(path)), in_(path_) {
    if (!in_ || std::filesystem::is_directory(path_)) {
      throw InputError(path_, 0, "cannot open the COLMAP model file");
    }
  }
  // The next line (without '\n' and a trailing '\r'); false at the end of the file.
  bool NextRaw(std::string* line) {
    if (!std::getline(in_, *line)) return false;
    ++line_;
    if (!line->empty() && line->back() == '\r') line->pop_back();
    return true;
  }
  // The next line that is neither blank nor a '#' comment.
  bool NextData(std::string* line) {
    while (NextRaw(line)) {
      const std::size_t first = line->find_first_not_of(" \t");
      if (first != std::string::npos && (*line)[first] != '#') return true;
    }
    return false;
  }
  const std::string& path() const { return path_; }
  std::int64_t line() const { return line_; }
  [[noreturn]] void Fail(const std::string& message) const {
    throw InputError(path_, line_, message);
  }

 private:
  std::string path_;
  std::ifstream in_;
  std::int64_t line_ = 0;
};

std::vector<std::string_view> Tokens(std::string_view line) {
  std::vector<std::string_view> tokens;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) tokens.push_back(line.substr(start, i - start));
  }
  return tokens;
}

double ParseFinite(const LineReader& reader, std::string_view token, const char* what) {
  double value = 0;
  if (!ParseDouble(token, &value)) {
    reader.Fail(fmt::format("{} '{}' is not a number", what, token));
  }
  if (!std::isfinite(value)) reader.Fail(fmt::format("{} is NaN or infinite", what));
  return value;
}

std::int64_t ParseInteger(const LineReader& reader, std::string_view token, const char* what,
                          std::int64_t min, std::int64_t max) {
  std::int64_t value = 0;
  if (!ParseInt64(token, &value)) {
    reader.Fail(fmt::format("{} '{}' is not an integer", what, token));
  }
  if (value < min || value > max) {
    reader.Fail(fmt::format("{} {} is out of range [{}, {}]", what, value, min, max));
  }
  return value;
}

constexpr std::int64_t kMaxId32 = std::numeric_limits<std::uint32_t>::max();
constexpr std::int64_t kMaxInt64 = std::numeric_limits<std::int64_t>::max();

// Camera intrinsics from a COLMAP model name and its parameters (COLMAP's pixel convention).
geometry::PinholeRadTan CameraFromColmap(const LineReader& reader, std::string_view model,
                                         const std::vector<double>& p) {
  struct ModelInfo {
    std::string_view name;
    std::size_t num_params;
  };
  static constexpr ModelInfo kModels[] = {{"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4},
                                          {"SIMPLE_RADIAL", 4},  {"RADIAL", 5},
                                          {"OPENCV", 8},         {"FULL_OPENCV", 12}};
  const ModelInfo* info = nullptr;
  for (const ModelInfo& m : kModels) {
    if (m.name == model) info = &m;
  }
  if (info == nullptr) {
    reader.Fail(
        fmt::format("camera model '{}' is not supported (crop4d reads SIMPLE_PINHOLE, PINHOLE, "
                    "SIMPLE_RADIAL, RADIAL, OPENCV and FULL_OPENCV with k4 = k5 = k6 = 0)",
                    model));
  }
  if (p.size() != info->num_params) {
    reader.Fail(fmt::format("camera model {} has {} parameters, found {}", model, info->num_params,
                            p.size()));
  }
  geometry::PinholeRadTan c;
  if (model == "SIMPLE_PINHOLE" || model == "SIMPLE_RADIAL" || model == "RADIAL") {
    c.fx = c.fy = p[0];
    c.cx = p[1];
    c.cy = p[2];
    if (model != "SIMPLE_PINHOLE") c.k1 = p[3];
    if (model == "RADIAL") c.k2 = p[4];
  } else {
    c.fx = p[0];
    c.fy = p[1];
    c.cx = p[2];
    c.cy = p[3];
    if (model != "PINHOLE") {
      c.k1 = p[4];
      c.k2 = p[5];
      c.p1 = p[6];
      c.p2 = p[7];
    }
    if (model == "FULL_OPENCV") {
      c.k3 = p[8];
      if (p[9] != 0.0 || p[10] != 0.0 || p[11] != 0.0) {
        reader.Fail(
            "FULL_OPENCV with rational coefficients k4, k5, k6 ≠ 0 is not supported (crop4d's "
            "camera is pinhole radial-tangential)");
      }
    }
  }
  c.cx -= kPixelOffset;
  c.cy -= kPixelOffset;
  return c;
}

std::vector<ColmapCamera> ReadCameras(const std::string& path) {
  LineReader reader(path);
  std::vector<ColmapCamera> cameras;
  std::unordered_set<std::uint32_t> ids;
  for (std::string line; reader.NextData(&line);) {
    const std::vector<std::string_view> t = Tokens(line);
    if (t.size() < 4) reader.Fail("expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
    ColmapCamera camera;
    camera.camera_id =
        static_cast<std::uint32_t>(ParseInteger(reader, t[0], "CAMERA_ID", 0, kMaxId32));
    if (!ids.insert(camera.camera_id).second) {
      reader.Fail(fmt::format("duplicate CAMERA_ID {}", camera.camera_id));
    }
    const int width = static_cast<int>(ParseInteger(reader, t[2], "WIDTH", 1, 1 << 20));
    const int height = static_cast<int>(ParseInteger(reader, t[3], "HEIGHT", 1, 1 << 20));
    std::vector<double> params;
    for (std::size_t i = 4; i < t.size(); ++i) params.push_back(ParseFinite(reader, t[i], "PARAM"));
    camera.intrinsics = CameraFromColmap(reader, t[1], params);
    camera.intrinsics.width = width;
    camera.intrinsics.height = height;
    if (const std::string why = camera.intrinsics.Check(); !why.empty()) {
      reader.Fail("invalid intrinsics: " + why);
    }
    cameras.push_back(camera);
  }
  return cameras;
}

// images.txt; `points_lines` gets the line number of each image's POINTS2D line.
std::vector<ColmapImage> ReadImages(const std::string& path,
                                    const std::unordered_set<std::uint32_t>& camera_ids,
                                    std::vector<std::int64_t>* points_lines) {
  LineReader reader(path);
  std::vector<ColmapImage> images;
  std::unordered_set<std::uint32_t> ids;
  for (std::string line; reader.NextData(&line);) {
    const std::vector<std::string_view> t = Tokens(line);
    if (t.size() != 10) {
      reader.Fail(fmt::format(
          "expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME (10 fields), found {}", t.size()));
    }
    ColmapImage image;
    image.image_id =
        static_cast<std::uint32_t>(ParseInteger(reader, t[0], "IMAGE_ID", 0, kMaxId32));
    if (!ids.insert(image.image_id).second) {
      reader.Fail(fmt::format("duplicate IMAGE_ID {}", image.image_id));
    }
    double v[7];
    static constexpr const char* kNames[] = {"QW", "QX", "QY", "QZ", "TX", "TY", "TZ"};
    for (int k = 0; k < 7; ++k) v[k] = ParseFinite(reader, t[1 + k], kNames[k]);
    const Eigen::Quaterniond q(v[0], v[1], v[2], v[3]);
    if (q.norm() < 1e-6) reader.Fail("zero quaternion");
    const geometry::Rigid3 camera_from_world(q, Eigen::Vector3d(v[4], v[5], v[6]));
    image.world_from_camera = camera_from_world.Inverse();
    image.camera_id =
        static_cast<std::uint32_t>(ParseInteger(reader, t[8], "CAMERA_ID", 0, kMaxId32));
    if (!camera_ids.contains(image.camera_id)) {
      reader.Fail(fmt::format("CAMERA_ID {} is not in cameras.txt", image.camera_id));
    }
    image.name = std::string(t[9]);

    // The POINTS2D line follows directly (empty when the image has no 2D points).
    if (!reader.NextRaw(&line)) {
      reader.Fail(
          fmt::format("image {} has no POINTS2D line (X Y POINT3D_ID ...)", image.image_id));
    }
    const std::vector<std::string_view> p = Tokens(line);
    if (p.size() % 3 != 0) {
      reader.Fail(
          fmt::format("expected POINTS2D as X Y POINT3D_ID triples, found {} fields", p.size()));
    }
    image.points2d.resize(p.size() / 3);
    for (std::size_t i = 0; i < image.points2d.size(); ++i) {
      ColmapPoint2D& point = image.points2d[i];
      point.xy = Eigen::Vector2d(ParseFinite(reader, p[3 * i], "X") - kPixelOffset,
                                 ParseFinite(reader, p[3 * i + 1], "Y") - kPixelOffset);
      point.point3d_id = ParseInteger(reader, p[3 * i + 2], "POINT3D_ID", -1, kMaxInt64);
    }
    points_lines->push_back(reader.line());
    images.push_back(std::move(image));
  }
  return images;
}

// points3D.txt, checked against the images' 2D points (both directions).
std::vector<ColmapPoint3D> ReadPoints(const std::string& path,
                                      const std::vector<ColmapImage>& images,
                                      const std::string& images_path,
                                      const std::vector<std::int64_t>& points_lines) {
  std::unordered_map<std::uint32_t, std::size_t> image_index;
  for (std::size_t i = 0; i < images.size(); ++i) image_index[images[i].image_id] = i;
  // Which 2D points a track has claimed.
  std::vector<std::vector<bool>> claimed(images.size());
  for (std::size_t i = 0; i < images.size(); ++i)
    claimed[i].assign(images[i].points2d.size(), false);

  LineReader reader(path);
  std::vector<ColmapPoint3D> points;
  std::unordered_set<std::int64_t> ids;
  for (std::string line; reader.NextData(&line);) {
    const std::vector<std::string_view> t = Tokens(line);
    if (t.size() < 8 || (t.size() - 8) % 2 != 0) {
      reader.Fail("expected POINT3D_ID X Y Z R G B ERROR followed by (IMAGE_ID POINT2D_IDX) pairs");
    }
    ColmapPoint3D point;
    point.point3d_id = ParseInteger(reader, t[0], "POINT3D_ID", 0, kMaxInt64);
    if (!ids.insert(point.point3d_id).second) {
      reader.Fail(fmt::format("duplicate POINT3D_ID {}", point.point3d_id));
    }
    point.xyz = Eigen::Vector3d(ParseFinite(reader, t[1], "X"), ParseFinite(reader, t[2], "Y"),
                                ParseFinite(reader, t[3], "Z"));
    static constexpr const char* kColours[] = {"R", "G", "B"};
    for (int k = 0; k < 3; ++k) {
      point.rgb[k] = static_cast<std::uint8_t>(ParseInteger(reader, t[4 + k], kColours[k], 0, 255));
    }
    // COLMAP writes -1 for a point whose error was never computed.
    point.error = ParseFinite(reader, t[7], "ERROR");
    for (std::size_t i = 8; i < t.size(); i += 2) {
      ColmapTrackElement e;
      e.image_id = static_cast<std::uint32_t>(ParseInteger(reader, t[i], "IMAGE_ID", 0, kMaxId32));
      e.point2d_idx =
          static_cast<std::uint32_t>(ParseInteger(reader, t[i + 1], "POINT2D_IDX", 0, kMaxId32));
      const auto found = image_index.find(e.image_id);
      if (found == image_index.end()) {
        reader.Fail(fmt::format("track of point {}: IMAGE_ID {} is not in images.txt",
                                point.point3d_id, e.image_id));
      }
      const ColmapImage& image = images[found->second];
      if (e.point2d_idx >= image.points2d.size()) {
        reader.Fail(fmt::format("track of point {}: image {} has no 2D point {} (it has {})",
                                point.point3d_id, e.image_id, e.point2d_idx,
                                image.points2d.size()));
      }
      if (image.points2d[e.point2d_idx].point3d_id != point.point3d_id) {
        reader.Fail(fmt::format("track of point {}: 2D point {} of image {} refers to 3D point {}",
                                point.point3d_id, e.point2d_idx, e.image_id,
                                image.points2d[e.point2d_idx].point3d_id));
      }
      if (claimed[found->second][e.point2d_idx]) {
        reader.Fail(fmt::format("track of point {}: 2D point {} of image {} is listed twice",
                                point.point3d_id, e.point2d_idx, e.image_id));
      }
      claimed[found->second][e.point2d_idx] = true;
      point.track.push_back(e);
    }
    points.push_back(std::move(point));
  }
  // Every 2D point that names a 3D point must be in that point's track.
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (std::size_t k = 0; k < images[i].points2d.size(); ++k) {
      const std::int64_t id = images[i].points2d[k].point3d_id;
      if (id >= 0 && !claimed[i][k]) {
        throw InputError(images_path, points_lines[i],
                         fmt::format("2D point {} of image {} refers to 3D point {}, {}", k,
                                     images[i].image_id, id,
                                     ids.contains(id) ? "whose track does not contain it"
                                                      : "which is not in points3D.txt"));
      }
    }
  }
  return points;
}

}  // namespace

std::string ColmapImageName(std::string name) {
  std::replace_if(
      name.begin(), name.end(), [](unsigned char c) { return std::isspace(c) != 0; }, '_');
  return name;
}

const char* ColmapCameraModelName(const geometry::PinholeRadTan& camera) {
  return camera.k3 == 0.0 ? "OPENCV" : "FULL_OPENCV";
}

std::size_t ColmapModel::NumObservations() const {
  std::size_t n = 0;
  for (const ColmapImage& image : images) {
    for (const ColmapPoint2D& p : image.points2d) n += p.point3d_id >= 0 ? 1 : 0;
  }
  return n;
}

bool ColmapModel::Check(std::string* why) const {
  auto fail = [why](std::string message) {
    if (why != nullptr) *why = std::move(message);
    return false;
  };
  std::unordered_set<std::uint32_t> camera_ids;
  for (const ColmapCamera& c : cameras) {
    if (!camera_ids.insert(c.camera_id).second) {
      return fail(fmt::format("duplicate camera id {}", c.camera_id));
    }
    if (const std::string invalid = c.intrinsics.Check(); !invalid.empty()) {
      return fail(fmt::format("camera {} is invalid: {}", c.camera_id, invalid));
    }
  }
  std::unordered_map<std::uint32_t, std::size_t> image_index;
  for (std::size_t i = 0; i < images.size(); ++i) {
    const ColmapImage& image = images[i];
    if (!image_index.emplace(image.image_id, i).second) {
      return fail(fmt::format("duplicate image id {}", image.image_id));
    }
    if (!camera_ids.contains(image.camera_id)) {
      return fail(fmt::format("image {} refers to camera {}, which does not exist", image.image_id,
                              image.camera_id));
    }
    if (image.name.empty() || HasWhitespace(image.name)) {
      return fail(fmt::format("image {} has the name '{}' (empty or with whitespace)",
                              image.image_id, image.name));
    }
    if (!image.world_from_camera.translation().allFinite() ||
        !image.world_from_camera.rotation().coeffs().allFinite()) {
      return fail(fmt::format("image {} has a non-finite pose", image.image_id));
    }
    for (const ColmapPoint2D& p : image.points2d) {
      if (!p.xy.allFinite() || p.point3d_id < -1) {
        return fail(fmt::format("image {} has a non-finite 2D point or a 3D point id < -1",
                                image.image_id));
      }
    }
  }
  std::unordered_set<std::int64_t> point_ids;
  std::vector<std::vector<bool>> claimed(images.size());
  for (std::size_t i = 0; i < images.size(); ++i)
    claimed[i].assign(images[i].points2d.size(), false);
  for (const ColmapPoint3D& point : points) {
    if (point.point3d_id < 0 || !point_ids.insert(point.point3d_id).second) {
      return fail(fmt::format("3D point id {} is negative or duplicate", point.point3d_id));
    }
    if (!point.xyz.allFinite() || !std::isfinite(point.error)) {
      return fail(fmt::format("3D point {} is not finite", point.point3d_id));
    }
    for (const ColmapTrackElement& e : point.track) {
      const auto found = image_index.find(e.image_id);
      if (found == image_index.end() || e.point2d_idx >= images[found->second].points2d.size() ||
          images[found->second].points2d[e.point2d_idx].point3d_id != point.point3d_id ||
          claimed[found->second][e.point2d_idx]) {
        return fail(fmt::format(
            "track of 3D point {}: (image {}, 2D point {}) is missing, names another 3D point, "
            "or is listed twice",
            point.point3d_id, e.image_id, e.point2d_idx));
      }
      claimed[found->second][e.point2d_idx] = true;
    }
  }
  for (std::size_t i = 0; i < images.size(); ++i) {
    for (std::size_t k = 0; k < images[i].points2d.size(); ++k) {
      if (images[i].points2d[k].point3d_id >= 0 && !claimed[i][k]) {
        return fail(fmt::format("2D point {} of image {} is not in the track of 3D point {}", k,
                                images[i].image_id, images[i].points2d[k].point3d_id));
      }
    }
  }
  return true;
}

namespace {

// The files' parts, shared by WriteColmapText and ColmapTextWriter (the same bytes).

void CheckImageName(const std::string& folder, const ColmapImage& image) {
  if (image.name.empty() || HasWhitespace(image.name)) {
    throw InputError(Join(folder, "images.txt"), 0,
                     fmt::format("image {}: the name '{}' is empty or holds whitespace, which "
                                 "COLMAP's text format cannot store",
                                 image.image_id, image.name));
  }
}

void WriteCamerasFile(const std::string& folder, const std::vector<ColmapCamera>& cameras) {
  TextWriter out(Join(folder, "cameras.txt"));
  out.Print("# Camera list with one line of data per camera:\n");
  out.Print("#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n");
  out.Print("# Number of cameras: {}\n", cameras.size());
  out.Print(
      "# crop4d: principal point in COLMAP's pixel convention (top-left pixel centre at "
      "(0.5, 0.5))\n");
  for (const ColmapCamera& c : cameras) {
    out.Print("{} {} {} {}", c.camera_id, ColmapCameraModelName(c.intrinsics), c.intrinsics.width,
              c.intrinsics.height);
    for (double p : ColmapParams(c.intrinsics)) out.Print(" {}", p);
    out.Print("\n");
  }
  out.Commit();
}

template <typename Writer>
void PrintImagesHeader(std::size_t num_images, std::size_t num_observations, Writer* out) {
  const double mean_observations =
      num_images == 0 ? 0.0 : double(num_observations) / double(num_images);
  out->Print("# Image list with two lines of data per image:\n");
  out->Print("#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n");
  out->Print("#   POINTS2D[] as (X, Y, POINT3D_ID)\n");
  out->Print("# Number of images: {}, mean observations per image: {}\n", num_images,
             mean_observations);
  out->Print("# crop4d: pose = camera_from_world; 2D points in COLMAP's pixel convention\n");
}

template <typename Writer>
void PrintImage(const ColmapImage& image, Writer* out) {
  const geometry::Rigid3 camera_from_world = image.world_from_camera.Inverse();
  const Eigen::Quaterniond& q = camera_from_world.rotation();
  const Eigen::Vector3d& t = camera_from_world.translation();
  out->Print("{} {} {} {} {} {} {} {} {} {}\n", image.image_id, q.w(), q.x(), q.y(), q.z(), t.x(),
             t.y(), t.z(), image.camera_id, image.name);
  for (std::size_t k = 0; k < image.points2d.size(); ++k) {
    const ColmapPoint2D& p = image.points2d[k];
    out->Print("{}{} {} {}", k == 0 ? "" : " ", p.xy.x() + kPixelOffset, p.xy.y() + kPixelOffset,
               p.point3d_id);
  }
  out->Print("\n");
}

template <typename Writer>
void PrintPointsHeader(std::size_t num_points, std::size_t track_sum, Writer* out) {
  const double mean_track = num_points == 0 ? 0.0 : double(track_sum) / double(num_points);
  out->Print("# 3D point list with one line of data per point:\n");
  out->Print("#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n");
  out->Print("# Number of points: {}, mean track length: {}\n", num_points, mean_track);
}

template <typename Writer>
void PrintPoint(const ColmapPoint3D& p, Writer* out) {
  out->Print("{} {} {} {} {} {} {} {}", p.point3d_id, p.xyz.x(), p.xyz.y(), p.xyz.z(),
             int{p.rgb[0]}, int{p.rgb[1]}, int{p.rgb[2]}, p.error);
  for (const ColmapTrackElement& e : p.track) out->Print(" {} {}", e.image_id, e.point2d_idx);
  out->Print("\n");
}

// Buffers formatted text for a plain (temporary) file; Close() reports a failed write.
class SpillWriter {
 public:
  SpillWriter(const std::string& path, const std::string& target) : path_(path), target_(target) {
    file_.open(path_, std::ios::binary | std::ios::trunc);
    if (!file_) {
      throw InputError(target_, 0,
                       "cannot create the temporary file " + path_ + ": " + std::strerror(errno));
    }
  }
  template <typename... Args>
  void Print(fmt::format_string<Args...> format, Args&&... args) {
    fmt::format_to(std::back_inserter(buffer_), format, std::forward<Args>(args)...);
    if (buffer_.size() > (1u << 20)) Flush();
  }
  void Write(const void* data, std::size_t size) {
    const char* bytes = static_cast<const char*>(data);
    buffer_.append(bytes, bytes + size);
    if (buffer_.size() > (1u << 20)) Flush();
  }
  void Close() {
    Flush();
    file_.close();
    if (file_.fail()) {
      throw InputError(target_, 0, "cannot write the temporary file " + path_ + " (disk full?)");
    }
  }

 private:
  void Flush() {
    file_.write(buffer_.data(), static_cast<std::streamsize>(buffer_.size()));
    buffer_.clear();
  }

  std::string path_, target_;
  std::ofstream file_;
  fmt::memory_buffer buffer_;
};

// One observation of a 3D point, as it waits in its image group's temporary file.
struct SpilledPoint2D {
  std::uint32_t image = 0;   // index into the writer's images
  std::uint32_t unused = 0;  // no padding: every byte written is set
  double x = 0.0, y = 0.0;
  std::int64_t point3d_id = -1;
};

}  // namespace

void WriteColmapText(const std::string& folder, const ColmapModel& model) {
  for (const ColmapImage& image : model.images) CheckImageName(folder, image);
  std::string why;
  CROP4D_CHECK_MSG(model.Check(&why), why);
  WriteCamerasFile(folder, model.cameras);
  {
    TextWriter out(Join(folder, "images.txt"));
    PrintImagesHeader(model.images.size(), model.NumObservations(), &out);
    for (const ColmapImage& image : model.images) PrintImage(image, &out);
    out.Commit();
  }
  {
    std::size_t track_sum = 0;
    for (const ColmapPoint3D& p : model.points) track_sum += p.track.size();
    TextWriter out(Join(folder, "points3D.txt"));
    PrintPointsHeader(model.points.size(), track_sum, &out);
    for (const ColmapPoint3D& p : model.points) PrintPoint(p, &out);
    out.Commit();
  }
}

struct ColmapTextWriter::Spill {
  std::unique_ptr<SpillWriter> points;               // points3D.txt's lines
  std::vector<std::unique_ptr<SpillWriter>> groups;  // each image group's 2D points
};

ColmapTextWriter::ColmapTextWriter(const std::string& folder, std::vector<ColmapCamera> cameras,
                                   std::vector<ColmapImage> images,
                                   std::vector<std::uint32_t> image_groups)
    : folder_(folder),
      cameras_(std::move(cameras)),
      images_(std::move(images)),
      groups_(std::move(image_groups)),
      points2d_(images_.size(), 0),
      spill_(std::make_unique<Spill>()) {
  CROP4D_CHECK(groups_.size() == images_.size());
  std::unordered_set<std::uint32_t> camera_ids;
  for (const ColmapCamera& c : cameras_) {
    const std::string why = c.intrinsics.Check();
    CROP4D_CHECK_MSG(why.empty(), why);
    CROP4D_CHECK_MSG(camera_ids.insert(c.camera_id).second, "duplicate camera id");
  }
  std::unordered_set<std::uint32_t> image_ids;
  for (std::size_t i = 0; i < images_.size(); ++i) {
    CheckImageName(folder_, images_[i]);
    CROP4D_CHECK_MSG(camera_ids.count(images_[i].camera_id), "an image's camera is missing");
    CROP4D_CHECK_MSG(image_ids.insert(images_[i].image_id).second, "duplicate image id");
    CROP4D_CHECK_MSG(i == 0 || groups_[i] >= groups_[i - 1], "image groups out of order");
    images_[i].points2d.clear();
  }
  std::error_code ec;
  std::filesystem::create_directories(folder_, ec);
  if (ec) throw InputError(folder_, 0, "cannot create the folder: " + ec.message());
  spill_->points =
      std::make_unique<SpillWriter>(SpillPath("points3D"), Join(folder_, "points3D.txt"));
  const std::uint32_t num_groups = groups_.empty() ? 0 : groups_.back() + 1;
  for (std::uint32_t g = 0; g < num_groups; ++g) {
    spill_->groups.push_back(std::make_unique<SpillWriter>(SpillPath("group-" + std::to_string(g)),
                                                           Join(folder_, "images.txt")));
  }
}

ColmapTextWriter::~ColmapTextWriter() { RemoveSpills(); }

void ColmapTextWriter::RemoveSpills() {
  spill_.reset();
  std::error_code ec;
  std::filesystem::remove(SpillPath("points3D"), ec);
  const std::uint32_t num_groups = groups_.empty() ? 0 : groups_.back() + 1;
  for (std::uint32_t g = 0; g < num_groups; ++g) {
    std::filesystem::remove(SpillPath("group-" + std::to_string(g)), ec);
  }
}

std::string ColmapTextWriter::SpillPath(const std::string& part) const {
  return (std::filesystem::path(folder_) / (".crop4d-colmap-" + part + ".tmp")).string();
}

void ColmapTextWriter::AddPoint(std::int64_t point3d_id, const Eigen::Vector3d& xyz,
                                const std::array<std::uint8_t, 3>& rgb, double error,
                                const std::vector<ColmapObservation>& observations) {
  CROP4D_CHECK_MSG(!finished_, "ColmapTextWriter::AddPoint after Finish");
  CROP4D_CHECK(point3d_id >= 0 && xyz.allFinite() && std::isfinite(error));
  ColmapPoint3D point;
  point.point3d_id = point3d_id;
  point.xyz = xyz;
  point.rgb = rgb;
  point.error = error;
  for (const ColmapObservation& o : observations) {
    CROP4D_CHECK(o.image < images_.size() && o.pixel.allFinite());
    point.track.push_back({images_[o.image].image_id, points2d_[o.image]++});
    const SpilledPoint2D record{static_cast<std::uint32_t>(o.image), 0, o.pixel.x(), o.pixel.y(),
                                point3d_id};
    spill_->groups[groups_[o.image]]->Write(&record, sizeof(record));
  }
  track_sum_ += point.track.size();
  ++num_points_;
  PrintPoint(point, spill_->points.get());
}

void ColmapTextWriter::Finish() {
  CROP4D_CHECK_MSG(!finished_, "ColmapTextWriter::Finish called twice");
  finished_ = true;
  WriteCamerasFile(folder_, cameras_);
  spill_->points->Close();
  for (auto& group : spill_->groups) group->Close();
  {
    // A group's 2D points are read back and put in their images, in the order they came.
    std::size_t num_observations = 0;
    for (const std::uint32_t n : points2d_) num_observations += n;
    TextWriter out(Join(folder_, "images.txt"));
    PrintImagesHeader(images_.size(), num_observations, &out);
    std::size_t begin = 0;
    while (begin < images_.size()) {
      std::size_t end = begin;
      while (end < images_.size() && groups_[end] == groups_[begin]) ++end;
      for (std::size_t i = begin; i < end; ++i) images_[i].points2d.reserve(points2d_[i]);
      const std::string path = SpillPath("group-" + std::to_string(groups_[begin]));
      std::ifstream in(path, std::ios::binary);
      SpilledPoint2D record;
      while (in.read(reinterpret_cast<char*>(&record), sizeof(record))) {
        CROP4D_CHECK(record.image >= begin && record.image < end);
        images_[record.image].points2d.push_back({{record.x, record.y}, record.point3d_id});
      }
      if (in.bad()) throw InputError(Join(folder_, "images.txt"), 0, "cannot read " + path);
      for (std::size_t i = begin; i < end; ++i) {
        CROP4D_CHECK(images_[i].points2d.size() == points2d_[i]);
        PrintImage(images_[i], &out);
        images_[i].points2d = {};
      }
      begin = end;
    }
    out.Commit();
  }
  {
    TextWriter out(Join(folder_, "points3D.txt"));
    PrintPointsHeader(num_points_, track_sum_, &out);
    out.AppendFile(SpillPath("points3D"));
    out.Commit();
  }
  RemoveSpills();
}

ColmapModel ReadColmapText(const std::string& folder) {
  ColmapModel model;
  model.cameras = ReadCameras(Join(folder, "cameras.txt"));
  std::unordered_set<std::uint32_t> camera_ids;
  for (const ColmapCamera& c : model.cameras) camera_ids.insert(c.camera_id);
  const std::string images_path = Join(folder, "images.txt");
  std::vector<std::int64_t> points_lines;
  model.images = ReadImages(images_path, camera_ids, &points_lines);
  model.points = ReadPoints(Join(folder, "points3D.txt"), model.images, images_path, points_lines);
  return model;
}

}  // namespace crop4d::io
