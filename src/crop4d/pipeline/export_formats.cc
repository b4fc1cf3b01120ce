#include "crop4d/pipeline/export_formats.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/las.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

std::string OriginText(const geometry::GeodeticPoint& o) {
  char text[160];
  std::snprintf(text, sizeof(text), "lat %.9f lon %.9f alt %.4f m (WGS 84, ellipsoidal height)",
                o.lat_deg, o.lon_deg, o.alt_m);
  return text;
}

// The LAS points of `cloud` (or of the passes' `clouds` when merged, their pass in the point
// source id), classified by the analysis when it has the session.
std::vector<io::LasPoint> LasPoints(const ExportContext& ctx, const CloudJob& job,
                                    const std::vector<io::PlyPointCloud>& clouds,
                                    const io::PlyPointCloud& cloud) {
  std::vector<io::LasPoint> points;
  auto add = [&](const io::PlyPointCloud& part, std::uint16_t source_id) {
    const std::size_t begin = points.size();
    const std::vector<io::LasPoint> part_points =
        io::LasPointsFromEnu(part, ctx.origin, ctx.epsg, source_id, job.gps_time);
    points.insert(points.end(), part_points.begin(), part_points.end());
    if (job.threshold) {
      analysis::ClassifyPoints(*job.rule, *job.threshold, job.kind == "dense", part,
                               points.data() + begin);
    } else {
      for (std::size_t i = begin; i < points.size(); ++i) {
        points[i].classification = io::kAsprsUnclassified;
      }
    }
  };
  if (job.merged) {
    for (std::size_t k = 0; k < clouds.size(); ++k) {
      add(clouds[k], static_cast<std::uint16_t>(k + 1));
    }
  } else {
    add(cloud, 0);
  }
  return points;
}

}  // namespace

void ExportContext::Skip(const std::string& format, const std::string& message) const {
  spdlog::warn("export {}: {}", format, message);
  report->skipped.push_back({format, message});
}

std::string Join(const std::vector<std::string>& items, const std::string& separator) {
  std::string text;
  for (std::size_t i = 0; i < items.size(); ++i) text += (i ? separator : "") + items[i];
  return text;
}

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

std::uint64_t FileBytes(const fs::path& p) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(p, ec);
  return ec ? 0 : static_cast<std::uint64_t>(size);
}

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

void ExportCloud(const ExportContext& ctx, const CloudJob& job, std::vector<ExportedFile>* files) {
  std::vector<io::PlyPointCloud> clouds;
  std::vector<std::string> source_names;
  for (const fs::path& p : job.sources) {
    clouds.push_back(io::ReadPly(p.string()));
    source_names.push_back(ctx.Rel(p));
  }
  const std::string source = Join(source_names, " ");
  io::PlyPointCloud cloud = job.merged ? MergePassClouds(clouds) : std::move(clouds.front());
  const std::string name = job.session + "_" + job.kind;
  if (job.ply) {
    io::PlyWriteOptions ply_options;
    ply_options.comment =
        "crop4d export: " + job.what + " of session " + job.session +
        "\nframe: field ENU (x east, y north, z up), metres\norigin: " + OriginText(ctx.origin) +
        "\nsource: " + source;
    const fs::path path = ctx.out / "ply" / (name + ".ply");
    io::WritePly(path.string(), cloud, ply_options);
    files->push_back(
        {"ply", "ply/" + name + ".ply", FileBytes(path), source, cloud.size(), "points"});
  }
  if (job.las) {
    const std::vector<io::LasPoint> points = LasPoints(ctx, job, clouds, cloud);
    io::LasWriteOptions las_options;
    las_options.epsg = ctx.epsg;
    const fs::path path = ctx.out / "las" / (name + ".las");
    io::WriteLas(path.string(), points, las_options);
    files->push_back(
        {"las", "las/" + name + ".las", FileBytes(path), source, points.size(), "points"});
  }
}

void WriteExportManifest(const ExportContext& ctx, const std::string& field_folder,
                         const ExportOptions& options, bool classified,
                         const std::string& classes_why) {
  const int epsg = ctx.epsg;
  json manifest;
  manifest["generator"] = "crop4d export";
  manifest["workspace"] = fs::absolute(ctx.ws.root()).lexically_normal().string();
  manifest["field"] = fs::absolute(field_folder).lexically_normal().string();
  manifest["formats"] = options.formats;
  manifest["clouds"] = options.clouds;
  manifest["crs"] = {
      {"enu_origin",
       {{"lat_deg", ctx.origin.lat_deg},
        {"lon_deg", ctx.origin.lon_deg},
        {"alt_m", ctx.origin.alt_m}}},
      {"ply_tum_colmap", "field ENU frame (x east, y north, z up), metres, origin enu_origin"},
      {"las",
       "EPSG:" + std::to_string(epsg) +
           " easting, northing (m); z: WGS 84 ellipsoidal height = origin alt_m + ENU up (m)"},
      {"geotiff", "EPSG:" + std::to_string(epsg)},
      {"utm_epsg", epsg}};
  if (std::find(options.formats.begin(), options.formats.end(), "las") != options.formats.end()) {
    manifest["las_points"] = {
        {"gps_time",
         "adjusted standard GPS time (GPS seconds - 1e9, global encoding bit 0) of the "
         "session's date, 00:00 UTC: the same for every point of a session"},
        {"classification",
         classified ? "ASPRS classes from WS/analysis: 2 ground, 3/4/5 low/medium/high vegetation "
                      "(below 0.5 m, 0.5-2 m, 2 m and above the terrain), 1 unclassified (outside "
                      "the terrain model, more than 0.1 m below it, lone points, sessions not "
                      "analysed)"
                    : "1 (unclassified) for every point: " + classes_why}};
  }
  json files = json::array();
  for (const ExportedFile& f : ctx.report->files) {
    files.push_back({{"path", f.path},
                     {"bytes", f.bytes},
                     {"format", f.format},
                     {"source", f.source},
                     {f.item_unit.empty() ? "items" : f.item_unit, f.items}});
  }
  manifest["files"] = std::move(files);
  json skipped = json::array();
  for (const ExportSkip& s : ctx.report->skipped) {
    skipped.push_back({{"format", s.format}, {"message", s.message}});
  }
  manifest["skipped"] = std::move(skipped);
  io::WriteFileAtomic((ctx.out / "export.json").string(), manifest.dump(2) + "\n");
}

}  // namespace crop4d::pipeline
