#pragma once

// Tests only (header-only; used by the dense and densify-stage tests): a small synthetic field
// rendered with the simulator's renderer from the simulator's true camera poses, only the
// images that see a region of interest, and its ground truth.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <filesystem>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/dense/height_field_stereo.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::dense::testing {

// The "tiny" field (two rows of 8 m) with sessions on the given dates and the demo's camera
// (640×480, fx 280, the resolution the dense stage is made for) or, when `small_camera`, the tiny
// preset's (320×240, fx 140: faster, for tests of the plumbing).
inline sim::SimConfig StripConfig(const std::vector<std::string>& dates, std::uint64_t seed = 1,
                                  bool small_camera = false) {
  sim::SimConfig config = sim::PresetConfig("tiny");
  config.seed = seed;
  config.sessions.clear();
  for (const std::string& d : dates) config.sessions.push_back({d, false});
  if (!small_camera) config.camera = sim::PresetConfig("demo").camera;
  config.Check();
  return config;
}

struct RenderedImage {
  Timestamp t = 0;
  geometry::Rigid3 world_from_camera;
  cv::Mat bgr;
  cv::Mat depth;  // CV_32F camera z of the visible surface (when asked for)
};

struct RenderedSession {
  std::string id;
  Timestamp date = 0;
  geometry::PinholeRadTan camera;
  std::vector<RenderedImage> images;
};

// Renders the images of session `index` whose camera is within `max_distance_m` of `center`
// (on the terrain) and sees it inside the image: the views a dense reconstruction of a small
// region around `center` needs. `wind_sway_m` > 0: the leaves sway by this much (gusts of 2 s).
inline RenderedSession RenderAround(const sim::Simulator& simulator, sim::Renderer* renderer,
                                    int index, const Eigen::Vector2d& center, double max_distance_m,
                                    bool depth = false, double wind_sway_m = 0.0) {
  const sim::World& world = simulator.world();
  const sim::SessionRecord rec = simulator.SimulateSession(index);
  sim::SessionConditions conditions = rec.conditions;
  if (wind_sway_m > 0) {
    conditions.wind_sway_m = wind_sway_m;
    conditions.wind_period_s = 2.0;
  }
  renderer->SetSession(conditions);
  RenderedSession out;
  out.id = rec.info.id;
  out.date = rec.info.date;
  out.camera = simulator.config().camera.Intrinsics();
  const geometry::Rigid3 body_from_camera = simulator.BodyFromCamera();
  const Eigen::Vector3d target(center.x(), center.y(), world.TerrainHeight(center.x(), center.y()));
  for (const Timestamp t : rec.image_times) {
    const geometry::Rigid3 world_from_camera =
        rec.trajectory->WorldFromBody(rec.Seconds(t)) * body_from_camera;
    if ((world_from_camera.translation() - target).norm() > max_distance_m) continue;
    Eigen::Vector2d pixel;
    if (!out.camera.Project(world_from_camera.Inverse() * target, &pixel) ||
        !out.camera.IsInImage(pixel, -40.0)) {
      continue;
    }
    RenderedImage image;
    image.t = t;
    image.world_from_camera = world_from_camera;
    renderer->SetTime(rec.Seconds(t));
    renderer->Render(world_from_camera, &image.bgr, depth ? &image.depth : nullptr);
    out.images.push_back(std::move(image));
  }
  return out;
}

inline RgbImage ToRgbImage(const cv::Mat& bgr) {
  cv::Mat rgb;
  cv::cvtColor(bgr, rgb, cv::COLOR_BGR2RGB);
  RgbImage out;
  out.width = rgb.cols;
  out.height = rgb.rows;
  out.rgb.assign(rgb.data, rgb.data + static_cast<std::size_t>(rgb.cols) * rgb.rows * 3);
  return out;
}

// A sparse "soil" cloud like the fused SIFT cloud: true terrain points every `spacing_m` over
// `box`, with ±1 cm of deterministic noise.
inline std::vector<Eigen::Vector3d> SoilCloud(const sim::World& world,
                                              const Eigen::AlignedBox2d& box,
                                              double spacing_m = 0.1) {
  std::vector<Eigen::Vector3d> points;
  int k = 0;
  for (double y = box.min().y(); y <= box.max().y(); y += spacing_m) {
    for (double x = box.min().x(); x <= box.max().x(); x += spacing_m) {
      const double noise = 0.01 * std::sin(12.9898 * k++);
      points.emplace_back(x, y, world.TerrainHeight(x, y) + noise);
    }
  }
  return points;
}

// Writes a field folder with the rendered session (field.yaml, cam0 only) and a workspace with
// its "fused" output: the true poses as WS/fused/<id>/poses.tum and a soil cloud over `box` as
// sparse.ply.
inline void WriteFieldAndWorkspace(const sim::Simulator& simulator, const RenderedSession& rs,
                                   const Eigen::AlignedBox2d& box, const std::string& field,
                                   const std::string& workspace) {
  io::WriteFieldYaml(field + "/field.yaml", simulator.MakeFieldInfo());
  const std::string cam = field + "/sessions/" + rs.id + "/cam0";
  io::CameraSensor sensor;
  sensor.camera = rs.camera;
  sensor.body_from_sensor = simulator.BodyFromCamera();
  io::WriteCameraSensorYaml(cam + "/sensor.yaml", sensor);
  std::filesystem::create_directories(cam + "/data");
  std::vector<io::ImageEntry> entries;
  std::vector<io::StampedPose> poses;
  for (const RenderedImage& im : rs.images) {
    io::ImageEntry e;
    e.t = im.t;
    e.filename = std::to_string(im.t) + ".png";
    cv::imwrite(cam + "/data/" + e.filename, im.bgr);
    entries.push_back(e);
    poses.push_back({im.t, im.world_from_camera});
  }
  io::WriteImageCsv(cam + "/data.csv", entries);
  io::WriteTum(workspace + "/fused/" + rs.id + "/poses.tum", poses);
  io::PlyPointCloud sparse;
  sparse.points = SoilCloud(simulator.world(), box);
  io::WritePly(workspace + "/fused/" + rs.id + "/sparse.ply", sparse);
}

}  // namespace crop4d::dense::testing
