#pragma once

// Tests only (header-only): a fake true geometry — flat ground z = 0 with one raised box, seen
// by cameras with exactly known poses — so that the association evaluation can be tested
// without rendering, and matches built by projecting known world points.

#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <string>
#include <utility>
#include <vector>

#include "crop4d/eval/truth_geometry.h"

namespace crop4d::eval::testing {

// The camera of the "tiny" simulation preset: 320×240 with lens distortion.
inline geometry::PinholeRadTan TestCamera() {
  geometry::PinholeRadTan camera;
  camera.width = 320;
  camera.height = 240;
  camera.fx = camera.fy = 140.0;
  camera.cx = 159.5;
  camera.cy = 119.5;
  camera.k1 = -0.12;
  camera.k2 = 0.02;
  camera.p1 = 4.0e-4;
  camera.p2 = -3.0e-4;
  return camera;
}

// A camera `height` m above (x, y, 0) looking along +y (heading_rad = 0) or another heading
// (counter-clockwise from +y), pitched down by 35°.
inline geometry::Rigid3 DownwardCamera(double x, double y, double heading_rad = 0.0,
                                       double height = 1.5) {
  Eigen::Matrix3d level;  // camera x = east, y = down, z = north
  level.col(0) = Eigen::Vector3d::UnitX();
  level.col(1) = -Eigen::Vector3d::UnitZ();
  level.col(2) = Eigen::Vector3d::UnitY();
  const Eigen::Matrix3d pitch =
      Eigen::AngleAxisd(-35.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()).toRotationMatrix();
  const Eigen::Matrix3d yaw =
      Eigen::AngleAxisd(heading_rad, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  return geometry::Rigid3(Eigen::Matrix3d(yaw * level * pitch), Eigen::Vector3d(x, y, height));
}

// Ground z = 0 and an axis-aligned box of height `box_height` over [box_min, box_max] (its top
// only: the step at its silhouette is a depth edge).
struct FakeScene {
  Eigen::Vector2d box_min{10.0, 10.0};
  Eigen::Vector2d box_max{10.5, 10.5};
  double box_height = 0.3;

  // Distance along the ray (direction with camera z = 1, i.e. the camera z of the hit), 0 when
  // nothing is hit.
  double Depth(const geometry::Rigid3& world_from_camera, const Eigen::Vector3d& ray) const {
    const Eigen::Vector3d c = world_from_camera.translation();
    const Eigen::Vector3d d = world_from_camera.rotation() * ray;
    if (d.z() >= -1e-9) return 0.0;
    double best = -c.z() / d.z();  // ground
    const double s_top = (box_height - c.z()) / d.z();
    const Eigen::Vector3d top = c + s_top * d;
    if (s_top > 0.0 && top.x() >= box_min.x() && top.x() <= box_max.x() && top.y() >= box_min.y() &&
        top.y() <= box_max.y()) {
      best = std::min(best, s_top);
    }
    return best;
  }

  DepthImage Render(const geometry::PinholeRadTan& camera,
                    const geometry::Rigid3& world_from_camera) const {
    DepthImage depth;
    depth.width = camera.width;
    depth.height = camera.height;
    depth.z.assign(static_cast<std::size_t>(camera.width) * camera.height, 0.0f);
    for (int v = 0; v < camera.height; ++v) {
      for (int u = 0; u < camera.width; ++u) {
        Eigen::Vector3d ray;
        if (!camera.Unproject(Eigen::Vector2d(u, v), &ray)) continue;
        depth.z[static_cast<std::size_t>(v) * camera.width + u] =
            static_cast<float>(Depth(world_from_camera, ray));
      }
    }
    return depth;
  }
};

// TruthGeometry over a FakeScene: images registered with AddImage.
class FakeTruth : public TruthGeometry {
 public:
  FakeScene scene;
  geometry::PinholeRadTan camera = TestCamera();
  std::map<std::pair<std::string, Timestamp>, geometry::Rigid3> poses;
  // Every Depth() call, in order (to check the order of the requests).
  std::vector<std::pair<std::string, Timestamp>> depth_calls;

  void AddImage(const std::string& session, Timestamp t, const geometry::Rigid3& pose) {
    poses[{session, t}] = pose;
  }

  bool TrueCamera(const std::string& session, Timestamp t, geometry::PinholeRadTan* cam,
                  geometry::Rigid3* world_from_camera) override {
    const auto it = poses.find({session, t});
    if (it == poses.end()) return false;
    *cam = camera;
    *world_from_camera = it->second;
    return true;
  }
  bool Depth(const std::string& session, Timestamp t, DepthImage* depth) override {
    depth_calls.emplace_back(session, t);
    const auto it = poses.find({session, t});
    if (it == poses.end()) return false;
    *depth = scene.Render(camera, it->second);
    return true;
  }

  // The pixel of world point `p` in an image (false when behind the camera).
  bool Project(const std::string& session, Timestamp t, const Eigen::Vector3d& p,
               Eigen::Vector2d* pixel) const {
    const geometry::Rigid3& pose = poses.at({session, t});
    return camera.Project(pose.Inverse() * p, pixel);
  }
};

}  // namespace crop4d::eval::testing
