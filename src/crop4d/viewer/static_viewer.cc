#include "crop4d/viewer/static_viewer.h"

#include <filesystem>
#include <fstream>
#include <sstream>

#include "crop4d/io/atomic_file.h"
#include "crop4d/viewer/bundle.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::viewer {

namespace fs = std::filesystem;

ViewerDataSummary WriteStaticViewer(const std::string& workspace, const std::string& dir,
                                    const ViewerDataOptions& options) {
  // The page reads the tiles and the report at ws/, laid out as in a workspace.
  const workspace::Layout bundled(fs::path(dir) / "ws");
  const ViewerDataSummary summary =
      WriteViewerData(workspace, bundled.ViewerDir().string(), options);
  for (const BundledFile* f = kViewerBundle; f->path != nullptr; ++f)
    io::WriteFileAtomic((fs::path(dir) / f->path).string(), std::string(f->bytes()));
  const fs::path report = workspace::Layout(workspace).Report();
  if (fs::is_regular_file(report)) {
    std::ifstream in(report, std::ios::binary);
    std::ostringstream bytes;
    bytes << in.rdbuf();
    io::WriteFileAtomic(bundled.Report().string(), bytes.str());
  }
  return summary;
}

std::string FormatViewerDataSummary(const ViewerDataSummary& summary) {
  std::ostringstream out;
  for (const auto& s : summary.sessions) {
    out << "  " << s.id << " (" << s.date << "): " << s.points << " points from " << s.source
        << ", " << s.nodes << " tiles" << (s.rebuilt ? " (built)" : " (up to date)") << "\n";
  }
  out << "  " << summary.sites << " measurement sites; terrain from " << summary.terrain_source
      << "\n";
  return out.str();
}

}  // namespace crop4d::viewer
