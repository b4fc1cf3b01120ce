#pragma once

// The landmarks of a season across its passes (DESIGN.md §2.4): the observations (pass, image,
// feature) of each pass's own landmarks, joined by the cross matches of association.
//
// Every (pass, image, feature) is a node. A pass's landmark links its observations (row SLAM
// made them consistent). A cross match links feature a of pass a with feature b of pass b, and
// each of the two with the observations of the track it belongs to in its pass (its cloud
// track: the match then joins whole tracks, not single features). The matches are replayed
// best first (smallest descriptor distance) through a union-find that refuses any union putting
// two features of one image into a landmark (features/union_find.h): the weakest link of a
// conflict is the one cut, as features/tracks.h does within a pass, and the refused match is
// counted as conflicting.

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "crop4d/features/tracks.h"

namespace crop4d::fusion {

// One feature of one image of one pass.
struct PassFeature {
  int pass = 0;
  int image = 0;
  int feature = 0;

  bool operator==(const PassFeature&) const = default;
};

class CrossPassTracks {
 public:
  // A landmark of pass `pass` seen by `observations` (its images and features).
  void AddPassLandmark(int pass, const std::vector<features::Observation>& observations);

  // A cross match of feature a with feature b (of another pass) at descriptor distance
  // `distance`; `track_a` and `track_b` are the observations of the track of a (in a's pass)
  // and of b (in b's pass), empty when the feature is in no track.
  void AddCrossMatch(const PassFeature& a, const PassFeature& b, float distance,
                     const std::vector<features::Observation>& track_a,
                     const std::vector<features::Observation>& track_b);

  struct Result {
    // Each landmark's observations, sorted by pass then image (at most one per image); two or
    // more per landmark. Landmarks are ordered by their first node (the order in which their
    // features were first added).
    std::vector<std::vector<PassFeature>> landmarks;
    // Cross matches refused because they would put two features of one image in a landmark.
    std::int64_t num_conflicting_matches = 0;
  };

  // The landmarks over the passes with `use[p]` (every pass: empty `use`): the passes' own
  // landmarks, then the cross matches between two used passes, best first. Observations keep
  // the pass indices given.
  Result Join(const std::vector<bool>& use = {}) const;

  std::size_t num_nodes() const { return nodes_.size(); }
  std::size_t num_cross_matches() const { return matches_.size(); }

 private:
  int Node(int pass, int image, int feature);

  struct Match {
    // The match itself first, then the links to the two features' tracks.
    std::vector<std::pair<int, int>> edges;
    float distance = 0;
    int pass_a = 0, pass_b = 0;
  };

  std::unordered_map<std::uint64_t, int> node_ids_;
  std::vector<PassFeature> nodes_;
  // First node of each pass landmark, and the links from it to the landmark's other nodes.
  std::vector<int> landmark_nodes_;
  std::vector<std::pair<int, int>> landmark_edges_;
  std::vector<Match> matches_;
};

}  // namespace crop4d::fusion
