#pragma once

// The fuse stage's view of one row pass (internal to pipeline/fuse_*.cc): its workspace data, its
// row-SLAM problem for the joint optimiser (rebuilt from the pass's priors and measurements in
// the workspace, never from the field), and its cloud tracks triangulated from given cameras.

#include <cstdint>
#include <map>
#include <string>
#include <unordered_map>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/track_cloud.h"
#include "crop4d/slam/triangulation.h"
#include "crop4d/workspace/pass_data.h"

namespace crop4d::pipeline::fuse {

// A pass as the fuse stage holds it: its workspace data, its row-SLAM problem rebuilt for the
// joint optimiser (`input` points into `data.measurements`) and the cloud track of each of its
// keypoints.
struct LoadedPass {
  workspace::PassData data;
  fusion::JointOptimiser::Pass input;
  // Cloud track of each (image, feature) of the pass.
  std::unordered_map<std::uint64_t, int> cloud_of;
};

// The key of an (image, feature) of a pass in LoadedPass::cloud_of.
inline std::uint64_t ImageFeatureKey(int image, int feature) {
  return (static_cast<std::uint64_t>(image) << 32) | static_cast<std::uint32_t>(feature);
}

// Loads the pass's features (without their descriptors), tracks, states and measurements from
// the workspace and rebuilds its row-SLAM problem (`input`) and `cloud_of`. `pass->data` names
// the session and pass.
void LoadPassProblem(const std::string& workspace, LoadedPass* pass);

// The image file names of the pass by timestamp.
std::map<Timestamp, std::string> ImageNames(const LoadedPass& pass);

// The cloud tracks of a pass (their keypoints and colours) triangulated from the given cameras
// (one per image) with the intrinsics `camera`.
slam::TrackCloud CloudOfTracks(const LoadedPass& pass, const geometry::PinholeRadTan& camera,
                               const std::vector<geometry::Rigid3>& cameras,
                               const slam::TriangulationOptions& options);

}  // namespace crop4d::pipeline::fuse
