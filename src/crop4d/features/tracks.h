#pragma once

// Feature tracks from pairwise matches by union-find (Moulon & Monasse, "Unordered Feature
// Tracking Made Fast and Easy", CVMP 2012): every (image, feature) is a node, every verified
// inlier match an edge, and a track is a connected component.
//
// A component that holds two features of one image is inconsistent (one 3D point cannot be
// seen twice in an image). Moulon & Monasse drop such components; by default this builder
// splits them instead: the component's matches are replayed in order of increasing descriptor
// distance through a second union-find that refuses any union whose two sides share an image.
// The best-supported chains survive as consistent tracks and only the weakest links that
// caused the conflict are cut. Components without conflict come out exactly as plain
// union-find gives them.
//
// A track becomes a landmark when it is long enough: the paper accepts a landmark seen in more
// than 6 images, hence min_track_length = 7 by default.

#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/features/matcher.h"

namespace crop4d::features {

// One feature of one image.
struct Observation {
  std::int32_t image = -1;
  std::int32_t feature = -1;

  bool operator==(const Observation&) const = default;
  auto operator<=>(const Observation&) const = default;
};

// A match between two observations; `distance` (descriptor distance) ranks matches when an
// inconsistent component is split.
struct TrackEdge {
  Observation a;
  Observation b;
  float distance = 0;
};

// A consistent track: at most one observation per image, sorted by image.
struct Track {
  std::vector<Observation> observations;

  std::size_t size() const { return observations.size(); }
  bool operator==(const Track&) const = default;
};

// The inlier matches of the verified pairs as track edges, in the order of `pairs`.
std::vector<TrackEdge> EdgesFromPairs(const std::vector<PairMatches>& pairs);

class TrackBuilder {
 public:
  enum class ConflictPolicy {
    // Split an inconsistent component by replaying its matches, best first, refusing unions
    // that would put two features of one image in a track.
    kSplit,
    // Drop every observation of an inconsistent component.
    kDrop,
  };

  struct Options {
    // Shortest track returned, in images. The paper accepts a landmark seen in more than 6
    // images: 7.
    int min_track_length = 7;
    // What to do with a component that holds two features of one image.
    ConflictPolicy conflict_policy = ConflictPolicy::kSplit;

    OptionCheck Check() const;
  };

  struct Summary {
    // Matches given.
    int num_edges = 0;
    // Connected components of the match graph (two or more features).
    int num_components = 0;
    // Components that held two features of one image.
    int num_inconsistent_components = 0;
    // Consistent tracks (two or more images) the inconsistent components were split into
    // (kSplit), or observations dropped with them (kDrop).
    int num_tracks_from_splits = 0;
    int num_dropped_observations = 0;
    // Consistent tracks of two or more images, before the length filter.
    int num_tracks = 0;
    // Tracks of at least min_track_length images: the accepted landmarks.
    int num_accepted_tracks = 0;
    // Mean length of the accepted tracks (0 when none).
    double mean_accepted_track_length = 0;
  };

  explicit TrackBuilder(Options options);

  // Tracks from `edges` over images with `num_features[i]` features each. Observations must
  // lie inside these counts (checked). Tracks are sorted by their first observation; the
  // result depends only on the input (not on threads or memory layout).
  std::vector<Track> Build(const std::vector<int>& num_features,
                           const std::vector<TrackEdge>& edges, Summary* summary = nullptr) const;
  // Tracks from the inlier matches of the verified pairs.
  std::vector<Track> Build(const std::vector<int>& num_features,
                           const std::vector<PairMatches>& pairs, Summary* summary = nullptr) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace crop4d::features
