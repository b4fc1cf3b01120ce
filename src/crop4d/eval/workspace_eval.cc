#include "crop4d/eval/workspace_eval.h"

#include <fmt/format.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/core/version.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/tum.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::ordered_json;  // keys in the order written (schema order)

// "2" < "10": runs of digits compare as numbers, everything else character by character.
bool NaturalLess(const std::string& a, const std::string& b) {
  std::size_t i = 0, j = 0;
  while (i < a.size() && j < b.size()) {
    const bool da = std::isdigit(static_cast<unsigned char>(a[i])) != 0;
    const bool db = std::isdigit(static_cast<unsigned char>(b[j])) != 0;
    if (da && db) {
      std::size_t ie = i, je = j;
      while (ie < a.size() && std::isdigit(static_cast<unsigned char>(a[ie]))) ++ie;
      while (je < b.size() && std::isdigit(static_cast<unsigned char>(b[je]))) ++je;
      std::string na = a.substr(i, ie - i), nb = b.substr(j, je - j);
      na.erase(0, std::min(na.find_first_not_of('0'), na.size()));
      nb.erase(0, std::min(nb.find_first_not_of('0'), nb.size()));
      if (na.size() != nb.size()) return na.size() < nb.size();
      if (na != nb) return na < nb;
      i = ie;
      j = je;
    } else {
      if (a[i] != b[j]) return a[i] < b[j];
      ++i;
      ++j;
    }
  }
  if ((a.size() - i) != (b.size() - j)) return (a.size() - i) < (b.size() - j);
  return a < b;
}

std::vector<std::string> SubFolders(const fs::path& dir) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, ec)) {
    if (entry.is_directory(ec)) names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end(), NaturalLess);
  return names;
}

std::string ReadWholeFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot open file");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Reads summary.json into `pass`; throws InputError naming the file.
void ReadPassSummary(const fs::path& path, PassEval* pass) {
  const std::string file = path.string();
  std::error_code ec;
  if (!fs::exists(path, ec)) throw InputError(file, 0, "file not found");
  json j;
  try {
    j = json::parse(ReadWholeFile(path));
  } catch (const json::parse_error& e) {
    throw InputError(file, 0, fmt::format("not valid JSON ({})", e.what()));
  }
  if (!j.is_object()) throw InputError(file, 0, "expected a JSON object");

  const auto string_key = [&](const char* key, std::string* out) {
    if (!j.contains(key)) return false;
    if (j[key].is_string()) {
      *out = j[key].get<std::string>();
    } else if (j[key].is_number_integer()) {
      *out = std::to_string(j[key].get<std::int64_t>());
    } else {
      throw InputError(file, 0, fmt::format("'{}' must be a string", key));
    }
    return true;
  };
  const auto int_key = [&](const char* key, int* out) {
    if (!j.contains(key)) return;
    if (!j[key].is_number_integer())
      throw InputError(file, 0, fmt::format("'{}' must be an integer", key));
    *out = j[key].get<int>();
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
  string_key("sensors", &pass->sensors);
  if (!j.contains("pose_frame"))
    throw InputError(file, 0, "missing required key 'pose_frame' (\"camera\" or \"body\")");
  if (!j["pose_frame"].is_string())
    throw InputError(file, 0, "'pose_frame' must be \"camera\" or \"body\"");
  pass->pose_frame = j["pose_frame"].get<std::string>();
  if (pass->pose_frame != "camera" && pass->pose_frame != "body") {
    throw InputError(
        file, 0,
        fmt::format("'pose_frame' is '{}', expected \"camera\" or \"body\"", pass->pose_frame));
  }
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

std::string Cm(const ErrorStats& s) {
  return s.count == 0 ? std::string("-") : fmt::format("{:.2f}", 100.0 * s.rmse);
}
std::string Value(const ErrorStats& s, const char* format) {
  return s.count == 0 ? std::string("-") : fmt::format(fmt::runtime(format), s.rmse);
}

}  // namespace

bool WorkspaceEvalOptions::Check() const {
  return metrics.Check() && std::isfinite(max_dt_s) && max_dt_s >= 0.0;
}

WorkspaceEval EvaluateWorkspace(const std::string& workspace, const std::string& field,
                                const WorkspaceEvalOptions& options) {
  CROP4D_CHECK(options.Check());
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
  const fs::path sessions_dir = fs::path(workspace) / "sessions";
  for (const std::string& session : SubFolders(sessions_dir)) {
    if (!options.sessions.empty() && std::find(options.sessions.begin(), options.sessions.end(),
                                               session) == options.sessions.end()) {
      continue;
    }
    for (const std::string& pass_id : SubFolders(sessions_dir / session / "rows")) {
      PassEval pass;
      pass.session = session;
      pass.pass = pass_id;
      const std::string rel = "sessions/" + session + "/rows/" + pass_id + "/";
      pass.poses_file = rel + "poses.tum";
      eval.passes.push_back(pass);
    }
  }
  if (eval.passes.empty()) {
    throw InputError(
        workspace, 0,
        options.sessions.empty()
            ? "no row pass in the workspace: expected sessions/<session>/rows/<pass>/ folders "
              "(written by crop4d slam)"
            : "no row pass of the selected sessions in the workspace");
  }

  // Truth files, read once per session and frame (body_poses.tum is at the IMU rate).
  std::map<std::string, std::vector<io::StampedPose>> truth_cache;
  const Timestamp max_dt = SecondsToTimestamp(options.max_dt_s);
  for (PassEval& pass : eval.passes) {
    try {
      const fs::path pass_dir = fs::path(workspace) / pass.poses_file;
      ReadPassSummary(pass_dir.parent_path() / "summary.json", &pass);
      pass.truth_file = "ground_truth/" + pass.session + "/" +
                        (pass.pose_frame == "camera" ? "cam0_poses.tum" : "body_poses.tum");
      if (!fs::exists(pass_dir, ec)) throw InputError(pass_dir.string(), 0, "file not found");
      const std::vector<io::StampedPose> estimate = io::ReadTum(pass_dir.string());
      pass.estimate_poses = static_cast<int>(estimate.size());
      if (estimate.empty()) throw InputError(pass_dir.string(), 0, "holds no pose");

      auto cached = truth_cache.find(pass.truth_file);
      if (cached == truth_cache.end()) {
        const fs::path truth_path = fs::path(field) / pass.truth_file;
        if (!fs::exists(truth_path, ec)) {
          throw InputError(truth_path.string(), 0,
                           fmt::format("no ground truth for session '{}' ({} poses): file not "
                                       "found",
                                       pass.session, pass.pose_frame));
        }
        cached = truth_cache.emplace(pass.truth_file, io::ReadTum(truth_path.string())).first;
      }
      const AssociatedPoses associated = AssociateByTime(estimate, cached->second, max_dt);
      pass.exact = associated.exact;
      pass.interpolated = associated.interpolated;
      pass.dropped_out_of_span = associated.dropped_out_of_span;
      pass.dropped_gap = associated.dropped_gap;
      if (associated.size() == 0) {
        throw InputError(
            pass_dir.string(), 0,
            fmt::format("none of its {} poses can be compared with {} ({} outside "
                        "the truth's time span, {} in gaps wider than {} s)",
                        estimate.size(), pass.truth_file, associated.dropped_out_of_span,
                        associated.dropped_gap, options.max_dt_s));
      }
      pass.metrics =
          ComputeTrajectoryMetrics(associated.estimate, associated.truth, options.metrics);
    } catch (const InputError& e) {
      pass.error = e.what();
    }
  }

  // Pooled.
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
  return eval;
}

std::string WorkspaceEvalJson(const WorkspaceEval& eval) {
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
    p["poses_file"] = pass.poses_file;
    p["truth_file"] = pass.truth_file;
    p["error"] = pass.ok() ? json(nullptr) : json(pass.error);
    p["association"] = {{"estimate_poses", pass.estimate_poses},
                        {"exact", pass.exact},
                        {"interpolated", pass.interpolated},
                        {"dropped_out_of_span", pass.dropped_out_of_span},
                        {"dropped_gap", pass.dropped_gap}};
    p["metrics"] = pass.ok() ? MetricsJson(pass.metrics) : json(nullptr);
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
  return root.dump(2) + "\n";
}

std::string WriteWorkspaceEval(const WorkspaceEval& eval, const std::string& path) {
  const std::string out =
      path.empty() ? (fs::path(eval.workspace) / "eval" / "metrics.json").string() : path;
  io::WriteFileAtomic(out, WorkspaceEvalJson(eval));
  return out;
}

std::string FormatWorkspaceEvalTable(const WorkspaceEval& eval) {
  std::size_t w_session = 7, w_pass = 4, w_sensors = 7;
  for (const PassEval& p : eval.passes) {
    w_session = std::max(w_session, p.session.size());
    w_pass = std::max(w_pass, p.pass.size());
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
  for (const PassEval& p : eval.passes) {
    if (!p.ok()) {
      line(p.session, p.pass, p.sensors, "error: " + p.error);
      continue;
    }
    const TrajectoryMetrics& m = p.metrics;
    line(p.session, p.pass, p.sensors,
         numbers(std::to_string(m.num_poses), Cm(m.ate_raw_m), Cm(m.ate_aligned_m),
                 Value(m.rpe_translation_percent, "{:.2f}"), Value(m.rotation_deg, "{:.3f}")));
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
