#pragma once

// The associate stage's view of one row pass (internal to pipeline/associate_*.cc): its
// workspace data with the camera and image files row SLAM used (from measurements.bin), the
// landmarks each image sees, the local planes of its cloud; and the pre-alignment of two passes.

#include <cstdint>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "crop4d/association/local_planes.h"
#include "crop4d/association/robust_matcher.h"
#include "crop4d/fusion/pass_alignment.h"
#include "crop4d/geometry/camera.h"
#include "crop4d/pipeline/associate_stage.h"
#include "crop4d/workspace/pass_data.h"

namespace crop4d::pipeline::associate {

// A pass loaded for association: features, camera, image files, the landmarks seen in each
// image, and (for a pass that projects its landmarks) the local planes of its cloud.
struct PassContext {
  workspace::PassData data;
  geometry::PinholeRadTan camera;
  std::vector<std::string> image_paths;
  std::vector<std::vector<association::LandmarkObservation>> landmarks_per_image;
  std::unique_ptr<association::LocalPlanes> planes;
  // A low quantile of the cloud's heights: the ground under the plants, for the footprints.
  double ground_z = 0;
  // The cloud point of each (image, feature) of the pass.
  std::unordered_map<std::uint64_t, int> cloud_of;
  // Solved with RTK: poses good to centimetres.
  bool precise = false;
};

// Loads the pass from the workspace: features, tracks, measurements (camera, image files under
// `field_folder`), its landmarks per image and, unless the method is naive, its local planes.
std::unique_ptr<PassContext> LoadPass(const std::string& field_folder, const std::string& workspace,
                                      const std::string& session, const slam::RowPass& pass,
                                      const AssociateStageOptions& options);

// Pass b's frame relative to pass a's (association/prealignment.h).
fusion::PassAlignment PreAlign(const PassContext& a, const PassContext& b,
                               const AssociateStageOptions& options);

}  // namespace crop4d::pipeline::associate
