#pragma once

// Precision of the cross matches between row passes (`crop4d associate`, DESIGN.md §2 step 3)
// against the ground truth of a synthetic field.
//
// A match joins a keypoint of an image of pass a with one of an image of pass b. Each keypoint's
// true 3D point is what its pixel sees in the true geometry (truth_geometry.h). The match is
//   correct    when both true points are known and lie within max_distance_m (2 cm) of each
//              other: both keypoints see the same piece of the field;
//   incorrect  when both are known and farther apart;
//   unknown    when either is unknown (no truth for the image, sky or outside the image, or a
//              depth edge under the keypoint), counted apart and left out of the precision.
// precision = correct / (correct + incorrect).
// The known matches are also counted apart when keypoint a sees a point at most near_depth_m
// deep (5 m): the ground and crop next to the vehicle, which is what registers the field. A
// match on the distant tree line or the grass beyond the field may be correct to 2 cm, but a
// half pixel there spans centimetres, so it places nothing in the field to the centimetre.
//
// Pairs of passes are grouped by type (ClassifyPair): two rows of one session driven in the
// same or in opposite directions, two sessions, two sessions with rain in between (the soil
// texture changed: the hardest case for appearance-based matching).

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "crop4d/association/association_file.h"
#include "crop4d/core/option_check.h"
#include "crop4d/eval/truth_geometry.h"

namespace crop4d::eval {

enum class PairType {
  kCrossRowSameDirection,      // one session, the two passes driven the same way
  kCrossRowOppositeDirection,  // one session, opposite ways (views rotated by ~180°)
  kCrossSession,               // two sessions, no rain in between
  kCrossSessionAfterRain,      // two sessions with rain in between
};
inline constexpr int kNumPairTypes = 4;

// "cross_row_same_direction", "cross_row_opposite_direction", "cross_session",
// "cross_session_after_rain" (the JSON names).
const char* PairTypeName(PairType type);
// Short words for the table: "row same dir", "row opposite dir", "session", "session+rain".
const char* PairTypeLabel(PairType type);

// Row and direction of a pass (WS/sessions/<session>/passes.csv).
struct PassLayout {
  int row = -1;
  int direction = 0;  // +1 along the row axis, −1 against it, 0 unknown
};

// The sessions of a field in recording order, and whether it rained before each.
struct SessionTimeline {
  std::vector<std::string> sessions;
  std::vector<bool> rain_before;  // one per session

  // Position of `session` in `sessions`, −1 when it is not there.
  int IndexOf(const std::string& session) const;
  // Whether it rained between sessions a and b: some session after the earlier of the two, up
  // to and including the later, has rain_before. False when either is unknown or a == b.
  bool RainBetween(const std::string& a, const std::string& b) const;
};

// The type of a pair of passes. Within one session: same direction when both directions are
// equal (also when both are unknown), opposite otherwise.
PairType ClassifyPair(const association::PassRef& a, const PassLayout& layout_a,
                      const association::PassRef& b, const PassLayout& layout_b,
                      const SessionTimeline& timeline);

// Counts of matches by outcome.
struct MatchCounts {
  std::int64_t matches = 0;
  std::int64_t correct = 0;
  std::int64_t incorrect = 0;
  std::int64_t unknown = 0;  // = the three below
  std::int64_t unknown_no_truth = 0;
  std::int64_t unknown_no_surface = 0;
  std::int64_t unknown_depth_edge = 0;
  // Known matches within AssociationEvalOptions::coarse_distance_m (5 cm): the incorrect ones
  // among them are near misses (keypoint localisation), the others gross errors.
  std::int64_t within_coarse = 0;
  // Known matches (correct + incorrect) whose keypoint in image a sees a true point at most
  // AssociationEvalOptions::near_depth_m deep, and the correct ones among them.
  std::int64_t known_near = 0;
  std::int64_t correct_near = 0;

  // correct / (correct + incorrect); NaN when both are 0.
  double Precision() const;
  // correct_near / known_near; NaN when known_near is 0.
  double NearPrecision() const;
  // within_coarse / (correct + incorrect); NaN when both are 0.
  double CoarsePrecision() const;
  void Add(const MatchCounts& other);
};

struct AssociationEvalOptions {
  // A match is correct when its two true points are at most this far apart, m.
  double max_distance_m = 0.02;
  // A second, looser threshold reported beside it (MatchCounts::within_coarse), m.
  double coarse_distance_m = 0.05;
  // Matches whose keypoint a sees a true point at most this deep (camera z) are also counted
  // apart (MatchCounts::known_near, correct_near), m: the range of the robust method's
  // landmarks (AssociateStageOptions::max_landmark_distance_m).
  double near_depth_m = 5.0;
  TruePointOptions true_point;

  OptionCheck Check() const;
};

// One association file, read, with the layout of its two passes.
struct AssociationInput {
  std::string file;  // for people (relative to the workspace)
  association::PassAssociation association;
  PassLayout layout_a, layout_b;
  // Why the file cannot be evaluated (unreadable); the others are still evaluated.
  std::string error;
};

struct AssociationFileEval {
  std::string file;
  std::string method;  // "robust", "naive" (from the file)
  association::PassRef a, b;
  PassLayout layout_a, layout_b;
  PairType type = PairType::kCrossRowSameDirection;
  std::string error;  // non-empty: not evaluated
  MatchCounts counts;
  // Median and 90th percentile of |P_a − P_b| over the matches with both true points known,
  // m (NaN when none): how wrong the wrong matches are.
  double median_distance_m = 0.0;
  double p90_distance_m = 0.0;

  bool ok() const { return error.empty(); }
};

// The files of one pair type and one method, pooled.
struct AssociationGroupEval {
  PairType type = PairType::kCrossRowSameDirection;
  std::string method;
  int files = 0;
  MatchCounts counts;
};

struct AssociationEval {
  AssociationEvalOptions options;
  std::vector<AssociationFileEval> files;     // in input order
  std::vector<AssociationGroupEval> groups;   // type order, then method by name; only non-empty
  std::vector<AssociationGroupEval> methods;  // all types pooled, per method
  int num_failed = 0;                         // files with an error
  std::int64_t images = 0;                    // distinct images whose true geometry was needed
  DepthSourceStats depth;                     // truth.stats() after the evaluation

  // The pooled counts of one pair type and method (all zero when it has no file).
  MatchCounts GroupCounts(PairType type, const std::string& method) const;
};

// The order in which the sessions of the readable inputs are evaluated: their index in the
// timeline; sessions outside it after it, by name.
std::map<std::string, int> RankSessions(const std::vector<AssociationInput>& inputs,
                                        const SessionTimeline& timeline);

// Evaluates every input. The true geometry of each image that appears in a match is asked for
// once, session after session (in timeline order, unknown sessions last by name) and in time
// order within a session.
AssociationEval EvaluateAssociations(const std::vector<AssociationInput>& inputs,
                                     const SessionTimeline& timeline, TruthGeometry& truth,
                                     const AssociationEvalOptions& options = {});

}  // namespace crop4d::eval
