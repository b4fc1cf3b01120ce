#include "crop4d/eval/calibration_eval.h"

#include <yaml-cpp/yaml.h>

#include <Eigen/Core>
#include <filesystem>

#include "crop4d/core/error.h"
#include "crop4d/fusion/camera_refinement.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

geometry::PinholeRadTan Intrinsics(const YAML::Node& node) {
  geometry::PinholeRadTan c;
  for (const auto& [key, value] :
       {std::pair{"fx", &c.fx}, std::pair{"fy", &c.fy}, std::pair{"cx", &c.cx},
        std::pair{"cy", &c.cy}, std::pair{"k1", &c.k1}, std::pair{"k2", &c.k2},
        std::pair{"p1", &c.p1}, std::pair{"p2", &c.p2}, std::pair{"k3", &c.k3}}) {
    *value = node[key].as<double>();
  }
  return c;
}

// A 4 × 4 rigid transform given as rows.
geometry::Rigid3 Transform(const YAML::Node& node) {
  Eigen::Matrix4d m;
  if (!node.IsSequence() || node.size() != 4)
    throw YAML::Exception(YAML::Mark::null_mark(), "not 4 rows");
  for (int r = 0; r < 4; ++r) {
    if (!node[r].IsSequence() || node[r].size() != 4) {
      throw YAML::Exception(YAML::Mark::null_mark(), "a row of T_BS has not 4 values");
    }
    for (int c = 0; c < 4; ++c) m(r, c) = node[r][c].as<double>();
  }
  const Eigen::Matrix3d R = m.topLeftCorner<3, 3>();
  if (!((R.transpose() * R - Eigen::Matrix3d::Identity()).norm() < 1e-6)) {
    throw YAML::Exception(YAML::Mark::null_mark(), "T_BS is not a rotation and a translation");
  }
  return geometry::Rigid3(R, m.topRightCorner<3, 1>());
}

}  // namespace

std::optional<CalibrationTruth> ReadCalibrationTruth(const std::string& field) {
  const fs::path path = fs::path(field) / "ground_truth" / "calibration_truth.yaml";
  std::error_code ec;
  if (!fs::exists(path, ec)) return std::nullopt;
  try {
    const YAML::Node camera = YAML::LoadFile(path.string())["cam0"];
    if (!camera.IsMap()) throw YAML::Exception(YAML::Mark::null_mark(), "no cam0 section");
    CalibrationTruth truth;
    truth.true_intrinsics = Intrinsics(camera["true_intrinsics"]);
    truth.written_intrinsics = Intrinsics(camera["written_intrinsics"]);
    truth.true_body_from_camera = Transform(camera["true_T_BS"]);
    truth.written_body_from_camera = Transform(camera["written_T_BS"]);
    return truth;
  } catch (const YAML::Exception& e) {
    throw InputError(path.string(), e.mark.is_null() ? 0 : e.mark.line + 1,
                     std::string("malformed calibration truth: ") + e.msg);
  }
}

CalibrationError EvaluateFusedCalibration(const std::string& workspace, const std::string& session,
                                          const CalibrationTruth& truth) {
  const workspace::FusedCamera fused =
      workspace::ReadFusedCamera(workspace::Layout(workspace).FusedCamera(session).string());
  // The truth's intrinsics take the fused camera's image size.
  geometry::PinholeRadTan true_camera = truth.true_intrinsics;
  geometry::PinholeRadTan written_camera = truth.written_intrinsics;
  for (geometry::PinholeRadTan* c : {&true_camera, &written_camera}) {
    c->width = fused.intrinsics.width;
    c->height = fused.intrinsics.height;
  }
  CalibrationError error;
  error.refined = fused.refined;
  error.written_deg = fusion::RayAngleRmsDeg(written_camera, truth.written_body_from_camera,
                                             true_camera, truth.true_body_from_camera);
  error.fused_deg = fusion::RayAngleRmsDeg(fused.intrinsics, fused.body_from_camera, true_camera,
                                           truth.true_body_from_camera);
  return error;
}

}  // namespace crop4d::eval
