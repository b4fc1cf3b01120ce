#include "crop4d/eval/fused_eval.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/eval/natural_order.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/pass_summary.h"

namespace crop4d::eval {
namespace {

namespace fs = std::filesystem;

bool Selected(const std::vector<std::string>& sessions, const std::string& session) {
  return sessions.empty() || std::find(sessions.begin(), sessions.end(), session) != sessions.end();
}

// Whether a row pass of the session says its frame is set by convention (summary.json "trust"
// holds origin_by_convention: a session without GPS).
bool SessionFrameByConvention(const std::string& workspace, const std::string& session) {
  const workspace::Layout ws(workspace);
  for (const std::string& pass : ws.PassFolders(session)) {
    std::error_code ec;
    if (!fs::exists(ws.PassSummary(session, pass), ec)) continue;
    const workspace::PassSummary summary =
        workspace::ReadPassSummary(ws.PassSummary(session, pass).string());
    if (std::find(summary.trust.begin(), summary.trust.end(), "origin_by_convention") !=
        summary.trust.end()) {
      return true;
    }
  }
  return false;
}

}  // namespace

FusedEval EvaluateFusedTrajectories(const std::string& workspace, const std::string& field,
                                    const std::vector<std::string>& session_order,
                                    const std::vector<std::string>& sessions, Timestamp max_dt,
                                    const TrajectoryMetricsOptions& options) {
  FusedEval eval;
  std::vector<std::string> names;
  std::error_code ec;
  const workspace::Layout ws(workspace);
  for (const std::string& s : ws.FusedSessionFolders(workspace::Layout::Order::kNatural)) {
    if (Selected(sessions, s) && fs::exists(ws.FusedPoses(s), ec)) {
      names.push_back(s);
    }
  }
  SortByOrder(session_order, &names);

  std::vector<ErrorStats> raw, aligned, rot;
  std::vector<Eigen::Vector3d> all_estimate, all_truth;
  std::optional<CalibrationTruth> calibration_truth;
  try {
    calibration_truth = ReadCalibrationTruth(field);
  } catch (const InputError& e) {
    spdlog::warn("eval: the fused calibration is not evaluated: {}", e.what());
  }
  for (const std::string& session : names) {
    FusedSessionEval s;
    s.session = session;
    s.poses_file = ws.FusedPoses(session).lexically_relative(ws.root()).generic_string();
    s.truth_file = "ground_truth/" + session + "/cam0_poses.tum";
    try {
      const fs::path poses_path = ws.FusedPoses(session);
      const std::vector<io::StampedPose> estimate = io::ReadTum(poses_path.string());
      s.estimate_poses = static_cast<int>(estimate.size());
      if (estimate.empty()) throw InputError(poses_path.string(), 0, "holds no pose");
      const fs::path truth_path = fs::path(field) / s.truth_file;
      if (!fs::exists(truth_path, ec)) {
        throw InputError(truth_path.string(), 0,
                         fmt::format("no ground truth for session '{}': file not found", session));
      }
      const AssociatedPoses associated =
          AssociateByTime(estimate, io::ReadTum(truth_path.string()), max_dt);
      s.exact = associated.exact;
      s.interpolated = associated.interpolated;
      s.dropped = associated.dropped();
      if (associated.size() == 0) {
        throw InputError(poses_path.string(), 0,
                         fmt::format("none of its {} poses can be compared with {}",
                                     estimate.size(), s.truth_file));
      }
      std::vector<geometry::Rigid3> estimate_poses = associated.estimate;
      s.frame_by_convention = SessionFrameByConvention(workspace, session);
      if (s.frame_by_convention) {
        const geometry::Rigid3 truth_from_local =
            AlignYawTranslation(estimate_poses, associated.truth);
        for (geometry::Rigid3& pose : estimate_poses) pose = truth_from_local * pose;
      }
      s.metrics = ComputeTrajectoryMetrics(estimate_poses, associated.truth, options);
      if (calibration_truth) {
        try {
          s.calibration = EvaluateFusedCalibration(workspace, session, *calibration_truth);
        } catch (const InputError& e) {
          spdlog::warn("eval: session {}: the fused calibration is not evaluated: {}", session,
                       e.what());
        }
      }
      for (int k = 0; k < associated.size(); ++k) {
        all_estimate.push_back(estimate_poses[k].translation());
        all_truth.push_back(associated.truth[k].translation());
      }
      ++eval.num_evaluated;
      eval.num_poses += s.metrics.num_poses;
      raw.push_back(s.metrics.ate_raw_m);
      aligned.push_back(s.metrics.ate_aligned_m);
      rot.push_back(s.metrics.rotation_deg);
    } catch (const InputError& e) {
      s.error = e.what();
      ++eval.num_failed;
    }
    eval.sessions.push_back(std::move(s));
  }
  eval.ate_raw_m = ErrorStats::Pool(raw);
  eval.ate_aligned_m = ErrorStats::Pool(aligned);
  eval.rotation_deg = ErrorStats::Pool(rot);
  if (all_estimate.size() >= 3) {
    eval.truth_from_estimate_joint = AlignSE3(all_estimate, all_truth);
    std::vector<double> errors;
    errors.reserve(all_estimate.size());
    for (std::size_t k = 0; k < all_estimate.size(); ++k) {
      errors.push_back((eval.truth_from_estimate_joint * all_estimate[k] - all_truth[k]).norm());
    }
    eval.ate_aligned_joint_m = ErrorStats::Of(errors);
  }
  return eval;
}

std::vector<SessionCloudFiles> FindCloudFiles(const std::string& workspace,
                                              const std::string& label,
                                              const std::vector<std::string>& session_order,
                                              const std::vector<std::string>& sessions) {
  std::vector<SessionCloudFiles> clouds;
  std::error_code ec;
  const workspace::Layout ws(workspace);
  const auto relative = [&](const fs::path& p) {
    return p.lexically_relative(ws.root()).generic_string();
  };
  std::vector<std::string> names;
  constexpr auto kNatural = workspace::Layout::Order::kNatural;
  for (const std::string& s :
       label == "fused" ? ws.FusedSessionFolders(kNatural) : ws.SessionFolders(kNatural)) {
    if (Selected(sessions, s)) names.push_back(s);
  }
  SortByOrder(session_order, &names);
  for (const std::string& session : names) {
    SessionCloudFiles c;
    c.session = session;
    if (label == "fused") {
      if (fs::is_regular_file(ws.FusedSparse(session), ec)) {
        c.files.push_back(relative(ws.FusedSparse(session)));
      }
    } else {
      for (const std::string& pass : ws.PassFolders(session, kNatural)) {
        if (fs::is_regular_file(ws.PassLandmarks(session, pass), ec)) {
          c.files.push_back(relative(ws.PassLandmarks(session, pass)));
        }
      }
    }
    if (!c.files.empty()) clouds.push_back(std::move(c));
  }
  return clouds;
}

CloudSetEval EvaluateCloudSet(const std::string& workspace, const std::string& field,
                              const std::string& label,
                              const std::vector<SessionCloudFiles>& clouds,
                              const CloudSetOptions& options) {
  CloudSetEval eval;
  eval.label = label;
  TerrainGrid terrain;
  const fs::path terrain_path = fs::path(field) / "ground_truth" / "terrain.csv";
  std::error_code ec;
  try {
    if (!fs::exists(terrain_path, ec)) {
      throw InputError(terrain_path.string(), 0, "file not found (the true terrain)");
    }
    terrain = TerrainGrid::Read(terrain_path.string());
  } catch (const InputError& e) {
    eval.error = e.what();
  }

  std::vector<SessionGround> grounds;
  for (const SessionCloudFiles& c : clouds) {
    CloudSetEval::Session s;
    s.session = c.session;
    s.files = c.files;
    if (eval.error.empty()) {
      try {
        std::vector<Eigen::Vector3d> points;
        for (const std::string& file : c.files) {
          io::PlyPointCloud cloud = io::ReadPly((fs::path(workspace) / file).string());
          points.insert(points.end(), cloud.points.begin(), cloud.points.end());
        }
        s.points = static_cast<std::int64_t>(points.size());
        const fs::path plants_path = fs::path(field) / "ground_truth" / c.session / "plants.csv";
        if (!fs::exists(plants_path, ec)) {
          throw InputError(
              plants_path.string(), 0,
              fmt::format("no true plants for session '{}': file not found", c.session));
        }
        // Weeds (weeds.csv, same columns; fields of `realism: real`) are no ground either:
        // one that emerged between two sessions is a change of the surface, not a
        // misregistration.
        std::vector<PlantFootprint> plants = ReadPlantsCsv(plants_path.string());
        const fs::path weeds_path = fs::path(field) / "ground_truth" / c.session / "weeds.csv";
        if (fs::exists(weeds_path, ec)) {
          const std::vector<PlantFootprint> weeds = ReadPlantsCsv(weeds_path.string());
          plants.insert(plants.end(), weeds.begin(), weeds.end());
        }
        SessionGround ground;
        ground.session = c.session;
        ground.points = SelectGroundPoints(points, plants, terrain, options.selection);
        s.ground_points = static_cast<std::int64_t>(ground.points.size());
        grounds.push_back(std::move(ground));
      } catch (const InputError& e) {
        s.error = e.what();
      }
    }
    eval.sessions.push_back(std::move(s));
  }
  if (eval.error.empty()) {
    eval.misalignment = ComputeGroundMisalignment(grounds, options.misalignment);
  }
  return eval;
}

}  // namespace crop4d::eval
