#pragma once

// The ceiling of cross-pass association: how many correct matches the image pairs of `crop4d
// associate` hold at all (issue 26, item 4), against the ground truth of a synthetic field.
//
// Both association methods match the keypoints of two images and keep at most one match per
// keypoint of image a, so neither can find more correct matches in an image pair than there are
// keypoints of image a with a keypoint of image b whose true point lies within max_distance_m
// (2 cm; association_eval.h). The ceiling counts those keypoints in every image pair that some
// method matched (the union over the methods' files of one pair of passes), and apart those
// that see a point at most near_depth_m (5 m) deep: next to the vehicle, where the field is
// registered. A method's share of the ceiling is its correct matches (AssociationGroupEval's
// counts) over the ceiling of its pair type.
//
// Two keypoints can also lie within 2 cm by chance, without seeing the same texture (after rain
// the soil is new): the same count with image b's true points shifted by chance_shift_m east
// estimates that part (the ground is nearly flat at that scale, so the shifted points still lie
// on it).

#include <Eigen/Core>
#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/eval/association_eval.h"

namespace crop4d::eval {

// The keypoints of every image of a pass, by image index (CrossMatch::image_a / image_b), and
// each image's timestamp (for its true geometry).
struct PassKeypoints {
  std::vector<Timestamp> times;
  std::vector<std::vector<Eigen::Vector2d>> pixels;  // one per image, distorted pixels
};

// Loads a pass's keypoints (the workspace's features.bin); throws InputError when it cannot.
using PassKeypointsLoader = std::function<PassKeypoints(const association::PassRef&)>;

struct CeilingCounts {
  std::int64_t image_pairs = 0;
  // Keypoints of image a with a known true point, and those of them with a partner in image b
  // within max_distance_m (all / at most near_depth_m deep in image a).
  std::int64_t keypoints = 0;
  std::int64_t partners = 0;
  std::int64_t partners_near = 0;
  // partners_near with image b's true points shifted by chance_shift_m east.
  std::int64_t chance_near = 0;

  void Add(const CeilingCounts& other);
};

struct CeilingGroup {
  PairType type = PairType::kCrossRowSameDirection;
  int pass_pairs = 0;
  CeilingCounts counts;
};

struct AssociationCeiling {
  double chance_shift_m = 0.1;
  std::vector<CeilingGroup> groups;  // one per pair type with pass pairs, in type order
  // Pass pairs whose keypoints could not be loaded ("session/pass ~ session/pass: why").
  std::vector<std::string> errors;
};

// The keypoints of image a (true points `a`) with a partner among image b's (`b`, shifted by
// `shift_b`) within options.max_distance_m, added to `counts` (keypoints, partners,
// partners_near; or only chance_near when `chance` is set).
struct KeypointTruth {
  bool ok = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double depth_m = 0.0;
};
void CountPartners(const std::vector<KeypointTruth>& a, const std::vector<KeypointTruth>& b,
                   const Eigen::Vector3d& shift_b, bool chance,
                   const AssociationEvalOptions& options, CeilingCounts* counts);

// The ceiling of every pair type of the readable inputs (their errors are left out). Each pass's
// keypoints are loaded once and their true points asked for in time order, the passes of one
// session after another (as EvaluateAssociations, whose depth maps are then cached); a pass's
// keypoints are freed after its last pair, so memory holds about two sessions' passes.
AssociationCeiling EvaluateCeiling(const std::vector<AssociationInput>& inputs,
                                   const SessionTimeline& timeline, TruthGeometry& truth,
                                   const PassKeypointsLoader& load_keypoints,
                                   const AssociationEvalOptions& options = {});

}  // namespace crop4d::eval
