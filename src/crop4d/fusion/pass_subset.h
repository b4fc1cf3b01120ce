#pragma once

// The joint 4D problem restricted to some of its passes (DESIGN.md §2.4): the fuse stage first
// solves the trusted sessions' passes alone, so that a degraded session cannot move them, then
// every pass with the trusted ones held where that solve put them.

#include <vector>

#include "crop4d/fusion/joint_optimiser.h"

namespace crop4d::fusion {

struct PassSubset {
  // The kept passes, renumbered 0..n−1 in their order.
  std::vector<JointOptimiser::Pass> passes;
  std::vector<JointLandmark> landmarks;
  std::vector<JointGroundTie> ties;
  // The index in the whole problem of each kept pass.
  std::vector<int> original_pass;
};

// The problem over the passes with `keep[p]`: `landmarks` must see kept passes only (CHECKed;
// join them over the kept passes, fusion/cross_pass_tracks.h); their observations and the ties
// between two kept passes are renumbered, the other ties left out.
PassSubset RestrictToPasses(const std::vector<JointOptimiser::Pass>& passes,
                            std::vector<JointLandmark> landmarks,
                            const std::vector<JointGroundTie>& ties, const std::vector<bool>& keep);

}  // namespace crop4d::fusion
