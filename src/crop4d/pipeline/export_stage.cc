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

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/lone_points.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/colmap_text.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/las.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;
using Clock = std::chrono::steady_clock;

bool Wants(const ExportOptions& options, const std::string& format) {
  return std::find(options.formats.begin(), options.formats.end(), format) != options.formats.end();
}

// Names of the entries of `dir` that satisfy `keep`, sorted; empty when `dir` is not a folder.
std::vector<std::string> ListNames(const fs::path& dir,
                                   const std::function<bool(const fs::directory_entry&)>& keep) {
  std::vector<std::string> names;
  std::error_code ec;
  if (!fs::is_directory(dir, ec)) return names;
  for (const fs::directory_entry& entry : fs::directory_iterator(dir, ec)) {
    if (keep(entry)) names.push_back(entry.path().filename().string());
  }
  std::sort(names.begin(), names.end());
  return names;
}

bool IsDir(const fs::directory_entry& e) {
  std::error_code ec;
  return e.is_directory(ec);
}

std::function<bool(const fs::directory_entry&)> FilesEndingIn(const std::string& extension) {
  return [extension](const fs::directory_entry& e) {
    std::error_code ec;
    return e.is_regular_file(ec) && e.path().extension() == extension;
  };
}

// Copies `from` to `to` atomically.
void CopyFileAtomic(const fs::path& from, const fs::path& to) {
  std::ifstream in(from, std::ios::binary);
  if (!in) throw InputError(from.string(), 0, "cannot read");
  io::AtomicFile out(to.string());
  char buffer[1 << 16];
  while (in) {
    in.read(buffer, sizeof(buffer));
    out.stream().write(buffer, in.gcount());
  }
  if (in.bad()) throw InputError(from.string(), 0, "read failed");
  out.Commit();
}

// What one session offers.
struct SessionInputs {
  std::string id;
  fs::path fused_sparse;                 // empty when missing
  std::vector<std::string> pass_clouds;  // pass names with rows/<pass>/landmarks.ply
  fs::path dense;                        // empty when missing
  fs::path fused_poses;                  // empty when missing
  std::vector<std::string> pass_poses;   // pass names with rows/<pass>/poses.tum
};

// The work of one output (or a PLY and a LAS of the same cloud).
struct Job {
  std::string label;
  std::function<void(std::vector<ExportedFile>*)> run;
};

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string text;
  for (std::size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

std::string OriginText(const geometry::GeodeticPoint& o) {
  char text[160];
  std::snprintf(text, sizeof(text), "lat %.9f lon %.9f alt %.4f m (WGS 84, ellipsoidal height)",
                o.lat_deg, o.lon_deg, o.alt_m);
  return text;
}

// The clouds of several row passes as one: common scalars (same name and type), colours when
// every pass has them, and a scalar `pass` (1-based index in `clouds`).
io::PlyPointCloud MergePassClouds(const std::vector<io::PlyPointCloud>& clouds) {
  io::PlyPointCloud merged;
  bool all_colours = true;
  for (const io::PlyPointCloud& c : clouds)
    all_colours = all_colours && c.colors.size() == c.size();
  std::vector<io::PlyScalarField> scalars;
  if (!clouds.empty()) {
    for (const io::PlyScalarField& s : clouds.front().scalars) {
      bool common = s.name != "pass";
      for (const io::PlyPointCloud& c : clouds) {
        const io::PlyScalarField* other = c.FindScalar(s.name);
        common = common && other != nullptr && other->type == s.type;
      }
      if (common) scalars.push_back({s.name, s.type, {}});
    }
  }
  io::PlyScalarField pass{"pass", io::PlyType::kUint16, {}};
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    const io::PlyPointCloud& c = clouds[k];
    merged.points.insert(merged.points.end(), c.points.begin(), c.points.end());
    if (all_colours) merged.colors.insert(merged.colors.end(), c.colors.begin(), c.colors.end());
    for (io::PlyScalarField& s : scalars) {
      const std::vector<double>& values = c.FindScalar(s.name)->values;
      s.values.insert(s.values.end(), values.begin(), values.end());
    }
    pass.values.insert(pass.values.end(), c.size(), double(k + 1));
  }
  // Normals only when every pass has them (they do not in practice).
  bool all_normals = !clouds.empty();
  for (const io::PlyPointCloud& c : clouds)
    all_normals = all_normals && c.normals.size() == c.size();
  if (all_normals) {
    for (const io::PlyPointCloud& c : clouds) {
      merged.normals.insert(merged.normals.end(), c.normals.begin(), c.normals.end());
    }
  }
  merged.scalars = std::move(scalars);
  merged.scalars.push_back(std::move(pass));
  return merged;
}

// The analysis' separation of the ground from the vegetation (docs/analysis.md), read back from
// WS/analysis to classify the points of the LAS files.
struct AnalysisClasses {
  io::GeoTiffRaster dtm;  // the terrain model, ellipsoidal heights (the LAS z convention)
  analysis::GreennessIndex index = analysis::GreennessIndex::kExG;
  analysis::CanopyOptions canopy;  // min_height_m, min_height_any_colour_m
  double lone_point_radius_m = 0.0;
  std::map<std::string, double> thresholds;  // the vegetation threshold of each session analysed
};

// WS/analysis/dtm.tif and the options and thresholds of WS/analysis/summary.json; nullopt, with
// `why`, when either is missing or cannot be read.
std::optional<AnalysisClasses> ReadAnalysisClasses(const fs::path& analysis, std::string* why) {
  std::error_code ec;
  if (!fs::is_regular_file(analysis / "dtm.tif", ec) ||
      !fs::is_regular_file(analysis / "summary.json", ec)) {
    *why = "no terrain model WS/analysis/dtm.tif with its summary.json (run `crop4d analyze`)";
    return std::nullopt;
  }
  try {
    AnalysisClasses classes;
    classes.dtm = io::ReadGeoTiff((analysis / "dtm.tif").string());
    std::ifstream in(analysis / "summary.json");
    const json summary = json::parse(in);
    const json& options = summary.at("options");
    const std::string index = options.at("vegetation").at("index").get<std::string>();
    if (index == analysis::GreennessIndexName(analysis::GreennessIndex::kExGR)) {
      classes.index = analysis::GreennessIndex::kExGR;
    } else if (index != analysis::GreennessIndexName(analysis::GreennessIndex::kExG)) {
      throw std::runtime_error("unknown vegetation index '" + index + "'");
    }
    classes.canopy.min_height_m = options.at("canopy").at("min_height_m").get<double>();
    classes.canopy.min_height_any_colour_m =
        options.at("canopy").at("min_height_any_colour_m").get<double>();
    classes.lone_point_radius_m = options.value("lone_point_radius_m", 0.0);
    for (const json& session : summary.at("sessions")) {
      classes.thresholds[session.at("session").get<std::string>()] =
          session.at("vegetation_threshold").get<double>();
    }
    return classes;
  } catch (const std::exception& e) {
    *why = std::string("cannot read the analysis in WS/analysis: ") + e.what();
    return std::nullopt;
  }
}

// A point of the terrain model this far below it is not ground (a false match below the soil).
constexpr double kBelowTerrainM = 0.10;

// Sets the ASPRS class of `points` (the LAS points of `cloud`, in its order) as the analysis
// separates them: above the terrain model by the canopy rule of the analysis
// (CanopyOptions::IsCanopy: vegetation by colour at min_height_m, any colour at
// min_height_any_colour_m) → vegetation, 3/4/5 by height (io::AsprsVegetationClass); otherwise →
// ground (2). Unclassified (1): points outside the terrain model or where it has no height, more
// than kBelowTerrainM below it, and the lone points the analysis leaves out of a dense cloud.
// `threshold`: the session's vegetation threshold; `dense`: the cloud is a dense cloud.
void ClassifyLasPoints(const AnalysisClasses& a, double threshold, bool dense,
                       const io::PlyPointCloud& cloud, io::LasPoint* points) {
  const io::UtmGrid& grid = a.dtm.grid;
  std::vector<std::uint8_t> lone;
  bool finite = true;
  for (const Eigen::Vector3d& p : cloud.points) finite = finite && p.allFinite();
  if (dense && a.lone_point_radius_m > 0 && finite) {
    lone = analysis::FindLonePoints(cloud.points, a.lone_point_radius_m);
  }
  const bool colours = cloud.colors.size() == cloud.points.size();
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    io::LasPoint& p = points[i];
    p.classification = io::kAsprsUnclassified;
    if (!lone.empty() && lone[i]) continue;
    const double col = std::floor((p.xyz.x() - grid.min_easting) / grid.cell_m);
    const double row = std::floor((grid.max_northing - p.xyz.y()) / grid.cell_m);
    if (!(col >= 0 && row >= 0 && col < grid.width && row < grid.height)) continue;
    const float ground = a.dtm.values[std::size_t(row) * grid.width + std::size_t(col)];
    if (!std::isfinite(ground) || (a.dtm.nodata && ground == *a.dtm.nodata)) continue;
    const double h = p.xyz.z() - ground;
    const bool vegetation =
        colours && analysis::Greenness(a.index, cloud.colors[i][0], cloud.colors[i][1],
                                       cloud.colors[i][2]) > threshold;
    if (a.canopy.IsCanopy(vegetation, h)) {
      p.classification = io::AsprsVegetationClass(h);
    } else if (h >= -kBelowTerrainM) {
      p.classification = io::kAsprsGround;
    }
  }
}

// The date of a session (midnight UTC): its session.yaml, else the date its id starts with.
std::optional<Timestamp> SessionDate(const io::Field& field, const std::string& id) {
  try {
    return field.OpenSession(id).info().date;
  } catch (const std::exception&) {
    return io::DateFromSessionId(id);
  }
}

std::uint64_t FileBytes(const fs::path& p) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(p, ec);
  return ec ? 0 : static_cast<std::uint64_t>(size);
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
  std::error_code ec;
  if (!fs::is_directory(workspace, ec)) {
    throw InputError(workspace, 0, "no such workspace folder");
  }
  bool any_stage = false;
  for (const char* folder : {"sessions", "fused", "dense", "analysis"}) {
    any_stage = any_stage || fs::is_directory(fs::path(workspace) / folder, ec);
  }
  if (!any_stage) {
    throw InputError(workspace, 0,
                     "nothing to export: the workspace holds no results (no sessions/, fused/, "
                     "dense/ or analysis/ folder; run `crop4d slam` or `crop4d run` first)");
  }
  const io::Field field(field_folder);
  const geometry::GeodeticPoint origin = field.info().origin;
  const int epsg = geometry::UtmEpsgCode(origin);
  const fs::path ws(workspace);
  const fs::path out(out_dir);
  {
    const fs::path a = fs::weakly_canonical(ws, ec), b = fs::weakly_canonical(out, ec);
    if (a == b) throw InputError(out_dir, 0, "the output folder must not be the workspace");
  }

  ExportReport report;
  report.out_dir = out_dir;
  report.epsg = epsg;
  auto skip = [&report](const std::string& format, const std::string& message) {
    spdlog::warn("export {}: {}", format, message);
    report.skipped.push_back({format, message});
  };
  auto rel = [&ws](const fs::path& p) { return fs::relative(p, ws).generic_string(); };

  // Sessions: the field's, in its order, then any other the workspace holds.
  std::vector<std::string> session_ids = field.session_ids();
  {
    std::set<std::string> extra;
    for (const std::string& s : ListNames(ws / "sessions", IsDir)) extra.insert(s);
    for (const std::string& s : ListNames(ws / "fused", IsDir)) {
      if (s != "colmap") extra.insert(s);
    }
    for (const std::string& s : ListNames(ws / "dense", FilesEndingIn(".ply"))) {
      extra.insert(fs::path(s).stem().string());
    }
    for (const std::string& s : extra) {
      if (std::find(session_ids.begin(), session_ids.end(), s) == session_ids.end()) {
        session_ids.push_back(s);
      }
    }
  }
  std::vector<SessionInputs> sessions;
  for (const std::string& id : session_ids) {
    SessionInputs s;
    s.id = id;
    if (fs::is_regular_file(ws / "fused" / id / "sparse.ply", ec)) {
      s.fused_sparse = ws / "fused" / id / "sparse.ply";
    }
    if (fs::is_regular_file(ws / "fused" / id / "poses.tum", ec)) {
      s.fused_poses = ws / "fused" / id / "poses.tum";
    }
    if (fs::is_regular_file(ws / "dense" / (id + ".ply"), ec)) {
      s.dense = ws / "dense" / (id + ".ply");
    }
    const fs::path rows = ws / "sessions" / id / "rows";
    for (const std::string& pass : ListNames(rows, IsDir)) {
      if (fs::is_regular_file(rows / pass / "landmarks.ply", ec)) s.pass_clouds.push_back(pass);
      if (fs::is_regular_file(rows / pass / "poses.tum", ec)) s.pass_poses.push_back(pass);
    }
    sessions.push_back(std::move(s));
  }

  std::vector<Job> jobs;

  // ---- point clouds: ply and las ----
  const bool want_ply = Wants(options, "ply"), want_las = Wants(options, "las");
  // LAS points carry their session's date as GPS time and the analysis' class.
  std::optional<AnalysisClasses> classes;
  std::string classes_why;
  std::map<std::string, double> gps_times;  // adjusted standard GPS time of each session's date
  if (want_las) {
    classes = ReadAnalysisClasses(ws / "analysis", &classes_why);
    if (!classes) spdlog::warn("export las: points unclassified (1): {}", classes_why);
    for (const SessionInputs& s : sessions) {
      const std::optional<Timestamp> date = SessionDate(field, s.id);
      if (date) {
        gps_times[s.id] = io::AdjustedStandardGpsTime(*date);
      } else {
        spdlog::warn("export las: session {} has no date (session.yaml): GPS time 0", s.id);
      }
    }
  }
  // Shared by the jobs (which run before this function returns).
  const AnalysisClasses* const analysis_classes = classes ? &*classes : nullptr;
  const std::map<std::string, double>* const session_times = &gps_times;
  if (want_ply || want_las) {
    const std::string formats = want_ply && want_las ? "ply, las" : (want_ply ? "ply" : "las");
    std::vector<std::string> kinds;
    if (options.clouds != "dense") kinds.push_back("sparse");
    if (options.clouds != "sparse") kinds.push_back("dense");
    for (const std::string& kind : kinds) {
      std::vector<std::string> missing;
      int found = 0;
      for (const SessionInputs& s : sessions) {
        // The file(s) this cloud comes from.
        std::vector<fs::path> sources;
        std::string what;
        if (kind == "dense") {
          if (!s.dense.empty()) sources.push_back(s.dense);
          what = "dense cloud";
        } else if (!s.fused_sparse.empty()) {
          sources.push_back(s.fused_sparse);
          what = "fused sparse cloud";
        } else {
          for (const std::string& pass : s.pass_clouds) {
            sources.push_back(ws / "sessions" / s.id / "rows" / pass / "landmarks.ply");
          }
          what = "row-SLAM sparse clouds of the passes (not fused)";
        }
        if (sources.empty()) {
          missing.push_back(s.id);
          continue;
        }
        ++found;
        const bool merged = kind == "sparse" && s.fused_sparse.empty();
        const std::string id = s.id;
        jobs.push_back(
            {"cloud " + id + " " + kind, [=, &out, &rel](std::vector<ExportedFile>* files) {
               std::vector<io::PlyPointCloud> clouds;
               std::vector<std::string> source_names;
               for (const fs::path& p : sources) {
                 clouds.push_back(io::ReadPly(p.string()));
                 source_names.push_back(rel(p));
               }
               const std::string source = Join(source_names, " ");
               io::PlyPointCloud cloud =
                   merged ? MergePassClouds(clouds) : std::move(clouds.front());
               const std::string name = id + "_" + kind;
               if (want_ply) {
                 io::PlyWriteOptions ply_options;
                 ply_options.comment =
                     "crop4d export: " + what + " of session " + id +
                     "\nframe: field ENU (x east, y north, z up), metres\norigin: " +
                     OriginText(origin) + "\nsource: " + source;
                 const fs::path path = out / "ply" / (name + ".ply");
                 io::WritePly(path.string(), cloud, ply_options);
                 files->push_back({"ply", "ply/" + name + ".ply", FileBytes(path), source,
                                   cloud.size(), "points"});
               }
               if (want_las) {
                 const auto time = session_times->find(id);
                 const double gps_time = time != session_times->end() ? time->second : 0.0;
                 // The session's vegetation threshold, when the analysis has the session.
                 std::optional<double> threshold;
                 if (analysis_classes != nullptr) {
                   const auto found = analysis_classes->thresholds.find(id);
                   if (found != analysis_classes->thresholds.end()) {
                     threshold = found->second;
                   }
                 }
                 std::vector<io::LasPoint> points;
                 auto add = [&](const io::PlyPointCloud& part, std::uint16_t source_id) {
                   const std::size_t begin = points.size();
                   const std::vector<io::LasPoint> part_points =
                       io::LasPointsFromEnu(part, origin, epsg, source_id, gps_time);
                   points.insert(points.end(), part_points.begin(), part_points.end());
                   if (threshold) {
                     ClassifyLasPoints(*analysis_classes, *threshold, kind == "dense", part,
                                       points.data() + begin);
                   } else {
                     for (std::size_t i = begin; i < points.size(); ++i) {
                       points[i].classification = io::kAsprsUnclassified;
                     }
                   }
                 };
                 if (merged) {
                   for (std::size_t k = 0; k < clouds.size(); ++k) {
                     add(clouds[k], static_cast<std::uint16_t>(k + 1));
                   }
                 } else {
                   add(cloud, 0);
                 }
                 io::LasWriteOptions las_options;
                 las_options.epsg = epsg;
                 const fs::path path = out / "las" / (name + ".las");
                 io::WriteLas(path.string(), points, las_options);
                 files->push_back({"las", "las/" + name + ".las", FileBytes(path), source,
                                   points.size(), "points"});
               }
             }});
      }
      const std::string where =
          kind == "dense"
              ? "WS/dense/<session>.ply: run `crop4d densify`"
              : "WS/fused/<session>/sparse.ply or WS/sessions/<session>/rows/<pass>/landmarks.ply";
      if (found == 0) {
        skip(formats, "no " + kind + " point cloud of any session (" + where + ")");
      } else if (!missing.empty()) {
        skip(formats, "no " + kind + " point cloud of session" + (missing.size() > 1 ? "s " : " ") +
                          Join(missing, ", ") + " (" + where + ")");
      }
    }
  }

  // ---- colmap ----
  if (Wants(options, "colmap")) {
    const fs::path model = ws / "fused" / "colmap";
    const std::vector<std::string> names = {"cameras.txt", "images.txt", "points3D.txt"};
    std::vector<std::string> missing;
    for (const std::string& n : names) {
      if (!fs::is_regular_file(model / n, ec)) missing.push_back("WS/" + rel(model / n));
    }
    if (!missing.empty()) {
      skip("colmap", "no COLMAP model: missing " + Join(missing, ", ") + " (run `crop4d fuse`)");
    } else {
      jobs.push_back(
          {"colmap", [=, &out, &rel](std::vector<ExportedFile>* files) {
             const io::ColmapModel m = io::ReadColmapText(model.string());
             std::string problem;
             if (!m.Check(&problem)) throw InputError(model.string(), 0, problem);
             const std::uint64_t counts[3] = {m.cameras.size(), m.images.size(), m.points.size()};
             const char* units[3] = {"cameras", "images", "points"};
             for (int i = 0; i < 3; ++i) {
               const fs::path to = out / "colmap" / names[i];
               CopyFileAtomic(model / names[i], to);
               files->push_back({"colmap", "colmap/" + names[i], FileBytes(to),
                                 rel(model / names[i]), counts[i], units[i]});
             }
           }});
    }
  }

  // ---- tum ----
  if (Wants(options, "tum")) {
    std::vector<std::string> missing;
    int found = 0;
    for (const SessionInputs& s : sessions) {
      std::vector<std::pair<fs::path, std::string>> items;  // source, output name
      if (!s.fused_poses.empty()) {
        items.emplace_back(s.fused_poses, s.id + ".tum");
      } else {
        for (const std::string& pass : s.pass_poses) {
          items.emplace_back(ws / "sessions" / s.id / "rows" / pass / "poses.tum",
                             s.id + "_" + pass + ".tum");
        }
      }
      if (items.empty()) missing.push_back(s.id);
      for (const auto& item : items) {
        // Named copies: clang 14 cannot capture structured bindings in a lambda.
        const fs::path from = item.first;
        const std::string name = item.second;
        ++found;
        jobs.push_back(
            {"tum " + name, [=, &out, &rel](std::vector<ExportedFile>* files) {
               const std::size_t poses = io::ReadTum(from.string()).size();
               const fs::path to = out / "tum" / name;
               CopyFileAtomic(from, to);
               files->push_back({"tum", "tum/" + name, FileBytes(to), rel(from), poses, "poses"});
             }});
      }
    }
    const std::string where =
        "WS/fused/<session>/poses.tum or WS/sessions/<session>/rows/<pass>/poses.tum";
    if (found == 0) {
      skip("tum", "no trajectory of any session (" + where + ")");
    } else if (!missing.empty()) {
      skip("tum", "no trajectory of session" + std::string(missing.size() > 1 ? "s " : " ") +
                      Join(missing, ", ") + " (" + where + ")");
    }
  }

  // ---- geotiff and csv: the analysis folder ----
  const fs::path analysis = ws / "analysis";
  if (Wants(options, "geotiff")) {
    const std::vector<std::string> tifs = ListNames(analysis, FilesEndingIn(".tif"));
    if (tifs.empty()) skip("geotiff", "no raster in WS/analysis/*.tif (run `crop4d analyze`)");
    for (const std::string& name : tifs) {
      jobs.push_back({"geotiff " + name, [=, &out, &rel](std::vector<ExportedFile>* files) {
                        const io::GeoTiffRaster raster =
                            io::ReadGeoTiff((analysis / name).string());
                        const fs::path to = out / "geotiff" / name;
                        CopyFileAtomic(analysis / name, to);
                        files->push_back({"geotiff", "geotiff/" + name, FileBytes(to),
                                          rel(analysis / name), raster.grid.num_cells(), "cells"});
                      }});
    }
  }
  if (Wants(options, "csv")) {
    const std::vector<std::string> csvs = ListNames(analysis, FilesEndingIn(".csv"));
    if (csvs.empty()) skip("csv", "no table in WS/analysis/*.csv (run `crop4d analyze`)");
    for (const std::string& name : csvs) {
      jobs.push_back({"csv " + name, [=, &out, &rel](std::vector<ExportedFile>* files) {
                        io::CsvReader reader((analysis / name).string());
                        io::CsvRecord record;
                        std::uint64_t rows = 0;
                        while (reader.Next(&record)) ++rows;
                        // A header line without '#' counts as a record.
                        if (!reader.header().has_value() && rows > 0) --rows;
                        const fs::path to = out / "csv" / name;
                        CopyFileAtomic(analysis / name, to);
                        files->push_back({"csv", "csv/" + name, FileBytes(to), rel(analysis / name),
                                          rows, "rows"});
                      }});
    }
  }

  if (jobs.empty()) {
    std::vector<std::string> reasons;
    for (const ExportSkip& s : report.skipped) reasons.push_back(s.format + ": " + s.message);
    throw InputError(workspace, 0,
                     "nothing to export in the formats asked for (" + Join(options.formats, ",") +
                         "): " + Join(reasons, "; "));
  }

  Progress::Options progress_options;
  progress_options.silent = !options.show_progress;
  Progress progress("export", jobs.size(), "input", progress_options);
  for (const Job& job : jobs) {
    spdlog::debug("export: {}", job.label);
    job.run(&report.files);
    progress.Add();
  }
  progress.Finish();
  // The report in the order of the formats (a PLY and a LAS of one cloud come from one job).
  const std::vector<std::string>& order = ExportFormatNames();
  std::stable_sort(report.files.begin(), report.files.end(),
                   [&order](const ExportedFile& a, const ExportedFile& b) {
                     return std::find(order.begin(), order.end(), a.format) <
                            std::find(order.begin(), order.end(), b.format);
                   });

  // export.json: what was written, from where, and the frames.
  json manifest;
  manifest["generator"] = "crop4d export";
  manifest["workspace"] = fs::absolute(ws).lexically_normal().string();
  manifest["field"] = fs::absolute(field_folder).lexically_normal().string();
  manifest["formats"] = options.formats;
  manifest["clouds"] = options.clouds;
  manifest["crs"] = {
      {"enu_origin",
       {{"lat_deg", origin.lat_deg}, {"lon_deg", origin.lon_deg}, {"alt_m", origin.alt_m}}},
      {"ply_tum_colmap", "field ENU frame (x east, y north, z up), metres, origin enu_origin"},
      {"las",
       "EPSG:" + std::to_string(epsg) +
           " easting, northing (m); z: WGS 84 ellipsoidal height = origin alt_m + ENU up (m)"},
      {"geotiff", "EPSG:" + std::to_string(epsg)},
      {"utm_epsg", epsg}};
  if (Wants(options, "las")) {
    manifest["las_points"] = {
        {"gps_time",
         "adjusted standard GPS time (GPS seconds - 1e9, global encoding bit 0) of the "
         "session's date, 00:00 UTC: the same for every point of a session"},
        {"classification",
         classes ? "ASPRS classes from WS/analysis: 2 ground, 3/4/5 low/medium/high vegetation "
                   "(below 0.5 m, 0.5-2 m, 2 m and above the terrain), 1 unclassified (outside "
                   "the terrain model, more than 0.1 m below it, lone points, sessions not "
                   "analysed)"
                 : "1 (unclassified) for every point: " + classes_why}};
  }
  json files = json::array();
  for (const ExportedFile& f : report.files) {
    files.push_back({{"path", f.path},
                     {"bytes", f.bytes},
                     {"format", f.format},
                     {"source", f.source},
                     {f.item_unit.empty() ? "items" : f.item_unit, f.items}});
  }
  manifest["files"] = std::move(files);
  json skipped = json::array();
  for (const ExportSkip& s : report.skipped) {
    skipped.push_back({{"format", s.format}, {"message", s.message}});
  }
  manifest["skipped"] = std::move(skipped);
  io::WriteFileAtomic((out / "export.json").string(), manifest.dump(2) + "\n");

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
