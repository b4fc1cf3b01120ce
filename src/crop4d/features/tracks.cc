#include "crop4d/features/tracks.h"

#include <algorithm>

#include "crop4d/core/error.h"
#include "crop4d/features/union_find.h"

namespace crop4d::features {

OptionCheck TrackBuilder::Options::Check() const {
  OptionChecker c;
  c.AtLeast("min_track_length", min_track_length, 2);
  return c.Result();
}

TrackBuilder::TrackBuilder(Options options) : options_(std::move(options)) {
  CROP4D_CHECK_OPTIONS(options_, "TrackBuilder::Options");
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

namespace {

// The features of all images as nodes: features of image i occupy [offset[i], offset[i + 1]).
struct FeatureNodes {
  std::vector<std::size_t> offset;
  std::vector<Observation> observation_of;  // by node
  const std::vector<int>* num_features = nullptr;

  explicit FeatureNodes(const std::vector<int>& counts) : num_features(&counts) {
    const std::size_t num_images = counts.size();
    offset.assign(num_images + 1, 0);
    for (std::size_t i = 0; i < num_images; ++i) {
      CROP4D_CHECK(counts[i] >= 0);
      offset[i + 1] = offset[i] + static_cast<std::size_t>(counts[i]);
    }
    observation_of.resize(offset.back());
    for (std::size_t i = 0; i < num_images; ++i) {
      for (int f = 0; f < counts[i]; ++f) {
        observation_of[offset[i] + f] = {static_cast<std::int32_t>(i), f};
      }
    }
  }
  std::size_t size() const { return offset.back(); }
  std::size_t NodeOf(const Observation& o) const {
    CROP4D_CHECK_MSG(o.image >= 0 && static_cast<std::size_t>(o.image) < num_features->size() &&
                         o.feature >= 0 && o.feature < (*num_features)[o.image],
                     "track edge outside the feature counts");
    return offset[o.image] + static_cast<std::size_t>(o.feature);
  }
};

// The connected components of the matches: numbered by their first node, their nodes in
// increasing id, i.e. sorted by (image, feature).
struct Components {
  std::vector<int> of_root;  // component of a union-find root, −1: untouched node
  std::vector<std::vector<std::size_t>> nodes;
};

Components ConnectedComponents(const FeatureNodes& nodes, const std::vector<TrackEdge>& edges,
                               UnionFind* components) {
  std::vector<char> touched(nodes.size(), 0);
  for (const TrackEdge& e : edges) {
    const std::size_t a = nodes.NodeOf(e.a), b = nodes.NodeOf(e.b);
    components->Union(a, b);
    touched[a] = touched[b] = 1;
  }
  Components out;
  out.of_root.assign(nodes.size(), -1);
  for (std::size_t node = 0; node < nodes.size(); ++node) {
    if (!touched[node]) continue;
    const std::size_t root = components->Find(node);
    if (out.of_root[root] < 0) {
      out.of_root[root] = static_cast<int>(out.nodes.size());
      out.nodes.emplace_back();
    }
    out.nodes[out.of_root[root]].push_back(node);
  }
  return out;
}

// Splits each inconsistent component (two features of one image) into consistent pieces: its
// edges are added best (smallest distance) first, ties in the input order, each only when it
// joins no two features of one image. Pieces of two or more observations become tracks.
void SplitInconsistent(const FeatureNodes& nodes, const std::vector<TrackEdge>& edges,
                       const Components& components, UnionFind* union_find,
                       const std::vector<int>& inconsistent, std::vector<Track>* tracks,
                       TrackBuilder::Summary* s) {
  std::vector<int> slot_of_component(components.nodes.size(), -1);
  for (std::size_t k = 0; k < inconsistent.size(); ++k) {
    slot_of_component[inconsistent[k]] = static_cast<int>(k);
  }
  std::vector<std::vector<int>> component_edges(inconsistent.size());
  for (std::size_t e = 0; e < edges.size(); ++e) {
    const int c = components.of_root[union_find->Find(nodes.NodeOf(edges[e].a))];
    if (slot_of_component[c] >= 0) {
      component_edges[slot_of_component[c]].push_back(static_cast<int>(e));
    }
  }
  std::vector<std::uint64_t> image_of(nodes.size());
  for (std::size_t node = 0; node < nodes.size(); ++node) {
    image_of[node] = static_cast<std::uint64_t>(nodes.observation_of[node].image);
  }
  ConsistentUnionFind split(std::move(image_of));
  std::vector<int> piece_of_root(nodes.size(), -1);  // roots are unique to a component
  for (std::size_t k = 0; k < inconsistent.size(); ++k) {
    std::vector<int>& order = component_edges[k];
    std::stable_sort(order.begin(), order.end(),
                     [&](int x, int y) { return edges[x].distance < edges[y].distance; });
    for (int e : order) split.Union(nodes.NodeOf(edges[e].a), nodes.NodeOf(edges[e].b));
    // The pieces, numbered by their first node.
    std::vector<Track> pieces;
    for (std::size_t node : components.nodes[inconsistent[k]]) {
      const std::size_t root = split.Find(node);
      if (piece_of_root[root] < 0) {
        piece_of_root[root] = static_cast<int>(pieces.size());
        pieces.emplace_back();
      }
      pieces[piece_of_root[root]].observations.push_back(nodes.observation_of[node]);
    }
    for (Track& piece : pieces) {
      if (piece.size() < 2) {
        ++s->num_dropped_observations;
        continue;
      }
      ++s->num_tracks_from_splits;
      tracks->push_back(std::move(piece));
    }
  }
}

}  // namespace

std::vector<Track> TrackBuilder::Build(const std::vector<int>& num_features,
                                       const std::vector<TrackEdge>& edges,
                                       Summary* summary) const {
  Summary local;
  Summary& s = summary != nullptr ? *summary : local;
  s = Summary();
  s.num_edges = static_cast<int>(edges.size());
  const FeatureNodes nodes(num_features);

  // 1. Plain union-find over every match; 2. its components.
  UnionFind union_find(nodes.size());
  const Components components = ConnectedComponents(nodes, edges, &union_find);
  s.num_components = static_cast<int>(components.nodes.size());

  // The consistent components (no two features of one image) are tracks.
  std::vector<Track> tracks;
  std::vector<int> inconsistent;  // component ids
  for (std::size_t c = 0; c < components.nodes.size(); ++c) {
    const std::vector<std::size_t>& component = components.nodes[c];
    bool consistent = true;
    for (std::size_t k = 1; k < component.size() && consistent; ++k) {
      consistent =
          nodes.observation_of[component[k]].image != nodes.observation_of[component[k - 1]].image;
    }
    if (!consistent) {
      inconsistent.push_back(static_cast<int>(c));
      continue;
    }
    Track track;
    track.observations.reserve(component.size());
    for (std::size_t node : component) track.observations.push_back(nodes.observation_of[node]);
    tracks.push_back(std::move(track));
  }
  s.num_inconsistent_components = static_cast<int>(inconsistent.size());

  // 3. Inconsistent components: dropped or split.
  if (!inconsistent.empty()) {
    if (options_.conflict_policy == ConflictPolicy::kDrop) {
      for (int c : inconsistent) {
        s.num_dropped_observations += static_cast<int>(components.nodes[c].size());
      }
    } else {
      SplitInconsistent(nodes, edges, components, &union_find, inconsistent, &tracks, &s);
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
