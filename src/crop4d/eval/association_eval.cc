#include "crop4d/eval/association_eval.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <set>
#include <tuple>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/eval/quantile.h"

namespace crop4d::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// One keypoint whose true point is needed: side 0 = a, 1 = b of match `match` of input `input`.
struct Query {
  int session_rank = 0;
  std::string session;
  Timestamp t = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  std::size_t slot = 0;  // index into the results
};

void CountUnknown(TruePointStatus status, MatchCounts* counts) {
  ++counts->unknown;
  switch (status) {
    case TruePointStatus::kNoSurface:
      ++counts->unknown_no_surface;
      break;
    case TruePointStatus::kDepthEdge:
      ++counts->unknown_depth_edge;
      break;
    default:
      ++counts->unknown_no_truth;
      break;
  }
}

}  // namespace

const char* PairTypeName(PairType type) {
  switch (type) {
    case PairType::kCrossRowSameDirection:
      return "cross_row_same_direction";
    case PairType::kCrossRowOppositeDirection:
      return "cross_row_opposite_direction";
    case PairType::kCrossSession:
      return "cross_session";
    case PairType::kCrossSessionAfterRain:
      return "cross_session_after_rain";
  }
  return "?";
}

const char* PairTypeLabel(PairType type) {
  switch (type) {
    case PairType::kCrossRowSameDirection:
      return "row same dir";
    case PairType::kCrossRowOppositeDirection:
      return "row opposite dir";
    case PairType::kCrossSession:
      return "session";
    case PairType::kCrossSessionAfterRain:
      return "session+rain";
  }
  return "?";
}

int SessionTimeline::IndexOf(const std::string& session) const {
  const auto it = std::find(sessions.begin(), sessions.end(), session);
  return it == sessions.end() ? -1 : static_cast<int>(it - sessions.begin());
}

bool SessionTimeline::RainBetween(const std::string& a, const std::string& b) const {
  int ia = IndexOf(a), ib = IndexOf(b);
  if (ia < 0 || ib < 0 || ia == ib) return false;
  if (ia > ib) std::swap(ia, ib);
  for (int k = ia + 1; k <= ib; ++k) {
    if (k < static_cast<int>(rain_before.size()) && rain_before[k]) return true;
  }
  return false;
}

PairType ClassifyPair(const association::PassRef& a, const PassLayout& layout_a,
                      const association::PassRef& b, const PassLayout& layout_b,
                      const SessionTimeline& timeline) {
  if (a.session == b.session) {
    return layout_a.direction == layout_b.direction ? PairType::kCrossRowSameDirection
                                                    : PairType::kCrossRowOppositeDirection;
  }
  return timeline.RainBetween(a.session, b.session) ? PairType::kCrossSessionAfterRain
                                                    : PairType::kCrossSession;
}

double MatchCounts::Precision() const {
  const std::int64_t known = correct + incorrect;
  return known > 0 ? static_cast<double>(correct) / static_cast<double>(known) : kNaN;
}

double MatchCounts::CoarsePrecision() const {
  const std::int64_t known = correct + incorrect;
  return known > 0 ? static_cast<double>(within_coarse) / static_cast<double>(known) : kNaN;
}

double MatchCounts::NearPrecision() const {
  return known_near > 0 ? static_cast<double>(correct_near) / static_cast<double>(known_near)
                        : kNaN;
}

void MatchCounts::Add(const MatchCounts& o) {
  matches += o.matches;
  correct += o.correct;
  incorrect += o.incorrect;
  unknown += o.unknown;
  unknown_no_truth += o.unknown_no_truth;
  unknown_no_surface += o.unknown_no_surface;
  unknown_depth_edge += o.unknown_depth_edge;
  within_coarse += o.within_coarse;
  known_near += o.known_near;
  correct_near += o.correct_near;
}

MatchCounts AssociationEval::GroupCounts(PairType type, const std::string& method) const {
  for (const AssociationGroupEval& g : groups) {
    if (g.type == type && g.method == method) return g.counts;
  }
  return {};
}

std::map<std::string, int> RankSessions(const std::vector<AssociationInput>& inputs,
                                        const SessionTimeline& timeline) {
  std::map<std::string, int> ranks;
  std::set<std::string> extra;  // sessions outside the timeline: after it, by name
  for (const AssociationInput& input : inputs) {
    if (!input.error.empty()) continue;
    for (const association::PassRef* ref : {&input.association.a, &input.association.b}) {
      const int index = timeline.IndexOf(ref->session);
      if (index >= 0) {
        ranks[ref->session] = index;
      } else {
        extra.insert(ref->session);
      }
    }
  }
  int next = static_cast<int>(timeline.sessions.size());
  for (const std::string& session : extra) ranks[session] = next++;
  return ranks;
}

OptionCheck AssociationEvalOptions::Check() const {
  OptionChecker c;
  c.Greater("max_distance_m", max_distance_m, 0.0)
      .Finite("max_distance_m", max_distance_m)
      .Greater("coarse_distance_m", coarse_distance_m, 0.0)
      .Finite("coarse_distance_m", coarse_distance_m)
      .Greater("near_depth_m", near_depth_m, 0.0)
      .Nested("true_point", true_point.Check());
  return c.Result();
}

AssociationEval EvaluateAssociations(const std::vector<AssociationInput>& inputs,
                                     const SessionTimeline& timeline, TruthGeometry& truth,
                                     const AssociationEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateAssociations");
  AssociationEval eval;
  eval.options = options;

  const std::map<std::string, int> ranks = RankSessions(inputs, timeline);
  const auto rank_of = [&](const std::string& session) { return ranks.at(session); };

  // Every keypoint of every match, grouped by image.
  std::vector<std::size_t> first_slot(inputs.size(), 0);
  std::vector<Query> queries;
  std::size_t slots = 0;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    first_slot[i] = slots;
    if (!inputs[i].error.empty()) continue;
    const association::PassAssociation& pa = inputs[i].association;
    const int rank_a = rank_of(pa.a.session), rank_b = rank_of(pa.b.session);
    for (const association::CrossMatch& m : pa.matches) {
      queries.push_back({rank_a, pa.a.session, m.t_a, Eigen::Vector2d(m.xa, m.ya), slots++});
      queries.push_back({rank_b, pa.b.session, m.t_b, Eigen::Vector2d(m.xb, m.yb), slots++});
    }
  }
  std::sort(queries.begin(), queries.end(), [](const Query& x, const Query& y) {
    return std::tie(x.session_rank, x.t, x.slot) < std::tie(y.session_rank, y.t, y.slot);
  });
  std::int64_t images = 0;
  for (std::size_t k = 0; k < queries.size(); ++k) {
    if (k == 0 || queries[k].session_rank != queries[k - 1].session_rank ||
        queries[k].t != queries[k - 1].t) {
      ++images;
    }
  }
  eval.images = images;

  std::vector<TruePointResult> results(slots);
  {
    Progress progress("eval true points", static_cast<std::uint64_t>(images), "img");
    std::size_t k = 0;
    while (k < queries.size()) {
      std::size_t end = k;
      while (end < queries.size() && queries[end].session_rank == queries[k].session_rank &&
             queries[end].t == queries[k].t) {
        ++end;
      }
      geometry::PinholeRadTan camera;
      geometry::Rigid3 world_from_camera;
      DepthImage depth;
      const bool known =
          truth.TrueCamera(queries[k].session, queries[k].t, &camera, &world_from_camera) &&
          truth.Depth(queries[k].session, queries[k].t, &depth);
      for (std::size_t q = k; q < end; ++q) {
        if (known) {
          results[queries[q].slot] = TruePointInImage(depth, camera, world_from_camera,
                                                      queries[q].pixel, options.true_point);
        }  // else: the default result, kNoTruth
      }
      progress.Add();
      k = end;
    }
    progress.Finish();
  }

  // Per file, then pooled per type × method and per method.
  std::map<std::pair<int, std::string>, AssociationGroupEval> groups;
  std::map<std::string, AssociationGroupEval> methods;
  for (std::size_t i = 0; i < inputs.size(); ++i) {
    const AssociationInput& input = inputs[i];
    AssociationFileEval f;
    f.file = input.file;
    f.method = input.association.method;
    f.a = input.association.a;
    f.b = input.association.b;
    f.layout_a = input.layout_a;
    f.layout_b = input.layout_b;
    f.error = input.error;
    f.median_distance_m = f.p90_distance_m = kNaN;
    if (!f.ok()) {
      ++eval.num_failed;
      eval.files.push_back(std::move(f));
      continue;
    }
    f.type = ClassifyPair(f.a, f.layout_a, f.b, f.layout_b, timeline);
    std::vector<double> distances;
    std::size_t slot = first_slot[i];
    for (std::size_t m = 0; m < input.association.matches.size(); ++m, slot += 2) {
      ++f.counts.matches;
      const TruePointResult& ra = results[slot];
      const TruePointResult& rb = results[slot + 1];
      if (!ra.ok() || !rb.ok()) {
        // The worse of the two reasons: no truth, then no surface, then a depth edge.
        CountUnknown(!ra.ok() && (rb.ok() || ra.status < rb.status) ? ra.status : rb.status,
                     &f.counts);
        continue;
      }
      const double d = (ra.point_world - rb.point_world).norm();
      distances.push_back(d);
      if (d <= options.coarse_distance_m) ++f.counts.within_coarse;
      const bool near = ra.depth_m <= options.near_depth_m;
      if (near) ++f.counts.known_near;
      if (d <= options.max_distance_m) {
        ++f.counts.correct;
        if (near) ++f.counts.correct_near;
      } else {
        ++f.counts.incorrect;
      }
    }
    f.median_distance_m = Quantile(&distances, 0.5);
    f.p90_distance_m = Quantile(&distances, 0.9);

    AssociationGroupEval& g = groups[{static_cast<int>(f.type), f.method}];
    g.type = f.type;
    g.method = f.method;
    ++g.files;
    g.counts.Add(f.counts);
    AssociationGroupEval& all = methods[f.method];
    all.method = f.method;
    ++all.files;
    all.counts.Add(f.counts);
    eval.files.push_back(std::move(f));
  }
  for (auto& [key, group] : groups) eval.groups.push_back(group);
  for (auto& [key, group] : methods) eval.methods.push_back(group);
  eval.depth = truth.stats();
  return eval;
}

}  // namespace crop4d::eval
