#include "crop4d/workspace/fused_camera.h"

#include <array>
#include <cmath>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/workspace/json_file.h"

namespace crop4d::workspace {

using nlohmann::json;

void WriteFusedCamera(const std::string& path, const FusedCamera& camera) {
  const geometry::PinholeRadTan& c = camera.intrinsics;
  const Eigen::Quaterniond& q = camera.body_from_camera.rotation();
  const Eigen::Vector3d& t = camera.body_from_camera.translation();
  json j = {
      {"intrinsics",
       {{"width", c.width},
        {"height", c.height},
        {"fx", c.fx},
        {"fy", c.fy},
        {"cx", c.cx},
        {"cy", c.cy},
        {"k1", c.k1},
        {"k2", c.k2},
        {"p1", c.p1},
        {"p2", c.p2},
        {"k3", c.k3}}},
      {"body_from_camera",
       {{"rotation_xyzw", {q.x(), q.y(), q.z(), q.w()}}, {"translation", {t.x(), t.y(), t.z()}}}},
      {"refined", camera.refined},
      {"rotation_change_deg", camera.rotation_change_deg}};
  WriteJsonOfSchema(path, std::move(j), kFusedCameraSchema);
}

FusedCamera ReadFusedCamera(const std::string& path) {
  const std::string rerun = "crop4d fuse";
  const json j = ReadJsonOfSchema(path, kFusedCameraSchema, rerun);
  FusedCamera camera;
  ReadFields(path, rerun, [&] {
    const json& i = j.at("intrinsics");
    geometry::PinholeRadTan& c = camera.intrinsics;
    c.width = i.at("width").get<int>();
    c.height = i.at("height").get<int>();
    for (const auto& [key, value] :
         {std::pair{"fx", &c.fx}, std::pair{"fy", &c.fy}, std::pair{"cx", &c.cx},
          std::pair{"cy", &c.cy}, std::pair{"k1", &c.k1}, std::pair{"k2", &c.k2},
          std::pair{"p1", &c.p1}, std::pair{"p2", &c.p2}, std::pair{"k3", &c.k3}}) {
      *value = i.at(key).get<double>();
    }
    const json& pose = j.at("body_from_camera");
    const auto q = pose.at("rotation_xyzw").get<std::array<double, 4>>();
    const auto t = pose.at("translation").get<std::array<double, 3>>();
    const Eigen::Quaterniond rotation(q[3], q[0], q[1], q[2]);
    if (!(std::abs(rotation.norm() - 1.0) < 1e-9)) {
      throw InputError(path, 0, "body_from_camera: rotation_xyzw is not a unit quaternion");
    }
    // Kept as stored (a unit quaternion normalised again could move its last bit).
    camera.body_from_camera = geometry::Rigid3::FromUnitQuaternion(rotation, {t[0], t[1], t[2]});
    camera.refined = j.at("refined").get<bool>();
    camera.rotation_change_deg = j.at("rotation_change_deg").get<double>();
  });
  if (const OptionCheck why = camera.intrinsics.Check(); !why.empty()) {
    throw InputError(path, 0, "invalid intrinsics: " + why + " (run `" + rerun + " --force`)");
  }
  return camera;
}

}  // namespace crop4d::workspace
