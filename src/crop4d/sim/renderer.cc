#include "crop4d/sim/renderer.h"

#define GL_GLEXT_PROTOTYPES
#include <GL/gl.h>
#include <GL/glext.h>

#include <algorithm>
#include <array>
#include <cmath>
#include <cstring>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>
#include <string>
#include <unordered_map>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/sim/gl_context.h"
#include "crop4d/sim/plant_mesh.h"
#include "crop4d/sim/random.h"
#include "crop4d/sim/shaders.h"
#include "crop4d/sim/textures.h"

namespace crop4d::sim {
namespace {

using Eigen::Matrix3d;
using Eigen::Matrix4d;
using Eigen::Matrix4f;
using Eigen::Vector2d;
using Eigen::Vector3d;

constexpr double kNear = 0.05;        // near clip plane (m)
constexpr double kChunkLength = 1.0;  // plant chunks: one row × this length
constexpr double kTileSize = 4.0;     // terrain tiles
constexpr double kFineDx = 0.075;     // terrain grid across the rows (beds, tyre tracks)
constexpr double kCoarseDx = 0.5;     // terrain grid elsewhere
constexpr double kDy = 0.25;          // terrain grid along the rows

GLuint CompileShader(GLenum type, const std::string& source, const char* name) {
  const GLuint shader = glCreateShader(type);
  const char* text = source.c_str();
  glShaderSource(shader, 1, &text, nullptr);
  glCompileShader(shader);
  GLint ok = 0;
  glGetShaderiv(shader, GL_COMPILE_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetShaderInfoLog(shader, sizeof(log), nullptr, log);
    throw std::runtime_error(std::string("renderer: shader ") + name + " does not compile: " + log);
  }
  return shader;
}

GLuint LinkProgram(const std::string& vertex, const std::string& fragment, const char* name) {
  const GLuint vs = CompileShader(GL_VERTEX_SHADER, vertex, name);
  const GLuint fs = CompileShader(GL_FRAGMENT_SHADER, fragment, name);
  const GLuint program = glCreateProgram();
  glAttachShader(program, vs);
  glAttachShader(program, fs);
  glLinkProgram(program);
  glDeleteShader(vs);
  glDeleteShader(fs);
  GLint ok = 0;
  glGetProgramiv(program, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(program, sizeof(log), nullptr, log);
    throw std::runtime_error(std::string("renderer: program ") + name + " does not link: " + log);
  }
  return program;
}

std::string LitFragment(const char* body) {
  return std::string("#version 330 core\n") + shaders::kLightingCommon + body;
}

std::string LitVertex(const char* body) {
  return std::string("#version 330 core\n") + shaders::kLitVertexCommon + body;
}

// Normal → 4 signed bytes (w = flag).
void PackNormal(const Vector3d& n, std::int8_t flag, std::int8_t out[4]) {
  for (int i = 0; i < 3; ++i) {
    out[i] = static_cast<std::int8_t>(std::lround(std::clamp(n[i], -1.0, 1.0) * 127.0));
  }
  out[3] = flag;
}

struct TerrainVertex {
  float position[3];
  std::int8_t normal[4];
  std::uint8_t macro[2][4];  // the soil macro texture at its two scales (see BuildTerrain)
};
static_assert(sizeof(TerrainVertex) == 24);

// The soil macro texture's two layers: metres per texture period, and the second layer's
// rotation (cos, sin) and offset, at incommensurate scales so that their product never repeats
// within a field.
constexpr double kMacroPeriod1 = 61.7, kMacroPeriod2 = 17.3;
constexpr double kMacroCos2 = 0.8, kMacroSin2 = 0.6, kMacroOffset2[2] = {0.37, 0.71};

struct TreeVertex {
  float position[3];
  float uv[2];
  float normal[3];
};

// Column-major 4x4 float for glUniformMatrix4fv.
Matrix4f ToFloat(const Matrix4d& m) { return m.cast<float>(); }

// OpenCV pinhole intrinsics to an OpenGL clip transform. Window row j is image row v (no
// flip): x_ndc = 2 (u + ½) / W − 1 with u = fx X/Z + cx; likewise y; depth maps Z ∈ [n, f]
// to [−1, 1]. Works directly on OpenCV camera coordinates (x right, y down, z forward).
Matrix4d Projection(const geometry::PinholeRadTan& k, double near, double far) {
  Matrix4d p = Matrix4d::Zero();
  p(0, 0) = 2.0 * k.fx / k.width;
  p(0, 2) = 2.0 * (k.cx + 0.5) / k.width - 1.0;
  p(1, 1) = 2.0 * k.fy / k.height;
  p(1, 2) = 2.0 * (k.cy + 0.5) / k.height - 1.0;
  p(2, 2) = (far + near) / (far - near);
  p(2, 3) = -2.0 * far * near / (far - near);
  p(3, 2) = 1.0;
  return p;
}

struct GpuMesh {
  GLuint vao = 0, vbo = 0, ibo = 0;
  GLsizei count = 0;
  std::size_t bytes = 0;
  std::uint64_t last_used = 0;
  bool built = false;
};

struct Chunk {
  int row = 0;               // the row, or the weeds' strip
  bool weeds = false;        // World::weeds() rather than World::plants()
  int begin = 0, end = 0;    // plant (or weed) indices
  Eigen::AlignedBox3d box;   // bounds of the plants on the session's date
  Eigen::AlignedBox3d core;  // stems to half height: distances for the detail
  bool empty = true;         // no emerged plant
  std::array<GpuMesh, kNumPlantLods> lods;
};

struct TerrainTile {
  Eigen::AlignedBox3d box;
  std::array<GLsizei, 3> offset{};  // first index per level of detail
  std::array<GLsizei, 3> count{};
};

}  // namespace

OptionCheck RenderOptions::Check() const {
  OptionChecker c;
  c.Nested("camera", camera.Check())
      .InRange("msaa_samples", msaa_samples, 1, 16)
      .InRange("shadow_map_size", shadow_map_size, 256, 8192)
      .Greater("max_depth_m", max_depth_m, 1.0)
      .AtLeast("anisotropy", anisotropy, 0)
      .Greater("shadow_extent_m", shadow_extent_m, 1.0)
      .AtLeast("soil_texture_size", soil_texture_size, 64)
      .Require((soil_texture_size & (soil_texture_size - 1)) == 0, "soil_texture_size",
               "must be a power of two", soil_texture_size)
      .Greater("soil_texture_extent_m", soil_texture_extent_m, 0.1)
      .Greater("plant_draw_distance_m", plant_draw_distance_m, 0.0)
      .AtLeast("lod_full_distance_m", lod_full_distance_m, 0.0)
      .Require(lod_medium_distance_m >= lod_full_distance_m, "lod_medium_distance_m",
               "must be >= lod_full_distance_m", lod_medium_distance_m)
      .Require(lod_coarse_distance_m >= lod_medium_distance_m, "lod_coarse_distance_m",
               "must be >= lod_medium_distance_m", lod_coarse_distance_m)
      .Require(lod_far_distance_m >= lod_coarse_distance_m, "lod_far_distance_m",
               "must be >= lod_coarse_distance_m", lod_far_distance_m)
      .Greater("tree_line_distance_m", tree_line_distance_m, 1.0)
      .AtLeast("mesh_cache_mb", mesh_cache_mb, 16);
  return c.Result();
}

struct Renderer::Impl {
  Impl(const World& w, const RenderOptions& o) : world(w), options(o) {}

  World world;
  RenderOptions options;
  GlContext gl;

  GLuint terrain_program = 0, plant_program = 0, shadow_program = 0, sky_program = 0,
         tree_program = 0;
  GLuint empty_vao = 0;
  // Depth-only mask over the parts of the undistorted image that the lens distortion never
  // reads: drawn at the near plane first, so the early depth test skips their shading.
  GLuint mask_program = 0, mask_vao = 0, mask_vbo = 0;
  GLsizei mask_count = 0;
  GLuint terrain_vao = 0, terrain_vbo = 0, terrain_ibo = 0;
  std::vector<TerrainTile> tiles;
  GLuint tree_vao = 0, tree_vbo = 0;
  GLsizei tree_count = 0;
  GLuint soil_texture = 0, foliage_texture = 0;
  GLuint shadow_texture = 0, shadow_fbo = 0;
  GLuint msaa_fbo = 0, msaa_color = 0, msaa_depth = 0;
  GLuint resolve_fbo = 0, resolve_color = 0, resolve_depth = 0;
  float max_anisotropy = 1.0f;

  geometry::PinholeRadTan undistorted;  // the rendered pinhole camera
  double far_plane = 200.0;
  cv::Mat map_fixed, map_interp;  // colour remap (fixed point)
  cv::Mat map_x, map_y;           // depth remap (float)
  // Where in its pixel the resolved depth was taken: the blit keeps one sample of the
  // multisampled depth, whose position is not the pixel centre.
  float depth_sample_dx = 0.0f, depth_sample_dy = 0.0f;

  std::vector<Chunk> chunks;
  std::size_t mesh_bytes = 0;
  std::uint64_t frame = 0;
  long long triangles = 0;

  SessionConditions session;
  bool has_session = false;
  int soil_epoch_loaded = -1;
  int soil_level_loaded = 0;
  SoilChangeOptions soil_change_loaded;
  cv::Mat soil_base;  // the loaded epoch's texture, kept when the soil changes within an epoch
  Vector3d sun_dir = Vector3d::UnitZ();
  Vector3d sun_color = Vector3d::Ones();
  Vector3d ambient_color = Vector3d::Ones();
  Vector3d haze_color = Vector3d::Ones();
  float wet = 0.0f;
  double time_s = 0.0;  // SetTime

  bool shadow_valid = false;
  std::array<long long, 2> shadow_key{};
  Matrix4d shadow_matrix = Matrix4d::Identity();

  void Init();
  void BuildTerrain();
  void BuildTreeLine();
  void CreateTargets();
  void ComputeDistortionMaps();
  void BuildUnusedMask();
  void UploadTexture(GLuint texture, const cv::Mat& rgba, bool repeat, bool mipmaps);
  void LoadSoil(int epoch, int level, const SoilChangeOptions& change);
  void Session(const SessionConditions& c);
  GpuMesh& Mesh(Chunk& chunk, PlantLod lod);
  void EvictMeshes();
  void UpdateShadow(const Vector3d& camera_position, const Vector3d& forward);
  void SetLightingUniforms(GLuint program);
  void RenderFrame(const geometry::Rigid3& world_from_camera, cv::Mat* bgr, cv::Mat* depth);
};

void Renderer::Impl::Init() {
  gl.MakeCurrent();
  GLint max_samples = 1;
  glGetIntegerv(GL_MAX_SAMPLES, &max_samples);
  options.msaa_samples = std::min(options.msaa_samples, static_cast<int>(max_samples));
  if (gl.HasExtension("GL_ARB_texture_filter_anisotropic") ||
      gl.HasExtension("GL_EXT_texture_filter_anisotropic")) {
    glGetFloatv(GL_MAX_TEXTURE_MAX_ANISOTROPY_EXT, &max_anisotropy);
  }
  if (options.anisotropy == 0) {
    const bool software = gl.description().find("llvmpipe") != std::string::npos ||
                          gl.description().find("softpipe") != std::string::npos;
    options.anisotropy = software ? 1 : 8;
  }

  terrain_program = LinkProgram(LitVertex(shaders::kTerrainVertex),
                                LitFragment(shaders::kTerrainFragment), "terrain");
  plant_program =
      LinkProgram(LitVertex(shaders::kPlantVertex), LitFragment(shaders::kPlantFragment), "plant");
  shadow_program = LinkProgram(shaders::kShadowVertex, shaders::kShadowFragment, "shadow");
  sky_program = LinkProgram(shaders::kSkyVertex, LitFragment(shaders::kSkyFragment), "sky");
  tree_program =
      LinkProgram(LitVertex(shaders::kTreeVertex), LitFragment(shaders::kTreeFragment), "tree");
  glGenVertexArrays(1, &empty_vao);
  mask_program = LinkProgram(shaders::kMaskVertex, shaders::kShadowFragment, "mask");

  ComputeDistortionMaps();
  BuildUnusedMask();
  CreateTargets();
  BuildTerrain();
  BuildTreeLine();

  glGenTextures(1, &foliage_texture);
  UploadTexture(foliage_texture, GenerateFoliageTexture(world.options().seed), true, true);
  glGenTextures(1, &soil_texture);

  // Chunks: the plants of each row and the weeds of each strip between rows (both sorted by y)
  // cut into pieces of kChunkLength.
  const auto cut = [this](const auto& items, std::pair<int, int> range, int row, bool weeds) {
    int i = range.first;
    while (i < range.second) {
      const double y_end = (std::floor(items[i].xy.y() / kChunkLength) + 1.0) * kChunkLength;
      Chunk chunk;
      chunk.row = row;
      chunk.weeds = weeds;
      chunk.begin = i;
      while (i < range.second && items[i].xy.y() < y_end) ++i;
      chunk.end = i;
      chunks.push_back(std::move(chunk));
    }
  };
  const int num_rows = world.options().num_rows;
  for (int row = 0; row < num_rows; ++row)
    cut(world.plants(), world.RowPlantRange(row), row, false);
  for (int strip = 0; strip <= num_rows; ++strip) {
    cut(world.weeds(), world.WeedStripRange(strip), strip, true);
  }
}

void Renderer::Impl::ComputeDistortionMaps() {
  const geometry::PinholeRadTan& cam = options.camera;
  // Field of view of the undistorted image: undistort the border of the output image.
  double x_min = 1e9, x_max = -1e9, y_min = 1e9, y_max = -1e9;
  auto visit = [&](double u, double v) {
    Vector2d xy;
    const Vector2d xd((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
    if (!cam.Undistort(xd, &xy)) xy = xd;
    x_min = std::min(x_min, xy.x());
    x_max = std::max(x_max, xy.x());
    y_min = std::min(y_min, xy.y());
    y_max = std::max(y_max, xy.y());
  };
  const double W = cam.width, H = cam.height;
  for (double u = -0.5; u <= W - 0.5; u += 2.0) {
    visit(u, -0.5);
    visit(u, H - 0.5);
  }
  for (double v = -0.5; v <= H - 0.5; v += 2.0) {
    visit(-0.5, v);
    visit(W - 0.5, v);
  }
  visit(W - 0.5, H - 0.5);
  // Same focal length (no loss of resolution at the centre), at most twice the size.
  undistorted = cam;
  undistorted.k1 = undistorted.k2 = undistorted.p1 = undistorted.p2 = undistorted.k3 = 0.0;
  constexpr double kMargin = 3.0;  // pixels, for the bilinear interpolation
  x_min = std::max(x_min, (-W) / cam.fx - cam.cx / cam.fx);
  x_max = std::min(x_max, (2.0 * W - cam.cx) / cam.fx);
  y_min = std::max(y_min, (-H) / cam.fy - cam.cy / cam.fy);
  y_max = std::min(y_max, (2.0 * H - cam.cy) / cam.fy);
  const double u0 = std::floor(cam.fx * x_min - kMargin), u1 = std::ceil(cam.fx * x_max + kMargin);
  const double v0 = std::floor(cam.fy * y_min - kMargin), v1 = std::ceil(cam.fy * y_max + kMargin);
  undistorted.cx = -u0;
  undistorted.cy = -v0;
  undistorted.width = static_cast<int>(u1 - u0) + 1;
  undistorted.height = static_cast<int>(v1 - v0) + 1;

  map_x.create(cam.height, cam.width, CV_32F);
  map_y.create(cam.height, cam.width, CV_32F);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      Vector2d xy;
      const Vector2d xd((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy);
      if (!cam.Undistort(xd, &xy)) xy = Vector2d(-1e3, -1e3);
      map_x.at<float>(v, u) = static_cast<float>(undistorted.fx * xy.x() + undistorted.cx);
      map_y.at<float>(v, u) = static_cast<float>(undistorted.fy * xy.y() + undistorted.cy);
    }
  }
  cv::convertMaps(map_x, map_y, map_fixed, map_interp, CV_16SC2);
}

void Renderer::Impl::BuildUnusedMask() {
  const int W = undistorted.width, H = undistorted.height;
  const geometry::PinholeRadTan& cam = options.camera;
  // Pixels read by the colour remap (bilinear, border replicated) and the depth remap (its
  // sample offset, nearest across edges), with a margin of two pixels.
  constexpr int kPad = 2;
  std::vector<int> lo(H, W), hi(H, -1);
  for (int v = 0; v < cam.height; ++v) {
    for (int u = 0; u < cam.width; ++u) {
      const int x = static_cast<int>(std::floor(map_x.at<float>(v, u)));
      const int y = static_cast<int>(std::floor(map_y.at<float>(v, u)));
      const int y_a = std::clamp(y - kPad, 0, H - 1), y_b = std::clamp(y + 1 + kPad, 0, H - 1);
      const int x_a = std::clamp(x - kPad, 0, W - 1), x_b = std::clamp(x + 1 + kPad, 0, W - 1);
      for (int yy = y_a; yy <= y_b; ++yy) {
        lo[yy] = std::min(lo[yy], x_a);
        hi[yy] = std::max(hi[yy], x_b);
      }
    }
  }
  // Rectangles left and right of each row's span, rows with equal spans merged.
  std::vector<float> vertices;
  auto rect = [&](int x0, int x1, int y0, int y1) {  // pixels [x0, x1) × [y0, y1)
    if (x1 <= x0 || y1 <= y0) return;
    const float a = 2.0f * x0 / W - 1.0f, b = 2.0f * x1 / W - 1.0f;
    const float c = 2.0f * y0 / H - 1.0f, d = 2.0f * y1 / H - 1.0f;
    vertices.insert(vertices.end(), {a, c, b, c, b, d, a, c, b, d, a, d});
  };
  int y0 = 0;
  for (int y = 1; y <= H; ++y) {
    if (y < H && lo[y] == lo[y0] && hi[y] == hi[y0]) continue;
    if (hi[y0] < lo[y0]) {
      rect(0, W, y0, y);
    } else {
      rect(0, lo[y0], y0, y);
      rect(hi[y0] + 1, W, y0, y);
    }
    y0 = y;
  }
  mask_count = static_cast<GLsizei>(vertices.size() / 2);
  glGenVertexArrays(1, &mask_vao);
  glBindVertexArray(mask_vao);
  glGenBuffers(1, &mask_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, mask_vbo);
  glBufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(float), vertices.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 2, GL_FLOAT, GL_FALSE, 2 * sizeof(float), nullptr);
  glBindVertexArray(0);
}

void Renderer::Impl::CreateTargets() {
  const int W = undistorted.width, H = undistorted.height;
  glGenFramebuffers(1, &msaa_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, msaa_fbo);
  glGenRenderbuffers(1, &msaa_color);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_color);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, options.msaa_samples, GL_RGBA8, W, H);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, msaa_color);
  glGenRenderbuffers(1, &msaa_depth);
  glBindRenderbuffer(GL_RENDERBUFFER, msaa_depth);
  glRenderbufferStorageMultisample(GL_RENDERBUFFER, options.msaa_samples, GL_DEPTH_COMPONENT32F, W,
                                   H);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, msaa_depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw std::runtime_error("renderer: multisample framebuffer incomplete");
  }
  if (options.msaa_samples > 1) {
    GLfloat position[2] = {0.5f, 0.5f};
    glGetMultisamplefv(GL_SAMPLE_POSITION, 0, position);
    depth_sample_dx = position[0] - 0.5f;
    depth_sample_dy = position[1] - 0.5f;
  }
  glGenFramebuffers(1, &resolve_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, resolve_fbo);
  glGenRenderbuffers(1, &resolve_color);
  glBindRenderbuffer(GL_RENDERBUFFER, resolve_color);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_RGBA8, W, H);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, resolve_color);
  glGenRenderbuffers(1, &resolve_depth);
  glBindRenderbuffer(GL_RENDERBUFFER, resolve_depth);
  glRenderbufferStorage(GL_RENDERBUFFER, GL_DEPTH_COMPONENT32F, W, H);
  glFramebufferRenderbuffer(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, resolve_depth);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw std::runtime_error("renderer: resolve framebuffer incomplete");
  }

  // Shadow map: depth texture with hardware comparison.
  glGenTextures(1, &shadow_texture);
  glBindTexture(GL_TEXTURE_2D, shadow_texture);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_DEPTH_COMPONENT32F, options.shadow_map_size,
               options.shadow_map_size, 0, GL_DEPTH_COMPONENT, GL_FLOAT, nullptr);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_MODE, GL_COMPARE_REF_TO_TEXTURE);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_COMPARE_FUNC, GL_LEQUAL);
  glGenFramebuffers(1, &shadow_fbo);
  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo);
  glFramebufferTexture2D(GL_FRAMEBUFFER, GL_DEPTH_ATTACHMENT, GL_TEXTURE_2D, shadow_texture, 0);
  glDrawBuffer(GL_NONE);
  glReadBuffer(GL_NONE);
  if (glCheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
    throw std::runtime_error("renderer: shadow framebuffer incomplete");
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
}

// The terrain: one tensor-product grid (fine across the cultivated rows, where beds and tyre
// tracks are, coarse elsewhere; no T-junctions), cut into tiles for culling, with three levels
// of detail per tile (index strides 1, 3 and 9 across, 1, 2 and 4 along) and skirts that hide
// the cracks between tiles of different detail.
void Renderer::Impl::BuildTerrain() {
  const WorldOptions& wo = world.options();
  const Eigen::AlignedBox2d bounds = world.Bounds();
  const double outer = options.tree_line_distance_m + 8.0;
  const double x_lo = bounds.min().x() - outer, x_hi = bounds.max().x() + outer;
  const double y_lo = bounds.min().y() - outer, y_hi = bounds.max().y() + outer;
  const double fine_lo = -0.5 * wo.row_spacing_m - 1.5;
  const double fine_hi = (wo.num_rows - 0.5) * wo.row_spacing_m + 1.5;
  std::vector<double> xs;
  for (double x = x_lo; x < fine_lo; x += kCoarseDx) xs.push_back(x);
  const int fine_n = static_cast<int>(std::ceil((fine_hi - fine_lo) / kFineDx));
  for (int i = 0; i <= fine_n; ++i) xs.push_back(fine_lo + (fine_hi - fine_lo) * i / fine_n);
  for (double x = fine_hi + kCoarseDx; x <= x_hi; x += kCoarseDx) xs.push_back(x);
  std::vector<double> ys;
  const int ny_cells = static_cast<int>(std::ceil((y_hi - y_lo) / kDy));
  for (int j = 0; j <= ny_cells; ++j) ys.push_back(y_lo + kDy * j);
  const int nx = static_cast<int>(xs.size()), ny = static_cast<int>(ys.size());

  std::vector<TerrainVertex> vertices(static_cast<std::size_t>(nx) * ny);
  std::vector<float> heights(vertices.size());
  // The soil's large-scale variation (a 256² texture at kMacroPeriod1 and, rotated,
  // kMacroPeriod2 per period: 24 and 6.8 cm per texel, smooth over metres) is sampled per
  // vertex here once, not per pixel: two trilinear fetches per soil pixel were ≈15 % of a frame
  // on llvmpipe.
  const cv::Mat macro = GenerateSoilMacroTexture(world.options().seed);
  cv::parallel_for_(cv::Range(0, ny), [&](const cv::Range& range) {
    for (int j = range.start; j < range.end; ++j) {
      for (int i = 0; i < nx; ++i) {
        TerrainVertex& v = vertices[static_cast<std::size_t>(j) * nx + i];
        const double z = world.TerrainHeight(xs[i], ys[j]);
        v.position[0] = static_cast<float>(xs[i]);
        v.position[1] = static_cast<float>(ys[j]);
        v.position[2] = static_cast<float>(z);
        heights[static_cast<std::size_t>(j) * nx + i] = static_cast<float>(z);
        PackNormal(world.TerrainNormal(xs[i], ys[j]), 0, v.normal);
        SampleRepeat(macro, xs[i] / kMacroPeriod1, ys[j] / kMacroPeriod1, v.macro[0]);
        SampleRepeat(macro,
                     (kMacroCos2 * xs[i] - kMacroSin2 * ys[j]) / kMacroPeriod2 + kMacroOffset2[0],
                     (kMacroSin2 * xs[i] + kMacroCos2 * ys[j]) / kMacroPeriod2 + kMacroOffset2[1],
                     v.macro[1]);
      }
    }
  });

  // Tile boundaries in grid indices.
  std::vector<int> tile_i{0}, tile_j{0};
  for (int i = 1; i < nx; ++i) {
    if (xs[i] - xs[tile_i.back()] >= kTileSize - 1e-9 || i == nx - 1) tile_i.push_back(i);
  }
  for (int j = 1; j < ny; ++j) {
    if (ys[j] - ys[tile_j.back()] >= kTileSize - 1e-9 || j == ny - 1) tile_j.push_back(j);
  }
  std::vector<std::uint32_t> indices;
  const int stride_x[3] = {1, 3, 9};
  const int stride_y[3] = {1, 2, 4};
  auto index = [&](int i, int j) { return static_cast<std::uint32_t>(j * nx + i); };
  for (std::size_t tj = 0; tj + 1 < tile_j.size(); ++tj) {
    for (std::size_t ti = 0; ti + 1 < tile_i.size(); ++ti) {
      const int i0 = tile_i[ti], i1 = tile_i[ti + 1], j0 = tile_j[tj], j1 = tile_j[tj + 1];
      TerrainTile tile;
      float z_min = 1e9f, z_max = -1e9f;
      for (int j = j0; j <= j1; ++j) {
        for (int i = i0; i <= i1; ++i) {
          z_min = std::min(z_min, heights[j * nx + i]);
          z_max = std::max(z_max, heights[j * nx + i]);
        }
      }
      tile.box = Eigen::AlignedBox3d(Vector3d(xs[i0], ys[j0], z_min - 0.07),
                                     Vector3d(xs[i1], ys[j1], z_max));
      for (int lod = 0; lod < 3; ++lod) {
        tile.offset[lod] = static_cast<GLsizei>(indices.size());
        // Grid lines of this level: every stride-th, plus the tile's last line.
        std::vector<int> is, js;
        for (int i = i0; i < i1; i += stride_x[lod]) is.push_back(i);
        is.push_back(i1);
        for (int j = j0; j < j1; j += stride_y[lod]) js.push_back(j);
        js.push_back(j1);
        for (std::size_t b = 0; b + 1 < js.size(); ++b) {
          for (std::size_t a = 0; a + 1 < is.size(); ++a) {
            const std::uint32_t p00 = index(is[a], js[b]), p10 = index(is[a + 1], js[b]);
            const std::uint32_t p01 = index(is[a], js[b + 1]), p11 = index(is[a + 1], js[b + 1]);
            indices.insert(indices.end(), {p00, p10, p11, p00, p11, p01});
          }
        }
        // Skirts along the four edges: the edge vertices and copies lowered by the shader.
        auto skirt = [&](const std::vector<std::pair<int, int>>& edge) {
          for (std::size_t k = 0; k + 1 < edge.size(); ++k) {
            const std::uint32_t a = index(edge[k].first, edge[k].second);
            const std::uint32_t b = index(edge[k + 1].first, edge[k + 1].second);
            const std::uint32_t la = static_cast<std::uint32_t>(vertices.size());
            TerrainVertex va = vertices[a], vb = vertices[b];
            va.normal[3] = 127;
            vb.normal[3] = 127;
            vertices.push_back(va);
            vertices.push_back(vb);
            indices.insert(indices.end(), {a, b, la + 1, a, la + 1, la});
          }
        };
        std::vector<std::pair<int, int>> bottom, top, left, right;
        for (int i : is) {
          bottom.push_back({i, j0});
          top.push_back({i, j1});
        }
        for (int j : js) {
          left.push_back({i0, j});
          right.push_back({i1, j});
        }
        skirt(bottom);
        skirt(top);
        skirt(left);
        skirt(right);
        tile.count[lod] = static_cast<GLsizei>(indices.size()) - tile.offset[lod];
      }
      tiles.push_back(tile);
    }
  }

  glGenVertexArrays(1, &terrain_vao);
  glBindVertexArray(terrain_vao);
  glGenBuffers(1, &terrain_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, terrain_vbo);
  glBufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(TerrainVertex), vertices.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(TerrainVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_BYTE, GL_TRUE, sizeof(TerrainVertex),
                        reinterpret_cast<void*>(offsetof(TerrainVertex, normal)));
  for (int k = 0; k < 2; ++k) {
    glEnableVertexAttribArray(2 + k);
    glVertexAttribPointer(2 + k, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(TerrainVertex),
                          reinterpret_cast<void*>(offsetof(TerrainVertex, macro) + 4 * k));
  }
  glGenBuffers(1, &terrain_ibo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, terrain_ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, indices.size() * sizeof(std::uint32_t), indices.data(),
               GL_STATIC_DRAW);
  glBindVertexArray(0);

  far_plane = std::max(options.max_depth_m, 1.1 * std::hypot(x_hi - x_lo, y_hi - y_lo) + 10.0);
}

// The tree line: a ring of trees (a rounded rectangle around the field) drawn as a vertical
// band whose top follows the crowns; two layers for depth.
void Renderer::Impl::BuildTreeLine() {
  const Eigen::AlignedBox2d bounds = world.Bounds();
  Random random(HashCombine(world.options().seed, 0x7433u));
  std::vector<TreeVertex> vertices;
  std::vector<std::uint32_t> indices;
  constexpr double kTextureMetres = 60.0;  // tree line length covered by the foliage texture
  for (int layer = 0; layer < 2; ++layer) {
    const double margin = options.tree_line_distance_m + 7.0 * layer;
    const double corner = 15.0;
    const Vector2d lo = bounds.min() - Vector2d::Constant(margin - corner);
    const Vector2d hi = bounds.max() + Vector2d::Constant(margin - corner);
    // Sample the rounded rectangle by arc length.
    std::vector<Vector2d> path, normals;
    auto add_segment = [&](const Vector2d& a, const Vector2d& b, const Vector2d& n) {
      const int steps = std::max(1, static_cast<int>((b - a).norm() / 0.6));
      for (int s = 0; s < steps; ++s) {
        path.push_back(a + (b - a) * (static_cast<double>(s) / steps));
        normals.push_back(n);
      }
    };
    auto add_arc = [&](const Vector2d& c, double a0) {
      const int steps = static_cast<int>(0.5 * M_PI * corner / 0.6);
      for (int s = 0; s < steps; ++s) {
        const double a = a0 + 0.5 * M_PI * s / steps;
        const Vector2d d(std::cos(a), std::sin(a));
        path.push_back(c + corner * d);
        normals.push_back(-d);
      }
    };
    add_segment({lo.x(), lo.y() - corner}, {hi.x(), lo.y() - corner}, {0, 1});
    add_arc({hi.x(), lo.y()}, -0.5 * M_PI);
    add_segment({hi.x() + corner, lo.y()}, {hi.x() + corner, hi.y()}, {-1, 0});
    add_arc({hi.x(), hi.y()}, 0.0);
    add_segment({hi.x(), hi.y() + corner}, {lo.x(), hi.y() + corner}, {0, -1});
    add_arc({lo.x(), hi.y()}, 0.5 * M_PI);
    add_segment({lo.x() - corner, hi.y()}, {lo.x() - corner, lo.y()}, {1, 0});
    add_arc({lo.x(), lo.y()}, M_PI);
    // Crown heights: trees every 3–8 m, parabolic crowns, undergrowth in between.
    const int n = static_cast<int>(path.size());
    std::vector<double> arc(n + 1, 0.0);
    for (int k = 1; k <= n; ++k) arc[k] = arc[k - 1] + (path[k % n] - path[k - 1]).norm();
    const double total = arc[n];
    std::vector<double> top(n + 1, 3.0 + 2.0 * layer);
    for (double s = 0.0; s < total; s += random.Uniform(3.0, 8.0)) {
      const double h = random.Uniform(8.0, 19.0) + 3.0 * layer;
      const double r = random.Uniform(2.5, 5.5);
      for (int k = 0; k <= n; ++k) {
        double d = std::abs(arc[k] - s);
        d = std::min(d, total - d);
        if (d < r) top[k] = std::max(top[k], h - (h * 0.35) * (d * d) / (r * r));
      }
    }
    for (int k = 0; k <= n; ++k) {
      const Vector2d& p = path[k % n];
      const Vector2d& nn = normals[k % n];
      const double ground = world.TerrainHeight(p.x(), p.y()) - 1.0;
      const float u = static_cast<float>(arc[k] / kTextureMetres + 0.37 * layer);
      for (int end = 0; end < 2; ++end) {
        TreeVertex v;
        v.position[0] = static_cast<float>(p.x());
        v.position[1] = static_cast<float>(p.y());
        v.position[2] = static_cast<float>(end == 0 ? ground : ground + 1.0 + top[k]);
        v.uv[0] = u;
        v.uv[1] = static_cast<float>(end);
        v.normal[0] = static_cast<float>(nn.x());
        v.normal[1] = static_cast<float>(nn.y());
        v.normal[2] = 0.0f;
        vertices.push_back(v);
      }
      if (k < n) {
        const std::uint32_t a = static_cast<std::uint32_t>(vertices.size() - 2);
        indices.insert(indices.end(), {a, a + 2, a + 3, a, a + 3, a + 1});
      }
    }
  }
  glGenVertexArrays(1, &tree_vao);
  glBindVertexArray(tree_vao);
  glGenBuffers(1, &tree_vbo);
  glBindBuffer(GL_ARRAY_BUFFER, tree_vbo);
  glBufferData(GL_ARRAY_BUFFER, vertices.size() * sizeof(TreeVertex), vertices.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(TreeVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 2, GL_FLOAT, GL_FALSE, sizeof(TreeVertex),
                        reinterpret_cast<void*>(offsetof(TreeVertex, uv)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 3, GL_FLOAT, GL_FALSE, sizeof(TreeVertex),
                        reinterpret_cast<void*>(offsetof(TreeVertex, normal)));
  GLuint ibo = 0;
  glGenBuffers(1, &ibo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, indices.size() * sizeof(std::uint32_t), indices.data(),
               GL_STATIC_DRAW);
  tree_count = static_cast<GLsizei>(indices.size());
  glBindVertexArray(0);
}

void Renderer::Impl::UploadTexture(GLuint texture, const cv::Mat& rgba, bool repeat, bool mipmaps) {
  CROP4D_CHECK(rgba.type() == CV_8UC4 && rgba.isContinuous());
  glBindTexture(GL_TEXTURE_2D, texture);
  glPixelStorei(GL_UNPACK_ALIGNMENT, 4);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGBA8, rgba.cols, rgba.rows, 0, GL_RGBA, GL_UNSIGNED_BYTE,
               rgba.data);
  if (mipmaps) glGenerateMipmap(GL_TEXTURE_2D);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER,
                  mipmaps ? GL_LINEAR_MIPMAP_LINEAR : GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  const GLint wrap = repeat ? GL_REPEAT : GL_CLAMP_TO_EDGE;
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, wrap);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, wrap);
  if (max_anisotropy > 1.0f) {
    glTexParameterf(GL_TEXTURE_2D, GL_TEXTURE_MAX_ANISOTROPY_EXT,
                    std::min(max_anisotropy, static_cast<float>(options.anisotropy)));
  }
}

void Renderer::Impl::LoadSoil(int epoch, int level, const SoilChangeOptions& change) {
  const bool changes = level > 0 && (change.fraction > 0.0 || change.drying != 0.0);
  if (!changes) level = 0;
  if (epoch == soil_epoch_loaded && level == soil_level_loaded &&
      change.fraction == soil_change_loaded.fraction &&
      change.patch_m == soil_change_loaded.patch_m && change.drying == soil_change_loaded.drying) {
    return;
  }
  SoilTextureOptions soil;
  soil.size_px = options.soil_texture_size;
  soil.extent_m = options.soil_texture_extent_m;
  soil.seed = world.options().seed;
  soil.epoch = epoch;
  if (!changes) {
    UploadTexture(soil_texture, GenerateSoilTexture(soil), true, true);
    soil_base.release();
  } else {
    // The same ground as the epoch's first session, with the patches renewed since.
    if (soil_base.empty() || epoch != soil_epoch_loaded) soil_base = GenerateSoilTexture(soil);
    UploadTexture(soil_texture, ApplySoilChange(soil, soil_base, level, change), true, true);
  }
  soil_level_loaded = level;
  soil_change_loaded = change;
  if (!options.soil_trilinear) {
    // Bilinear in the nearest mip level: half the texels of a trilinear fetch (≈10 % of the
    // frame time on llvmpipe); the three hex-tiled fetches per soil pixel dominate the frame.
    glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR_MIPMAP_NEAREST);
  }
  soil_epoch_loaded = epoch;
}

void Renderer::Impl::Session(const SessionConditions& c) {
  gl.MakeCurrent();
  session = c;
  has_session = true;
  LoadSoil(c.soil_epoch, c.soil_change_level, c.soil_change);

  // Sun: azimuth clockwise from north, so east = sin, north = cos.
  const double el = std::clamp(c.sun_elevation_rad, 0.02, 0.5 * M_PI);
  sun_dir = Vector3d(std::cos(el) * std::sin(c.sun_azimuth_rad),
                     std::cos(el) * std::cos(c.sun_azimuth_rad), std::sin(el));
  // Warmer, weaker sun near the horizon (a rough air-mass attenuation); a bluish sky ambient.
  const double air = std::clamp(std::sin(el), 0.05, 1.0);
  sun_color = Vector3d(1.0, 0.93 + 0.05 * air, 0.80 + 0.15 * air) * (0.55 + 0.5 * air);
  ambient_color = Vector3d(0.42, 0.46, 0.55) * (0.8 + 0.3 * air);
  haze_color = Vector3d(0.74, 0.81, 0.89);
  wet = c.rain_before ? 1.0f : 0.0f;

  // Plants on this date: bounds per chunk; meshes are rebuilt on demand.
  for (Chunk& chunk : chunks) {
    for (GpuMesh& mesh : chunk.lods) {
      if (mesh.built) {
        glDeleteVertexArrays(1, &mesh.vao);
        glDeleteBuffers(1, &mesh.vbo);
        glDeleteBuffers(1, &mesh.ibo);
      }
      mesh = GpuMesh();
    }
    chunk.box.setEmpty();
    chunk.core.setEmpty();
    chunk.empty = true;
    for (int i = chunk.begin; i < chunk.end; ++i) {
      const Eigen::Vector2d& xy = chunk.weeds ? world.weeds()[i].xy : world.plants()[i].xy;
      const PlantState s = chunk.weeds ? world.WeedStateAt(world.weeds()[i], c.date)
                                       : world.StateAt(world.plants()[i], c.date);
      if (!s.emerged) continue;
      chunk.empty = false;
      const double z = world.TerrainHeight(xy.x(), xy.y());
      const double r = 1.15 * s.canopy_radius_m + 0.05;
      chunk.box.extend(Vector3d(xy.x() - r, xy.y() - r, z - 0.05));
      chunk.box.extend(Vector3d(xy.x() + r, xy.y() + r, z + 1.3 * s.height_m + 0.05));
      chunk.core.extend(Vector3d(xy.x(), xy.y(), z));
      chunk.core.extend(Vector3d(xy.x(), xy.y(), z + 0.5 * s.height_m));
    }
  }
  mesh_bytes = 0;
  shadow_valid = false;
}

GpuMesh& Renderer::Impl::Mesh(Chunk& chunk, PlantLod lod) {
  GpuMesh& mesh = chunk.lods[static_cast<int>(lod)];
  mesh.last_used = frame;
  if (mesh.built) return mesh;
  PlantMesh data;
  for (int i = chunk.begin; i < chunk.end; ++i) {
    if (chunk.weeds) {
      AppendWeedMesh(world, world.weeds()[i], session.date, lod, &data);
    } else {
      AppendPlantMesh(world, world.plants()[i], session.date, session.wind_seed, lod, &data);
    }
  }
  glGenVertexArrays(1, &mesh.vao);
  glBindVertexArray(mesh.vao);
  glGenBuffers(1, &mesh.vbo);
  glBindBuffer(GL_ARRAY_BUFFER, mesh.vbo);
  glBufferData(GL_ARRAY_BUFFER, data.vertices.size() * sizeof(PlantVertex), data.vertices.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, sizeof(PlantVertex), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_BYTE, GL_TRUE, sizeof(PlantVertex),
                        reinterpret_cast<void*>(offsetof(PlantVertex, normal)));
  glEnableVertexAttribArray(2);
  glVertexAttribPointer(2, 4, GL_UNSIGNED_BYTE, GL_TRUE, sizeof(PlantVertex),
                        reinterpret_cast<void*>(offsetof(PlantVertex, color)));
  glGenBuffers(1, &mesh.ibo);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, mesh.ibo);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, data.indices.size() * sizeof(std::uint32_t),
               data.indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  mesh.count = static_cast<GLsizei>(data.indices.size());
  mesh.bytes = data.vertices.size() * sizeof(PlantVertex) + data.indices.size() * 4;
  mesh.built = true;
  mesh_bytes += mesh.bytes;
  return mesh;
}

void Renderer::Impl::EvictMeshes() {
  const std::size_t budget = static_cast<std::size_t>(options.mesh_cache_mb) << 20;
  if (mesh_bytes <= budget) return;
  std::vector<GpuMesh*> built;
  for (Chunk& chunk : chunks) {
    for (GpuMesh& mesh : chunk.lods) {
      if (mesh.built && mesh.last_used < frame) built.push_back(&mesh);
    }
  }
  std::sort(built.begin(), built.end(),
            [](const GpuMesh* a, const GpuMesh* b) { return a->last_used < b->last_used; });
  for (GpuMesh* mesh : built) {
    if (mesh_bytes <= budget * 3 / 4) break;
    glDeleteVertexArrays(1, &mesh->vao);
    glDeleteBuffers(1, &mesh->vbo);
    glDeleteBuffers(1, &mesh->ibo);
    mesh_bytes -= mesh->bytes;
    *mesh = GpuMesh();
  }
}

void Renderer::Impl::SetLightingUniforms(GLuint program) {
  glUseProgram(program);
  auto set3 = [&](const char* name, const Vector3d& v) {
    glUniform3f(glGetUniformLocation(program, name), static_cast<float>(v.x()),
                static_cast<float>(v.y()), static_cast<float>(v.z()));
  };
  set3("u_sun_dir", sun_dir);
  set3("u_sun_color", sun_color);
  set3("u_ambient_color", ambient_color);
  set3("u_haze_color", haze_color);
  glUniform1f(glGetUniformLocation(program, "u_brightness"),
              static_cast<float>(session.brightness));
  glUniform1i(glGetUniformLocation(program, "u_shadow_map"), 1);
  glUniform1f(glGetUniformLocation(program, "u_shadow_enabled"), shadow_valid ? 1.0f : 0.0f);
  const Matrix4f shadow = ToFloat(shadow_matrix);
  glUniformMatrix4fv(glGetUniformLocation(program, "u_shadow_matrix"), 1, GL_FALSE, shadow.data());
}

// The sun's shadow map covers a square of shadow_extent_m around the view, aligned with the
// sun's azimuth and snapped to a grid of a quarter of its side, so that it is a function of
// the snapped position only (deterministic) and is re-rendered only when the view moves on.
void Renderer::Impl::UpdateShadow(const Vector3d& camera_position, const Vector3d& forward) {
  const double E = options.shadow_extent_m;
  Vector2d h(sun_dir.x(), sun_dir.y());
  if (h.norm() < 1e-6) h = Vector2d(0, 1);
  h.normalize();
  const Vector2d r(h.y(), -h.x());
  Vector2d f(forward.x(), forward.y());
  if (f.norm() > 1e-6) f.normalize();
  const Vector2d c = camera_position.head<2>() + 0.3 * E * f;
  const double step = 0.25 * E;
  const std::array<long long, 2> key = {std::llround(c.dot(r) / step),
                                        std::llround(c.dot(h) / step)};
  if (shadow_valid && key == shadow_key) return;
  shadow_key = key;
  const Vector2d center2 = key[0] * step * r + key[1] * step * h;
  const Vector3d center(center2.x(), center2.y(), world.TerrainHeight(center2.x(), center2.y()));

  // Light frame: x = r (horizontal), z = towards the sun, y = z × x.
  const Vector3d rx(r.x(), r.y(), 0.0);
  const Vector3d rz = sun_dir;
  const Vector3d ry = rz.cross(rx).normalized();
  constexpr double kEye = 20.0;  // light eye above the centre along the sun direction
  const Vector3d eye = center + kEye * rz;
  Matrix4d view = Matrix4d::Identity();
  view.block<1, 3>(0, 0) = rx.transpose();
  view.block<1, 3>(1, 0) = ry.transpose();
  view.block<1, 3>(2, 0) = rz.transpose();
  view.block<3, 1>(0, 3) = -(view.block<3, 3>(0, 0) * eye);
  const double el = std::asin(std::clamp(sun_dir.z(), -1.0, 1.0));
  const double half_x = 0.5 * E;
  const double half_y = 0.5 * E * std::sin(el) + 0.8 * std::cos(el) + 0.1;
  const double near = kEye - 12.0, far = kEye + 12.0;
  Matrix4d ortho = Matrix4d::Identity();
  ortho(0, 0) = 1.0 / half_x;
  ortho(1, 1) = 1.0 / half_y;
  ortho(2, 2) = -2.0 / (far - near);
  ortho(2, 3) = -(far + near) / (far - near);
  const Matrix4d light_view_proj = ortho * view;
  Matrix4d bias = Matrix4d::Identity() * 0.5;
  bias(3, 3) = 1.0;
  bias.block<3, 1>(0, 3) = Vector3d::Constant(0.5);
  shadow_matrix = bias * light_view_proj;

  glBindFramebuffer(GL_FRAMEBUFFER, shadow_fbo);
  glViewport(0, 0, options.shadow_map_size, options.shadow_map_size);
  glClear(GL_DEPTH_BUFFER_BIT);
  glEnable(GL_DEPTH_TEST);
  glDepthFunc(GL_LESS);
  glEnable(GL_POLYGON_OFFSET_FILL);
  glPolygonOffset(1.5f, 4.0f);
  glUseProgram(shadow_program);
  const Matrix4f lvp = ToFloat(light_view_proj);
  glUniformMatrix4fv(glGetUniformLocation(shadow_program, "u_light_view_proj"), 1, GL_FALSE,
                     lvp.data());
  // Plants (medium detail) whose bounds overlap the shadowed square.
  for (Chunk& chunk : chunks) {
    if (chunk.empty) continue;
    bool outside[4] = {true, true, true, true};
    for (int k = 0; k < 8; ++k) {
      const Eigen::Vector4d p =
          light_view_proj *
          chunk.box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)).homogeneous();
      outside[0] &= p.x() < -1.0;
      outside[1] &= p.x() > 1.0;
      outside[2] &= p.y() < -1.0;
      outside[3] &= p.y() > 1.0;
    }
    if (outside[0] || outside[1] || outside[2] || outside[3]) continue;
    GpuMesh& mesh = Mesh(chunk, PlantLod::kMedium);
    if (mesh.count == 0) continue;
    glBindVertexArray(mesh.vao);
    glDrawElements(GL_TRIANGLES, mesh.count, GL_UNSIGNED_INT, nullptr);
  }
  glDisable(GL_POLYGON_OFFSET_FILL);
  glBindVertexArray(0);
  shadow_valid = true;
}

void Renderer::Impl::RenderFrame(const geometry::Rigid3& world_from_camera, cv::Mat* bgr,
                                 cv::Mat* depth) {
  gl.MakeCurrent();
  if (!has_session) Session(SessionConditions{});
  ++frame;
  triangles = 0;
  const Matrix3d R_wc = world_from_camera.RotationMatrix();
  const Vector3d c = world_from_camera.translation();
  const Matrix3d R_cw = R_wc.transpose();
  Matrix4d camera_from_world = Matrix4d::Identity();
  camera_from_world.block<3, 3>(0, 0) = R_cw;
  camera_from_world.block<3, 1>(0, 3) = -R_cw * c;
  const Matrix4d view_proj = Projection(undistorted, kNear, far_plane) * camera_from_world;
  const Matrix4f view_proj_f = ToFloat(view_proj);
  const Vector3d forward = R_wc.col(2);

  if (options.shadows) UpdateShadow(c, forward);

  // Frustum test in the camera frame: outside if all corners are beyond one plane.
  const double x_lo = (-0.5 - undistorted.cx) / undistorted.fx;
  const double x_hi = (undistorted.width - 0.5 - undistorted.cx) / undistorted.fx;
  const double y_lo = (-0.5 - undistorted.cy) / undistorted.fy;
  const double y_hi = (undistorted.height - 0.5 - undistorted.cy) / undistorted.fy;
  auto visible = [&](const Eigen::AlignedBox3d& box) {
    bool out[5] = {true, true, true, true, true};
    for (int k = 0; k < 8; ++k) {
      const Vector3d p = R_cw * (box.corner(static_cast<Eigen::AlignedBox3d::CornerType>(k)) - c);
      out[0] &= p.z() < kNear;
      out[1] &= p.x() < x_lo * p.z();
      out[2] &= p.x() > x_hi * p.z();
      out[3] &= p.y() < y_lo * p.z();
      out[4] &= p.y() > y_hi * p.z();
    }
    return !(out[0] || out[1] || out[2] || out[3] || out[4]);
  };

  const int W = undistorted.width, H = undistorted.height;
  glBindFramebuffer(GL_FRAMEBUFFER, msaa_fbo);
  glViewport(0, 0, W, H);
  glDisable(GL_CULL_FACE);
  glClearDepth(1.0);
  glClear(GL_DEPTH_BUFFER_BIT);
  glActiveTexture(GL_TEXTURE1);
  glBindTexture(GL_TEXTURE_2D, shadow_texture);

  glEnable(GL_DEPTH_TEST);
  if (mask_count > 0) {
    glUseProgram(mask_program);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    glDepthFunc(GL_ALWAYS);
    glBindVertexArray(mask_vao);
    glDrawArrays(GL_TRIANGLES, 0, mask_count);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
  }
  glDepthFunc(GL_LESS);

  auto set_common = [&](GLuint program) {
    SetLightingUniforms(program);
    glUniformMatrix4fv(glGetUniformLocation(program, "u_view_proj"), 1, GL_FALSE,
                       view_proj_f.data());
    glUniform3f(glGetUniformLocation(program, "u_camera_pos"), static_cast<float>(c.x()),
                static_cast<float>(c.y()), static_cast<float>(c.z()));
  };
  const double lod_scale = options.camera.fx / 500.0;

  // Plants first, front to back (they hide much of the soil: less soil shading, and the
  // early depth test rejects hidden leaves).
  set_common(plant_program);
  {
    // Two gust waves with seeded phases; the second at 1.37× the frequency of the first.
    Random wind(HashCombine(session.wind_seed, 0x5a7u));
    const double phase1 = wind.Uniform(0.0, 2.0 * M_PI), phase2 = wind.Uniform(0.0, 2.0 * M_PI);
    const double w = 2.0 * M_PI / session.wind_period_s;
    glUniform4f(glGetUniformLocation(plant_program, "u_sway"),
                static_cast<float>(session.wind_sway_m),
                static_cast<float>(std::fmod(w * time_s + phase1, 2.0 * M_PI)),
                static_cast<float>(std::fmod(1.37 * w * time_s + phase2, 2.0 * M_PI)), 0.0f);
  }
  std::vector<std::pair<double, Chunk*>> drawn;
  for (Chunk& chunk : chunks) {
    if (chunk.empty) continue;
    const double d = std::sqrt(chunk.core.squaredExteriorDistance(c));
    if (d > options.plant_draw_distance_m || !visible(chunk.box)) continue;
    drawn.emplace_back(d, &chunk);
  }
  std::sort(drawn.begin(), drawn.end(), [](const auto& a, const auto& b) {
    return a.first < b.first || (a.first == b.first && a.second < b.second);
  });
  for (auto& [d, chunk_pointer] : drawn) {
    Chunk& chunk = *chunk_pointer;
    const PlantLod lod = d < options.lod_full_distance_m * lod_scale     ? PlantLod::kFull
                         : d < options.lod_medium_distance_m * lod_scale ? PlantLod::kMedium
                         : d < options.lod_coarse_distance_m * lod_scale ? PlantLod::kCoarse
                         : d < options.lod_far_distance_m * lod_scale    ? PlantLod::kFar
                                                                         : PlantLod::kDistant;
    GpuMesh& mesh = Mesh(chunk, lod);
    if (mesh.count == 0) continue;
    glBindVertexArray(mesh.vao);
    glDrawElements(GL_TRIANGLES, mesh.count, GL_UNSIGNED_INT, nullptr);
    triangles += mesh.count / 3;
  }

  // Terrain.
  set_common(terrain_program);
  glActiveTexture(GL_TEXTURE0);
  glBindTexture(GL_TEXTURE_2D, soil_texture);
  glUniform1i(glGetUniformLocation(terrain_program, "u_soil"), 0);
  glUniform1f(glGetUniformLocation(terrain_program, "u_soil_extent"),
              static_cast<float>(options.soil_texture_extent_m));
  glUniform1f(glGetUniformLocation(terrain_program, "u_soil_size"),
              static_cast<float>(options.soil_texture_size));
  glUniform1ui(glGetUniformLocation(terrain_program, "u_soil_seed"),
               static_cast<GLuint>(HashCombine(world.options().seed,
                                               static_cast<std::uint64_t>(session.soil_epoch)) &
                                   0xffffffffu));
  const Eigen::AlignedBox2d field = world.Bounds();
  glUniform4f(glGetUniformLocation(terrain_program, "u_field_box"),
              static_cast<float>(field.min().x()), static_cast<float>(field.min().y()),
              static_cast<float>(field.max().x()), static_cast<float>(field.max().y()));
  glUniform1f(glGetUniformLocation(terrain_program, "u_wet"), wet);
  glBindVertexArray(terrain_vao);
  for (const TerrainTile& tile : tiles) {
    if (!visible(tile.box)) continue;
    const double d = std::sqrt(tile.box.squaredExteriorDistance(c));
    const int lod = d < 6.0 * lod_scale ? 0 : d < 18.0 * lod_scale ? 1 : 2;
    glDrawElements(GL_TRIANGLES, tile.count[lod], GL_UNSIGNED_INT,
                   reinterpret_cast<void*>(static_cast<std::size_t>(tile.offset[lod]) * 4));
    triangles += tile.count[lod] / 3;
  }

  // Tree line.
  set_common(tree_program);
  glActiveTexture(GL_TEXTURE3);
  glBindTexture(GL_TEXTURE_2D, foliage_texture);
  glUniform1i(glGetUniformLocation(tree_program, "u_foliage"), 3);
  glBindVertexArray(tree_vao);
  glDrawElements(GL_TRIANGLES, tree_count, GL_UNSIGNED_INT, nullptr);
  triangles += tree_count / 3;
  glBindVertexArray(0);
  glActiveTexture(GL_TEXTURE0);

  // Sky last, on the far plane: only the pixels nothing else covers are shaded. Skipped when
  // every ray of the image border points down steeply enough to hit the modelled ground.
  bool sky_visible = false;
  const double sky_height = c.z() - world.TerrainHeight(c.x(), c.y()) + 1.0;
  for (double fu : {0.0, 0.5, 1.0}) {
    for (double fv : {0.0, 0.5, 1.0}) {
      const Vector3d ray = R_wc * Vector3d((fu * W - undistorted.cx) / undistorted.fx,
                                           (fv * H - undistorted.cy) / undistorted.fy, 1.0);
      const double drop = -ray.z() / ray.head<2>().norm();  // tangent of the depression
      if (drop <= 0.0 || sky_height / drop > options.tree_line_distance_m) sky_visible = true;
    }
  }
  // The sky can only show where a ray's depression is below t = height / tree-line distance,
  // -dz < t |d_xy|, which implies the linear condition -dz < t |d|_max (d = R_wc (x, y, 1)):
  // scissor the sky to the bounding box of that part of the image (the rest is covered).
  int sky_y0 = 0, sky_y1 = H, sky_x0 = 0, sky_x1 = W;
  if (sky_visible && sky_height > 0.0) {
    const double t = sky_height / options.tree_line_distance_m;
    const Vector3d g = R_wc.row(2).transpose();  // dz = g · (x, y, 1)
    std::array<Vector2d, 4> corners = {Vector2d(0, 0), Vector2d(W, 0), Vector2d(W, H),
                                       Vector2d(0, H)};
    double r_max = 0.0;
    auto ray_of = [&](const Vector2d& p) {
      return Vector3d((p.x() - 0.5 - undistorted.cx) / undistorted.fx,
                      (p.y() - 0.5 - undistorted.cy) / undistorted.fy, 1.0);
    };
    for (const Vector2d& p : corners) r_max = std::max(r_max, ray_of(p).norm());
    auto f = [&](const Vector2d& p) { return g.dot(ray_of(p)) + t * r_max; };  // > 0: maybe sky
    // Clip the image rectangle to f > 0 (Sutherland–Hodgman, one plane).
    double bx0 = 1e30, by0 = 1e30, bx1 = -1e30, by1 = -1e30;
    auto add = [&](const Vector2d& p) {
      bx0 = std::min(bx0, p.x());
      by0 = std::min(by0, p.y());
      bx1 = std::max(bx1, p.x());
      by1 = std::max(by1, p.y());
    };
    for (int k = 0; k < 4; ++k) {
      const Vector2d& a = corners[k];
      const Vector2d& b = corners[(k + 1) % 4];
      const double fa = f(a), fb = f(b);
      if (fa > 0.0) add(a);
      if ((fa > 0.0) != (fb > 0.0)) add(a + (b - a) * (fa / (fa - fb)));
    }
    if (bx1 < bx0) {
      sky_visible = false;
    } else {
      sky_x0 = std::clamp(static_cast<int>(std::floor(bx0)) - 2, 0, W);
      sky_x1 = std::clamp(static_cast<int>(std::ceil(bx1)) + 2, 0, W);
      sky_y0 = std::clamp(static_cast<int>(std::floor(by0)) - 2, 0, H);
      sky_y1 = std::clamp(static_cast<int>(std::ceil(by1)) + 2, 0, H);
      if (sky_x1 <= sky_x0 || sky_y1 <= sky_y0) sky_visible = false;
    }
  }
  if (sky_visible) {
    glEnable(GL_SCISSOR_TEST);
    glScissor(sky_x0, sky_y0, sky_x1 - sky_x0, sky_y1 - sky_y0);
    glDepthFunc(GL_LEQUAL);
    glDepthMask(GL_FALSE);
    SetLightingUniforms(sky_program);
    const Eigen::Matrix3f r_wc_f = R_wc.cast<float>();
    glUniformMatrix3fv(glGetUniformLocation(sky_program, "u_world_from_camera"), 1, GL_FALSE,
                       r_wc_f.data());
    glUniform4f(glGetUniformLocation(sky_program, "u_intrinsics"),
                static_cast<float>(undistorted.fx), static_cast<float>(undistorted.fy),
                static_cast<float>(undistorted.cx), static_cast<float>(undistorted.cy));
    Random cloud_random(
        HashCombine(world.options().seed, 0xc10du, static_cast<std::uint64_t>(session.date)));
    // One draw per statement (the order of function arguments is unspecified in C++).
    const float cloud_y = static_cast<float>(cloud_random.Uniform(0, 100));
    const float cloud_x = static_cast<float>(cloud_random.Uniform(0, 100));
    glUniform2f(glGetUniformLocation(sky_program, "u_cloud_offset"), cloud_x, cloud_y);
    glUniform1f(glGetUniformLocation(sky_program, "u_cloudiness"),
                static_cast<float>(cloud_random.Uniform(0.2, 0.9)));
    glBindVertexArray(empty_vao);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    glDisable(GL_SCISSOR_TEST);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_LESS);
  }

  // Resolve the multisampled image (colour averaged, depth of one sample), read back.
  glBindFramebuffer(GL_READ_FRAMEBUFFER, msaa_fbo);
  glBindFramebuffer(GL_DRAW_FRAMEBUFFER, resolve_fbo);
  glBlitFramebuffer(
      0, 0, W, H, 0, 0, W, H,
      depth != nullptr ? GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT : GL_COLOR_BUFFER_BIT,
      GL_NEAREST);
  glBindFramebuffer(GL_FRAMEBUFFER, resolve_fbo);
  glPixelStorei(GL_PACK_ALIGNMENT, 4);
  cv::Mat bgra(H, W, CV_8UC4);
  glReadPixels(0, 0, W, H, GL_BGRA, GL_UNSIGNED_BYTE, bgra.data);
  cv::Mat window_depth;
  if (depth != nullptr) {
    window_depth.create(H, W, CV_32F);
    glReadPixels(0, 0, W, H, GL_DEPTH_COMPONENT, GL_FLOAT, window_depth.data);
  }
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  EvictMeshes();

  // Lens distortion: each output pixel samples the undistorted image where its ray lands.
  const geometry::PinholeRadTan& cam = options.camera;
  if (bgr != nullptr) {
    cv::Mat distorted;
    cv::remap(bgra, distorted, map_fixed, map_interp, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    cv::cvtColor(distorted, *bgr, cv::COLOR_BGRA2BGR);
  }
  if (depth != nullptr) {
    // Window depth d ∈ [0, 1] to camera z: z_ndc = 2d − 1 = A + B / z (Projection()).
    const double A = (far_plane + kNear) / (far_plane - kNear);
    const double B = -2.0 * far_plane * kNear / (far_plane - kNear);
    cv::Mat z(H, W, CV_32F);
    for (int i = 0; i < W * H; ++i) {
      const float d = window_depth.ptr<float>()[i];
      z.ptr<float>()[i] = d >= 1.0f ? 0.0f : static_cast<float>(B / (2.0 * d - 1.0 - A));
    }
    // Bilinear where the four neighbours lie on one surface, nearest across depth edges.
    depth->create(cam.height, cam.width, CV_32F);
    cv::parallel_for_(cv::Range(0, cam.height), [&](const cv::Range& range) {
      for (int v = range.start; v < range.end; ++v) {
        const float* mx = map_x.ptr<float>(v);
        const float* my = map_y.ptr<float>(v);
        float* out = depth->ptr<float>(v);
        for (int u = 0; u < cam.width; ++u) {
          const float x = mx[u] - depth_sample_dx, y = my[u] - depth_sample_dy;
          const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
          if (x0 < 0 || y0 < 0 || x0 + 1 >= W || y0 + 1 >= H) {
            out[u] = 0.0f;
            continue;
          }
          const float fx = x - x0, fy = y - y0;
          const float d00 = z.at<float>(y0, x0), d10 = z.at<float>(y0, x0 + 1);
          const float d01 = z.at<float>(y0 + 1, x0), d11 = z.at<float>(y0 + 1, x0 + 1);
          const float lo = std::min(std::min(d00, d10), std::min(d01, d11));
          const float hi = std::max(std::max(d00, d10), std::max(d01, d11));
          if (lo > 0.0f && hi < 1.03f * lo) {
            out[u] = (d00 * (1 - fx) + d10 * fx) * (1 - fy) + (d01 * (1 - fx) + d11 * fx) * fy;
          } else {
            out[u] = z.at<float>(std::lround(y) < H ? static_cast<int>(std::lround(y)) : H - 1,
                                 std::lround(x) < W ? static_cast<int>(std::lround(x)) : W - 1);
          }
        }
      }
    });
  }
}

Renderer::Renderer(const World& world, const RenderOptions& options) {
  if (const OptionCheck why = options.Check(); !why.empty()) {
    throw InputError("render options: " + why);
  }
  impl_ = std::make_unique<Impl>(world, options);
  impl_->Init();
}

Renderer::~Renderer() = default;

void Renderer::SetSession(const SessionConditions& conditions) { impl_->Session(conditions); }

void Renderer::SetTime(double seconds) { impl_->time_s = seconds; }

void Renderer::Render(const geometry::Rigid3& world_from_camera, cv::Mat* bgr, cv::Mat* depth) {
  impl_->RenderFrame(world_from_camera, bgr, depth);
}

const geometry::PinholeRadTan& Renderer::undistorted_camera() const { return impl_->undistorted; }

const std::string& Renderer::gl_description() const { return impl_->gl.description(); }

long long Renderer::last_triangle_count() const { return impl_->triangles; }

}  // namespace crop4d::sim
