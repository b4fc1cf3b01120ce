#pragma once

// Refining the camera calibration in the joint 4D problem (fusion/joint_optimiser.h). A rig's
// written calibration is off by a little (a pixel or two of focal length and principal point,
// a few tenths of a degree of T_BS rotation): in row SLAM the pass's own poses absorb it, but
// in the joint problem the same ground is seen from both driving directions and from other
// dates, and a calibration error puts it in two places. Every image of one camera shares one
// calibration (slam::CameraCalibrationBlocks: fx, fy, cx, cy, k1, k2, a rotation and a lever-arm
// shift of T_BS), refined with the poses, each with a Gaussian prior at the written value so
// that what the images do not observe stays where the calibration put it.
//
// The lever arm (refine_lever_arm, off by default): the passes of a row are driven both ways, so
// a camera written 1.5 cm off puts the cameras of the two directions 3 cm apart across the same
// ground (horizontal components; the vertical one shifts every camera alike and stays with its
// prior). Only its difference from the GPS antenna's lever arm is observed, and along the track
// it trades with the time offset (a shift of v·td). On simulated rigs whose antenna lever arms
// and time offset are off too, refining it moved the camera 3 cm along the track and placed the
// fused cameras worse (bench/RESULTS.md, "Calibration refinement"), so it is held unless asked.
//
// Observability: a shift of the principal point and a small rotation of T_BS move the image
// nearly alike (Δc ≈ f δθ), so the images pin their sum down and the priors share it; the
// geometry (the cameras' rays) is what the refinement corrects, not each number.

#include <ceres/problem.h>

#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/calibrated_reprojection_factor.h"
#include "crop4d/slam/row_optimiser.h"

namespace crop4d::fusion {

struct CalibrationRefinementOptions {
  // Unset (auto, the default): a camera is refined when every pass of it has its camera–IMU
  // time offset in the problem (an offset left out is absorbed into the calibration) and the
  // kept observations of landmarks shared between passes in its images (cross-row and
  // cross-session matches) number at least min_cross_observations; true: every camera; false:
  // none (the calibration as written).
  std::optional<bool> refine;
  int min_cross_observations = 1000;
  // Prior standard deviations about the written calibration: fx and fy, px; cx and cy, px;
  // k1 and k2; the T_BS rotation, degrees; its lever arm, m.
  double focal_sigma_px = 10.0;
  double principal_point_sigma_px = 10.0;
  double distortion_sigma = 0.05;
  double rotation_sigma_deg = 1.0;
  double lever_arm_sigma_m = 0.05;
  // Also refine the lever arm of T_BS (above); held as written otherwise.
  bool refine_lever_arm = false;

  OptionCheck Check() const;
};

// Whether two camera models are the same (every value equal).
bool SameIntrinsics(const geometry::PinholeRadTan& a, const geometry::PinholeRadTan& b);

// One camera of the rig: the passes that give it identical intrinsics and T_BS (sessions of
// one rig share it).
struct RigCamera {
  std::vector<int> passes;
  geometry::PinholeRadTan camera;
  geometry::Rigid3 body_from_camera;
};

// The cameras of `passes` (passes without camera in none), in the order of their first pass.
// Passes with `apart[p]` (empty: none) never share a camera with passes without: an incremental
// fuse's held session keeps the calibration it was written with while the sessions after it
// refine a copy of their own.
std::vector<RigCamera> GroupPassesByCamera(const std::vector<slam::RowOptimiser::Input>& passes,
                                           const std::vector<bool>& apart = {});

// The priors of one camera's calibration blocks about `camera`'s written values; the lever arm
// is held constant unless options.refine_lever_arm. Nothing when no reprojection factor of the
// camera is in the problem.
void AddCalibrationPriors(const CalibrationRefinementOptions& options, const RigCamera& camera,
                          slam::CameraCalibrationBlocks* blocks, ceres::Problem* problem);

// One camera's calibration after the joint solve.
struct RefinedCalibration {
  std::vector<int> passes;
  // False: held as written (refinement off, or auto with too few cross observations).
  bool refined = false;
  std::int64_t num_cross_observations = 0;
  geometry::PinholeRadTan written_camera, camera;
  geometry::Rigid3 written_body_from_camera, body_from_camera;
  // The rotation from the written T_BS to the refined one, degrees, and the move of its lever
  // arm (body frame), m.
  double RotationChangeDeg() const;
  Eigen::Vector3d LeverArmChange() const {
    return body_from_camera.translation() - written_body_from_camera.translation();
  }
};

// A joint solve in two steps (fuse with degraded sessions: the trusted passes alone, then every
// pass with those held, which holds their cameras too): the second step must hold the cameras
// where the first refined them, not as written, or the trusted sessions' cameras would differ
// from a season without the degraded ones. Points every pass whose camera is written as one
// that `first` refined (the trusted passes and the degraded sessions of the same rig) at the
// refined camera, kept in `storage`. Passes with `keep[p]` (empty: none) keep their camera (an
// incremental fuse's held passes).
void UseRefinedCalibrations(const std::vector<RefinedCalibration>& first,
                            std::vector<slam::RowOptimiser::Input>* passes,
                            std::deque<geometry::PinholeRadTan>* storage,
                            const std::vector<bool>& keep = {});
// After the second step: its calibrations held at a refinement of the first step are reported
// as that refinement of the written calibration.
void ReportRefinedCalibrations(const std::vector<RefinedCalibration>& first,
                               std::vector<RefinedCalibration>* second);

// How far apart two calibrations send a camera's rays: the RMS angle, degrees, between the
// body-frame rays of a 9 × 7 grid of pixels spread over the image (5 % from its borders),
// unprojected through (camera_a, body_from_camera_a) and through (camera_b, body_from_camera_b).
// The lever arms are left out (a ray's direction only). Both cameras must be of one image size.
double RayAngleRmsDeg(const geometry::PinholeRadTan& camera_a,
                      const geometry::Rigid3& body_from_camera_a,
                      const geometry::PinholeRadTan& camera_b,
                      const geometry::Rigid3& body_from_camera_b);

}  // namespace crop4d::fusion
