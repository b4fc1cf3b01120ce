#include "crop4d/eval/workspace_eval.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string_view>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/core/version.h"
#include "crop4d/eval/natural_order.h"
#include "crop4d/eval/time_offset_eval.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/workspace/eval_metrics.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_data.h"
#include "crop4d/workspace/pass_list.h"
#include "crop4d/workspace/pass_summary.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;  // keys in the order written (schema order)

// Reads summary.json into `pass` through its typed reader (schema, JSON and the fields every
// reader needs), then what eval needs on top: that it is this pass's, and its pose frame. Throws
// InputError naming the file.
void ReadPassSummary(const fs::path& path, PassEval* pass) {
  const std::string file = path.string();
  const workspace::PassSummary summary = workspace::ReadPassSummary(file);
  const nlohmann::json& j = summary.json;

  const auto string_key = [&](const char* key, std::string* out) {
    if (!j.contains(key)) return false;
    if (j.at(key).is_string()) {
      *out = j.at(key).get<std::string>();
    } else if (j.at(key).is_number_integer()) {
      *out = std::to_string(j.at(key).get<std::int64_t>());
    } else {
      throw InputError(file, 0, fmt::format("'{}' must be a string", key));
    }
    return true;
  };
  const auto int_key = [&](const char* key, int* out) {
    if (!j.contains(key)) return;
    if (!j.at(key).is_number_integer())
      throw InputError(file, 0, fmt::format("'{}' must be an integer", key));
    *out = j.at(key).get<int>();
  };

  std::string session, pass_id;
  if (string_key("session", &session) && session != pass->session) {
    throw InputError(
        file, 0,
        fmt::format("'session' is '{}' but the pass is in sessions/{}/", session, pass->session));
  }
  if (string_key("pass", &pass_id) && pass_id != pass->pass) {
    throw InputError(
        file, 0, fmt::format("'pass' is '{}' but the pass is in rows/{}/", pass_id, pass->pass));
  }
  int_key("row", &pass->row);
  int_key("direction", &pass->direction);
  pass->sensors = summary.sensors;
  if (!j.contains("pose_frame"))
    throw InputError(file, 0, "missing required key 'pose_frame' (\"camera\" or \"body\")");
  if (!j.at("pose_frame").is_string())
    throw InputError(file, 0, "'pose_frame' must be \"camera\" or \"body\"");
  pass->pose_frame = j.at("pose_frame").get<std::string>();
  pass->frame_by_convention = std::find(summary.trust.begin(), summary.trust.end(),
                                        "origin_by_convention") != summary.trust.end();
  const nlohmann::json back_end = j.value("back_end", nlohmann::json::object());
  if (back_end.is_object() && back_end.contains("time_offset_s") &&
      back_end.at("time_offset_s").is_number()) {
    pass->time_offset_s = back_end.at("time_offset_s").get<double>();
  }
  if (pass->pose_frame != "camera" && pass->pose_frame != "body") {
    throw InputError(
        file, 0,
        fmt::format("'pose_frame' is '{}', expected \"camera\" or \"body\"", pass->pose_frame));
  }
}

// The true time offset over `estimate`'s stamps (time_offset_eval.h), from the session's capture
// instants (read once per session into `captures`); nullopt when the field has none.
std::optional<double> PassTrueTimeOffset(
    const std::string& field, const std::string& session,
    const std::vector<io::StampedPose>& estimate,
    std::map<std::string, std::map<Timestamp, Timestamp>>* captures) {
  auto it = captures->find(session);
  if (it == captures->end()) {
    const fs::path path = fs::path(field) / "ground_truth" / session / "cam0_exposure.csv";
    std::error_code ec;
    it = captures
             ->emplace(session, fs::exists(path, ec) ? ReadCaptureInstants(path.string())
                                                     : std::map<Timestamp, Timestamp>())
             .first;
  }
  std::vector<Timestamp> stamps;
  for (const io::StampedPose& pose : estimate) stamps.push_back(pose.t);
  return TrueTimeOffset(stamps, it->second);
}

json StatsJson(const ErrorStats& s) {
  json j;
  j["count"] = s.count;
  if (s.count == 0) {
    j["rmse"] = nullptr;
    j["mean"] = nullptr;
    j["max"] = nullptr;
  } else {
    j["rmse"] = s.rmse;
    j["mean"] = s.mean;
    j["max"] = s.max;
  }
  return j;
}

json RpeJson(double distance_m, const ErrorStats& translation, const ErrorStats& rotation) {
  json j;
  j["distance_m"] = distance_m;
  j["pairs"] = translation.count;
  j["translation_percent"] = StatsJson(translation);
  j["rotation_deg_per_m"] = StatsJson(rotation);
  return j;
}

json MetricsJson(const TrajectoryMetrics& m) {
  json j;
  j["num_poses"] = m.num_poses;
  j["path_length_m"] = m.path_length_m;
  j["ate_raw_m"] = StatsJson(m.ate_raw_m);
  j["ate_aligned_m"] = StatsJson(m.ate_aligned_m);
  const Eigen::Vector3d& t = m.truth_from_estimate.translation();
  const Eigen::Quaterniond& q = m.truth_from_estimate.rotation();
  j["truth_from_estimate"] = {{"translation_m", {t.x(), t.y(), t.z()}},
                              {"rotation_xyzw", {q.x(), q.y(), q.z(), q.w()}},
                              {"rotation_angle_deg", RotationAngleDeg(q)}};
  j["rotation_deg"] = StatsJson(m.rotation_deg);
  j["rpe"] = RpeJson(m.rpe_distance_m, m.rpe_translation_percent, m.rpe_rotation_deg_per_m);
  return j;
}

// ---- JSON of the later stages ---------------------------------------------------------------

json NumberOrNull(double value) { return std::isfinite(value) ? json(value) : json(nullptr); }

json CountsJson(const MatchCounts& c, json j = json::object()) {
  j["matches"] = c.matches;
  j["correct"] = c.correct;
  j["incorrect"] = c.incorrect;
  j["unknown"] = c.unknown;
  j["unknown_no_truth"] = c.unknown_no_truth;
  j["unknown_no_surface"] = c.unknown_no_surface;
  j["unknown_depth_edge"] = c.unknown_depth_edge;
  j["precision"] = NumberOrNull(c.Precision());
  j["within_coarse"] = c.within_coarse;
  j["coarse_precision"] = NumberOrNull(c.CoarsePrecision());
  j["known_near"] = c.known_near;
  j["correct_near"] = c.correct_near;
  j["near_precision"] = NumberOrNull(c.NearPrecision());
  return j;
}

json PassRefJson(const association::PassRef& ref, const PassLayout& layout) {
  return {{"session", ref.session},
          {"pass", ref.pass},
          {"row", layout.row},
          {"direction", layout.direction}};
}

json CeilingJson(const AssociationCeiling& ceiling, const AssociationEval& e) {
  json by_type = json::array();
  for (const CeilingGroup& g : ceiling.groups) {
    const CeilingCounts& c = g.counts;
    json share = json::object();
    for (const AssociationGroupEval& m : e.methods) {
      share[m.method] =
          c.partners_near > 0
              ? json(static_cast<double>(e.GroupCounts(g.type, m.method).correct_near) /
                     static_cast<double>(c.partners_near))
              : json(nullptr);
    }
    by_type.push_back({{"type", PairTypeName(g.type)},
                       {"pass_pairs", g.pass_pairs},
                       {"image_pairs", c.image_pairs},
                       {"keypoints", c.keypoints},
                       {"partners", c.partners},
                       {"partners_near", c.partners_near},
                       {"chance_near", c.chance_near},
                       {"share_of_ceiling_near", std::move(share)}});
  }
  return {{"chance_shift_m", ceiling.chance_shift_m},
          {"by_type", std::move(by_type)},
          {"errors", ceiling.errors}};
}

json AssociationSectionJson(const WorkspaceAssociationEval& section) {
  const AssociationEval& e = section.eval;
  json j;
  j["error"] = section.error.empty() ? json(nullptr) : json(section.error);
  j["options"] = {{"max_distance_m", e.options.max_distance_m},
                  {"coarse_distance_m", e.options.coarse_distance_m},
                  {"near_depth_m", e.options.near_depth_m},
                  {"max_edge_m", e.options.true_point.max_edge_m},
                  {"max_depth_m", e.options.true_point.max_depth_m}};
  j["num_files"] = section.num_files;
  j["num_failed"] = e.num_failed;
  j["depth_maps"] = {{"images", e.images},
                     {"from_field", e.depth.from_field},
                     {"from_cache", e.depth.from_cache},
                     {"rendered", e.depth.rendered},
                     {"unavailable", e.depth.unavailable},
                     {"setup_s", e.depth.setup_seconds},
                     {"render_s", e.depth.render_seconds}};
  json by_type = json::array();
  for (const AssociationGroupEval& g : e.groups) {
    json item;
    item["type"] = PairTypeName(g.type);
    item["method"] = g.method;
    item["files"] = g.files;
    by_type.push_back(CountsJson(g.counts, std::move(item)));
  }
  j["by_type"] = std::move(by_type);
  json by_method = json::array();
  for (const AssociationGroupEval& g : e.methods) {
    json item;
    item["method"] = g.method;
    item["files"] = g.files;
    by_method.push_back(CountsJson(g.counts, std::move(item)));
  }
  j["by_method"] = std::move(by_method);
  json files = json::array();
  for (const AssociationFileEval& f : e.files) {
    json item;
    item["file"] = f.file;
    item["method"] = f.method;
    item["a"] = PassRefJson(f.a, f.layout_a);
    item["b"] = PassRefJson(f.b, f.layout_b);
    item["type"] = f.ok() ? json(PairTypeName(f.type)) : json(nullptr);
    item["error"] = f.ok() ? json(nullptr) : json(f.error);
    item = CountsJson(f.counts, std::move(item));
    item["median_distance_m"] = NumberOrNull(f.median_distance_m);
    item["p90_distance_m"] = NumberOrNull(f.p90_distance_m);
    files.push_back(std::move(item));
  }
  j["files"] = std::move(files);
  j["ceiling"] = CeilingJson(section.ceiling, e);
  return j;
}

json RigidJson(const geometry::Rigid3& T) {
  const Eigen::Vector3d& t = T.translation();
  const Eigen::Quaterniond& q = T.rotation();
  return {{"translation_m", {t.x(), t.y(), t.z()}},
          {"rotation_xyzw", {q.x(), q.y(), q.z(), q.w()}},
          {"rotation_angle_deg", RotationAngleDeg(q)}};
}

json FusedJson(const FusedEval& fused) {
  json j;
  json sessions = json::array();
  for (const FusedSessionEval& s : fused.sessions) {
    json item;
    item["session"] = s.session;
    item["poses_file"] = s.poses_file;
    item["truth_file"] = s.truth_file;
    item["frame_by_convention"] = s.frame_by_convention;
    item["error"] = s.ok() ? json(nullptr) : json(s.error);
    item["association"] = {{"estimate_poses", s.estimate_poses},
                           {"exact", s.exact},
                           {"interpolated", s.interpolated},
                           {"dropped", s.dropped}};
    item["metrics"] = s.ok() ? MetricsJson(s.metrics) : json(nullptr);
    if (s.calibration) {
      item["calibration_ray_error_deg"] = {{"written", s.calibration->written_deg},
                                           {"fused", s.calibration->fused_deg},
                                           {"refined", s.calibration->refined}};
    }
    sessions.push_back(std::move(item));
  }
  j["sessions"] = std::move(sessions);
  json overall;
  overall["num_sessions"] = static_cast<int>(fused.sessions.size());
  overall["num_evaluated"] = fused.num_evaluated;
  overall["num_failed"] = fused.num_failed;
  overall["num_poses"] = fused.num_poses;
  overall["ate_raw_m"] = StatsJson(fused.ate_raw_m);
  overall["ate_aligned_m"] = StatsJson(fused.ate_aligned_m);
  overall["ate_aligned_joint_m"] = StatsJson(fused.ate_aligned_joint_m);
  overall["truth_from_estimate_joint"] = fused.ate_aligned_joint_m.count > 0
                                             ? RigidJson(fused.truth_from_estimate_joint)
                                             : json(nullptr);
  overall["rotation_deg"] = StatsJson(fused.rotation_deg);
  j["overall"] = std::move(overall);
  return j;
}

json MisalignmentJson(const MisalignmentStats& m, json j = json::object()) {
  j["count"] = m.count;
  j["skipped"] = m.skipped;
  const bool any = m.count > 0;
  j["median_m"] = any ? NumberOrNull(m.median_m) : json(nullptr);
  j["p90_m"] = any ? NumberOrNull(m.p90_m) : json(nullptr);
  j["signed_median_m"] = any ? NumberOrNull(m.signed_median_m) : json(nullptr);
  j["mean_abs_m"] = any ? NumberOrNull(m.mean_abs_m) : json(nullptr);
  return j;
}

json CloudSetJson(const CloudSetEval& set) {
  json j;
  j["error"] = set.error.empty() ? json(nullptr) : json(set.error);
  json sessions = json::array();
  for (const CloudSetEval::Session& s : set.sessions) {
    sessions.push_back({{"session", s.session},
                        {"files", static_cast<int>(s.files.size())},
                        {"points", s.points},
                        {"ground_points", s.ground_points},
                        {"error", s.error.empty() ? json(nullptr) : json(s.error)}});
  }
  j["sessions"] = std::move(sessions);
  j["pooled"] = MisalignmentJson(set.misalignment.pooled);
  json pairs = json::array();
  for (const PairMisalignment& p : set.misalignment.pairs) {
    json item;
    item["a"] = p.a;
    item["b"] = p.b;
    pairs.push_back(MisalignmentJson(p.stats, std::move(item)));
  }
  j["pairs"] = std::move(pairs);
  j["pooled_self"] = MisalignmentJson(set.misalignment.pooled_self);
  json self = json::array();
  for (const SelfMisalignment& m : set.misalignment.self) {
    json item;
    item["session"] = m.session;
    self.push_back(MisalignmentJson(m.stats, std::move(item)));
  }
  j["self"] = std::move(self);
  return j;
}

std::string Cm(const ErrorStats& s) {
  return s.count == 0 ? std::string("-") : fmt::format("{:.2f}", 100.0 * s.rmse);
}
std::string Value(const ErrorStats& s, const char* format) {
  return s.count == 0 ? std::string("-") : fmt::format(fmt::runtime(format), s.rmse);
}

// ---- Dense clouds ---------------------------------------------------------------------------

json PlantTopsJson(const PlantTopStats& t) {
  return {{"num_plants", t.num_plants},
          {"num_found", t.num_found},
          {"num_missing", t.num_missing},
          {"median_m", NumberOrNull(t.median_m)},
          {"p10_m", NumberOrNull(t.p10_m)},
          {"p90_m", NumberOrNull(t.p90_m)},
          {"rmse_m", NumberOrNull(t.rmse_m)},
          {"within_share", NumberOrNull(t.within_share)},
          {"low_share", NumberOrNull(t.low_share)},
          {"high_share", NumberOrNull(t.high_share)}};
}

json DenseJson(const DenseEval& dense) {
  json j;
  j["options"] = {{"top_radius_m", dense.options.top_radius_m},
                  {"tolerance_m", dense.options.tolerance_m},
                  {"plant_margin_m", dense.options.ground.plant_margin_m},
                  {"max_terrain_distance_m", dense.options.ground.max_terrain_distance_m}};
  j["error"] = dense.error.empty() ? json(nullptr) : json(dense.error);
  json sessions = json::array();
  for (const DenseSessionEval& s : dense.sessions) {
    json item;
    item["session"] = s.session;
    item["file"] = s.file;
    item["error"] = s.ok() ? json(nullptr) : json(s.error);
    if (s.ok()) {
      item["points"] = s.points;
      item["plant_tops"] = PlantTopsJson(s.tops);
      item["soil"] = {{"num_points", s.soil.num_points},
                      {"median_m", NumberOrNull(s.soil.median_m)},
                      {"abs_median_m", NumberOrNull(s.soil.abs_median_m)},
                      {"abs_p90_m", NumberOrNull(s.soil.abs_p90_m)}};
    }
    sessions.push_back(std::move(item));
  }
  j["sessions"] = std::move(sessions);
  j["plant_tops"] = PlantTopsJson(dense.tops);
  return j;
}

// ---- Canopy heights ------------------------------------------------------------------------

json CanopyStatsJson(const CanopyErrorStats& s, json j = json::object()) {
  j["num_truth"] = s.num_truth;
  j["num_pairs"] = s.num_pairs;
  j["num_missing"] = s.num_missing;
  j["rmse_m"] = NumberOrNull(s.rmse_m);
  j["bias_m"] = NumberOrNull(s.bias_m);
  j["mae_m"] = NumberOrNull(s.mae_m);
  j["max_abs_error_m"] = NumberOrNull(s.max_abs_error_m);
  j["num_failures"] = s.num_failures;
  return j;
}

json CanopyPairJson(const CanopyPair& p) {
  return {{"site_id", p.site_id},
          {"session", p.session},
          {"date", p.date},
          {"truth_m", p.truth_m},
          {"estimate_m", NumberOrNull(p.estimate_m)},
          {"error_m", NumberOrNull(p.error_m)},
          {"n_points", p.n_points >= 0 ? json(p.n_points) : json(nullptr)}};
}

json CanopyJson(const CanopyEval& canopy) {
  json j;
  j["truth_file"] = canopy.truth_file;
  j["options"] = {{"max_error_m", canopy.options.max_error_m}};
  for (const CanopyMethodEval& m : canopy.methods) {
    json item;
    item["file"] = m.file;
    item["error"] = m.ok() ? json(nullptr) : json(m.error);
    item = CanopyStatsJson(m.overall, std::move(item));
    item["rmse_interval_m"] = m.rmse_interval.valid()
                                  ? json{{"low", m.rmse_interval.low},
                                         {"high", m.rmse_interval.high},
                                         {"level", m.rmse_interval.level},
                                         {"num_sites", m.rmse_interval.num_sites},
                                         {"resamples", m.rmse_interval.resamples}}
                                  : json(nullptr);
    item["num_without_truth"] = m.num_without_truth;
    item["worst"] = m.worst >= 0 ? CanopyPairJson(m.pairs[m.worst]) : json(nullptr);
    json failures = json::array();
    for (const int i : m.failures) failures.push_back(CanopyPairJson(m.pairs[i]));
    item["failures"] = std::move(failures);
    json sessions = json::array();
    for (const CanopySessionEval& s : m.sessions) {
      json session;
      session["session"] = s.session;
      session["date"] = s.date;
      sessions.push_back(CanopyStatsJson(s.stats, std::move(session)));
    }
    item["sessions"] = std::move(sessions);
    json pairs = json::array();
    for (const CanopyPair& p : m.pairs) pairs.push_back(CanopyPairJson(p));
    item["pairs"] = std::move(pairs);
    j[m.method] = std::move(item);
  }
  if (canopy.plants) {
    const PlantEval& p = *canopy.plants;
    const auto number = [](double v) { return std::isfinite(v) ? json(v) : json(nullptr); };
    json sites = json::array();
    for (const SitePlantCounts& c : p.sites) {
      sites.push_back({{"site_id", c.site_id},
                       {"true", c.num_true},
                       {"found", c.num_found},
                       {"matched", c.num_matched}});
    }
    j["plants"] = {{"file", p.file},
                   {"truth_session", p.truth_session},
                   {"max_stem_offset_m", p.options.max_stem_offset_m},
                   {"true", p.num_true},
                   {"found", p.num_found},
                   {"matched", p.num_matched},
                   {"recall", number(p.recall)},
                   {"precision", number(p.precision)},
                   {"median_stem_offset_m", number(p.median_stem_offset_m)},
                   {"tops", p.num_tops},
                   {"top_rmse_m", number(p.top_rmse_m)},
                   {"top_bias_m", number(p.top_bias_m)},
                   {"top_failures", p.num_top_failures},
                   {"sites_unknown", p.num_sites_unknown},
                   {"sites", std::move(sites)}};
  } else {
    j["plants"] = nullptr;
    j["plants_skipped"] = canopy.plants_skipped;
  }
  return j;
}

// ---- Association files ---------------------------------------------------------------------

// Every *.bin under WS/associations (any depth: robust/, naive/), relative to the workspace,
// in natural order.
std::vector<std::string> FindAssociationFiles(const std::string& workspace) {
  std::vector<std::string> files;
  const fs::path root = workspace::Layout(workspace).AssociationsRoot();
  std::error_code ec;
  if (!fs::is_directory(root, ec)) return files;
  for (auto it = fs::recursive_directory_iterator(root, ec); !ec && it != fs::end(it);
       it.increment(ec)) {
    if (it->is_regular_file(ec) && it->path().extension() == ".bin") {
      files.push_back(fs::relative(it->path(), workspace, ec).generic_string());
    }
  }
  std::sort(files.begin(), files.end(), NaturalLess);
  return files;
}

// The sessions in recording order with their rain, from simulate.yaml; empty when the field
// has none (then sessions sort by name and no pair counts as "after rain").
SessionTimeline ReadTimeline(const std::string& field) {
  SessionTimeline timeline;
  const fs::path path = fs::path(field) / "ground_truth" / "simulate.yaml";
  std::error_code ec;
  if (!fs::exists(path, ec)) return timeline;
  try {
    sim::SimConfig config = sim::PresetConfig("tiny");  // the file holds every key
    sim::LoadSimConfigFile(path.string(), &config);
    for (const sim::SessionSpec& s : config.sessions) {
      timeline.sessions.push_back(s.date);
      timeline.rain_before.push_back(s.rain_before);
    }
  } catch (const InputError& e) {
    spdlog::warn("eval: {}: session order and rain unknown", e.what());
  }
  return timeline;
}

// Row and direction of every pass of a session: WS/sessions/<session>/passes.csv (pass,row,
// direction,...), else each pass's summary.json. Passes found in neither are missing.
std::map<std::string, PassLayout> ReadPassLayouts(const std::string& workspace,
                                                  const std::string& session) {
  std::map<std::string, PassLayout> layouts;
  for (const slam::RowPass& p : workspace::ReadPassList(workspace, session)) {
    layouts[p.id] = PassLayout{p.row, p.direction};
  }
  const workspace::Layout ws(workspace);
  std::error_code ec;
  for (const std::string& pass : ws.PassFolders(session, workspace::Layout::Order::kNatural)) {
    if (layouts.count(pass) > 0 || !fs::exists(ws.PassSummary(session, pass), ec)) continue;
    try {
      const json& j = workspace::ReadPassSummary(ws.PassSummary(session, pass).string()).json;
      PassLayout layout;
      if (j.contains("row") && j["row"].is_number_integer()) layout.row = j["row"].get<int>();
      if (j.contains("direction") && j["direction"].is_number_integer()) {
        layout.direction = j["direction"].get<int>();
      }
      layouts[pass] = layout;
    } catch (const InputError&) {
      // Not readable: the pass stays without layout.
    }
  }
  return layouts;
}

bool BothSelected(const std::vector<std::string>& sessions, const association::PassRef& a,
                  const association::PassRef& b) {
  const auto selected = [&](const std::string& s) {
    return sessions.empty() || std::find(sessions.begin(), sessions.end(), s) != sessions.end();
  };
  return selected(a.session) && selected(b.session);
}

// The keypoints of a pass's images (its features.bin), for the association ceiling.
PassKeypoints LoadPassKeypoints(const std::string& workspace, const association::PassRef& ref) {
  for (const slam::RowPass& pass : workspace::ReadPassList(workspace, ref.session)) {
    if (pass.id != ref.pass) continue;
    const workspace::PassData data =
        workspace::LoadPassData(workspace, ref.session, pass, {.features = true});
    PassKeypoints keypoints;
    keypoints.times = data.times;
    for (const features::FeatureSet& f : data.features) {
      std::vector<Eigen::Vector2d>& pixels = keypoints.pixels.emplace_back();
      pixels.reserve(f.size());
      for (std::size_t i = 0; i < f.size(); ++i) pixels.push_back(f.Point(i));
    }
    return keypoints;
  }
  throw InputError(fmt::format("pass {} is not in sessions/{}/passes.csv", ref.pass, ref.session));
}

WorkspaceAssociationEval EvaluateWorkspaceAssociations(const std::string& workspace,
                                                       const std::string& field,
                                                       const std::vector<std::string>& files,
                                                       const SessionTimeline& timeline,
                                                       const WorkspaceEvalOptions& options) {
  WorkspaceAssociationEval result;
  std::vector<AssociationInput> inputs;
  std::map<std::string, std::map<std::string, PassLayout>> layouts;  // per session
  const auto layout_of = [&](const association::PassRef& ref, PassLayout* layout) {
    auto it = layouts.find(ref.session);
    if (it == layouts.end())
      it = layouts.emplace(ref.session, ReadPassLayouts(workspace, ref.session)).first;
    const auto found = it->second.find(ref.pass);
    if (found == it->second.end()) return false;
    *layout = found->second;
    return true;
  };
  for (const std::string& file : files) {
    AssociationInput input;
    input.file = file;
    std::string detail;
    const association::AssociationFileStatus status = association::ReadAssociationFile(
        (fs::path(workspace) / file).string(), &input.association, &detail);
    if (status != association::AssociationFileStatus::kOk) {
      input.error = fmt::format("{}: {}", association::ToString(status), detail);
    } else if (!BothSelected(options.sessions, input.association.a, input.association.b)) {
      continue;
    } else {
      const association::PassRef& a = input.association.a;
      const association::PassRef& b = input.association.b;
      const bool known_a = layout_of(a, &input.layout_a);
      const bool known_b = layout_of(b, &input.layout_b);
      // Without the directions the type of a same-session pair is unknown.
      if (a.session == b.session && !(known_a && known_b)) {
        const association::PassRef& missing = known_a ? b : a;
        input.error =
            fmt::format("pass {} is not in sessions/{}/passes.csv: its direction is unknown",
                        missing.pass, missing.session);
      }
    }
    inputs.push_back(std::move(input));
  }
  result.num_files = static_cast<int>(inputs.size());
  if (inputs.empty()) return result;

  SimulatedFieldTruthOptions truth_options;
  // The parent of every Layout::EvalDepthDir(session).
  truth_options.depth_cache_dir = options.depth_cache_dir.empty()
                                      ? (workspace::Layout(workspace).EvalDir() / "depth").string()
                                      : options.depth_cache_dir;
  truth_options.render = options.render_depth;
  try {
    SimulatedFieldTruth truth(field, truth_options);
    result.eval = EvaluateAssociations(inputs, timeline, truth, options.association);
    try {
      result.ceiling = EvaluateCeiling(
          inputs, timeline, truth,
          [&](const association::PassRef& ref) { return LoadPassKeypoints(workspace, ref); },
          options.association);
    } catch (const std::exception& e) {
      // The precision above stands; the ceiling says why it is missing.
      result.ceiling = AssociationCeiling();
      result.ceiling.errors.push_back(fmt::format("every pair of passes: {}", e.what()));
    }
  } catch (const std::exception& e) {
    // No simulate.yaml, no EGL to render with, a cache that cannot be written: the section
    // says why, the other sections are still evaluated.
    result.error = e.what();
    result.ceiling = AssociationCeiling();
    result.eval = AssociationEval();
    result.eval.options = options.association;
    for (const AssociationInput& input : inputs) {
      AssociationFileEval f;
      f.file = input.file;
      f.method = input.association.method;
      f.a = input.association.a;
      f.b = input.association.b;
      f.error = input.error.empty() ? "no true geometry" : input.error;
      result.eval.files.push_back(std::move(f));
    }
    result.eval.num_failed = static_cast<int>(inputs.size());
  }
  return result;
}

// The row passes of the workspace (of the selected sessions), in session and pass order.
std::vector<PassEval> ListPasses(const workspace::Layout& ws, const WorkspaceEvalOptions& options) {
  std::vector<PassEval> passes;
  for (const std::string& session : ws.SessionFolders(workspace::Layout::Order::kNatural)) {
    if (!options.sessions.empty() && std::find(options.sessions.begin(), options.sessions.end(),
                                               session) == options.sessions.end()) {
      continue;
    }
    for (const std::string& pass_id : ws.PassFolders(session, workspace::Layout::Order::kNatural)) {
      PassEval pass;
      pass.session = session;
      pass.pass = pass_id;
      pass.poses_file =
          ws.PassPoses(session, pass_id).lexically_relative(ws.root()).generic_string();
      passes.push_back(pass);
    }
  }
  return passes;
}

// Each pass's time offset in the joint problem (WS/fused/summary.json), when the workspace is
// fused; a summary that cannot be read leaves them unset (with a warning).
void ReadFusedTimeOffsets(const workspace::Layout& ws, std::vector<PassEval>* passes) {
  std::error_code ec;
  if (!fs::exists(ws.FusedSummary(), ec)) return;
  try {
    for (const workspace::FusedPassSummary& fused :
         workspace::ReadFusedSummary(ws.FusedSummary().string()).pass_list) {
      for (PassEval& pass : *passes) {
        if (pass.session == fused.session && pass.pass == fused.pass) {
          pass.fused_time_offset_s = fused.time_offset_s;
        }
      }
    }
  } catch (const InputError& e) {
    spdlog::warn("eval: the fused time offsets are not evaluated: {}", e.what());
  }
}

// Truth files, read once per session and frame (body_poses.tum is at the IMU rate).
struct TruthCache {
  std::map<std::string, std::vector<io::StampedPose>> poses;       // by truth file
  std::map<std::string, std::map<Timestamp, Timestamp>> captures;  // per session
};

// One pass against the truth: its summary, its poses associated by time with the truth's, the
// trajectory metrics and the camera-IMU time offset. Throws InputError for what cannot be read
// or compared.
void EvaluatePass(const workspace::Layout& ws, const std::string& field,
                  const WorkspaceEvalOptions& options, TruthCache* truth, PassEval* pass_ptr) {
  PassEval& pass = *pass_ptr;
  std::error_code ec;
  const Timestamp max_dt = SecondsToTimestamp(options.max_dt_s);
  const fs::path pass_dir = ws.PassPoses(pass.session, pass.pass);
  ReadPassSummary(ws.PassSummary(pass.session, pass.pass), &pass);
  pass.truth_file = "ground_truth/" + pass.session + "/" +
                    (pass.pose_frame == "camera" ? "cam0_poses.tum" : "body_poses.tum");
  if (!fs::exists(pass_dir, ec)) throw InputError(pass_dir.string(), 0, "file not found");
  const std::vector<io::StampedPose> estimate = io::ReadTum(pass_dir.string());
  pass.estimate_poses = static_cast<int>(estimate.size());
  if (estimate.empty()) throw InputError(pass_dir.string(), 0, "holds no pose");

  auto cached = truth->poses.find(pass.truth_file);
  if (cached == truth->poses.end()) {
    const fs::path truth_path = fs::path(field) / pass.truth_file;
    if (!fs::exists(truth_path, ec)) {
      throw InputError(truth_path.string(), 0,
                       fmt::format("no ground truth for session '{}' ({} poses): file not "
                                   "found",
                                   pass.session, pass.pose_frame));
    }
    cached = truth->poses.emplace(pass.truth_file, io::ReadTum(truth_path.string())).first;
  }
  const AssociatedPoses associated = AssociateByTime(estimate, cached->second, max_dt);
  pass.exact = associated.exact;
  pass.interpolated = associated.interpolated;
  pass.dropped_out_of_span = associated.dropped_out_of_span;
  pass.dropped_gap = associated.dropped_gap;
  if (associated.size() == 0) {
    throw InputError(pass_dir.string(), 0,
                     fmt::format("none of its {} poses can be compared with {} ({} outside "
                                 "the truth's time span, {} in gaps wider than {} s)",
                                 estimate.size(), pass.truth_file, associated.dropped_out_of_span,
                                 associated.dropped_gap, options.max_dt_s));
  }
  std::vector<geometry::Rigid3> estimate_poses = associated.estimate;
  if (pass.frame_by_convention) {
    const geometry::Rigid3 truth_from_local = AlignYawTranslation(estimate_poses, associated.truth);
    for (geometry::Rigid3& pose : estimate_poses) pose = truth_from_local * pose;
  }
  pass.metrics = ComputeTrajectoryMetrics(estimate_poses, associated.truth, options.metrics);
  if ((pass.time_offset_s || pass.fused_time_offset_s) && pass.pose_frame == "camera") {
    pass.true_time_offset_s = PassTrueTimeOffset(field, pass.session, estimate, &truth->captures);
  }
}

// The pooled statistics of the passes that were evaluated, and the worst of them.
void PoolPasses(WorkspaceEval* eval_ptr) {
  WorkspaceEval& eval = *eval_ptr;
  OverallEval& overall = eval.overall;
  overall.num_passes = static_cast<int>(eval.passes.size());
  std::vector<ErrorStats> raw, aligned, rot, rpe_t, rpe_r;
  for (std::size_t k = 0; k < eval.passes.size(); ++k) {
    const PassEval& pass = eval.passes[k];
    if (!pass.ok()) {
      ++overall.num_failed;
      continue;
    }
    ++overall.num_evaluated;
    overall.num_poses += pass.metrics.num_poses;
    raw.push_back(pass.metrics.ate_raw_m);
    aligned.push_back(pass.metrics.ate_aligned_m);
    rot.push_back(pass.metrics.rotation_deg);
    rpe_t.push_back(pass.metrics.rpe_translation_percent);
    rpe_r.push_back(pass.metrics.rpe_rotation_deg_per_m);
    if (overall.worst_pass < 0 ||
        pass.metrics.ate_raw_m.rmse > eval.passes[overall.worst_pass].metrics.ate_raw_m.rmse) {
      overall.worst_pass = static_cast<int>(k);
    }
  }
  overall.ate_raw_m = ErrorStats::Pool(raw);
  overall.ate_aligned_m = ErrorStats::Pool(aligned);
  overall.rotation_deg = ErrorStats::Pool(rot);
  overall.rpe_translation_percent = ErrorStats::Pool(rpe_t);
  overall.rpe_rotation_deg_per_m = ErrorStats::Pool(rpe_r);
}

}  // namespace

OptionCheck WorkspaceEvalOptions::Check() const {
  OptionChecker c;
  c.Nested("metrics", metrics.Check())
      .AtLeast("max_dt_s", max_dt_s, 0.0)
      .Finite("max_dt_s", max_dt_s)
      .Nested("association", association.Check())
      .Nested("clouds.selection", clouds.selection.Check())
      .Nested("clouds.misalignment", clouds.misalignment.Check())
      .Nested("canopy", canopy_options.Check())
      .Nested("dense", dense_options.Check());
  return c.Result();
}

WorkspaceEval EvaluateWorkspace(const std::string& workspace, const std::string& field,
                                const WorkspaceEvalOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EvaluateWorkspace");
  std::error_code ec;
  if (!fs::is_directory(workspace, ec))
    throw InputError(workspace, 0, "workspace folder not found");
  if (!fs::is_directory(field, ec)) throw InputError(field, 0, "field folder not found");
  const fs::path truth_root = fs::path(field) / "ground_truth";
  if (!fs::is_directory(truth_root, ec)) {
    throw InputError(truth_root.string(), 0,
                     "ground truth folder not found: crop4d eval needs a field with ground "
                     "truth, e.g. one made by crop4d simulate");
  }

  WorkspaceEval eval;
  eval.workspace = workspace;
  eval.field = field;
  eval.options = options;
  const workspace::Layout ws(workspace);
  eval.passes = ListPasses(ws, options);
  if (options.fused) ReadFusedTimeOffsets(ws, &eval.passes);
  const std::vector<std::string> association_files =
      options.associations ? FindAssociationFiles(workspace) : std::vector<std::string>();
  bool has_fused = false;
  for (const std::string& session : ws.FusedSessionFolders()) {
    has_fused = has_fused || fs::exists(ws.FusedPoses(session), ec);
  }
  const bool has_canopy = options.canopy && fs::is_regular_file(ws.SiteHeights(), ec);
  const SessionTimeline timeline = ReadTimeline(field);
  const std::vector<std::string> dense_files =
      options.dense ? FindDenseClouds(workspace, timeline.sessions, options.sessions)
                    : std::vector<std::string>();
  if (eval.passes.empty() && association_files.empty() && !(options.fused && has_fused) &&
      !has_canopy && dense_files.empty()) {
    throw InputError(
        workspace, 0,
        options.sessions.empty()
            ? "no row pass in the workspace: expected sessions/<session>/rows/<pass>/ folders "
              "(written by crop4d slam)"
            : "no row pass of the selected sessions in the workspace");
  }

  TruthCache truth;
  for (PassEval& pass : eval.passes) {
    try {
      EvaluatePass(ws, field, options, &truth, &pass);
    } catch (const InputError& e) {
      pass.error = e.what();
    }
  }
  PoolPasses(&eval);
  const Timestamp max_dt = SecondsToTimestamp(options.max_dt_s);

  // The later stages, each when its inputs exist.
  if (!association_files.empty()) {
    eval.association =
        EvaluateWorkspaceAssociations(workspace, field, association_files, timeline, options);
  }
  if (options.fused) {
    if (has_fused) {
      eval.fused = EvaluateFusedTrajectories(workspace, field, timeline.sessions, options.sessions,
                                             max_dt, options.metrics);
    }
    for (const char* label : {"row_slam", "fused"}) {
      const std::vector<SessionCloudFiles> clouds =
          FindCloudFiles(workspace, label, timeline.sessions, options.sessions);
      if (clouds.size() >= 2) {
        eval.clouds.push_back(EvaluateCloudSet(workspace, field, label, clouds, options.clouds));
      }
    }
  }
  if (!dense_files.empty()) {
    eval.dense = EvaluateDenseClouds(workspace, field, dense_files, options.dense_options);
  }
  if (options.canopy) {
    CanopyEvalOptions canopy_options = options.canopy_options;
    canopy_options.sessions = options.sessions;
    CanopyEval canopy;
    if (EvaluateWorkspaceCanopy(workspace, field, canopy_options, &canopy, &eval.canopy_skipped)) {
      eval.canopy = std::move(canopy);
    }
  }
  return eval;
}

namespace {

// The metrics.json object, keys in schema order.
json MetricsObject(const WorkspaceEval& eval) {
  json root;
  root["crop4d_version"] = kVersion;
  root["workspace"] = eval.workspace;
  root["field"] = eval.field;
  root["options"] = {{"rpe_distance_m", eval.options.metrics.rpe_distance_m},
                     {"max_dt_s", eval.options.max_dt_s}};
  json passes = json::array();
  for (const PassEval& pass : eval.passes) {
    json p;
    p["session"] = pass.session;
    p["pass"] = pass.pass;
    p["row"] = pass.row;
    p["direction"] = pass.direction;
    p["sensors"] = pass.sensors;
    p["pose_frame"] = pass.pose_frame;
    p["frame_by_convention"] = pass.frame_by_convention;
    p["poses_file"] = pass.poses_file;
    p["truth_file"] = pass.truth_file;
    p["error"] = pass.ok() ? json(nullptr) : json(pass.error);
    p["association"] = {{"estimate_poses", pass.estimate_poses},
                        {"exact", pass.exact},
                        {"interpolated", pass.interpolated},
                        {"dropped_out_of_span", pass.dropped_out_of_span},
                        {"dropped_gap", pass.dropped_gap}};
    p["metrics"] = pass.ok() ? MetricsJson(pass.metrics) : json(nullptr);
    // Row SLAM's and the joint problem's offsets, each with the truth and the error.
    for (const auto& [key, estimate] :
         {std::pair{"time_offset_s", pass.time_offset_s},
          std::pair{"fused_time_offset_s", pass.fused_time_offset_s}}) {
      if (!estimate) continue;
      const auto optional_json = [](const std::optional<double>& v) {
        return v ? json(*v) : json(nullptr);
      };
      std::optional<double> error;
      if (pass.true_time_offset_s) error = *estimate - *pass.true_time_offset_s;
      p[key] = {{"estimate", *estimate},
                {"truth", optional_json(pass.true_time_offset_s)},
                {"error", optional_json(error)}};
    }
    passes.push_back(std::move(p));
  }
  root["passes"] = std::move(passes);

  const OverallEval& o = eval.overall;
  json overall;
  overall["num_passes"] = o.num_passes;
  overall["num_evaluated"] = o.num_evaluated;
  overall["num_failed"] = o.num_failed;
  overall["num_poses"] = o.num_poses;
  overall["ate_raw_m"] = StatsJson(o.ate_raw_m);
  overall["ate_aligned_m"] = StatsJson(o.ate_aligned_m);
  overall["rotation_deg"] = StatsJson(o.rotation_deg);
  overall["rpe"] = RpeJson(eval.options.metrics.rpe_distance_m, o.rpe_translation_percent,
                           o.rpe_rotation_deg_per_m);
  if (o.worst_pass >= 0) {
    const PassEval& worst = eval.passes[o.worst_pass];
    overall["worst_pass"] = {{"session", worst.session},
                             {"pass", worst.pass},
                             {"sensors", worst.sensors},
                             {"ate_raw_rmse_m", worst.metrics.ate_raw_m.rmse},
                             {"ate_aligned_rmse_m", worst.metrics.ate_aligned_m.count > 0
                                                        ? json(worst.metrics.ate_aligned_m.rmse)
                                                        : json(nullptr)}};
  } else {
    overall["worst_pass"] = nullptr;
  }
  root["overall"] = std::move(overall);
  if (eval.association) root["association"] = AssociationSectionJson(*eval.association);
  if (eval.fused) root["fused"] = FusedJson(*eval.fused);
  if (!eval.clouds.empty()) {
    const CloudSetOptions& c = eval.options.clouds;
    json ground;
    ground["options"] = {{"plant_margin_m", c.selection.plant_margin_m},
                         {"max_terrain_distance_m", c.selection.max_terrain_distance_m},
                         {"radius_m", c.misalignment.radius_m},
                         {"min_points", c.misalignment.min_points},
                         {"max_slope_deg", c.misalignment.max_slope_deg},
                         {"max_query_points", c.misalignment.max_query_points}};
    for (const CloudSetEval& set : eval.clouds) ground[set.label] = CloudSetJson(set);
    root["ground_misalignment"] = std::move(ground);
  }
  if (eval.dense) root["dense"] = DenseJson(*eval.dense);
  if (eval.canopy) root["canopy"] = CanopyJson(*eval.canopy);
  return root;
}

}  // namespace

std::string WorkspaceEvalJson(const WorkspaceEval& eval) {
  return MetricsObject(eval).dump(2) + "\n";
}

std::string WriteWorkspaceEval(const WorkspaceEval& eval, const std::string& path) {
  const std::string out =
      path.empty() ? workspace::Layout(eval.workspace).EvalMetrics().string() : path;
  workspace::WriteEvalMetrics(out, MetricsObject(eval));
  return out;
}

std::string FormatWorkspaceEvalTable(const WorkspaceEval& eval) {
  // The row passes (unless there are none), then each later stage's section.
  std::string out = eval.passes.empty() ? std::string() : FormatPassTable(eval);
  const auto section = [&](const std::string& text) { out += (out.empty() ? "" : "\n") + text; };
  if (eval.association) section(FormatAssociationTable(*eval.association));
  if (eval.fused || !eval.clouds.empty()) section(FormatFusedTable(eval));
  if (eval.dense) section(FormatDenseTable(*eval.dense));
  if (eval.canopy) {
    section(FormatCanopyTable(*eval.canopy));
  } else if (!eval.canopy_skipped.empty()) {
    section("canopy height: not evaluated, " + eval.canopy_skipped + "\n");
  }
  return out;
}

// The ceiling per pair type, and each method's correct matches near the camera as a share of it.
std::string FormatCeilingTable(const AssociationCeiling& ceiling, const AssociationEval& e) {
  if (ceiling.groups.empty() && ceiling.errors.empty()) return "";
  const std::string near = fmt::format("<={:g}m", e.options.near_depth_m);
  std::string out = fmt::format(
      "association ceiling: keypoints of image a with a keypoint of image b whose true point is "
      "within {:g} cm, in the image pairs some method matched (no matcher finds more correct "
      "matches); by chance: image b's points shifted {:g} cm; share: a method's correct matches "
      "{} over the ceiling {}\n",
      100.0 * e.options.max_distance_m, 100.0 * ceiling.chance_shift_m, near, near);
  std::string header =
      fmt::format("{:<16}  {:>11}  {:>9}  {:>9}  {:>9}  {:>14}", "pair type", "image pairs",
                  "keypoints", "ceiling", "ceil " + near, "by chance " + near);
  for (const AssociationGroupEval& m : e.methods) {
    header += fmt::format("  {:>14}", m.method + " share %");
  }
  out += header + "\n";
  for (const CeilingGroup& g : ceiling.groups) {
    const CeilingCounts& c = g.counts;
    std::string line =
        fmt::format("{:<16}  {:>11}  {:>9}  {:>9}  {:>9}  {:>14}", PairTypeLabel(g.type),
                    c.image_pairs, c.keypoints, c.partners, c.partners_near, c.chance_near);
    for (const AssociationGroupEval& m : e.methods) {
      line += fmt::format(
          "  {:>14}",
          c.partners_near > 0
              ? fmt::format("{:.1f}",
                            100.0 *
                                static_cast<double>(e.GroupCounts(g.type, m.method).correct_near) /
                                static_cast<double>(c.partners_near))
              : std::string("-"));
    }
    out += line + "\n";
  }
  for (const std::string& error : ceiling.errors) {
    out += "ceiling not counted for " + error + "\n";
  }
  return out;
}

std::string FormatAssociationTable(const WorkspaceAssociationEval& section) {
  const AssociationEval& e = section.eval;
  std::string out = fmt::format(
      "association precision: correct when the true points of the two keypoints are within "
      "{:g} cm; unknown: no truth, sky or a depth edge\n",
      100.0 * e.options.max_distance_m);
  if (!section.error.empty()) {
    out +=
        fmt::format("{} association files not evaluated: {}\n", section.num_files, section.error);
    return out;
  }
  std::size_t w_method = 6;
  for (const AssociationGroupEval& g : e.methods) w_method = std::max(w_method, g.method.size());
  const auto percent = [](double value) {
    return std::isfinite(value) ? fmt::format("{:.2f}", 100.0 * value) : std::string("-");
  };
  const std::string coarse = fmt::format("<={:g}cm %", 100.0 * e.options.coarse_distance_m);
  const std::string near = fmt::format("<={:g}m", e.options.near_depth_m);
  const auto row = [&](const std::string& type, const std::string& method, const std::string& files,
                       const std::string& matches, const std::string& correct,
                       const std::string& incorrect, const std::string& unknown,
                       const std::string& precision, const std::string& coarse_precision,
                       const std::string& correct_near, const std::string& near_precision) {
    out += fmt::format(
        "{:<16}  {:<{}}  {:>5}  {:>8}  {:>8}  {:>9}  {:>8}  {:>11}  {:>10}  {:>12}  {:>10}\n", type,
        method, w_method, files, matches, correct, incorrect, unknown, precision, coarse_precision,
        correct_near, near_precision);
  };
  const auto line = [&](const std::string& type, const std::string& method, const MatchCounts& c,
                        int files) {
    row(type, method, std::to_string(files), std::to_string(c.matches), std::to_string(c.correct),
        std::to_string(c.incorrect), std::to_string(c.unknown), percent(c.Precision()),
        percent(c.CoarsePrecision()), std::to_string(c.correct_near), percent(c.NearPrecision()));
  };
  row("pair type", "method", "files", "matches", "correct", "incorrect", "unknown", "precision %",
      coarse, "correct " + near, near + " prec %");
  for (const AssociationGroupEval& g : e.groups) {
    line(PairTypeLabel(g.type), g.method, g.counts, g.files);
  }
  for (const AssociationGroupEval& g : e.methods) line("all", g.method, g.counts, g.files);
  // With both methods evaluated: how many more correct matches the robust method finds.
  std::string ratios;
  for (const AssociationGroupEval& r : e.groups) {
    if (r.method != "robust") continue;
    for (const AssociationGroupEval& n : e.groups) {
      if (n.method != "naive" || n.type != r.type) continue;
      const auto ratio = [](std::int64_t a, std::int64_t b) {
        return b > 0 ? fmt::format("{:.2f}x", static_cast<double>(a) / static_cast<double>(b))
                     : std::string("-");
      };
      ratios += fmt::format("  {}: {} ({} {})\n", PairTypeLabel(r.type),
                            ratio(r.counts.correct, n.counts.correct),
                            ratio(r.counts.correct_near, n.counts.correct_near), near);
    }
  }
  if (!ratios.empty()) {
    out += fmt::format(
               "correct matches, robust / naive (in brackets: those at most {:g} m deep in the "
               "first image):\n",
               e.options.near_depth_m) +
           ratios;
  }
  out += FormatCeilingTable(section.ceiling, e);
  const DepthSourceStats& d = e.depth;
  out += fmt::format(
      "true depth of {} images: {} from the field, {} cached, {} rendered ({:.1f} s, {:.2f} s "
      "each), {} unavailable\n",
      e.images, d.from_field, d.from_cache, d.rendered, d.setup_seconds + d.render_seconds,
      d.rendered > 0 ? d.render_seconds / static_cast<double>(d.rendered) : 0.0, d.unavailable);
  if (e.num_failed > 0) {
    out += fmt::format("{} of {} association files could not be evaluated\n", e.num_failed,
                       section.num_files);
  }
  return out;
}

std::string FormatFusedTable(const WorkspaceEval& eval) {
  std::string out;
  if (eval.fused) {
    const FusedEval& f = *eval.fused;
    std::size_t w = 7;
    for (const FusedSessionEval& s : f.sessions) w = std::max(w, s.session.size() + 1);
    out += fmt::format("{:<{}}  {:>6}  {:>10}  {:>14}  {:>7}\n", "fused", w, "N", "ATE raw cm",
                       "ATE aligned cm", "rot deg");
    for (const FusedSessionEval& s : f.sessions) {
      if (!s.ok()) {
        out += fmt::format("{:<{}}  error: {}\n", s.session, w, s.error);
        continue;
      }
      out += fmt::format("{:<{}}  {:>6}  {:>10}  {:>14}  {:>7}\n",
                         s.session + (s.frame_by_convention ? "*" : ""), w, s.metrics.num_poses,
                         Cm(s.metrics.ate_raw_m), Cm(s.metrics.ate_aligned_m),
                         Value(s.metrics.rotation_deg, "{:.3f}"));
    }
    out += fmt::format("{:<{}}  {:>6}  {:>10}  {:>14}  {:>7}\n",
                       fmt::format("all {}/{}", f.num_evaluated, f.sessions.size()), w, f.num_poses,
                       Cm(f.ate_raw_m), Cm(f.ate_aligned_m), Value(f.rotation_deg, "{:.3f}"));
    out += fmt::format(
        "aligned: SE(3) alignment per session; one alignment of all sessions together: {} cm\n",
        Cm(f.ate_aligned_joint_m));
    for (const FusedSessionEval& s : f.sessions) {
      if (!s.calibration) continue;
      out += fmt::format(
          "{:<{}}  calibration: rays {:.3f} deg from the truth as written, {:.3f} deg fused{}\n",
          s.session, w, s.calibration->written_deg, s.calibration->fused_deg,
          s.calibration->refined ? " (refined)" : " (as written)");
    }
  }
  if (!eval.clouds.empty()) {
    const CloudSetOptions& o = eval.options.clouds;
    if (!out.empty()) out += "\n";
    out += fmt::format(
        "ground misalignment: ground points (beyond canopy + {:g} cm, within {:g} cm of the true "
        "terrain) against the local plane ({:g} cm radius) of the other session\n",
        100.0 * o.selection.plant_margin_m, 100.0 * o.selection.max_terrain_distance_m,
        100.0 * o.misalignment.radius_m);
    std::size_t w = 18;
    for (const CloudSetEval& set : eval.clouds) {
      for (const PairMisalignment& p : set.misalignment.pairs) {
        w = std::max(w, p.a.size() + p.b.size() + 3);
      }
    }
    const auto cm = [](const MisalignmentStats& m, double value, bool sign) {
      if (m.count == 0 || !std::isfinite(value)) return std::string("-");
      return sign ? fmt::format("{:+.2f}", 100.0 * value) : fmt::format("{:.2f}", 100.0 * value);
    };
    const auto line = [&](const std::string& label, const std::string& pair,
                          const MisalignmentStats& m) {
      out += fmt::format("{:<8}  {:<{}}  {:>8}  {:>9}  {:>6}  {:>9}\n", label, pair, w, m.count,
                         cm(m, m.median_m, false), cm(m, m.p90_m, false),
                         cm(m, m.signed_median_m, true));
    };
    out += fmt::format("{:<8}  {:<{}}  {:>8}  {:>9}  {:>6}  {:>9}\n", "clouds", "sessions", w, "N",
                       "median cm", "p90 cm", "signed cm");
    for (const CloudSetEval& set : eval.clouds) {
      if (!set.error.empty()) {
        out += fmt::format("{:<8}  error: {}\n", set.label, set.error);
        continue;
      }
      // Consecutive sessions (what the associations connect); metrics.json has every pair.
      for (std::size_t k = 0; k + 1 < set.sessions.size(); ++k) {
        for (const PairMisalignment& p : set.misalignment.pairs) {
          if (p.a == set.sessions[k].session && p.b == set.sessions[k + 1].session) {
            line(set.label, p.a + " ~ " + p.b, p.stats);
          }
        }
      }
      line(set.label, "all pairs", set.misalignment.pooled);
      line(set.label, "self (noise floor)", set.misalignment.pooled_self);
      for (const CloudSetEval::Session& s : set.sessions) {
        if (!s.error.empty()) out += fmt::format("{:<8}  {}: {}\n", set.label, s.session, s.error);
      }
    }
    out +=
        "signed: median of the distances, positive when the earlier session lies above; self: "
        "each session's ground against its own (point left out)\n";
  }
  return out;
}

std::string FormatPassTable(const WorkspaceEval& eval) {
  std::size_t w_session = 7, w_pass = 4, w_sensors = 7;
  for (const PassEval& p : eval.passes) {
    w_session = std::max(w_session, p.session.size());
    w_pass = std::max(w_pass, p.pass.size() + (p.frame_by_convention ? 1 : 0));
    w_sensors = std::max(w_sensors, p.sensors.size());
  }
  std::string out;
  const auto line = [&](const std::string& session, const std::string& pass,
                        const std::string& sensors, const std::string& rest) {
    out += fmt::format("{:<{}}  {:<{}}  {:<{}}  {}\n", session, w_session, pass, w_pass, sensors,
                       w_sensors, rest);
  };
  const auto numbers = [](const std::string& n, const std::string& raw, const std::string& aligned,
                          const std::string& rpe, const std::string& rot) {
    return fmt::format("{:>6}  {:>10}  {:>14}  {:>6}  {:>7}", n, raw, aligned, rpe, rot);
  };
  line("session", "pass", "sensors",
       numbers("N", "ATE raw cm", "ATE aligned cm", "RPE %", "rot deg"));
  bool any_by_convention = false;
  for (const PassEval& p : eval.passes) {
    if (!p.ok()) {
      line(p.session, p.pass, p.sensors, "error: " + p.error);
      continue;
    }
    const TrajectoryMetrics& m = p.metrics;
    line(p.session, p.pass + (p.frame_by_convention ? "*" : ""), p.sensors,
         numbers(std::to_string(m.num_poses), Cm(m.ate_raw_m), Cm(m.ate_aligned_m),
                 Value(m.rpe_translation_percent, "{:.2f}"), Value(m.rotation_deg, "{:.3f}")));
    any_by_convention = any_by_convention || p.frame_by_convention;
  }
  const OverallEval& o = eval.overall;
  line("all", fmt::format("{}/{}", o.num_evaluated, o.num_passes), "",
       numbers(std::to_string(o.num_poses), Cm(o.ate_raw_m), Cm(o.ate_aligned_m),
               Value(o.rpe_translation_percent, "{:.2f}"), Value(o.rotation_deg, "{:.3f}")));
  const double d = eval.options.metrics.rpe_distance_m;
  out += fmt::format(
      "ATE, rot: RMSE over poses (aligned: SE(3) alignment per pass); RPE: RMSE over {}\n",
      d > 0.0 ? fmt::format("pose pairs {:g} m of true path apart", d)
              : std::string("passes, first pose to last"));
  if (any_by_convention) {
    out +=
        "* no GPS: the pass's frame is set by convention; its raw ATE and rot are after the "
        "rotation about the vertical and the shift that fit it to the truth (heading from the "
        "orientations, shift from the centroids)\n";
  }
  for (const PassEval& p : eval.passes) {
    if (!p.time_offset_s && !p.fused_time_offset_s) continue;
    out += fmt::format("{} {}: camera-IMU time offset", p.session, p.pass);
    for (const auto& [label, estimate] :
         {std::pair{"row SLAM", p.time_offset_s}, std::pair{"fused", p.fused_time_offset_s}}) {
      if (!estimate) continue;
      out += fmt::format(" {} {:+.1f} ms", label, 1e3 * *estimate);
      if (p.true_time_offset_s) {
        out += fmt::format(" (error {:+.1f} ms)", 1e3 * (*estimate - *p.true_time_offset_s));
      }
    }
    if (p.true_time_offset_s) out += fmt::format(", truth {:+.1f} ms", 1e3 * *p.true_time_offset_s);
    out += "\n";
  }
  if (o.worst_pass >= 0) {
    const PassEval& w = eval.passes[o.worst_pass];
    out += fmt::format("worst pass (ATE raw): {} {} ({}), {:.2f} cm\n", w.session, w.pass,
                       w.sensors, 100.0 * w.metrics.ate_raw_m.rmse);
  }
  if (o.num_failed > 0) {
    out += fmt::format("{} of {} passes could not be evaluated\n", o.num_failed, o.num_passes);
  }
  return out;
}

}  // namespace crop4d::eval
