#pragma once

// The folder layout of a crop4d workspace: the one place that knows where every artefact lives
// (docs/architecture.md lists each file with the stage that owns it). Every other module asks a
// Layout for a path instead of joining names by hand, so that moving a file is one edit here.
//
//   WS/crop4d.yaml, crop4d.log, run.json, run_log.jsonl, report.html, .crop4d.lock
//   WS/sessions/<session>/passes.csv
//   WS/sessions/<session>/rows/<pass>/  measurements.bin, features.bin, tracks.bin, states.csv,
//                                       initial_poses.tum, poses.tum, landmarks.ply, summary.json
//   WS/associations/<method>/<a>__<b>.bin + .json
//   WS/fused/  summary.json, quality.json, landmarks.ply, colmap/, <session>/poses.tum + sparse.ply
//   WS/dense/<session>.ply + <session>.json
//   WS/analysis/  summary.json, site_heights.csv, site_heights_single_plane.csv, site_plants.csv,
//                 growth.csv, dtm.tif, chm_<session>.tif, chm_change_<a>_<b>.tif, plots/
//   WS/eval/  metrics.json, inputs.fingerprint, depth/<session>/
//   WS/viewer/  the viewer's tiles
//
// Paths only: no function here touches the disk except the listings at the end.

#include <filesystem>
#include <string>
#include <vector>

namespace crop4d::workspace {

class Layout {
 public:
  explicit Layout(std::filesystem::path root) : root_(std::move(root)) {}

  const std::filesystem::path& root() const { return root_; }

  // The run's records (owned by `crop4d run` and the workspace lock).
  std::filesystem::path Config() const { return root_ / "crop4d.yaml"; }
  std::filesystem::path Log() const { return root_ / "crop4d.log"; }
  std::filesystem::path RunRecord() const { return root_ / "run.json"; }
  std::filesystem::path RunLog() const { return root_ / "run_log.jsonl"; }
  std::filesystem::path Report() const { return root_ / "report.html"; }
  std::filesystem::path Lock() const { return root_ / ".crop4d.lock"; }
  // A cluster run's plan and task states (owned by pipeline/cluster_run.h, which names the
  // files inside).
  std::filesystem::path ClusterDir() const { return root_ / "cluster"; }

  // Row SLAM (owned by the slam stage).
  std::filesystem::path SessionsDir() const { return root_ / "sessions"; }
  std::filesystem::path SessionDir(const std::string& session) const;
  std::filesystem::path PassList(const std::string& session) const;
  std::filesystem::path RowsDir(const std::string& session) const;
  std::filesystem::path PassDir(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassMeasurements(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassFeatures(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassTracks(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassStates(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassInitialPoses(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassPoses(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassLandmarks(const std::string& session, const std::string& pass) const;
  std::filesystem::path PassSummary(const std::string& session, const std::string& pass) const;

  // Cross-pass association (owned by the associate stage); the pair files inside are named by
  // association::PairFileName.
  std::filesystem::path AssociationsRoot() const { return root_ / "associations"; }
  std::filesystem::path AssociationsDir(const std::string& method) const;

  // The joint 4D model (owned by the fuse stage).
  std::filesystem::path FusedDir() const { return root_ / "fused"; }
  std::filesystem::path FusedSummary() const { return FusedDir() / "summary.json"; }
  std::filesystem::path FusedQuality() const { return FusedDir() / "quality.json"; }
  std::filesystem::path FusedLandmarks() const { return FusedDir() / "landmarks.ply"; }
  std::filesystem::path FusedColmapDir() const { return FusedDir() / "colmap"; }
  // The steps of the incremental fuse (pipeline/fuse_incremental.h), one folder per session.
  std::filesystem::path FusedStepsDir() const { return FusedDir() / "steps"; }
  std::filesystem::path FusedSessionDir(const std::string& session) const;
  std::filesystem::path FusedPoses(const std::string& session) const;
  std::filesystem::path FusedSparse(const std::string& session) const;
  std::filesystem::path FusedCamera(const std::string& session) const;

  // Dense clouds (owned by the densify stage).
  std::filesystem::path DenseDir() const { return root_ / "dense"; }
  std::filesystem::path DenseCloud(const std::string& session) const;
  std::filesystem::path DenseSummary(const std::string& session) const;

  // Crop measurements (owned by the analyze stage).
  std::filesystem::path AnalysisDir() const { return root_ / "analysis"; }
  std::filesystem::path AnalysisSummary() const { return AnalysisDir() / "summary.json"; }
  std::filesystem::path SiteHeights() const { return AnalysisDir() / "site_heights.csv"; }
  std::filesystem::path SiteHeightsSinglePlane() const;
  std::filesystem::path SitePlants() const { return AnalysisDir() / "site_plants.csv"; }
  std::filesystem::path Growth() const { return AnalysisDir() / "growth.csv"; }
  std::filesystem::path Dtm() const { return AnalysisDir() / "dtm.tif"; }
  std::filesystem::path PlotsDir() const { return AnalysisDir() / "plots"; }
  // File names inside AnalysisDir() (the analyze summary records them relative to it).
  static std::string ChmName(const std::string& session);
  static std::string ChmChangeName(const std::string& earlier, const std::string& later);
  std::filesystem::path Chm(const std::string& session) const;
  std::filesystem::path ChmChange(const std::string& earlier, const std::string& later) const;

  // Evaluation against ground truth (owned by `crop4d eval` and the run's eval step).
  std::filesystem::path EvalDir() const { return root_ / "eval"; }
  std::filesystem::path EvalMetrics() const { return EvalDir() / "metrics.json"; }
  std::filesystem::path EvalInputsFingerprint() const { return EvalDir() / "inputs.fingerprint"; }
  std::filesystem::path EvalDepthDir(const std::string& session) const;

  // The viewer's level-of-detail tiles (owned by the viewer).
  std::filesystem::path ViewerDir() const { return root_ / "viewer"; }

  // How a listing is sorted: by name (std::string's order) or in natural order ("row2" before
  // "row10", core/natural_less.h).
  enum class Order { kName, kNatural };
  // The sessions that have a folder under sessions/ (empty when there is none).
  std::vector<std::string> SessionFolders(Order order = Order::kName) const;
  // The pass folders of a session under rows/ (empty when there is none).
  std::vector<std::string> PassFolders(const std::string& session,
                                       Order order = Order::kName) const;
  // The session folders under fused/: every sub-folder but colmap/ (empty when there is none).
  std::vector<std::string> FusedSessionFolders(Order order = Order::kName) const;
  // The sessions with a dense cloud: the names of the dense/<session>.ply files.
  std::vector<std::string> DenseCloudSessions(Order order = Order::kName) const;
  // The sessions with a densify summary: the names of the dense/<session>.json files.
  std::vector<std::string> DenseSummarySessions(Order order = Order::kName) const;
  // The analyze stage's rasters in analysis/ (dtm.tif, chm_<session>.tif,
  // chm_change_<earlier>_<later>.tif), in name order.
  std::vector<std::filesystem::path> AnalysisRasters() const;
  // The analyze stage's tables in analysis/ that exist (SiteHeights, SiteHeightsSinglePlane,
  // SitePlants, Growth), in name order.
  std::vector<std::filesystem::path> AnalysisTables() const;
  // The stages' JSON records: every *.json file below sessions/, associations/, fused/, dense/
  // and analysis/ (the passes' summary.json, the association summaries, fused/summary.json and
  // quality.json, the densify summaries, analysis/summary.json), sorted by their path as text.
  std::vector<std::filesystem::path> StageRecordFiles() const;

 private:
  std::filesystem::path root_;
};

}  // namespace crop4d::workspace
