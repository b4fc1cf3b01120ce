#pragma once

// `crop4d export` (DESIGN.md §2.7, §5; docs/export.md): the results of a workspace in standard
// formats, in a folder of their own that can be handed to people and tools that know nothing of
// crop4d:
//
//   OUT/ply/<session>_sparse.ply   the fused sparse cloud of the session (WS/fused/<s>/sparse.ply)
//                                  or, when the session was not fused, the row-SLAM clouds of its
//                                  passes merged (WS/sessions/<s>/rows/<pass>/landmarks.ply, with
//                                  a scalar `pass`: 1-based index of the pass, in name order)
//   OUT/ply/<session>_dense.ply    the dense cloud (WS/dense/<s>.ply)
//   OUT/las/<session>_{sparse,dense}.las   the same clouds as LAS 1.4 (io/las.h): UTM easting,
//                                  northing of the field's zone and WGS 84 ellipsoidal height,
//                                  with the CRS as OGC WKT; a merged cloud's pass in the point
//                                  source id; the session's date (00:00 UTC) as adjusted standard
//                                  GPS time in every point; the ASPRS class of the analysis
//                                  (WS/analysis/dtm.tif and summary.json: 2 ground, 3/4/5
//                                  vegetation by height above the terrain, 1 where the analysis
//                                  cannot tell; docs/export.md)
//   OUT/colmap/{cameras,images,points3D}.txt   the fused COLMAP text model (checked, copied)
//   OUT/tum/<session>.tum          fused camera trajectory (WS/fused/<s>/poses.tum), or
//   OUT/tum/<session>_<pass>.tum   the row-SLAM trajectory of each pass when not fused
//   OUT/geotiff/<name>.tif         the rasters of WS/analysis (terrain model, canopy heights,
//                                  their changes), Cloud-Optimized GeoTIFFs copied as they are
//   OUT/csv/<name>.csv             the tables of WS/analysis (site heights, growth)
//   OUT/export.json                every file written: relative path, bytes, format, source
//
// PLY, TUM and COLMAP files stay in the field's ENU frame (metres, origin in field.yaml), which
// each file's header comment or export.json names. Every file is written atomically. A format
// whose inputs are missing is skipped with a warning that names what is missing (listed in the
// report and in export.json); a workspace with nothing to export is an InputError.

#include <cstdint>
#include <string>
#include <vector>

namespace crop4d::pipeline {

// The format names of ExportOptions::formats, in the order they are written.
const std::vector<std::string>& ExportFormatNames();

struct ExportOptions {
  // Formats to write: any of ply, las, colmap, tum, geotiff, csv.
  std::vector<std::string> formats = {"ply", "colmap", "tum", "geotiff", "csv"};
  // The clouds the ply and las formats write: "dense", "sparse" or "both".
  std::string clouds = "both";
  // A progress line per file written (core/progress.h).
  bool show_progress = true;

  // Known, non-empty formats and a known `clouds`. On failure, `why` (if not null) says what is
  // wrong.
  bool Check(std::string* why = nullptr) const;
};

struct ExportedFile {
  std::string format;       // "ply", "las", ...
  std::string path;         // relative to the output folder, '/'-separated
  std::uint64_t bytes = 0;  // size of the file written
  std::string source;       // the workspace file(s) it comes from, relative to the workspace
  std::uint64_t items = 0;  // points, poses, images, raster cells or table rows
  std::string item_unit;    // "points", "poses", ...
};

struct ExportSkip {
  std::string format;   // the format(s) concerned, e.g. "ply, las"
  std::string message;  // what is missing
};

struct ExportReport {
  std::string out_dir;
  int epsg = 0;  // the field's UTM zone (EPSG code)
  std::vector<ExportedFile> files;
  std::vector<ExportSkip> skipped;
  double seconds = 0;
};

// Exports `workspace` (of the field in `field_folder`) into `out_dir` (created when missing;
// files already there are overwritten, others left alone). Throws InputError for invalid
// options, a missing field or workspace, malformed inputs (naming the file), and when no
// requested format has anything to export.
ExportReport RunExport(const std::string& field_folder, const std::string& workspace,
                       const std::string& out_dir, const ExportOptions& options);

// A table of the files written and the formats skipped, for the terminal.
std::string FormatExportReport(const ExportReport& report);

}  // namespace crop4d::pipeline
