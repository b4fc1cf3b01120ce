#include "crop4d/pipeline/associate_stage.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <filesystem>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <unordered_map>

#include "crop4d/association/prealignment.h"
#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/task_arena.h"
#include "crop4d/core/version.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/associate_pass.h"
#include "crop4d/pipeline/slam_stage.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_data.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {
namespace {

using associate::LoadPass;
using associate::PassContext;
using associate::PreAlign;

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// Changes whenever the stage's outputs for the same inputs change.
constexpr int kAssociateStageRevision = 5;

// The fingerprint of a pair's inputs: the stage revision, the options and the two passes'
// row-SLAM fingerprints.
std::string PairFingerprint(const std::string& method, const AssociateStageOptions& options,
                            const workspace::PassData& a, const workspace::PassData& b) {
  Fnv1aHasher hasher;
  hasher.Add(kAssociateStageRevision);
  hasher.AddString(kVersion);
  hasher.AddString(AssociateOptionsJson(options, method).dump());
  hasher.AddString(a.label() + " " + a.fingerprint);
  hasher.AddString(b.label() + " " + b.fingerprint);
  return std::to_string(hasher.hash());
}

// The report of a pair whose outputs are up to date (read from its summary), or nullopt.
std::optional<PassPairReport> UpToDateReport(const PassPair& pair, const std::string& method,
                                             const std::string& fingerprint,
                                             const fs::path& out_dir) {
  const fs::path bin = out_dir / association::AssociationFileName(pair.a, pair.b);
  const fs::path summary_path = workspace::AssociationSummaryPath(bin);
  if (!fs::exists(bin) || !fs::exists(summary_path)) return std::nullopt;
  workspace::AssociationSummary summary;
  try {
    summary = workspace::ReadAssociationSummary(summary_path.string());
  } catch (const InputError& e) {
    spdlog::debug("{}: associated again: {}", bin.string(), e.what());
    return std::nullopt;
  }
  if (summary.fingerprint != fingerprint) return std::nullopt;
  std::string why;
  if (!workspace::OutputsIntact(out_dir, summary.json, &why)) {
    spdlog::debug("{}: associated again: {}", bin.string(), why);
    return std::nullopt;
  }
  PassPairReport report;
  static_cast<workspace::AssociationCounts&>(report) = summary;
  report.pair = pair;
  report.method = method;
  report.skipped = true;
  return report;
}

// The matches of every image pair as cross matches of the pass pair (association_file.h), and
// their counts in `report`.
association::PassAssociation CollectCrossMatches(
    const PassPair& pair, const std::string& method, const PassContext& a, const PassContext& b,
    const std::vector<association::ImagePair>& image_pairs,
    const std::vector<association::AssociationResult>& results,
    const std::vector<std::int64_t>& surface_counts, PassPairReport* report) {
  association::PassAssociation assoc;
  assoc.a = pair.a;
  assoc.b = pair.b;
  assoc.method = method;
  for (std::size_t k = 0; k < image_pairs.size(); ++k) {
    const int ia = image_pairs[k].image_a, ib = image_pairs[k].image_b;
    const association::AssociationStats& s = results[k].stats;
    report->landmarks += s.num_landmarks;
    report->projected += s.num_projected;
    report->surface_points += surface_counts[k];
    report->candidates += s.num_candidates;
    report->warped += s.num_warped;
    report->upright_b += s.num_upright_b;
    report->putative += s.num_putative;
    for (const association::LandmarkMatch& m : results[k].matches) {
      association::CrossMatch c;
      c.image_a = ia;
      c.feature_a = m.feature_a;
      c.image_b = ib;
      c.feature_b = m.feature_b;
      c.t_a = a.data.times[ia];
      c.t_b = b.data.times[ib];
      const features::Keypoint& ka = a.data.features[ia].keypoints[m.feature_a];
      const features::Keypoint& kb = b.data.features[ib].keypoints[m.feature_b];
      c.xa = ka.x;
      c.ya = ka.y;
      c.xb = kb.x;
      c.yb = kb.y;
      c.distance = m.distance;
      c.landmark_a = m.landmark;
      assoc.matches.push_back(c);
    }
  }
  return assoc;
}

// The pair's summary (WS/associations/<method>/<pair>.json, before its outputs are recorded).
json PairSummaryJson(const PassPair& pair, const std::string& method, const PassPairReport& report,
                     const json& options_json, const std::string& fingerprint) {
  return {{"a", {{"session", pair.a.session}, {"pass", pair.a.pass}}},
          {"b", {{"session", pair.b.session}, {"pass", pair.b.pass}}},
          {"type", ToString(pair.type)},
          {"method", method},
          {"image_pairs", report.image_pairs},
          {"landmarks", report.landmarks},
          {"surface_points", report.surface_points},
          {"projected", report.projected},
          {"candidates", report.candidates},
          {"warped", report.warped},
          {"upright_b", report.upright_b},
          {"putative", report.putative},
          {"matches", report.matches},
          {"prealigned", report.prealigned},
          {"alignment_inliers", report.alignment_inliers},
          {"alignment_shift_m", report.alignment_shift_m},
          {"seconds", report.seconds},
          {"seconds_per_image_pair",
           report.image_pairs > 0 ? report.seconds / report.image_pairs : 0.0},
          {"options", options_json},
          {"fingerprint", fingerprint}};
}

// Pass b's poses in pass a's frame, changed only by the pre-alignment where it runs (its
// outcome in `report`), and the matcher's position sigma for the pair (`robust`): widened for
// imprecise passes of one session, narrowed after a pre-alignment.
std::vector<geometry::Rigid3> PosesOfBInA(const PassPair& pair, const std::string& method,
                                          const PassContext& a, const PassContext& b,
                                          const AssociateStageOptions& options,
                                          association::RobustMatcher::Options* robust,
                                          PassPairReport* report) {
  std::vector<geometry::Rigid3> poses_b = b.data.poses;
  const bool imprecise = !(a.precise && b.precise);
  if (method == "robust" && imprecise && pair.a.session == pair.b.session &&
      options.prealign != "always") {
    robust->sigma_position_m =
        std::max(robust->sigma_position_m, options.imprecise_sigma_position_m);
  }
  if (method == "robust" &&
      (options.prealign == "always" ||
       (options.prealign == "auto" && imprecise && pair.a.session != pair.b.session))) {
    const fusion::PassAlignment alignment = PreAlign(a, b, options);
    if (alignment.ok) {
      const geometry::Rigid3 a_from_b = alignment.b_from_a.Inverse();
      for (geometry::Rigid3& pose : poses_b) {
        report->alignment_shift_m = std::max(
            report->alignment_shift_m, (a_from_b * pose.translation() - pose.translation()).norm());
        pose = a_from_b * pose;
      }
      report->prealigned = true;
      report->alignment_inliers = alignment.num_inliers;
      robust->sigma_position_m = options.prealigned_sigma_position_m;
    } else {
      spdlog::warn(
          "{} <-> {}: no pre-alignment (too few consistent naive matches); searching around the "
          "row-SLAM poses",
          a.data.label(), b.data.label());
    }
  }
  return poses_b;
}

PassPairReport AssociatePair(const PassPair& pair, const std::string& method, PassContext& a,
                             PassContext& b, const AssociateStageOptions& options,
                             const std::string& fingerprint, const fs::path& out_dir) {
  PassPairReport report;
  report.pair = pair;
  report.method = method;
  const auto start = Clock::now();
  const json options_json = AssociateOptionsJson(options, method);
  const fs::path bin = out_dir / association::AssociationFileName(pair.a, pair.b);
  const fs::path summary_path = workspace::AssociationSummaryPath(bin);

  association::RobustMatcher::Options robust = options.robust;
  const std::vector<geometry::Rigid3> poses_b =
      PosesOfBInA(pair, method, a, b, options, &robust, &report);
  const std::vector<association::ImagePair> image_pairs = association::SelectImagePairs(
      a.data.poses, poses_b, a.camera, b.camera, a.ground_z, options.image_pairs);
  std::vector<association::AssociationResult> results(image_pairs.size());
  std::vector<std::int64_t> surface_counts(image_pairs.size(), 0);
  association::RobustMatcher matcher(robust);
  InArena(options.num_threads, [&] {
    tbb::parallel_for(std::size_t{0}, image_pairs.size(), [&](std::size_t k) {
      const int ia = image_pairs[k].image_a, ib = image_pairs[k].image_b;
      const features::FeatureSet& fa = a.data.features[ia];
      const features::FeatureSet& fb = b.data.features[ib];
      if (fa.empty() || fb.empty()) return;
      if (method == "naive") {
        results[k] = association::NaiveMatch(a.camera, fa, b.camera, fb, options.naive);
        return;
      }
      association::RobustPairInput input;
      input.camera_a = &a.camera;
      input.world_from_camera_a = a.data.poses[ia];
      input.features_a = &fa;
      std::vector<association::LandmarkObservation> near;
      for (const association::LandmarkObservation& l : a.landmarks_per_image[ia]) {
        if ((l.position_world - a.data.poses[ia].translation()).norm() <=
            options.max_landmark_distance_m) {
          near.push_back(l);
        }
      }
      std::int64_t num_surface = 0;
      if (options.surface_points && a.planes != nullptr) {
        association::SurfacePointOptions surface = options.surface;
        surface.max_range_m = options.max_landmark_distance_m;
        const std::vector<association::LandmarkObservation> points = association::SurfacePoints(
            a.camera, a.data.poses[ia], fa, a.landmarks_per_image[ia], *a.planes, surface);
        num_surface = static_cast<std::int64_t>(points.size());
        near.insert(near.end(), points.begin(), points.end());
      }
      surface_counts[k] = num_surface;
      input.landmarks_a = &near;
      input.planes = a.planes.get();
      input.camera_b = &b.camera;
      input.world_from_camera_b = poses_b[ib];
      input.features_b = &fb;
      cv::Mat image;
      const double baseline = (a.data.poses[ia].translation() - poses_b[ib].translation()).norm();
      if (baseline > options.robust.warp_min_baseline_m && !a.image_paths[ia].empty()) {
        image = cv::imread(a.image_paths[ia], cv::IMREAD_GRAYSCALE);
        if (image.empty()) {
          spdlog::warn("{}: cannot read {}; its landmarks are matched without the warp",
                       a.data.label(), a.image_paths[ia]);
        }
      }
      input.image_a = image.empty() ? nullptr : &image;
      // I2 as well when the warped descriptors are compared upright.
      cv::Mat image_b;
      if (!image.empty() && robust.upright_after_warp && !b.image_paths[ib].empty()) {
        image_b = cv::imread(b.image_paths[ib], cv::IMREAD_GRAYSCALE);
        if (image_b.empty()) {
          spdlog::warn(
              "{}: cannot read {}; its keypoints are compared with their cached "
              "descriptors",
              b.data.label(), b.image_paths[ib]);
        }
      }
      input.image_b = image_b.empty() ? nullptr : &image_b;
      results[k] = matcher.Match(input);
    });
  });

  const association::PassAssociation assoc =
      CollectCrossMatches(pair, method, a, b, image_pairs, results, surface_counts, &report);
  report.image_pairs = static_cast<int>(image_pairs.size());
  report.matches = static_cast<std::int64_t>(assoc.matches.size());
  report.seconds = SecondsSince(start);
  association::WriteAssociationFile(bin.string(), assoc);
  json summary = PairSummaryJson(pair, method, report, options_json, fingerprint);
  workspace::RecordOutputs(&summary, out_dir, {bin.filename().string()});
  workspace::WriteAssociationSummary(summary_path.string(), summary);
  return report;
}

}  // namespace

const char* ToString(PassPairType type) {
  switch (type) {
    case PassPairType::kSameDirection:
      return "cross-row same direction";
    case PassPairType::kOppositeDirection:
      return "cross-row opposite direction";
    case PassPairType::kCrossSession:
      return "cross-session";
  }
  return "?";
}

std::string AssociateStageOptions::Check() const {
  if (method != "robust" && method != "naive" && method != "both") {
    return "method: must be robust, naive or both (got '" + method + "')";
  }
  if (session_gap < 1) return "session_gap: must be >= 1";
  if (prealign != "auto" && prealign != "always" && prealign != "never") {
    return "prealign: must be auto, always or never (got '" + prealign + "')";
  }
  if (prealign_stride < 1) return "prealign_stride: must be >= 1";
  if (!(prealign_radius_m > 0)) return "prealign_radius_m: must be > 0";
  if (!(prealigned_sigma_position_m > 0)) return "prealigned_sigma_position_m: must be > 0";
  if (!(imprecise_sigma_position_m > 0)) return "imprecise_sigma_position_m: must be > 0";
  if (min_track_length < 2) return "min_track_length: must be >= 2";
  if (!(max_landmark_distance_m > 0)) return "max_landmark_distance_m: must be > 0";
  if (num_threads < 0) return "num_threads: must be >= 0 (0: all cores)";
  // The nested options of the modules (docs/fusion.md, association).
  if (const std::string why = alignment.Check(); !why.empty()) return "alignment." + why;
  if (const std::string why = image_pairs.Check(); !why.empty()) return "image_pairs." + why;
  if (surface_points) {
    if (const std::string why = surface.Check(); !why.empty()) return "surface." + why;
  }
  if (const std::string why = robust.Check(); !why.empty()) return "robust." + why;
  if (const std::string why = naive.Check(); !why.empty()) return "naive." + why;
  return {};
}

std::vector<PassPair> ScheduleAssociations(const std::string& field_folder,
                                           const std::string& workspace,
                                           const AssociateStageOptions& options) {
  const io::Field field(field_folder);
  // Row passes (not whole-session passes) with a camera, per session in field order.
  std::vector<std::pair<std::string, std::vector<slam::RowPass>>> sessions;
  for (const std::string& id : field.session_ids()) {
    std::vector<slam::RowPass> passes;
    for (const slam::RowPass& p : workspace::ReadPassList(workspace, id)) {
      if (p.row < 0) continue;
      const fs::path summary = workspace::Layout(workspace).PassSummary(id, p.id);
      if (!fs::exists(summary)) continue;
      // Poses of the camera (not the body): row SLAM had a camera for the pass.
      if (workspace::ReadPassSummary(summary.string()).problem.camera.empty()) continue;
      passes.push_back(p);
    }
    if (!passes.empty()) sessions.emplace_back(id, std::move(passes));
  }
  std::vector<PassPair> pairs;
  auto add = [&](const std::string& sa, const slam::RowPass& a, const std::string& sb,
                 const slam::RowPass& b, PassPairType type) {
    for (const PassPair& p : pairs) {
      if ((p.a == association::PassRef{sa, a.id} && p.b == association::PassRef{sb, b.id}) ||
          (p.b == association::PassRef{sa, a.id} && p.a == association::PassRef{sb, b.id})) {
        return;
      }
    }
    pairs.push_back({{sa, a.id}, {sb, b.id}, type, a.row, b.row});
  };
  for (std::size_t s = 0; s < sessions.size(); ++s) {
    const auto& [id, passes] = sessions[s];
    if (options.same_session) {
      for (const slam::RowPass& p : passes) {
        // The nearest other pass in each direction (ties: the lower row first).
        for (const int same : {1, 0}) {
          const slam::RowPass* best = nullptr;
          for (const slam::RowPass& q : passes) {
            if (q.id == p.id || (q.direction == p.direction) != (same == 1)) continue;
            if (best == nullptr || std::abs(q.row - p.row) < std::abs(best->row - p.row) ||
                (std::abs(q.row - p.row) == std::abs(best->row - p.row) && q.row < best->row)) {
              best = &q;
            }
          }
          if (best == nullptr) continue;
          const bool p_first = p.row < best->row || (p.row == best->row && p.id < best->id);
          const PassPairType type =
              same == 1 ? PassPairType::kSameDirection : PassPairType::kOppositeDirection;
          if (p_first) {
            add(id, p, id, *best, type);
          } else {
            add(id, *best, id, p, type);
          }
        }
      }
    }
    if (options.cross_session) {
      for (std::size_t t = s + 1; t < sessions.size() && t <= s + options.session_gap; ++t) {
        for (const slam::RowPass& p : passes) {
          for (const slam::RowPass& q : sessions[t].second) {
            if (q.row == p.row) add(id, p, sessions[t].first, q, PassPairType::kCrossSession);
          }
        }
      }
    }
  }
  if (!options.session.empty()) {
    std::erase_if(pairs, [&](const PassPair& p) {
      return p.a.session != options.session && p.b.session != options.session;
    });
  }
  if (!options.pair.empty()) {
    std::erase_if(pairs, [&](const PassPair& p) { return PassPairName(p) != options.pair; });
  }
  return pairs;
}

std::string PassPairName(const PassPair& pair) {
  return fs::path(association::AssociationFileName(pair.a, pair.b)).stem().string();
}

std::vector<PassPairReport> RunAssociateStage(const std::string& field_folder,
                                              const std::string& workspace,
                                              const AssociateStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("associate." + why);
  const io::Field field(field_folder);
  if (!options.session.empty()) {
    const auto& ids = field.session_ids();
    if (std::find(ids.begin(), ids.end(), options.session) == ids.end()) {
      throw InputError(field_folder, 0, "no session '" + options.session + "' in this field");
    }
  }
  const std::vector<PassPair> pairs = ScheduleAssociations(field_folder, workspace, options);
  if (pairs.empty() && !options.pair.empty()) {
    throw InputError(workspace, 0, "no pass pair '" + options.pair + "' in this workspace");
  }
  if (pairs.empty()) {
    throw InputError(workspace, 0,
                     "no pair of row passes to associate (run `crop4d slam` on the field first; "
                     "association needs camera passes)");
  }
  spdlog::info("associate: {} pass pairs", pairs.size());
  for (const PassPair& p : pairs) {
    spdlog::info("  {}/{} <-> {}/{}  ({})", p.a.session, p.a.pass, p.b.session, p.b.pass,
                 ToString(p.type));
  }
  const std::vector<std::string> methods = options.method == "both"
                                               ? std::vector<std::string>{"robust", "naive"}
                                               : std::vector<std::string>{options.method};
  // Passes are loaded once, when first needed, and freed after the last pair that needs them:
  // the pairs come session by session, so about two sessions' passes are held at a time,
  // however long the season.
  std::map<association::PassRef, std::unique_ptr<PassContext>> loaded;
  std::map<association::PassRef, std::size_t> last_use;
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    last_use[pairs[i].a] = i;
    last_use[pairs[i].b] = i;
  }
  auto get = [&](const association::PassRef& ref) -> PassContext& {
    auto& slot = loaded[ref];
    if (!slot) {
      for (const slam::RowPass& p : workspace::ReadPassList(workspace, ref.session)) {
        if (p.id == ref.pass) slot = LoadPass(field_folder, workspace, ref.session, p, options);
      }
      if (!slot)
        throw InputError(workspace, 0, "pass " + ref.session + "/" + ref.pass + " missing");
    }
    return *slot;
  };
  std::vector<PassPairReport> reports;
  Progress::Options progress_options;
  progress_options.silent = !options.show_progress;
  Progress progress("associate", pairs.size() * methods.size(), "pair", progress_options);
  // Light pass data (summary and poses) decides what is up to date; features, tracks and images
  // are loaded only for the pairs that need work.
  std::map<association::PassRef, workspace::PassData> light;
  auto get_light = [&](const association::PassRef& ref) -> const workspace::PassData& {
    auto it = light.find(ref);
    if (it != light.end()) return it->second;
    for (const slam::RowPass& p : workspace::ReadPassList(workspace, ref.session)) {
      if (p.id == ref.pass)
        return light[ref] = workspace::LoadPassData(workspace, ref.session, p, {});
    }
    throw InputError(workspace, 0, "pass " + ref.session + "/" + ref.pass + " missing");
  };
  for (std::size_t i = 0; i < pairs.size(); ++i) {
    const PassPair& pair = pairs[i];
    for (const std::string& method : methods) {
      const fs::path out_dir = workspace::Layout(workspace).AssociationsDir(method);
      const std::string fingerprint =
          PairFingerprint(method, options, get_light(pair.a), get_light(pair.b));
      if (!options.force) {
        if (std::optional<PassPairReport> done =
                UpToDateReport(pair, method, fingerprint, out_dir)) {
          reports.push_back(*done);
          progress.Add();
          continue;
        }
      }
      PassContext& a = get(pair.a);
      PassContext& b = get(pair.b);
      reports.push_back(AssociatePair(pair, method, a, b, options, fingerprint, out_dir));
      const PassPairReport& r = reports.back();
      spdlog::debug("{}/{} <-> {}/{} {}: {} image pairs, {} matches, {:.1f} s{}", pair.a.session,
                    pair.a.pass, pair.b.session, pair.b.pass, method, r.image_pairs, r.matches,
                    r.seconds, r.skipped ? " (up to date)" : "");
      progress.Add();
    }
    for (const association::PassRef& ref : {pair.a, pair.b}) {
      if (last_use.at(ref) == i) loaded.erase(ref);
    }
  }
  progress.Finish();
  return reports;
}

}  // namespace crop4d::pipeline
