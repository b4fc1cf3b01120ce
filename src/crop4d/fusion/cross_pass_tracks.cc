#include "crop4d/fusion/cross_pass_tracks.h"

#include <algorithm>
#include <numeric>

#include "crop4d/core/error.h"
#include "crop4d/features/union_find.h"

namespace crop4d::fusion {
namespace {

// Node keys: 21 bits each for the image and the feature, the pass above them.
constexpr int kFieldBits = 21;
constexpr std::int64_t kFieldLimit = std::int64_t{1} << kFieldBits;

// The group of a node for the consistent union-find: its image (of its pass).
std::uint64_t ImageGroup(const PassFeature& f) {
  return (static_cast<std::uint64_t>(f.pass) << 32) | static_cast<std::uint32_t>(f.image);
}

}  // namespace

int CrossPassTracks::Node(int pass, int image, int feature) {
  CROP4D_CHECK_MSG(
      pass >= 0 && image >= 0 && feature >= 0 && image < kFieldLimit && feature < kFieldLimit,
      "CrossPassTracks: a pass, image or feature index out of range");
  const std::uint64_t key = (static_cast<std::uint64_t>(pass) << (2 * kFieldBits)) |
                            (static_cast<std::uint64_t>(image) << kFieldBits) |
                            static_cast<std::uint64_t>(feature);
  auto [it, inserted] = node_ids_.emplace(key, static_cast<int>(nodes_.size()));
  if (inserted) nodes_.push_back({pass, image, feature});
  return it->second;
}

void CrossPassTracks::AddPassLandmark(int pass,
                                      const std::vector<features::Observation>& observations) {
  int first = -1;
  for (const features::Observation& o : observations) {
    const int id = Node(pass, o.image, o.feature);
    if (first < 0) {
      first = id;
      landmark_nodes_.push_back(id);
    } else {
      landmark_edges_.emplace_back(first, id);
    }
  }
}

void CrossPassTracks::AddCrossMatch(const PassFeature& a, const PassFeature& b, float distance,
                                    const std::vector<features::Observation>& track_a,
                                    const std::vector<features::Observation>& track_b) {
  Match match;
  match.distance = distance;
  match.pass_a = a.pass;
  match.pass_b = b.pass;
  const int na = Node(a.pass, a.image, a.feature);
  const int nb = Node(b.pass, b.image, b.feature);
  match.edges.emplace_back(na, nb);
  for (const features::Observation& o : track_a) {
    match.edges.emplace_back(na, Node(a.pass, o.image, o.feature));
  }
  for (const features::Observation& o : track_b) {
    match.edges.emplace_back(nb, Node(b.pass, o.image, o.feature));
  }
  matches_.push_back(std::move(match));
}

CrossPassTracks::Result CrossPassTracks::Join(const std::vector<bool>& use_given) const {
  int num_passes = 0;
  for (const PassFeature& n : nodes_) num_passes = std::max(num_passes, n.pass + 1);
  const std::vector<bool> use = use_given.empty() ? std::vector<bool>(num_passes, true) : use_given;
  CROP4D_CHECK_MSG(static_cast<int>(use.size()) >= num_passes,
                   "CrossPassTracks::Join: fewer `use` flags than passes");
  std::vector<std::uint64_t> groups(nodes_.size());
  for (std::size_t i = 0; i < nodes_.size(); ++i) groups[i] = ImageGroup(nodes_[i]);
  features::ConsistentUnionFind uf(std::move(groups));

  // The passes' own landmarks.
  std::vector<bool> in_graph(nodes_.size(), false);
  for (int id : landmark_nodes_) in_graph[id] = use[nodes_[id].pass];
  for (const auto& [a, b] : landmark_edges_) {
    if (!use[nodes_[a].pass]) continue;
    uf.Union(a, b);
    in_graph[a] = in_graph[b] = true;
  }
  // The cross matches between used passes, best first (ties in the order given).
  std::vector<std::size_t> order;
  for (std::size_t m = 0; m < matches_.size(); ++m) {
    if (use[matches_[m].pass_a] && use[matches_[m].pass_b]) order.push_back(m);
  }
  std::stable_sort(order.begin(), order.end(), [&](std::size_t x, std::size_t y) {
    return matches_[x].distance < matches_[y].distance;
  });
  Result result;
  for (std::size_t m : order) {
    const std::vector<std::pair<int, int>>& edges = matches_[m].edges;
    if (!uf.Union(edges.front().first, edges.front().second)) {
      ++result.num_conflicting_matches;
      continue;
    }
    for (const auto& [a, b] : edges) {
      if (uf.Union(a, b)) in_graph[a] = in_graph[b] = true;
    }
  }

  // The landmarks, numbered by their first node; a node whose only link was refused is alone
  // and no landmark.
  std::unordered_map<std::size_t, std::size_t> landmark_of_root;
  std::vector<std::vector<PassFeature>> landmarks;
  for (std::size_t i = 0; i < nodes_.size(); ++i) {
    if (!in_graph[i]) continue;
    auto [it, inserted] = landmark_of_root.emplace(uf.Find(i), landmarks.size());
    if (inserted) landmarks.emplace_back();
    landmarks[it->second].push_back(nodes_[i]);
  }
  for (std::vector<PassFeature>& landmark : landmarks) {
    if (landmark.size() < 2) continue;
    std::sort(landmark.begin(), landmark.end(), [](const PassFeature& a, const PassFeature& b) {
      return a.pass != b.pass ? a.pass < b.pass : a.image < b.image;
    });
    result.landmarks.push_back(std::move(landmark));
  }
  return result;
}

}  // namespace crop4d::fusion
