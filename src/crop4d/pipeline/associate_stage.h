#pragma once

// The association stage (`crop4d associate`, DESIGN.md §2.3): cross matches between row passes
// that see the same ground — neighbours in space (other rows of the same session) and in time
// (the same row in the previous and next session).
//
// Schedule: in each session, every pass with its nearest pass driven in the same direction and
// its nearest pass driven in the opposite direction (nearest by row index); across sessions,
// every pass with the passes over the same row in the next `session_gap` sessions. Within a pair
// of passes, the image pairs come from the row-SLAM poses by ground-footprint overlap
// (association/footprint.h). Each image pair is matched by the paper's robust association
// (association/robust_matcher.h: landmarks of pass a projected into the image of pass b, bounded
// search, plane-induced warp beyond 0.5 m of baseline, nearest distinctive descriptor, 8-point
// RANSAC) or by the naive baseline (whole images, ratio test, RANSAC).
//
// Outputs per pass pair and method, in WS/associations/<method>/:
//   <a>__<b>.bin   the cross matches (association/association_file.h);
//   <a>__<b>.json  the pair, its type, counts (image pairs, landmarks projected, candidates,
//                  matches before and after RANSAC), time, and a fingerprint of the inputs: a
//                  pair whose inputs and options are unchanged is skipped (unless `force`).

#include <string>
#include <vector>

#include "crop4d/association/association_file.h"
#include "crop4d/association/footprint.h"
#include "crop4d/association/robust_matcher.h"
#include "crop4d/association/surface_points.h"
#include "crop4d/features/matcher.h"
#include "crop4d/fusion/pass_alignment.h"
#include "crop4d/workspace/association_summary.h"

namespace crop4d::pipeline {

// What two passes have in common.
enum class PassPairType {
  kSameDirection,      // same session, other row, driven the same way
  kOppositeDirection,  // same session, other row, driven the other way
  kCrossSession,       // same row, another session
};
const char* ToString(PassPairType type);

struct PassPair {
  association::PassRef a;
  association::PassRef b;
  PassPairType type = PassPairType::kSameDirection;
  int row_a = -1, row_b = -1;
};

struct AssociateStageOptions {
  // "robust", "naive" or "both".
  std::string method = "robust";
  // Only pairs with a pass of this session (empty: all).
  std::string session;
  // Only this pass pair, named as its files are without the extension
  // ("<session a>_<pass a>__<session b>_<pass b>", PassPairName; empty: every pair): one work
  // unit of the Slurm executor (pipeline/cluster_run.h).
  std::string pair;
  // Which neighbours: other rows of the same session, and the same row in other sessions up to
  // `session_gap` sessions later (1: the next session).
  bool same_session = true;
  bool cross_session = true;
  int session_gap = 1;
  // Image pairs by footprint overlap.
  association::PairSelectionOptions image_pairs = [] {
    association::PairSelectionOptions o;
    o.min_overlap = 0.3;
    o.max_pairs_per_image = 1;
    return o;
  }();
  // The landmarks of pass a projected into pass b: row-SLAM cloud tracks of at least this many
  // images, at most `max_landmark_distance_m` from the camera: the ground and crop the image
  // pair was chosen for. Farther points are seen at grazing angles or belong to the distant tree
  // line, where a keypoint's half pixel spans centimetres (5 cm at 30 m): matched, they place
  // nothing to the centimetre (on the demo field, 8 m instead of 5 m lowers the cross-row
  // precision at 2 cm from 96% to 90%).
  int min_track_length = 2;
  double max_landmark_distance_m = 5.0;
  // The features of I1 that are no landmark are projected too, placed on the local surface of
  // the landmarks around them (association/surface_points.h; its max_range_m is
  // max_landmark_distance_m): the paper's search is otherwise limited to the features that row
  // SLAM tracked.
  bool surface_points = true;
  association::SurfacePointOptions surface;
  association::RobustMatcher::Options robust;
  // The naive baseline (and the pre-alignment's matches) with exact nearest neighbours, as row
  // SLAM's front end: at 1 024 features per image the exhaustive search is 9x faster than
  // FLANN's forest and finds the true neighbours, so the baseline is no weaker for being
  // approximate (bench/RESULTS.md "The naive baseline with exact neighbours").
  features::PairMatcher::Options naive = [] {
    features::PairMatcher::Options o;
    o.descriptors.method = features::DescriptorMatchOptions::Method::kExhaustive;
    return o;
  }();
  // Pre-alignment of pass b onto pass a before the robust search, for poses that a metre-level
  // GPS placed: naive matches between every `prealign_stride`-th image of pass a and every
  // (prealign_stride / 3)-th image of pass b within `prealign_radius_m` give the same ground
  // points in both passes' clouds (those within `max_landmark_distance_m` of both cameras: not
  // the tree line), and a 4-DOF alignment of those (fusion/pass_alignment.h) corrects pass b's
  // poses; the bounded search then uses `prealigned_sigma_position_m`.
  // "auto": across sessions when either pass was not solved with RTK (within a session the
  // passes share the receiver's slowly drifting bias, so their relative error is decimetres:
  // the search box then uses `imprecise_sigma_position_m` instead); "always"; "never".
  std::string prealign = "auto";
  double imprecise_sigma_position_m = 0.3;
  int prealign_stride = 9;
  double prealign_radius_m = 5.0;
  double prealigned_sigma_position_m = 0.05;
  fusion::PassAlignmentOptions alignment = [] {
    fusion::PassAlignmentOptions o;
    o.inlier_threshold_m = 0.15;
    o.min_inliers = 30;
    return o;
  }();
  int num_threads = 0;
  bool force = false;
  bool show_progress = true;

  // Empty when the options are valid, else the option that is wrong and why ("state_rate_hz:
  // must be > 0"; the names of the configuration file's section, docs/run.md).
  std::string Check() const;
};

// A pass pair's association: the pair, the method, whether it was up to date, and its counts.
struct PassPairReport : workspace::AssociationCounts {
  PassPair pair;
  std::string method;
  bool skipped = false;  // up to date
};

// A pair's name: its association files' name without the extension.
std::string PassPairName(const PassPair& pair);

// The pass pairs of a workspace's sessions (in field order) under `options`.
std::vector<PassPair> ScheduleAssociations(const std::string& field_folder,
                                           const std::string& workspace,
                                           const AssociateStageOptions& options);

// Runs the stage; throws InputError when the workspace has no row SLAM results to match.
std::vector<PassPairReport> RunAssociateStage(const std::string& field_folder,
                                              const std::string& workspace,
                                              const AssociateStageOptions& options);

}  // namespace crop4d::pipeline
