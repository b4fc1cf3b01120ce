#include "crop4d/eval/truth_geometry.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double Seconds(Clock::time_point since) {
  return std::chrono::duration<double>(Clock::now() - since).count();
}

// The millimetre quantisation of the PNG format, applied to a rendered map before it is used,
// so that a map gives the same points whether it was just rendered or read from the cache.
std::uint16_t ToMillimetres(float z) {
  const double mm = std::isfinite(z) && z > 0.0f ? std::round(z * 1000.0) : 0.0;
  return static_cast<std::uint16_t>(std::clamp(mm, 0.0, 65535.0));
}
float FromMillimetres(std::uint16_t mm) {
  return mm == 0 || mm == 65535 ? 0.0f : static_cast<float>(mm * 1e-3);
}

}  // namespace

OptionCheck TruePointOptions::Check() const {
  OptionChecker c;
  c.Greater("max_edge_m", max_edge_m, 0.0)
      .Finite("max_edge_m", max_edge_m)
      .Greater("max_depth_m", max_depth_m, 0.0)
      .Finite("max_depth_m", max_depth_m);
  return c.Result();
}

const char* ToString(TruePointStatus status) {
  switch (status) {
    case TruePointStatus::kOk:
      return "ok";
    case TruePointStatus::kNoTruth:
      return "no_truth";
    case TruePointStatus::kNoSurface:
      return "no_surface";
    case TruePointStatus::kDepthEdge:
      return "depth_edge";
  }
  return "?";
}

TruePointStatus SampleDepth(const DepthImage& depth, const Eigen::Vector2d& pixel,
                            const TruePointOptions& options, double* depth_m) {
  if (!std::isfinite(pixel.x()) || !std::isfinite(pixel.y())) return TruePointStatus::kNoSurface;
  const long u = std::lround(pixel.x()), v = std::lround(pixel.y());
  // The whole 3×3 neighbourhood must lie inside the image.
  if (u < 1 || v < 1 || u > depth.width - 2 || v > depth.height - 2) {
    return TruePointStatus::kNoSurface;
  }
  double d[3][3];  // d[dv + 1][du + 1]
  for (int dv = -1; dv <= 1; ++dv) {
    for (int du = -1; du <= 1; ++du) {
      const double z = depth.at(static_cast<int>(u + du), static_cast<int>(v + dv));
      if (!(z > 0.0) || z > options.max_depth_m) return TruePointStatus::kNoSurface;
      d[dv + 1][du + 1] = z;
    }
  }
  // Edge test: the centre against the plane through each pair of opposite neighbours.
  constexpr int kLines[4][2] = {{1, 0}, {0, 1}, {1, 1}, {1, -1}};
  const double centre = d[1][1];
  for (const auto& line : kLines) {
    const double a = d[1 + line[1]][1 + line[0]], b = d[1 - line[1]][1 - line[0]];
    const double plane = 2.0 / (1.0 / a + 1.0 / b);
    if (std::abs(centre - plane) > options.max_edge_m) return TruePointStatus::kDepthEdge;
  }
  // Bilinear in inverse depth over the four pixel centres around the position; they all lie
  // in the 3×3 neighbourhood (the nearest pixel is one of them).
  const double x0 = std::floor(pixel.x()), y0 = std::floor(pixel.y());
  const double fx = pixel.x() - x0, fy = pixel.y() - y0;
  const int iu = static_cast<int>(x0) - static_cast<int>(u) + 1;
  const int iv = static_cast<int>(y0) - static_cast<int>(v) + 1;
  const double inv = (1.0 - fy) * ((1.0 - fx) / d[iv][iu] + fx / d[iv][iu + 1]) +
                     fy * ((1.0 - fx) / d[iv + 1][iu] + fx / d[iv + 1][iu + 1]);
  *depth_m = 1.0 / inv;
  return TruePointStatus::kOk;
}

TruePointResult TruePointInImage(const DepthImage& depth, const geometry::PinholeRadTan& camera,
                                 const geometry::Rigid3& world_from_camera,
                                 const Eigen::Vector2d& pixel, const TruePointOptions& options) {
  TruePointResult result;
  if (depth.width != camera.width || depth.height != camera.height) return result;  // kNoTruth
  result.status = SampleDepth(depth, pixel, options, &result.depth_m);
  if (!result.ok()) return result;
  Eigen::Vector3d ray;
  if (!camera.Unproject(pixel, &ray)) {
    result.status = TruePointStatus::kNoSurface;
    return result;
  }
  result.point_world = world_from_camera * (ray * result.depth_m);
  return result;
}

TruePointResult TruePoint(TruthGeometry& truth, const std::string& session, Timestamp t,
                          const Eigen::Vector2d& pixel, const TruePointOptions& options) {
  geometry::PinholeRadTan camera;
  geometry::Rigid3 world_from_camera;
  DepthImage depth;
  if (!truth.TrueCamera(session, t, &camera, &world_from_camera) ||
      !truth.Depth(session, t, &depth)) {
    return TruePointResult{};
  }
  return TruePointInImage(depth, camera, world_from_camera, pixel, options);
}

bool ReadDepthPng(const std::string& path, DepthImage* depth) {
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) return false;
  const cv::Mat mm = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (mm.empty() || mm.type() != CV_16UC1) return false;
  depth->width = mm.cols;
  depth->height = mm.rows;
  depth->z.resize(static_cast<std::size_t>(mm.cols) * mm.rows);
  for (int v = 0; v < mm.rows; ++v) {
    const std::uint16_t* row = mm.ptr<std::uint16_t>(v);
    float* out = depth->z.data() + static_cast<std::size_t>(v) * mm.cols;
    for (int u = 0; u < mm.cols; ++u) out[u] = FromMillimetres(row[u]);
  }
  return true;
}

void WriteDepthPng(const std::string& path, const DepthImage& depth) {
  CROP4D_CHECK(depth.z.size() == static_cast<std::size_t>(depth.width) * depth.height);
  cv::Mat mm(depth.height, depth.width, CV_16UC1);
  for (int v = 0; v < depth.height; ++v) {
    std::uint16_t* row = mm.ptr<std::uint16_t>(v);
    for (int u = 0; u < depth.width; ++u) row[u] = ToMillimetres(depth.at(u, v));
  }
  std::vector<unsigned char> bytes;
  // Level 1: encoding speed matters more than a few percent of size (as the simulator).
  if (!cv::imencode(".png", mm, bytes, {cv::IMWRITE_PNG_COMPRESSION, 1})) {
    throw InputError(path, 0, "cannot encode the depth map as PNG");
  }
  io::WriteFileAtomic(path, std::string(bytes.begin(), bytes.end()));
}

// ---- SimulatedFieldTruth ----------------------------------------------------------------------

struct SimulatedFieldTruth::Impl {
  std::string field;
  SimulatedFieldTruthOptions options;
  sim::SimConfig config;
  geometry::PinholeRadTan camera;
  std::vector<std::string> sessions;
  std::vector<bool> rain_before;
  // True poses per session (cam0_poses.tum), read on first use; an empty list when missing.
  std::map<std::string, std::vector<io::StampedPose>> poses;
  // Made on the first depth map that must be rendered.
  std::unique_ptr<sim::Simulator> simulator;
  std::unique_ptr<sim::Renderer> renderer;
  int renderer_session = -1;
  DepthSourceStats stats;

  const std::vector<io::StampedPose>& PosesOf(const std::string& session) {
    auto it = poses.find(session);
    if (it == poses.end()) {
      const fs::path path = fs::path(field) / "ground_truth" / session / "cam0_poses.tum";
      std::error_code ec;
      std::vector<io::StampedPose> list;
      if (fs::exists(path, ec)) list = io::ReadTum(path.string());
      it = poses.emplace(session, std::move(list)).first;
    }
    return it->second;
  }

  int SessionIndex(const std::string& session) const {
    const auto it = std::find(sessions.begin(), sessions.end(), session);
    return it == sessions.end() ? -1 : static_cast<int>(it - sessions.begin());
  }

  bool Render(int session_index, const geometry::Rigid3& world_from_camera, DepthImage* depth) {
    if (renderer == nullptr) {
      const auto start = Clock::now();
      simulator = std::make_unique<sim::Simulator>(config);
      sim::RenderOptions render_options;
      render_options.camera = camera;
      // Geometry options as in Simulator::Write; no shadows and a small soil texture change
      // only the colours, which are not read. Four samples per pixel: the renderer corrects
      // its depth read-back for the position of the multisample depth sample; with one sample
      // (Mesa llvmpipe) the depth comes out ~¼ pixel off vertically, centimetres on distant
      // soil.
      render_options.msaa_samples = 4;
      render_options.shadows = false;
      render_options.soil_texture_size = 256;
      renderer = std::make_unique<sim::Renderer>(simulator->world(), render_options);
      stats.setup_seconds += Seconds(start);
      spdlog::info("eval: rendering true depth maps with {}", renderer->gl_description());
    }
    if (renderer_session != session_index) {
      const auto start = Clock::now();
      renderer->SetSession(simulator->ConditionsOf(session_index));
      renderer_session = session_index;
      stats.setup_seconds += Seconds(start);
    }
    const auto start = Clock::now();
    cv::Mat z;
    renderer->Render(world_from_camera, nullptr, &z);
    stats.render_seconds += Seconds(start);
    depth->width = z.cols;
    depth->height = z.rows;
    depth->z.resize(static_cast<std::size_t>(z.cols) * z.rows);
    for (int v = 0; v < z.rows; ++v) {
      const float* row = z.ptr<float>(v);
      float* out = depth->z.data() + static_cast<std::size_t>(v) * z.cols;
      for (int u = 0; u < z.cols; ++u) out[u] = FromMillimetres(ToMillimetres(row[u]));
    }
    ++stats.rendered;
    return true;
  }
};

SimulatedFieldTruth::SimulatedFieldTruth(const std::string& field,
                                         const SimulatedFieldTruthOptions& options)
    : impl_(std::make_unique<Impl>()) {
  impl_->field = field;
  impl_->options = options;
  const fs::path config_path = fs::path(field) / "ground_truth" / "simulate.yaml";
  std::error_code ec;
  if (!fs::exists(config_path, ec)) {
    throw InputError(config_path.string(), 0,
                     "file not found: the true geometry of a field is re-created from the "
                     "simulator's configuration (a field written by crop4d simulate)");
  }
  impl_->config = sim::PresetConfig("tiny");  // every key is in the file: any base will do
  sim::LoadSimConfigFile(config_path.string(), &impl_->config);
  impl_->camera = impl_->config.camera.Intrinsics();
  for (const sim::SessionSpec& s : impl_->config.sessions) {
    impl_->sessions.push_back(s.date);
    impl_->rain_before.push_back(s.rain_before);
  }
}

SimulatedFieldTruth::~SimulatedFieldTruth() = default;

bool SimulatedFieldTruth::TrueCamera(const std::string& session, Timestamp t,
                                     geometry::PinholeRadTan* camera,
                                     geometry::Rigid3* world_from_camera) {
  const std::vector<io::StampedPose>& poses = impl_->PosesOf(session);
  const auto it =
      std::lower_bound(poses.begin(), poses.end(), t,
                       [](const io::StampedPose& p, Timestamp value) { return p.t < value; });
  if (it == poses.end() || it->t != t) return false;
  *camera = impl_->camera;
  *world_from_camera = it->pose;
  return true;
}

bool SimulatedFieldTruth::Depth(const std::string& session, Timestamp t, DepthImage* depth) {
  Impl& m = *impl_;
  ++m.stats.requested;
  const std::string name = fmt::format("{}.png", t);
  if (ReadDepthPng((fs::path(m.field) / "ground_truth" / session / "cam0_depth" / name).string(),
                   depth)) {
    ++m.stats.from_field;
    return true;
  }
  const std::string cached = m.options.depth_cache_dir.empty()
                                 ? std::string()
                                 : (fs::path(m.options.depth_cache_dir) / session / name).string();
  if (!cached.empty() && ReadDepthPng(cached, depth) && depth->width == m.camera.width &&
      depth->height == m.camera.height) {
    ++m.stats.from_cache;
    return true;
  }
  geometry::PinholeRadTan camera;
  geometry::Rigid3 world_from_camera;
  const int index = m.SessionIndex(session);
  if (!m.options.render || index < 0 || !TrueCamera(session, t, &camera, &world_from_camera)) {
    ++m.stats.unavailable;
    return false;
  }
  m.Render(index, world_from_camera, depth);
  if (!cached.empty()) WriteDepthPng(cached, *depth);
  return true;
}

DepthSourceStats SimulatedFieldTruth::stats() const { return impl_->stats; }

const std::vector<std::string>& SimulatedFieldTruth::sessions() const { return impl_->sessions; }
const std::vector<bool>& SimulatedFieldTruth::rain_before() const { return impl_->rain_before; }

}  // namespace crop4d::eval
