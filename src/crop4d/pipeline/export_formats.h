#pragma once

// The files of `crop4d export` (export_stage.h), one writer per kind: a session's cloud as PLY
// and LAS (with the frame in the PLY comment, the date as GPS time and the analysis' classes in
// the LAS points), copies of workspace files written atomically, and export.json. Internal to
// the export stage.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/analysis/point_classes.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/ply.h"
#include "crop4d/pipeline/export_stage.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {

// What every job needs: the workspace, the output folder, the field's frame, and the report's
// list of skipped formats.
struct ExportContext {
  workspace::Layout ws;
  std::filesystem::path out;
  geometry::GeodeticPoint origin;
  int epsg = 0;
  ExportReport* report = nullptr;

  // A workspace file as the report names its source: relative to the workspace.
  std::string Rel(const std::filesystem::path& p) const {
    return std::filesystem::relative(p, ws.root()).generic_string();
  }
  void Skip(const std::string& format, const std::string& message) const;
};

// One cloud of one session to write as PLY and/or LAS.
struct CloudJob {
  std::string session;
  std::string kind;                            // "sparse" or "dense"
  std::string what;                            // for the PLY comment
  std::vector<std::filesystem::path> sources;  // one cloud, or the passes' clouds to merge
  bool merged = false;                         // the row-SLAM clouds of the passes
  bool ply = false, las = false;               // the formats to write
  double gps_time = 0.0;                       // of the session's date (LAS)
  std::optional<double> threshold;             // the session's vegetation threshold (LAS classes)
  const analysis::PointClassRule* rule = nullptr;
};

// Writes OUT/ply/<session>_<kind>.ply and/or OUT/las/<session>_<kind>.las; adds them to `files`.
void ExportCloud(const ExportContext& ctx, const CloudJob& job, std::vector<ExportedFile>* files);

// The clouds of several row passes as one: common scalars (same name and type), colours when
// every pass has them, and a scalar `pass` (1-based index in `clouds`).
io::PlyPointCloud MergePassClouds(const std::vector<io::PlyPointCloud>& clouds);

// Copies `from` to `to` atomically.
void CopyFileAtomic(const std::filesystem::path& from, const std::filesystem::path& to);

// The size of a file; 0 when it cannot be read.
std::uint64_t FileBytes(const std::filesystem::path& p);

std::string Join(const std::vector<std::string>& items, const std::string& separator);

// export.json: what was written, from where, and the frames. `classified`: the LAS points carry
// the analysis' classes; else `classes_why` says why not.
void WriteExportManifest(const ExportContext& ctx, const std::string& field_folder,
                         const ExportOptions& options, bool classified,
                         const std::string& classes_why);

}  // namespace crop4d::pipeline
