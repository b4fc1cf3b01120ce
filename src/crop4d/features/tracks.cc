#include "crop4d/features/tracks.h"

#include <algorithm>

#include "crop4d/core/error.h"
#include "crop4d/features/union_find.h"

namespace crop4d::features {

bool TrackBuilder::Options::Check() const { return min_track_length >= 2; }

TrackBuilder::TrackBuilder(Options options) : options_(std::move(options)) {
  CROP4D_CHECK_MSG(options_.Check(), "invalid TrackBuilder::Options");
}

std::vector<TrackEdge> EdgesFromPairs(const std::vector<PairMatches>& pairs) {
  std::vector<TrackEdge> edges;
  for (const PairMatches& pair : pairs) {
    if (!pair.summary.verified) continue;
    for (int i : pair.inliers) {
      const FeatureMatch& m = pair.matches[i];
      edges.push_back({{pair.image1, m.feature1}, {pair.image2, m.feature2}, m.distance});
    }
  }
  return edges;
}

std::vector<Track> TrackBuilder::Build(const std::vector<int>& num_features,
                                       const std::vector<PairMatches>& pairs,
                                       Summary* summary) const {
  return Build(num_features, EdgesFromPairs(pairs), summary);
}

std::vector<Track> TrackBuilder::Build(const std::vector<int>& num_features,
                                       const std::vector<TrackEdge>& edges,
                                       Summary* summary) const {
  Summary local;
  Summary& s = summary != nullptr ? *summary : local;
  s = Summary();
  s.num_edges = static_cast<int>(edges.size());

  // Node id of (image, feature): features of image i occupy [offset[i], offset[i + 1]).
  const std::size_t num_images = num_features.size();
  std::vector<std::size_t> offset(num_images + 1, 0);
  for (std::size_t i = 0; i < num_images; ++i) {
    CROP4D_CHECK(num_features[i] >= 0);
    offset[i + 1] = offset[i] + static_cast<std::size_t>(num_features[i]);
  }
  const auto node_of = [&](const Observation& o) {
    CROP4D_CHECK_MSG(o.image >= 0 && static_cast<std::size_t>(o.image) < num_images &&
                         o.feature >= 0 && o.feature < num_features[o.image],
                     "track edge outside the feature counts");
    return offset[o.image] + static_cast<std::size_t>(o.feature);
  };
  std::vector<Observation> observation_of(offset.back());
  for (std::size_t i = 0; i < num_images; ++i) {
    for (int f = 0; f < num_features[i]; ++f) {
      observation_of[offset[i] + f] = {static_cast<std::int32_t>(i), f};
    }
  }

  // 1. Plain union-find over every match.
  UnionFind components(offset.back());
  std::vector<char> touched(offset.back(), 0);
  for (const TrackEdge& e : edges) {
    const std::size_t a = node_of(e.a), b = node_of(e.b);
    components.Union(a, b);
    touched[a] = touched[b] = 1;
  }

  // 2. Components, numbered by their first node; their nodes in increasing id, i.e. sorted by
  // (image, feature).
  std::vector<int> component_of_root(offset.back(), -1);
  std::vector<std::vector<std::size_t>> component_nodes;
  for (std::size_t node = 0; node < offset.back(); ++node) {
    if (!touched[node]) continue;
    const std::size_t root = components.Find(node);
    if (component_of_root[root] < 0) {
      component_of_root[root] = static_cast<int>(component_nodes.size());
      component_nodes.emplace_back();
    }
    component_nodes[component_of_root[root]].push_back(node);
  }
  s.num_components = static_cast<int>(component_nodes.size());

  std::vector<Track> tracks;
  std::vector<int> inconsistent;  // component ids
  for (std::size_t c = 0; c < component_nodes.size(); ++c) {
    const std::vector<std::size_t>& nodes = component_nodes[c];
    bool consistent = true;
    for (std::size_t k = 1; k < nodes.size() && consistent; ++k) {
      consistent = observation_of[nodes[k]].image != observation_of[nodes[k - 1]].image;
    }
    if (!consistent) {
      inconsistent.push_back(static_cast<int>(c));
      continue;
    }
    Track track;
    track.observations.reserve(nodes.size());
    for (std::size_t node : nodes) track.observations.push_back(observation_of[node]);
    tracks.push_back(std::move(track));
  }
  s.num_inconsistent_components = static_cast<int>(inconsistent.size());

  // 3. Inconsistent components.
  if (!inconsistent.empty()) {
    if (options_.conflict_policy == ConflictPolicy::kDrop) {
      for (int c : inconsistent) {
        s.num_dropped_observations += static_cast<int>(component_nodes[c].size());
      }
    } else {
      // The edges of each inconsistent component, best (smallest distance) first; ties keep
      // the input order.
      std::vector<int> slot_of_component(component_nodes.size(), -1);
      for (std::size_t k = 0; k < inconsistent.size(); ++k) {
        slot_of_component[inconsistent[k]] = static_cast<int>(k);
      }
      std::vector<std::vector<int>> component_edges(inconsistent.size());
      for (std::size_t e = 0; e < edges.size(); ++e) {
        const int c = component_of_root[components.Find(node_of(edges[e].a))];
        if (slot_of_component[c] >= 0) {
          component_edges[slot_of_component[c]].push_back(static_cast<int>(e));
        }
      }
      std::vector<std::uint64_t> image_of(offset.back());
      for (std::size_t node = 0; node < offset.back(); ++node) {
        image_of[node] = static_cast<std::uint64_t>(observation_of[node].image);
      }
      ConsistentUnionFind split(std::move(image_of));
      std::vector<int> piece_of_root(offset.back(), -1);  // roots are unique to a component
      for (std::size_t k = 0; k < inconsistent.size(); ++k) {
        std::vector<int>& order = component_edges[k];
        std::stable_sort(order.begin(), order.end(),
                         [&](int x, int y) { return edges[x].distance < edges[y].distance; });
        for (int e : order) split.Union(node_of(edges[e].a), node_of(edges[e].b));
        // The pieces, numbered by their first node.
        std::vector<Track> pieces;
        for (std::size_t node : component_nodes[inconsistent[k]]) {
          const std::size_t root = split.Find(node);
          if (piece_of_root[root] < 0) {
            piece_of_root[root] = static_cast<int>(pieces.size());
            pieces.emplace_back();
          }
          pieces[piece_of_root[root]].observations.push_back(observation_of[node]);
        }
        for (Track& piece : pieces) {
          if (piece.size() < 2) {
            ++s.num_dropped_observations;
            continue;
          }
          ++s.num_tracks_from_splits;
          tracks.push_back(std::move(piece));
        }
      }
    }
  }
  s.num_tracks = static_cast<int>(tracks.size());

  // 4. Length filter and a canonical order.
  std::vector<Track> accepted;
  double total_length = 0;
  for (Track& track : tracks) {
    if (static_cast<int>(track.size()) < options_.min_track_length) continue;
    total_length += static_cast<double>(track.size());
    accepted.push_back(std::move(track));
  }
  std::sort(accepted.begin(), accepted.end(), [](const Track& x, const Track& y) {
    return x.observations.front() < y.observations.front();
  });
  s.num_accepted_tracks = static_cast<int>(accepted.size());
  s.mean_accepted_track_length = accepted.empty() ? 0.0 : total_length / accepted.size();
  return accepted;
}

}  // namespace crop4d::features
