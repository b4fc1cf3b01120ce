#include "crop4d/fusion/pass_subset.h"

#include "crop4d/core/error.h"

namespace crop4d::fusion {

PassSubset RestrictToPasses(const std::vector<JointOptimiser::Pass>& passes,
                            std::vector<JointLandmark> landmarks,
                            const std::vector<JointGroundTie>& ties,
                            const std::vector<bool>& keep) {
  CROP4D_CHECK_MSG(keep.size() == passes.size(), "RestrictToPasses: one keep flag per pass");
  PassSubset out;
  std::vector<int> index(passes.size(), -1);
  for (std::size_t p = 0; p < passes.size(); ++p) {
    if (!keep[p]) continue;
    index[p] = static_cast<int>(out.passes.size());
    out.passes.push_back(passes[p]);
    out.original_pass.push_back(static_cast<int>(p));
  }
  for (JointLandmark& landmark : landmarks) {
    for (JointObservation& obs : landmark.observations) {
      CROP4D_CHECK_MSG(index.at(obs.pass) >= 0,
                       "RestrictToPasses: a landmark sees a left-out pass");
      obs.pass = index[obs.pass];
    }
    out.landmarks.push_back(std::move(landmark));
  }
  for (JointGroundTie tie : ties) {
    if (!keep[tie.pass_a] || !keep[tie.pass_b]) continue;
    tie.pass_a = index[tie.pass_a];
    tie.pass_b = index[tie.pass_b];
    out.ties.push_back(tie);
  }
  return out;
}

}  // namespace crop4d::fusion
