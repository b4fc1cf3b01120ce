#include "crop4d/eval/association_ceiling.h"

#include <fmt/format.h>

#include <algorithm>
#include <map>
#include <numeric>
#include <set>
#include <tuple>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"

namespace crop4d::eval {
namespace {

using association::PassRef;

std::string Label(const PassRef& ref) { return ref.session + "/" + ref.pass; }

// One pair of passes: the image pairs matched by any method, and its type.
struct PassPair {
  PassRef a, b;
  PairType type = PairType::kCrossRowSameDirection;
  std::set<std::pair<int, int>> image_pairs;
};

// The true points of the keypoints of the images of one pass that the ceiling needs.
struct PassTruth {
  std::string error;  // non-empty: the keypoints could not be loaded
  std::map<int, std::vector<KeypointTruth>> images;
};

PassTruth ComputePassTruth(const PassRef& ref, const std::set<int>& images, TruthGeometry& truth,
                           const PassKeypointsLoader& load_keypoints,
                           const AssociationEvalOptions& options, Progress* progress) {
  PassTruth out;
  PassKeypoints keypoints;
  try {
    keypoints = load_keypoints(ref);
  } catch (const InputError& e) {
    out.error = e.what();
    return out;
  }
  if (keypoints.pixels.size() != keypoints.times.size()) {
    out.error = fmt::format("{}: {} keypoint sets for {} images", Label(ref),
                            keypoints.pixels.size(), keypoints.times.size());
    return out;
  }
  for (const int image : images) {  // ascending index = time order
    if (image < 0 || static_cast<std::size_t>(image) >= keypoints.times.size()) {
      out.error = fmt::format("{}: matched image {} not among its {} images", Label(ref), image,
                              keypoints.times.size());
      return out;
    }
    std::vector<KeypointTruth>& points = out.images[image];
    points.resize(keypoints.pixels[image].size());
    geometry::PinholeRadTan camera;
    geometry::Rigid3 world_from_camera;
    DepthImage depth;
    const Timestamp t = keypoints.times[image];
    if (truth.TrueCamera(ref.session, t, &camera, &world_from_camera) &&
        truth.Depth(ref.session, t, &depth)) {
      for (std::size_t i = 0; i < points.size(); ++i) {
        const TruePointResult r = TruePointInImage(depth, camera, world_from_camera,
                                                   keypoints.pixels[image][i], options.true_point);
        points[i] = {r.ok(), r.point_world, r.depth_m};
      }
    }  // else: no truth, every keypoint unknown
    progress->Add();
  }
  return out;
}

}  // namespace

void CeilingCounts::Add(const CeilingCounts& o) {
  image_pairs += o.image_pairs;
  keypoints += o.keypoints;
  partners += o.partners;
  partners_near += o.partners_near;
  chance_near += o.chance_near;
}

void CountPartners(const std::vector<KeypointTruth>& a, const std::vector<KeypointTruth>& b,
                   const Eigen::Vector3d& shift_b, bool chance,
                   const AssociationEvalOptions& options, CeilingCounts* counts) {
  // Image b's known points sorted by x: each keypoint of a looks only at those within the match
  // distance in x (a few of the ~1000), instead of all of them.
  std::vector<Eigen::Vector3d> sorted;
  sorted.reserve(b.size());
  for (const KeypointTruth& p : b) {
    if (p.ok) sorted.push_back(p.point + shift_b);
  }
  std::sort(sorted.begin(), sorted.end(),
            [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) { return x.x() < y.x(); });
  const double d = options.max_distance_m;
  for (const KeypointTruth& p : a) {
    if (!p.ok) continue;
    if (!chance) ++counts->keypoints;
    auto it = std::lower_bound(sorted.begin(), sorted.end(), p.point.x() - d,
                               [](const Eigen::Vector3d& q, double x) { return q.x() < x; });
    bool found = false;
    for (; it != sorted.end() && it->x() <= p.point.x() + d; ++it) {
      if ((*it - p.point).norm() <= d) {
        found = true;
        break;
      }
    }
    if (!found) continue;
    const bool near = p.depth_m <= options.near_depth_m;
    if (chance) {
      if (near) ++counts->chance_near;
    } else {
      ++counts->partners;
      if (near) ++counts->partners_near;
    }
  }
}

AssociationCeiling EvaluateCeiling(const std::vector<AssociationInput>& inputs,
                                   const SessionTimeline& timeline, TruthGeometry& truth,
                                   const PassKeypointsLoader& load_keypoints,
                                   const AssociationEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateCeiling");
  AssociationCeiling ceiling;
  const std::map<std::string, int> ranks = RankSessions(inputs, timeline);

  // The image pairs of each pair of passes, over every method's file.
  std::map<std::pair<PassRef, PassRef>, PassPair> by_passes;
  for (const AssociationInput& input : inputs) {
    if (!input.error.empty()) continue;
    const association::PassAssociation& file = input.association;
    PassPair& pair = by_passes[{file.a, file.b}];
    pair.a = file.a;
    pair.b = file.b;
    pair.type = ClassifyPair(file.a, input.layout_a, file.b, input.layout_b, timeline);
    for (const association::CrossMatch& m : file.matches) {
      pair.image_pairs.emplace(m.image_a, m.image_b);
    }
  }
  // Session after session: by the later session of the pair, then the earlier one.
  std::vector<PassPair> pairs;
  for (auto& [key, pair] : by_passes) pairs.push_back(std::move(pair));
  const auto order = [&](const PassPair& p) {
    const int ra = ranks.at(p.a.session), rb = ranks.at(p.b.session);
    return std::make_tuple(std::max(ra, rb), std::min(ra, rb), p.a, p.b);
  };
  std::stable_sort(pairs.begin(), pairs.end(),
                   [&](const PassPair& x, const PassPair& y) { return order(x) < order(y); });

  // The images each pass needs, and the last pair that needs it (its truth is freed after it).
  std::map<PassRef, std::set<int>> needed;
  std::map<PassRef, std::size_t> last_use;
  std::uint64_t num_images = 0;
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    for (const auto& [ia, ib] : pairs[k].image_pairs) {
      needed[pairs[k].a].insert(ia);
      needed[pairs[k].b].insert(ib);
    }
    last_use[pairs[k].a] = last_use[pairs[k].b] = k;
  }
  for (const auto& [ref, images] : needed) num_images += images.size();

  Progress progress("eval association ceiling", num_images, "img");
  std::map<PassRef, PassTruth> loaded;
  std::map<int, CeilingGroup> groups;
  const Eigen::Vector3d chance_shift(ceiling.chance_shift_m, 0.0, 0.0);
  for (std::size_t k = 0; k < pairs.size(); ++k) {
    const PassPair& pair = pairs[k];
    // The earlier session's pass first, so that true geometry is asked for session by session.
    const bool a_first = ranks.at(pair.a.session) <= ranks.at(pair.b.session);
    for (const PassRef* ref : {a_first ? &pair.a : &pair.b, a_first ? &pair.b : &pair.a}) {
      if (loaded.count(*ref) == 0) {
        loaded.emplace(
            *ref, ComputePassTruth(*ref, needed[*ref], truth, load_keypoints, options, &progress));
      }
    }
    const PassTruth& ta = loaded.at(pair.a);
    const PassTruth& tb = loaded.at(pair.b);
    if (!ta.error.empty() || !tb.error.empty()) {
      ceiling.errors.push_back(fmt::format("{} ~ {}: {}", Label(pair.a), Label(pair.b),
                                           ta.error.empty() ? tb.error : ta.error));
    } else {
      CeilingGroup& group = groups[static_cast<int>(pair.type)];
      group.type = pair.type;
      ++group.pass_pairs;
      for (const auto& [ia, ib] : pair.image_pairs) {
        const std::vector<KeypointTruth>& pa = ta.images.at(ia);
        const std::vector<KeypointTruth>& pb = tb.images.at(ib);
        CountPartners(pa, pb, Eigen::Vector3d::Zero(), false, options, &group.counts);
        CountPartners(pa, pb, chance_shift, true, options, &group.counts);
        ++group.counts.image_pairs;
      }
    }
    for (const PassRef* ref : {&pair.a, &pair.b}) {
      if (last_use.at(*ref) == k) loaded.erase(*ref);
    }
  }
  progress.Finish();
  for (auto& [type, group] : groups) ceiling.groups.push_back(group);
  return ceiling;
}

}  // namespace crop4d::eval
