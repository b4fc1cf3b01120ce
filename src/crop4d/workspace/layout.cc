#include "crop4d/workspace/layout.h"

#include <algorithm>

#include "crop4d/core/natural_less.h"

namespace crop4d::workspace {

namespace fs = std::filesystem;

fs::path Layout::SessionDir(const std::string& session) const { return SessionsDir() / session; }

fs::path Layout::PassList(const std::string& session) const {
  return SessionDir(session) / "passes.csv";
}

fs::path Layout::RowsDir(const std::string& session) const { return SessionDir(session) / "rows"; }

fs::path Layout::PassDir(const std::string& session, const std::string& pass) const {
  return RowsDir(session) / pass;
}

fs::path Layout::PassMeasurements(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "measurements.bin";
}

fs::path Layout::PassFeatures(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "features.bin";
}

fs::path Layout::PassTracks(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "tracks.bin";
}

fs::path Layout::PassStates(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "states.csv";
}

fs::path Layout::PassInitialPoses(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "initial_poses.tum";
}

fs::path Layout::PassPoses(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "poses.tum";
}

fs::path Layout::PassLandmarks(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "landmarks.ply";
}

fs::path Layout::PassSummary(const std::string& session, const std::string& pass) const {
  return PassDir(session, pass) / "summary.json";
}

fs::path Layout::AssociationsDir(const std::string& method) const {
  return AssociationsRoot() / method;
}

fs::path Layout::FusedSessionDir(const std::string& session) const { return FusedDir() / session; }

fs::path Layout::FusedPoses(const std::string& session) const {
  return FusedSessionDir(session) / "poses.tum";
}

fs::path Layout::FusedSparse(const std::string& session) const {
  return FusedSessionDir(session) / "sparse.ply";
}

fs::path Layout::FusedCamera(const std::string& session) const {
  return FusedSessionDir(session) / "camera.json";
}

fs::path Layout::DenseCloud(const std::string& session) const {
  return DenseDir() / (session + ".ply");
}

fs::path Layout::DenseSummary(const std::string& session) const {
  return DenseDir() / (session + ".json");
}

fs::path Layout::SiteHeightsSinglePlane() const {
  return AnalysisDir() / "site_heights_single_plane.csv";
}

std::string Layout::ChmName(const std::string& session) { return "chm_" + session + ".tif"; }

std::string Layout::ChmChangeName(const std::string& earlier, const std::string& later) {
  return "chm_change_" + earlier + "_" + later + ".tif";
}

fs::path Layout::Chm(const std::string& session) const { return AnalysisDir() / ChmName(session); }

fs::path Layout::ChmChange(const std::string& earlier, const std::string& later) const {
  return AnalysisDir() / ChmChangeName(earlier, later);
}

fs::path Layout::EvalDepthDir(const std::string& session) const {
  return EvalDir() / "depth" / session;
}

namespace {

void Sort(std::vector<std::string>* names, Layout::Order order) {
  if (order == Layout::Order::kNatural) {
    std::sort(names->begin(), names->end(), NaturalLess);
  } else {
    std::sort(names->begin(), names->end());
  }
}

// Names of the sub-folders of `dir` in `order`; empty when `dir` is missing or unreadable.
std::vector<std::string> SubfolderNames(const fs::path& dir, Layout::Order order) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (it->is_directory(type_ec)) names.push_back(it->path().filename().string());
  }
  Sort(&names, order);
  return names;
}

}  // namespace

std::vector<std::string> Layout::SessionFolders(Order order) const {
  return SubfolderNames(SessionsDir(), order);
}

std::vector<std::string> Layout::PassFolders(const std::string& session, Order order) const {
  return SubfolderNames(RowsDir(session), order);
}

std::vector<std::string> Layout::FusedSessionFolders(Order order) const {
  std::vector<std::string> names = SubfolderNames(FusedDir(), order);
  const std::string colmap = FusedColmapDir().filename().string();
  names.erase(std::remove(names.begin(), names.end(), colmap), names.end());
  return names;
}

namespace {

// The sessions of the files in `dir` whose path is `path(session)` (the session being the file's
// stem), in `order`.
template <typename PathOf>
std::vector<std::string> SessionsOfFiles(const fs::path& dir, PathOf path, Layout::Order order) {
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (!it->is_regular_file(type_ec)) continue;
    const std::string session = it->path().stem().string();
    if (it->path() == path(session)) names.push_back(session);
  }
  Sort(&names, order);
  return names;
}

}  // namespace

std::vector<std::string> Layout::DenseCloudSessions(Order order) const {
  return SessionsOfFiles(
      DenseDir(), [this](const std::string& s) { return DenseCloud(s); }, order);
}

std::vector<std::string> Layout::DenseSummarySessions(Order order) const {
  return SessionsOfFiles(
      DenseDir(), [this](const std::string& s) { return DenseSummary(s); }, order);
}

std::vector<fs::path> Layout::AnalysisRasters() const {
  // The analyze stage empties analysis/ before it writes, so its rasters are the .tif files
  // there named as dtm.tif, ChmName or ChmChangeName name them.
  const std::string dtm = Dtm().filename().string();
  const std::string chm_prefix = "chm_";
  std::vector<std::string> names;
  std::error_code ec;
  for (fs::directory_iterator it(AnalysisDir(), ec), end; !ec && it != end; it.increment(ec)) {
    std::error_code type_ec;
    if (!it->is_regular_file(type_ec) || it->path().extension() != ".tif") continue;
    const std::string name = it->path().filename().string();
    if (name == dtm || name.rfind(chm_prefix, 0) == 0) names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  std::vector<fs::path> paths;
  for (const std::string& name : names) paths.push_back(AnalysisDir() / name);
  return paths;
}

std::vector<fs::path> Layout::AnalysisTables() const {
  std::vector<fs::path> paths;
  std::error_code ec;
  for (const fs::path& p : {SiteHeights(), SiteHeightsSinglePlane(), SitePlants(), Growth()}) {
    if (fs::is_regular_file(p, ec)) paths.push_back(p);
  }
  std::sort(paths.begin(), paths.end(), [](const fs::path& a, const fs::path& b) {
    return a.filename().string() < b.filename().string();
  });
  return paths;
}

std::vector<fs::path> Layout::StageRecordFiles() const {
  std::vector<std::string> files;
  for (const fs::path& folder :
       {SessionsDir(), AssociationsRoot(), FusedDir(), DenseDir(), AnalysisDir()}) {
    std::error_code ec;
    for (fs::recursive_directory_iterator it(folder, ec), end; !ec && it != end; it.increment(ec)) {
      if (it->path().extension() == ".json") files.push_back(it->path().string());
    }
  }
  std::sort(files.begin(), files.end());
  return std::vector<fs::path>(files.begin(), files.end());
}

}  // namespace crop4d::workspace
