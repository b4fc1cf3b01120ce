#pragma once

// The camera calibration the fused model was placed with, against a simulated rig's truth.
// Layout read:
//
//   FIELD/ground_truth/calibration_truth.yaml   the rig's true calibration and the one written
//                                               to the dataset (the simulator writes it when
//                                               the written calibration is off: realism real)
//   WS/fused/<session>/camera.json              the intrinsics and T_BS of the fused poses
//                                               (workspace/fused_camera.h)
//
// The figure is the RMS angle between the rays of the image's pixels through a calibration and
// through the truth (fusion::RayAngleRmsDeg): the geometry a calibration error bends, free of
// the near-degeneracy between a principal point shift and a small T_BS rotation.

#include <optional>
#include <string>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::eval {

struct CalibrationTruth {
  // Intrinsics without an image size (calibration_truth.yaml has none): width and height 0.
  geometry::PinholeRadTan true_intrinsics, written_intrinsics;
  geometry::Rigid3 true_body_from_camera, written_body_from_camera;
};

// The camera cam0 of FIELD/ground_truth/calibration_truth.yaml; nullopt when the field has no
// such file (an ideal or a real field). Throws InputError naming the file for a malformed one.
std::optional<CalibrationTruth> ReadCalibrationTruth(const std::string& field);

// One session's calibration error: how far the written and the fused calibration send the
// camera's rays from the true ones, degrees, and whether fuse refined it.
struct CalibrationError {
  double written_deg = 0.0;
  double fused_deg = 0.0;
  bool refined = false;
};

// The error of the session's WS/fused/<session>/camera.json against `truth`. Throws InputError
// for a missing or malformed camera.json.
CalibrationError EvaluateFusedCalibration(const std::string& workspace, const std::string& session,
                                          const CalibrationTruth& truth);

}  // namespace crop4d::eval
