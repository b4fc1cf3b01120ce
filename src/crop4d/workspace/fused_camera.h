#pragma once

// WS/fused/<session>/camera.json, written by the fuse stage, read by densify: the intrinsics
// that the session's fused cameras (poses.tum) go with and the camera's T_BS the fused poses
// were placed with — refined in the joint problem (`fuse.refine_calibration`,
// fusion/camera_refinement.h) or as the dataset wrote them. A schema-1 JSON object
// (json_file.h); every number round-trips exactly.

#include <string>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::workspace {

inline constexpr int kFusedCameraSchema = 1;

struct FusedCamera {
  geometry::PinholeRadTan intrinsics;
  geometry::Rigid3 body_from_camera;
  // False: the calibration as written (refinement off, or too few cross observations).
  bool refined = false;
  // The rotation between the written T_BS and the one the fused poses were placed with, degrees.
  double rotation_change_deg = 0.0;
};

void WriteFusedCamera(const std::string& path, const FusedCamera& camera);
// Throws InputError naming the file when it is missing, malformed, of another schema or holds
// invalid intrinsics.
FusedCamera ReadFusedCamera(const std::string& path);

}  // namespace crop4d::workspace
