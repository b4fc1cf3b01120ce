#pragma once

// The joint 4D problem in blocks of passes (DESIGN.md §2.4), so that its memory is bounded by a
// block's size instead of growing with the passes it covers. One joint solve holds, for every
// observation, its Ceres residual, its rows of the Jacobian and its share of the Schur complement
// and of that complement's sparse Cholesky factor: about 2–3 kB an observation (heaptrack on
// the demo's incremental fuse: 0.96 GB of heap for a step of about 300 000 observations). A
// session of the paper's field (21 rows × 150 m) holds tens of millions of observations.
//
// Above BlockSolveOptions::max_observations observations in the free passes, the free passes
// are cut into blocks of neighbouring passes: ordered across the rows (the passes of one row on
// every date together) and cut in that order into blocks of about equal size, each holding at
// most max_observations observations (a pass with more is a block of its own). Each block is solved
// as one joint problem with the landmarks it observes and the passes it shares them or a ground tie
// with, those held where the latest solve left them (block Gauss–Seidel), one block after the other
// across the field, `sweeps` times. The neighbours that are free passes of other blocks share
// the block's camera, so each block refines the calibration from where the previous one left
// it; the last sweep holds it, so that every pass ends placed with one calibration. In the
// first sweep a block uses only the neighbours already placed (the held passes and the blocks
// before it), not those still where row SLAM left them: it would be pulled towards them and
// its calibration would take up their errors. The passes are anchored by their GPS and coupled
// to their neighbours through shared landmarks only, so a few sweeps carry a correction across
// the field.
// Below the bound, one JointOptimiser::Solve, exactly as without blocks.

#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/fusion/joint_optimiser.h"

namespace crop4d::fusion {

struct BlockSolveOptions {
  // The most observations of free passes that one problem holds (0: any number: one problem).
  // With the held neighbours' observations of its landmarks, a block of 316 000 solved in
  // 1.3 GB (bench/RESULTS.md "Fuse in blocks of passes"); the demo's steps (220 000–290 000)
  // stay one problem each.
  int max_observations = 400000;
  // Sweeps over the blocks: the last holds the calibration that the ones before refined (with
  // one sweep, it refines it block by block).
  int sweeps = 3;

  OptionCheck Check() const;
};

// The blocks of the passes with `free[p]`, each a list of pass indices: ordered across the
// passes' mean direction of travel by their mean position (ties by index) and cut into blocks
// of about equal size, as many as needed for each block's `observations` to sum to at most
// `max_observations` (a single pass with more is a block of its own).
std::vector<std::vector<int>> PartitionPasses(const std::vector<JointOptimiser::Pass>& passes,
                                              const std::vector<std::int64_t>& observations,
                                              const std::vector<bool>& free,
                                              std::int64_t max_observations);

// JointOptimiser::Solve (same arguments and result) over blocks of passes when the free passes
// hold more than blocks.max_observations observations. The result's summary sums the blocks'
// iterations and times, sets initial_cost from the first sweep and final_cost from the last
// (both summed over its blocks, so a landmark shared by two blocks counts twice), counts the
// landmarks and observations of the merged result, and gives Summary::num_blocks and
// num_sweeps; a landmark's position and kept observations come from the last block that
// solved it, and a landmark seen from fixed passes only is triangulated against their cameras
// (one problem would refine it against the same held poses). A fixed pass that no block
// reaches keeps its given states; its cameras are placed at the image stamps.
JointOptimiser::Result SolveInBlocks(const JointOptimiser::Options& options,
                                     const BlockSolveOptions& blocks,
                                     const std::vector<JointOptimiser::Pass>& passes,
                                     const std::vector<JointLandmark>& landmarks,
                                     const std::vector<JointGroundTie>& ground_ties = {},
                                     const std::vector<bool>& fixed_passes = {},
                                     const std::vector<bool>& own_camera_passes = {});

}  // namespace crop4d::fusion
