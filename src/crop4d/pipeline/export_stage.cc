#include "crop4d/pipeline/export_stage.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <functional>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>
#include <sstream>

#include "crop4d/analysis/point_classes.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/colmap_text.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/las.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/pipeline/export_formats.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

bool Wants(const ExportOptions& options, const std::string& format) {
  return std::find(options.formats.begin(), options.formats.end(), format) != options.formats.end();
}

// What one session offers.
struct SessionInputs {
  std::string id;
  fs::path fused_sparse;                // empty when missing
  std::vector<fs::path> pass_clouds;    // the passes' landmarks.ply, in pass name order
  fs::path dense;                       // empty when missing
  fs::path fused_poses;                 // empty when missing
  std::vector<std::string> pass_poses;  // pass names with a poses.tum
};

// The work of one output (or a PLY and a LAS of the same cloud).
struct Job {
  std::string label;
  std::function<void(std::vector<ExportedFile>*)> run;
};

// The date of a session (midnight UTC): its session.yaml, else the date its id starts with.
std::optional<Timestamp> SessionDate(const io::Field& field, const std::string& id) {
  try {
    return field.OpenSession(id).info().date;
  } catch (const std::exception&) {
    return io::DateFromSessionId(id);
  }
}

// The analysis' separation of the ground from the vegetation, read back from WS/analysis
// (dtm.tif, and the options and thresholds of summary.json) to classify the points of the LAS
// files; nullopt, with `why`, when either is missing or cannot be read.
std::optional<analysis::PointClassRule> ReadPointClassRule(const workspace::Layout& ws,
                                                           std::string* why) {
  std::error_code ec;
  if (!fs::is_regular_file(ws.Dtm(), ec) || !fs::is_regular_file(ws.AnalysisSummary(), ec)) {
    *why = "no terrain model WS/analysis/dtm.tif with its summary.json (run `crop4d analyze`)";
    return std::nullopt;
  }
  try {
    analysis::PointClassRule rule;
    rule.dtm = io::ReadGeoTiff(ws.Dtm().string());
    const workspace::AnalysisSummary summary = workspace::ReadAnalysisSummary(ws.AnalysisSummary());
    const json& options = summary.options;
    const std::string index = options.at("vegetation").at("index").get<std::string>();
    if (index == analysis::GreennessIndexName(analysis::GreennessIndex::kExGR)) {
      rule.index = analysis::GreennessIndex::kExGR;
    } else if (index != analysis::GreennessIndexName(analysis::GreennessIndex::kExG)) {
      throw std::runtime_error("unknown vegetation index '" + index + "'");
    }
    rule.canopy.min_height_m = options.at("canopy").at("min_height_m").get<double>();
    rule.canopy.min_height_any_colour_m =
        options.at("canopy").at("min_height_any_colour_m").get<double>();
    rule.lone_point_radius_m = options.value("lone_point_radius_m", 0.0);
    for (const workspace::AnalysisSessionRecord& s : summary.sessions) {
      if (!std::isfinite(s.vegetation_threshold)) {
        throw std::runtime_error("session " + s.session + " has no vegetation threshold");
      }
      rule.thresholds[s.session] = s.vegetation_threshold;
    }
    return rule;
  } catch (const std::exception& e) {
    *why = std::string("cannot read the analysis in WS/analysis: ") + e.what();
    return std::nullopt;
  }
}

// Throws unless the workspace exists and holds the results of some stage.
void CheckWorkspace(const workspace::Layout& ws) {
  std::error_code ec;
  const std::string workspace = ws.root().string();
  if (!fs::is_directory(ws.root(), ec)) {
    throw InputError(workspace, 0, "no such workspace folder");
  }
  bool any_stage = false;
  for (const fs::path& folder :
       {ws.SessionsDir(), ws.FusedDir(), ws.DenseDir(), ws.AnalysisDir()}) {
    any_stage = any_stage || fs::is_directory(folder, ec);
  }
  if (!any_stage) {
    throw InputError(workspace, 0,
                     "nothing to export: the workspace holds no results (no sessions/, fused/, "
                     "dense/ or analysis/ folder; run `crop4d slam` or `crop4d run` first)");
  }
}

// The sessions: the field's, in its order, then any other the workspace holds; each with what
// it offers.
std::vector<SessionInputs> FindSessions(const io::Field& field, const workspace::Layout& ws) {
  std::vector<std::string> session_ids = field.session_ids();
  std::set<std::string> extra;
  for (const std::string& s : ws.SessionFolders()) extra.insert(s);
  for (const std::string& s : ws.FusedSessionFolders()) extra.insert(s);
  for (const std::string& s : ws.DenseCloudSessions()) extra.insert(s);
  for (const std::string& s : extra) {
    if (std::find(session_ids.begin(), session_ids.end(), s) == session_ids.end()) {
      session_ids.push_back(s);
    }
  }
  std::vector<SessionInputs> sessions;
  std::error_code ec;
  for (const std::string& id : session_ids) {
    SessionInputs s;
    s.id = id;
    if (fs::is_regular_file(ws.FusedSparse(id), ec)) s.fused_sparse = ws.FusedSparse(id);
    if (fs::is_regular_file(ws.FusedPoses(id), ec)) s.fused_poses = ws.FusedPoses(id);
    if (fs::is_regular_file(ws.DenseCloud(id), ec)) s.dense = ws.DenseCloud(id);
    for (const std::string& pass : ws.PassFolders(id)) {
      if (fs::is_regular_file(ws.PassLandmarks(id, pass), ec)) {
        s.pass_clouds.push_back(ws.PassLandmarks(id, pass));
      }
      if (fs::is_regular_file(ws.PassPoses(id, pass), ec)) s.pass_poses.push_back(pass);
    }
    sessions.push_back(std::move(s));
  }
  return sessions;
}

// ---- ply and las: every session's sparse and/or dense cloud ----
void AddCloudJobs(const ExportContext& ctx, const io::Field& field,
                  const std::vector<SessionInputs>& sessions, const ExportOptions& options,
                  const analysis::PointClassRule* rule, std::vector<Job>* jobs) {
  const bool want_ply = Wants(options, "ply"), want_las = Wants(options, "las");
  if (!want_ply && !want_las) return;
  // LAS points carry their session's date as GPS time and the analysis' class.
  std::map<std::string, double> gps_times;  // adjusted standard GPS time of each session's date
  if (want_las) {
    for (const SessionInputs& s : sessions) {
      const std::optional<Timestamp> date = SessionDate(field, s.id);
      if (date) {
        gps_times[s.id] = io::AdjustedStandardGpsTime(*date);
      } else {
        spdlog::warn("export las: session {} has no date (session.yaml): GPS time 0", s.id);
      }
    }
  }
  const std::string formats = want_ply && want_las ? "ply, las" : (want_ply ? "ply" : "las");
  std::vector<std::string> kinds;
  if (options.clouds != "dense") kinds.push_back("sparse");
  if (options.clouds != "sparse") kinds.push_back("dense");
  for (const std::string& kind : kinds) {
    std::vector<std::string> missing;
    int found = 0;
    for (const SessionInputs& s : sessions) {
      CloudJob job;
      job.session = s.id;
      job.kind = kind;
      if (kind == "dense") {
        if (!s.dense.empty()) job.sources.push_back(s.dense);
        job.what = "dense cloud";
      } else if (!s.fused_sparse.empty()) {
        job.sources.push_back(s.fused_sparse);
        job.what = "fused sparse cloud";
      } else {
        job.sources = s.pass_clouds;
        job.what = "row-SLAM sparse clouds of the passes (not fused)";
      }
      if (job.sources.empty()) {
        missing.push_back(s.id);
        continue;
      }
      ++found;
      job.merged = kind == "sparse" && s.fused_sparse.empty();
      job.ply = want_ply;
      job.las = want_las;
      const auto time = gps_times.find(s.id);
      job.gps_time = time != gps_times.end() ? time->second : 0.0;
      if (rule != nullptr) {
        const auto threshold = rule->thresholds.find(s.id);
        if (threshold != rule->thresholds.end()) job.threshold = threshold->second;
      }
      job.rule = rule;
      jobs->push_back({"cloud " + s.id + " " + kind, [&ctx, job](std::vector<ExportedFile>* files) {
                         ExportCloud(ctx, job, files);
                       }});
    }
    const std::string where =
        kind == "dense"
            ? "WS/dense/<session>.ply: run `crop4d densify`"
            : "WS/fused/<session>/sparse.ply or WS/sessions/<session>/rows/<pass>/landmarks.ply";
    if (found == 0) {
      ctx.Skip(formats, "no " + kind + " point cloud of any session (" + where + ")");
    } else if (!missing.empty()) {
      ctx.Skip(formats, "no " + kind + " point cloud of session" +
                            (missing.size() > 1 ? "s " : " ") + Join(missing, ", ") + " (" + where +
                            ")");
    }
  }
}

// ---- colmap: the fused model, checked and copied ----
void AddColmapJob(const ExportContext& ctx, std::vector<Job>* jobs) {
  const fs::path model = ctx.ws.FusedColmapDir();
  const std::vector<std::string> names = {"cameras.txt", "images.txt", "points3D.txt"};
  std::vector<std::string> missing;
  std::error_code ec;
  for (const std::string& n : names) {
    if (!fs::is_regular_file(model / n, ec)) missing.push_back("WS/" + ctx.Rel(model / n));
  }
  if (!missing.empty()) {
    ctx.Skip("colmap", "no COLMAP model: missing " + Join(missing, ", ") + " (run `crop4d fuse`)");
    return;
  }
  jobs->push_back(
      {"colmap", [&ctx, model, names](std::vector<ExportedFile>* files) {
         const io::ColmapModel m = io::ReadColmapText(model.string());
         std::string problem;
         if (!m.Check(&problem)) throw InputError(model.string(), 0, problem);
         const std::uint64_t counts[3] = {m.cameras.size(), m.images.size(), m.points.size()};
         const char* units[3] = {"cameras", "images", "points"};
         for (int i = 0; i < 3; ++i) {
           const fs::path to = ctx.out / "colmap" / names[i];
           CopyFileAtomic(model / names[i], to);
           files->push_back({"colmap", "colmap/" + names[i], FileBytes(to),
                             ctx.Rel(model / names[i]), counts[i], units[i]});
         }
       }});
}

// ---- tum: each session's fused trajectory, else its passes' ----
void AddTumJobs(const ExportContext& ctx, const std::vector<SessionInputs>& sessions,
                std::vector<Job>* jobs) {
  std::vector<std::string> missing;
  int found = 0;
  for (const SessionInputs& s : sessions) {
    std::vector<std::pair<fs::path, std::string>> items;  // source, output name
    if (!s.fused_poses.empty()) {
      items.emplace_back(s.fused_poses, s.id + ".tum");
    } else {
      for (const std::string& pass : s.pass_poses) {
        items.emplace_back(ctx.ws.PassPoses(s.id, pass), s.id + "_" + pass + ".tum");
      }
    }
    if (items.empty()) missing.push_back(s.id);
    for (const auto& item : items) {
      // Named copies: clang 14 cannot capture structured bindings in a lambda.
      const fs::path from = item.first;
      const std::string name = item.second;
      ++found;
      jobs->push_back(
          {"tum " + name, [&ctx, from, name](std::vector<ExportedFile>* files) {
             const std::size_t poses = io::ReadTum(from.string()).size();
             const fs::path to = ctx.out / "tum" / name;
             CopyFileAtomic(from, to);
             files->push_back({"tum", "tum/" + name, FileBytes(to), ctx.Rel(from), poses, "poses"});
           }});
    }
  }
  const std::string where =
      "WS/fused/<session>/poses.tum or WS/sessions/<session>/rows/<pass>/poses.tum";
  if (found == 0) {
    ctx.Skip("tum", "no trajectory of any session (" + where + ")");
  } else if (!missing.empty()) {
    ctx.Skip("tum", "no trajectory of session" + std::string(missing.size() > 1 ? "s " : " ") +
                        Join(missing, ", ") + " (" + where + ")");
  }
}

// The rows of an analysis table (Layout::AnalysisTables), read with its typed reader.
std::uint64_t TableRows(const workspace::Layout& ws, const fs::path& table) {
  if (table == ws.SitePlants()) return workspace::ReadSitePlants(table).size();
  if (table == ws.Growth()) return workspace::ReadGrowth(table).rows.size();
  return workspace::ReadSiteHeights(table).size();  // site_heights.csv, its single-plane twin
}

// ---- geotiff and csv: the rasters and tables of the analysis folder, copied ----
void AddAnalysisJobs(const ExportContext& ctx, const ExportOptions& options,
                     std::vector<Job>* jobs) {
  if (Wants(options, "geotiff")) {
    const std::vector<fs::path> rasters = ctx.ws.AnalysisRasters();
    if (rasters.empty()) {
      ctx.Skip("geotiff", "no raster in WS/analysis/*.tif (run `crop4d analyze`)");
    }
    for (const fs::path& from : rasters) {
      const std::string name = from.filename().string();
      jobs->push_back({"geotiff " + name, [&ctx, from, name](std::vector<ExportedFile>* files) {
                         const io::GeoTiffRaster raster = io::ReadGeoTiff(from.string());
                         const fs::path to = ctx.out / "geotiff" / name;
                         CopyFileAtomic(from, to);
                         files->push_back({"geotiff", "geotiff/" + name, FileBytes(to),
                                           ctx.Rel(from), raster.grid.num_cells(), "cells"});
                       }});
    }
  }
  if (Wants(options, "csv")) {
    const std::vector<fs::path> tables = ctx.ws.AnalysisTables();
    if (tables.empty()) ctx.Skip("csv", "no table in WS/analysis/*.csv (run `crop4d analyze`)");
    for (const fs::path& from : tables) {
      const std::string name = from.filename().string();
      jobs->push_back(
          {"csv " + name, [&ctx, from, name](std::vector<ExportedFile>* files) {
             const std::uint64_t rows = TableRows(ctx.ws, from);
             const fs::path to = ctx.out / "csv" / name;
             CopyFileAtomic(from, to);
             files->push_back({"csv", "csv/" + name, FileBytes(to), ctx.Rel(from), rows, "rows"});
           }});
    }
  }
}

// Runs the jobs; the report's files in the order of the formats (a PLY and a LAS of one cloud
// come from one job).
void RunJobs(const std::vector<Job>& jobs, const ExportOptions& options, ExportReport* report) {
  Progress::Options progress_options;
  progress_options.silent = !options.show_progress;
  Progress progress("export", jobs.size(), "input", progress_options);
  for (const Job& job : jobs) {
    spdlog::debug("export: {}", job.label);
    job.run(&report->files);
    progress.Add();
  }
  progress.Finish();
  const std::vector<std::string>& order = ExportFormatNames();
  std::stable_sort(report->files.begin(), report->files.end(),
                   [&order](const ExportedFile& a, const ExportedFile& b) {
                     return std::find(order.begin(), order.end(), a.format) <
                            std::find(order.begin(), order.end(), b.format);
                   });
}

}  // namespace

const std::vector<std::string>& ExportFormatNames() {
  static const std::vector<std::string> names = {"ply", "las", "colmap", "tum", "geotiff", "csv"};
  return names;
}

bool ExportOptions::Check(std::string* why) const {
  auto fail = [why](const std::string& message) {
    if (why != nullptr) *why = message;
    return false;
  };
  if (formats.empty()) return fail("no format given");
  for (const std::string& f : formats) {
    const std::vector<std::string>& names = ExportFormatNames();
    if (std::find(names.begin(), names.end(), f) == names.end()) {
      return fail("unknown format '" + f + "' (expected some of " + Join(names, ", ") + ")");
    }
  }
  if (clouds != "dense" && clouds != "sparse" && clouds != "both") {
    return fail("unknown clouds '" + clouds + "' (expected dense, sparse or both)");
  }
  return true;
}

ExportReport RunExport(const std::string& field_folder, const std::string& workspace,
                       const std::string& out_dir, const ExportOptions& options) {
  const Clock::time_point start = Clock::now();
  std::string why;
  if (!options.Check(&why)) throw InputError("crop4d export", 0, why);
  const workspace::Layout ws(workspace);
  CheckWorkspace(ws);
  const io::Field field(field_folder);
  ExportReport report;
  const ExportContext ctx{ws, fs::path(out_dir), field.info().origin,
                          geometry::UtmEpsgCode(field.info().origin), &report};
  {
    std::error_code ec;
    const fs::path a = fs::weakly_canonical(ws.root(), ec), b = fs::weakly_canonical(ctx.out, ec);
    if (a == b) throw InputError(out_dir, 0, "the output folder must not be the workspace");
  }
  report.out_dir = out_dir;
  report.epsg = ctx.epsg;
  const std::vector<SessionInputs> sessions = FindSessions(field, ws);

  std::vector<Job> jobs;
  std::optional<analysis::PointClassRule> classes;
  std::string classes_why;
  if (Wants(options, "las")) {
    classes = ReadPointClassRule(ws, &classes_why);
    if (!classes) spdlog::warn("export las: points unclassified (1): {}", classes_why);
  }
  AddCloudJobs(ctx, field, sessions, options, classes ? &*classes : nullptr, &jobs);
  if (Wants(options, "colmap")) AddColmapJob(ctx, &jobs);
  if (Wants(options, "tum")) AddTumJobs(ctx, sessions, &jobs);
  AddAnalysisJobs(ctx, options, &jobs);
  if (jobs.empty()) {
    std::vector<std::string> reasons;
    for (const ExportSkip& s : report.skipped) reasons.push_back(s.format + ": " + s.message);
    throw InputError(workspace, 0,
                     "nothing to export in the formats asked for (" + Join(options.formats, ",") +
                         "): " + Join(reasons, "; "));
  }
  RunJobs(jobs, options, &report);
  WriteExportManifest(ctx, field_folder, options, classes.has_value(), classes_why);
  report.seconds = std::chrono::duration<double>(Clock::now() - start).count();
  return report;
}

std::string FormatExportReport(const ExportReport& report) {
  std::ostringstream text;
  std::uint64_t total = 0;
  std::size_t width = 4;
  for (const ExportedFile& f : report.files) width = std::max(width, f.path.size());
  char line[512];
  std::snprintf(line, sizeof(line), "  %-*s  %12s  %12s  %s\n", int(width), "file", "bytes",
                "items", "source");
  text << line;
  for (const ExportedFile& f : report.files) {
    std::snprintf(line, sizeof(line), "  %-*s  %12llu  %12llu  %s\n", int(width), f.path.c_str(),
                  static_cast<unsigned long long>(f.bytes),
                  static_cast<unsigned long long>(f.items), f.source.c_str());
    text << line;
    total += f.bytes;
  }
  for (const ExportSkip& s : report.skipped) {
    text << "  skipped " << s.format << ": " << s.message << "\n";
  }
  std::snprintf(line, sizeof(line), "%zu files, %.1f MB in %s (+ export.json), %.1f s\n",
                report.files.size(), total / 1e6, report.out_dir.c_str(), report.seconds);
  text << line;
  return text.str();
}

}  // namespace crop4d::pipeline
