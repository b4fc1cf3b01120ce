// Association ceiling: how many correct keypoint pairs the image pairs of `crop4d associate` hold
// at all, against the correct matches that the robust and the naive methods found in them
// (bench/RESULTS.md, "Association and 4D fusion"). Every method that matches the images'
// keypoints — both of ours — can find at most this many correct matches.
//
// For every pair of passes with association files under WS/associations/{robust,naive}/, and for
// every image pair that either method matched, each keypoint of both images gets its true 3D
// point (eval/truth_geometry.h: the simulator's depth at the true pose, as `crop4d eval`). The
// ceiling counts the keypoints of image 1 that have a keypoint of image 2 within 2 cm: every
// correct match uses one of them, once, so no method that keeps one match per keypoint of image
// 1 (both of ours) can find more; "near" counts those that see a point at most 5 m deep. Two
// keypoints can also lie within 2 cm by chance, without seeing the same texture (after rain the
// soil is new): the same count with image 2's true points shifted by 10 cm east estimates that
// share (the ground is nearly flat at that scale, so the shifted points still lie on it).
//
// Usage: association_ceiling WS FIELD [DEPTH_CACHE]   (DEPTH_CACHE as `crop4d eval --depth-cache`)

#include <array>
#include <cstdio>
#include <filesystem>
#include <map>
#include <set>
#include <string>
#include <vector>

#include "crop4d/association/association_file.h"
#include "crop4d/eval/association_eval.h"
#include "crop4d/eval/truth_geometry.h"
#include "crop4d/workspace/pass_data.h"

namespace {

namespace fs = std::filesystem;
using namespace crop4d;

// The match distance (2 cm) and the near depth (5 m) of `crop4d eval`.
const eval::AssociationEvalOptions kOptions;

struct Counts {
  long long image_pairs = 0;
  long long ceiling = 0, ceiling_near = 0;
  long long chance_near = 0;  // the same with image 2's points shifted by 10 cm
  std::map<std::string, std::array<long long, 2>> correct;  // method → all, near
};

struct KeypointTruth {
  bool ok = false;
  Eigen::Vector3d point = Eigen::Vector3d::Zero();
  double depth = 0;
};

std::vector<KeypointTruth> TruePoints(eval::TruthGeometry& truth, const std::string& session,
                                      Timestamp t, const features::FeatureSet& features) {
  std::vector<KeypointTruth> out(features.size());
  geometry::PinholeRadTan camera;
  geometry::Rigid3 world_from_camera;
  eval::DepthImage depth;
  if (!truth.TrueCamera(session, t, &camera, &world_from_camera) ||
      !truth.Depth(session, t, &depth)) {
    return out;
  }
  for (std::size_t i = 0; i < features.size(); ++i) {
    const eval::TruePointResult r = eval::TruePointInImage(depth, camera, world_from_camera,
                                                           features.Point(i), kOptions.true_point);
    out[i] = {r.ok(), r.point_world, r.depth_m};
  }
  return out;
}

const slam::RowPass& FindPass(const std::vector<slam::RowPass>& passes, const std::string& id) {
  for (const slam::RowPass& p : passes) {
    if (p.id == id) return p;
  }
  throw std::runtime_error("pass " + id + " not in passes.csv");
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 3) {
    std::fprintf(stderr, "usage: %s WS FIELD [DEPTH_CACHE]\n", argv[0]);
    return 2;
  }
  const std::string workspace = argv[1], field = argv[2];
  eval::SimulatedFieldTruthOptions truth_options;
  if (argc > 3) truth_options.depth_cache_dir = argv[3];
  eval::SimulatedFieldTruth truth(field, truth_options);
  eval::SessionTimeline timeline;
  timeline.sessions = truth.sessions();
  timeline.rain_before = truth.rain_before();

  // The association files of each pair of passes, by method.
  std::map<std::pair<association::PassRef, association::PassRef>,
           std::map<std::string, association::PassAssociation>>
      pairs;
  for (const char* method : {"robust", "naive"}) {
    const fs::path dir = fs::path(workspace) / "associations" / method;
    if (!fs::is_directory(dir)) continue;
    for (const auto& entry : fs::directory_iterator(dir)) {
      if (entry.path().extension() != ".bin") continue;
      association::PassAssociation a;
      std::string detail;
      if (association::ReadAssociationFile(entry.path().string(), &a, &detail) !=
          association::AssociationFileStatus::kOk) {
        std::fprintf(stderr, "%s: unreadable (%s)\n", entry.path().c_str(), detail.c_str());
        return 1;
      }
      pairs[{a.a, a.b}][method] = std::move(a);
    }
  }

  std::map<eval::PairType, Counts> by_type;
  for (const auto& [refs, files] : pairs) {
    const auto& [ref_a, ref_b] = refs;
    const slam::RowPass pass_a =
        FindPass(workspace::ReadPassList(workspace, ref_a.session), ref_a.pass);
    const slam::RowPass pass_b =
        FindPass(workspace::ReadPassList(workspace, ref_b.session), ref_b.pass);
    const workspace::PassData a =
        workspace::LoadPassData(workspace, ref_a.session, pass_a, {.features = true});
    const workspace::PassData b =
        workspace::LoadPassData(workspace, ref_b.session, pass_b, {.features = true});
    const eval::PairType type = eval::ClassifyPair(ref_a, {pass_a.row, pass_a.direction}, ref_b,
                                                   {pass_b.row, pass_b.direction}, timeline);
    Counts& counts = by_type[type];
    std::set<std::pair<int, int>> image_pairs;
    for (const auto& [method, file] : files) {
      for (const association::CrossMatch& m : file.matches) {
        image_pairs.emplace(m.image_a, m.image_b);
      }
    }
    for (const auto& [ia, ib] : image_pairs) {
      const std::vector<KeypointTruth> ta =
          TruePoints(truth, a.session, a.times[ia], a.features[ia]);
      const std::vector<KeypointTruth> tb =
          TruePoints(truth, b.session, b.times[ib], b.features[ib]);
      // The keypoints of image 1 with a partner in image 2 within the match distance: each can
      // be the correct side of one match at most, so no one-to-one matcher finds more.
      const auto with_partner = [&](const Eigen::Vector3d& shift, long long* all, long long* near) {
        for (std::size_t i = 0; i < ta.size(); ++i) {
          if (!ta[i].ok) continue;
          for (std::size_t j = 0; j < tb.size(); ++j) {
            if (tb[j].ok && (ta[i].point - tb[j].point - shift).norm() <= kOptions.max_distance_m) {
              if (all != nullptr) ++*all;
              if (ta[i].depth <= kOptions.near_depth_m) ++*near;
              break;
            }
          }
        }
      };
      with_partner(Eigen::Vector3d::Zero(), &counts.ceiling, &counts.ceiling_near);
      with_partner(Eigen::Vector3d(0.1, 0, 0), nullptr, &counts.chance_near);
      ++counts.image_pairs;
      for (const auto& [method, file] : files) {
        std::array<long long, 2>& c = counts.correct[method];
        for (const association::CrossMatch& m : file.matches) {
          if (m.image_a != ia || m.image_b != ib) continue;
          const KeypointTruth& pa = ta[m.feature_a];
          const KeypointTruth& pb = tb[m.feature_b];
          if (!pa.ok || !pb.ok || (pa.point - pb.point).norm() > kOptions.max_distance_m) continue;
          ++c[0];
          if (pa.depth <= kOptions.near_depth_m) ++c[1];
        }
      }
    }
    std::fprintf(stderr, "%s/%s ~ %s/%s: %zu image pairs\n", ref_a.session.c_str(),
                 ref_a.pass.c_str(), ref_b.session.c_str(), ref_b.pass.c_str(), image_pairs.size());
  }

  std::printf(
      "| pair type | image pairs | keypoints with a partner within 2 cm (within 5 m) | by chance "
      "within 5 m "
      "| naive correct (within 5 m) | robust correct (within 5 m) | naive, robust share of the "
      "ceiling within 5 m |\n|---|---|---|---|---|---|---|\n");
  for (const auto& [type, c] : by_type) {
    const auto get = [&](const char* method) {
      const auto it = c.correct.find(method);
      return it == c.correct.end() ? std::array<long long, 2>{0, 0} : it->second;
    };
    const std::array<long long, 2> naive = get("naive"), robust = get("robust");
    const auto share = [&](long long n) {
      return c.ceiling_near > 0 ? 100.0 * static_cast<double>(n) / c.ceiling_near : 0.0;
    };
    std::printf(
        "| %s | %lld | %lld (%lld) | %lld | %lld (%lld) | %lld (%lld) | %.1f %%, %.1f %% |\n",
        eval::PairTypeName(type), c.image_pairs, c.ceiling, c.ceiling_near, c.chance_near, naive[0],
        naive[1], robust[0], robust[1], share(naive[1]), share(robust[1]));
  }
  return 0;
}
