#include "crop4d/pipeline/fuse_stage.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/version.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/pipeline/fuse_incremental.h"
#include "crop4d/pipeline/fuse_outputs.h"
#include "crop4d/pipeline/fuse_pass.h"
#include "crop4d/pipeline/fuse_problem.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/stage_files.h"
#include "crop4d/workspace/stage_summary.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

// The whole season in one joint problem (FuseStageOptions::one_problem).
FuseReport RunOneProblemFuse(fuse::SeasonPasses& season, const std::string& workspace,
                             const std::vector<fs::path>& association_files,
                             const FuseStageOptions& options) {
  const auto start = Clock::now();
  FuseReport report;
  const workspace::Layout layout(workspace);
  fuse::PassList& passes = season.passes;
  const std::vector<std::string>& sessions = season.sessions;
  Fnv1aHasher fingerprint;
  fingerprint.Add(fuse::kFuseStageRevision);
  fingerprint.AddString(kVersion);
  fingerprint.AddString(FuseOptionsJson(options).dump());
  for (const auto& pass : passes) {
    fingerprint.AddString(pass->data.label());
    fingerprint.AddString(pass->data.fingerprint);
  }
  for (const fs::path& path : association_files) {
    fingerprint.AddString(path.filename().string());
    fingerprint.AddString(workspace::FileHash(path));
  }
  const std::string stamp = std::to_string(fingerprint.hash());
  const fs::path out_dir = layout.FusedDir();
  if (!options.force && fuse::FusedUpToDate(layout, sessions, stamp)) {
    spdlog::info("fuse: up to date, skipped (--force to fuse again)");
    report.skipped = true;
    report.num_sessions = static_cast<int>(sessions.size());
    report.num_passes = static_cast<int>(passes.size());
    report.quality = ReadSeasonQuality(workspace);
    return report;
  }
  // The steps of an incremental fuse do not belong to this one.
  fs::remove_all(layout.FusedStepsDir());

  // Load the passes and rebuild their problems.
  for (auto& pass : passes) fuse::LoadPassProblem(workspace, pass.get());
  report.num_sessions = static_cast<int>(sessions.size());
  report.num_passes = static_cast<int>(passes.size());

  std::vector<fuse::SessionPair> session_pairs;
  const fusion::CrossPassTracks graph = fuse::BuildLandmarkGraph(
      passes, season.index, association_files, options, &report, &session_pairs);

  const std::vector<bool> every_pass(passes.size(), true);
  std::vector<fusion::JointLandmark> landmarks =
      fuse::JoinLandmarks(graph, passes, every_pass, &report.num_conflicting_matches);
  spdlog::info(
      "fuse: {} passes of {} sessions, {} landmarks, {} cross matches from {} files ({} dropped "
      "as inconsistent)",
      passes.size(), sessions.size(), landmarks.size(), report.num_cross_matches,
      report.num_association_files, report.num_conflicting_matches);

  const std::vector<fusion::JointGroundTie> ties =
      fuse::GroundTies(passes, session_pairs, options, &report);

  // The grades of the sessions: a degraded session must not move the others.
  const std::vector<bool> protects = fuse::GradeSessions(passes, options, &report);

  const fusion::JointOptimiser::Result result =
      fuse::SolveJoint(graph, passes, landmarks, ties, protects, {}, options);
  report.joint = result.summary;
  report.calibrations = result.calibrations;

  // Outputs.
  const std::vector<std::vector<geometry::Rigid3>> cameras =
      fuse::FusedCameras(passes, result, &report);
  const std::vector<workspace::FusedCamera> intrinsics = fuse::FusedIntrinsics(passes, result);
  fuse::WriteSessionOutputs(passes, cameras, intrinsics, sessions, options, layout);
  fuse::WriteSeasonLandmarks(passes, cameras, intrinsics, landmarks, result, options.write_colmap,
                             layout);
  report.seconds = SecondsSince(start);

  json summary = fuse::FuseSummaryJson(report, result, stamp, options, sessions);
  workspace::WriteSeasonQuality(layout.FusedQuality().string(), report.quality);
  // Every file in fused/ is this stage's: all are recorded, and checked before a rerun skips.
  workspace::RecordOutputs(&summary, out_dir, workspace::FilesBelow(out_dir));
  workspace::WriteFusedSummary(layout.FusedSummary().string(), summary);
  return report;
}

}  // namespace

std::string FuseStageOptions::Check() const {
  if (method != "robust" && method != "naive") {
    return "method: must be robust or naive (got '" + method + "')";
  }
  if (max_matches_per_image_pair < 0) return "max_matches_per_image_pair: must be >= 0 (0: all)";
  if (window_sessions < 1) return "window_sessions: must be >= 1";
  if (full_sweeps < 1) return "full_sweeps: must be >= 1";
  if (full && one_problem) {
    return "full: a full re-optimisation a window at a time and one_problem (the season in one "
           "problem) exclude each other";
  }
  if (ground_tie_max_matches < 0) return "ground_tie_max_matches: must be >= 0";
  // The nested options of the modules (docs/fusion.md).
  if (const std::string why = ground_tie.Check(); !why.empty()) return "ground_tie." + why;
  if (const std::string why = optimiser.Check(); !why.empty()) return "optimiser." + why;
  if (const std::string why = blocks.Check(); !why.empty()) return "blocks." + why;
  if (const std::string why = cloud.Check(); !why.empty()) return "cloud." + why;
  return {};
}

FuseReport RunFuseStage(const std::string& field_folder, const std::string& workspace,
                        const FuseStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("fuse." + why);
  const io::Field field(field_folder);
  fuse::SeasonPasses season = fuse::ListSeasonPasses(field.session_ids(), workspace);
  const workspace::Layout layout(workspace);
  const fs::path association_dir = layout.AssociationsDir(options.method);
  const std::vector<fs::path> association_files = fuse::AssociationFiles(association_dir);
  if (association_files.empty()) {
    spdlog::warn(
        "fuse: no associations in {} (run `crop4d associate`); the passes are optimised "
        "together but nothing ties them to each other",
        association_dir.string());
  }
  return options.one_problem
             ? RunOneProblemFuse(season, workspace, association_files, options)
             : fuse::RunIncrementalFuse(season, workspace, association_files, options);
}

}  // namespace crop4d::pipeline
