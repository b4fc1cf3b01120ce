#pragma once

// The fuse stage's outputs under WS/fused/ (workspace::Layout): each session's fused poses and
// sparse cloud, the joint landmarks, the whole reconstruction as a COLMAP text model, the
// summary; and the stage's printed report (FormatFuseReport, fuse_stage.h).

#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/fusion/cross_pass_tracks.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/colmap_text.h"
#include "crop4d/io/ply.h"
#include "crop4d/pipeline/fuse_pass.h"
#include "crop4d/pipeline/fuse_stage.h"
#include "crop4d/workspace/fused_camera.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline::fuse {

// Each pass's intrinsics as its fused cameras go with them: its rig camera's calibration
// refined by the joint problem, or as written (JointOptimiser::Result::calibrations).
std::vector<workspace::FusedCamera> FusedIntrinsics(
    const std::vector<std::unique_ptr<LoadedPass>>& passes,
    const fusion::JointOptimiser::Result& result);

// WS/fused/<session>/poses.tum, camera.json and sparse.ply: the session's fused cameras (all
// passes, in time order), the intrinsics they go with (those of its first pass: a session's
// passes share its camera) and its passes' clouds re-triangulated from them.
void WriteSessionOutputs(const std::vector<std::unique_ptr<LoadedPass>>& passes,
                         const std::vector<std::vector<geometry::Rigid3>>& cameras,
                         const std::vector<workspace::FusedCamera>& intrinsics,
                         const std::vector<std::string>& sessions, const FuseStageOptions& options,
                         const workspace::Layout& layout);

// WS/fused/landmarks.ply (the joint landmarks, with how many passes and sessions see each)
// and, with `colmap`, WS/fused/colmap (the whole 4D reconstruction as a COLMAP text model: one
// camera per session, images named <session>/<pass>/<image file>, the joint landmarks as 3D
// points), written a landmark at a time, so that the season's landmarks and their observations
// need not be in memory together (the incremental fuse reads them a step at a time). `cameras`
// and `intrinsics` are every pass's fused cameras; with `colmap` the passes' image names
// (data.measurements.camera) must be loaded. A landmark's point id is its order of coming.
class SeasonLandmarkWriter {
 public:
  SeasonLandmarkWriter(const std::vector<std::unique_ptr<LoadedPass>>& passes,
                       const std::vector<std::vector<geometry::Rigid3>>& cameras,
                       const std::vector<workspace::FusedCamera>& intrinsics, bool colmap,
                       const workspace::Layout& layout);
  ~SeasonLandmarkWriter();

  // The next landmark, at `position`; its observation o counts when kept[o].
  void Add(const fusion::JointLandmark& landmark, const Eigen::Vector3d& position,
           const std::vector<bool>& kept);
  // Writes the files (each atomically).
  void Finish();

 private:
  void AppendPly();

  const std::vector<std::unique_ptr<LoadedPass>>& passes_;
  const std::vector<std::vector<geometry::Rigid3>>& cameras_;
  const std::vector<workspace::FusedCamera>& intrinsics_;
  std::unique_ptr<io::PlyStreamWriter> ply_;
  io::PlyPointCloud part_;  // landmarks not yet appended to the PLY
  std::unique_ptr<io::ColmapTextWriter> colmap_;
  std::vector<std::size_t> first_image_;  // per pass: the COLMAP index of its first image
  std::int64_t count_ = 0;
};

// The landmarks of one joint problem (`result`) so.
void WriteSeasonLandmarks(const std::vector<std::unique_ptr<LoadedPass>>& passes,
                          const std::vector<std::vector<geometry::Rigid3>>& cameras,
                          const std::vector<workspace::FusedCamera>& intrinsics,
                          const std::vector<fusion::JointLandmark>& landmarks,
                          const fusion::JointOptimiser::Result& result, bool colmap,
                          const workspace::Layout& layout);

// The joint problem's counts, fit and times as summary.json's "joint" holds them, and back
// (throws nlohmann::json::exception on a missing or mistyped field).
nlohmann::json JointSummaryJson(const fusion::JointOptimiser::Summary& summary);
fusion::JointOptimiser::Summary JointSummaryFromJson(const nlohmann::json& joint);

// The ground ties per pair of passes as summary.json's "ground_ties" holds them.
nlohmann::json TiePairsJson(const std::vector<FuseTiePairReport>& pairs);

// Adds one step's joint problem to the season's (incremental fuse): counts, costs, iterations
// and times summed, RMS values pooled, converged when every step converged.
void AddJointSummary(const fusion::JointOptimiser::Summary& step,
                     fusion::JointOptimiser::Summary* total);

// WS/fused/summary.json's content: the fingerprint, the options, the sessions, the association
// and joint-problem counts, the ground ties, each pass's move and time offset, the rig's cameras
// (refined or as written), the timings.
nlohmann::json FuseSummaryJson(const FuseReport& report,
                               const fusion::JointOptimiser::Result& result,
                               const std::string& stamp, const FuseStageOptions& options,
                               const std::vector<std::string>& sessions);

}  // namespace crop4d::pipeline::fuse
