#include "crop4d/pipeline/analyze_stage.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <set>

#include "crop4d/analysis/lone_points.h"
#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/version.h"
#include "crop4d/eval/canopy_eval.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/ply.h"
#include "crop4d/pipeline/analyze_plots.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Bump when the stage's outputs change for the same inputs and options.
// 2: touching plants split; 3: tops bounded by the next session's; 4: lone points left out;
// 5: ground filter; 6: Cloud-Optimized GeoTIFFs and the height-change rasters.
constexpr int kAnalyzeStageRevision = 6;
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

json OptionsJson(const AnalyzeStageOptions& o) {
  return {{"sites_file", o.sites_file},
          {"cloud", o.cloud},
          {"vegetation",
           {{"index", analysis::GreennessIndexName(o.vegetation.index)},
            {"threshold",
             std::isfinite(o.vegetation.threshold) ? json(o.vegetation.threshold) : json("auto")},
            {"min_threshold", o.vegetation.min_threshold},
            {"min_separability", o.vegetation.min_separability}}},
          {"terrain",
           {{"cell_m", o.terrain.cell_m},
            {"fit_radius_m", o.terrain.fit_radius_m},
            {"min_points", o.terrain.min_points},
            {"outlier_sigmas", o.terrain.outlier_sigmas},
            {"use_later_sessions", o.terrain.use_later_sessions},
            {"later_tolerance_m", o.terrain.later_tolerance_m},
            {"vegetation_clearance_m", o.terrain.vegetation_clearance_m},
            {"max_fill_distance_m", o.terrain.max_fill_distance_m},
            {"ground_filter",
             {{"window_m", o.terrain.ground_filter.window_m},
              {"cell_m", o.terrain.ground_filter.cell_m},
              {"max_height_m", o.terrain.ground_filter.max_height_m}}}}},
          {"canopy",
           {{"min_height_m", o.canopy.min_height_m},
            {"min_height_any_colour_m", o.canopy.min_height_any_colour_m},
            {"cell_m", o.canopy.cell_m},
            {"top", analysis::CanopyTopName(o.canopy.top)},
            {"top_radius_m", o.canopy.top_radius_m},
            {"plant_top_quantile", o.canopy.plant_top_quantile},
            {"max_shrink_m", o.canopy.max_shrink_m},
            {"crown_radius_m", o.canopy.crown_radius_m},
            {"min_peak_fraction", o.canopy.min_peak_fraction},
            {"top_quantile", o.canopy.top_quantile},
            {"min_canopy_cells", o.canopy.min_canopy_cells}}},
          {"plants",
           {{"cell_m", o.plants.cell_m},
            {"min_cells", o.plants.min_cells},
            {"max_area_m2", o.plants.max_area_m2},
            {"top_fraction", o.plants.top_fraction},
            {"min_spacing_m", o.plants.min_spacing_m},
            {"min_prominence_m", o.plants.min_prominence_m},
            {"min_prominence_fraction", o.plants.min_prominence_fraction}}},
          {"plane",
           {{"inlier_threshold_m", o.plane.inlier_threshold_m},
            {"iterations", o.plane.iterations},
            {"seed", o.plane.seed}}},
          {"growth", {{"robust_loss_m", o.growth.robust_loss_m}}},
          {"lone_point_radius_m", o.lone_point_radius_m},
          {"raster_cell_m", o.raster_cell_m},
          {"margin_m", o.margin_m},
          {"write_rasters", o.write_rasters},
          {"write_plots", o.write_plots}};
}

std::string Fixed(double v, int decimals) {
  return std::isfinite(v) ? fmt::format("{:.{}f}", v, decimals) : std::string();
}

// A session to analyse: its id, date and cloud.
struct SessionInput {
  std::string id;
  Timestamp date = 0;
  fs::path cloud;
  bool dense = false;
};

std::vector<SessionInput> FindSessions(const io::Field& field, const fs::path& ws,
                                       const std::string& which) {
  std::vector<SessionInput> out;
  for (const std::string& id : field.session_ids()) {
    SessionInput s;
    s.id = id;
    const fs::path dense = ws / "dense" / (id + ".ply");
    const fs::path sparse = ws / "fused" / id / "sparse.ply";
    if (which != "sparse" && fs::exists(dense)) {
      s.cloud = dense;
      s.dense = true;
    } else if (which != "dense" && fs::exists(sparse)) {
      s.cloud = sparse;
    } else {
      spdlog::warn("analyze: session {} has no {} cloud in {}, skipped", id,
                   which == "auto" ? "registered" : which, ws.string());
      continue;
    }
    s.date = field.OpenSession(id).info().date;
    out.push_back(s);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const SessionInput& a, const SessionInput& b) { return a.date < b.date; });
  return out;
}

Eigen::AlignedBox2d AnalysedArea(const io::FieldInfo& info, const std::vector<io::Site>& sites,
                                 double margin) {
  Eigen::AlignedBox2d box;
  for (const io::RowDeclaration& r : info.rows) {
    box.extend(r.start_enu);
    box.extend(r.end_enu);
  }
  for (const io::Site& s : sites) {
    box.extend(s.center_enu - Eigen::Vector2d::Constant(s.radius_m));
    box.extend(s.center_enu + Eigen::Vector2d::Constant(s.radius_m));
  }
  box.extend(box.min() - Eigen::Vector2d::Constant(margin));
  box.extend(box.max() + Eigen::Vector2d::Constant(margin));
  return box;
}

analysis::SessionCloud LoadCloud(const SessionInput& s, const Eigen::AlignedBox2d& area) {
  const io::PlyPointCloud ply = io::ReadPly(s.cloud.string());
  if (ply.colors.size() != ply.points.size()) {
    throw InputError(s.cloud.string(), 0,
                     "the cloud has no colours: vegetation is found by colour (red, green, blue "
                     "vertex properties)");
  }
  analysis::SessionCloud cloud;
  cloud.session = s.id;
  for (std::size_t i = 0; i < ply.points.size(); ++i) {
    const Eigen::Vector3d& p = ply.points[i];
    if (!p.allFinite() || !area.contains(p.head<2>())) continue;
    cloud.points.push_back(p);
    cloud.colors.push_back(ply.colors[i]);
  }
  return cloud;
}

void WriteSiteCsv(const fs::path& path, const std::vector<SiteResult>& results, bool ours) {
  std::string text = "site_id,session,date,height_m,cover,volume_m3,n_points\n";
  for (const SiteResult& r : results) {
    const analysis::SiteCanopy& c = ours ? r.ours : r.single_plane;
    text += fmt::format("{},{},{},{},{},{},{}\n", r.site_id, r.session, FormatDate(r.date),
                        Fixed(c.height_m, 4), Fixed(c.cover, 3), Fixed(c.volume_m3, 5), c.n_points);
  }
  io::WriteFileAtomic(path.string(), text);
}

// The plants of each site and their tops: one row per plant and session, in the order of
// `results` (site-major); an empty top_m where the plant was not seen (or, with another
// --canopy-top than plant-tops, not measured).
void WriteSitePlantsCsv(const fs::path& path, const std::vector<SiteResult>& results) {
  std::string text = "site_id,plant,x_m,y_m,session,date,top_m\n";
  for (const SiteResult& r : results) {
    for (std::size_t n = 0; n < r.stems.size(); ++n) {
      const double top = n < r.ours.plant_tops.size() ? r.ours.plant_tops[n] : kNaN;
      text += fmt::format("{},{},{:.3f},{:.3f},{},{},{}\n", r.site_id, n + 1, r.stems[n].x(),
                          r.stems[n].y(), r.session, FormatDate(r.date), Fixed(top, 4));
    }
  }
  io::WriteFileAtomic(path.string(), text);
}

void WriteGrowthCsv(const fs::path& path, const std::vector<SiteGrowth>& growth,
                    const std::vector<SessionInput>& sessions, Timestamp day0) {
  std::string text =
      "site_id,status,asymptote_m,rate_per_day,midpoint_date,max_growth_m_per_day,rmse_m,n";
  for (std::size_t k = 0; k + 1 < sessions.size(); ++k) {
    text += fmt::format(",growth_{}_{}_m_per_day", sessions[k].id, sessions[k + 1].id);
  }
  text += "\n";
  for (const SiteGrowth& g : growth) {
    const analysis::GrowthFit& f = g.fit;
    const bool ok = f.ok();
    const std::string midpoint =
        ok ? FormatDate(day0 +
                        static_cast<Timestamp>(std::llround(f.curve.midpoint_day * 86400.0)) *
                            1'000'000'000LL)
           : std::string();
    text += fmt::format(
        "{},{},{},{},{},{},{},{}", g.site_id, analysis::GrowthStatusName(f.status),
        ok ? Fixed(f.curve.asymptote_m, 4) : "", ok ? Fixed(f.curve.rate_per_day, 5) : "", midpoint,
        ok ? Fixed(f.curve.MaxGrowthRate(), 5) : "", ok ? Fixed(f.rmse_m, 4) : "", f.num_points);
    // One column per consecutive pair of sessions: the interval's rate when both ends have a
    // height.
    for (std::size_t k = 0; k + 1 < sessions.size(); ++k) {
      const double from = DurationSeconds(day0, sessions[k].date) / 86400.0;
      const double to = DurationSeconds(day0, sessions[k + 1].date) / 86400.0;
      std::string cell;
      for (const analysis::GrowthInterval& in : f.intervals) {
        if (std::abs(in.day_from - from) < 1e-6 && std::abs(in.day_to - to) < 1e-6) {
          cell = Fixed(in.rate_m_per_day, 5);
        }
      }
      text += "," + cell;
    }
    text += "\n";
  }
  io::WriteFileAtomic(path.string(), text);
}

// Site results of an earlier run (for the table of a skipped, up-to-date stage).
std::vector<SiteResult> ReadSiteCsvs(const fs::path& dir) {
  // The files this stage wrote, read back with the reader `crop4d eval` uses.
  std::map<std::pair<std::string, std::string>, SiteResult> by_key;
  std::vector<std::pair<std::string, std::string>> order;
  for (const bool ours : {true, false}) {
    const fs::path path = dir / (ours ? "site_heights.csv" : "site_heights_single_plane.csv");
    if (!fs::exists(path)) continue;
    for (const eval::SiteHeight& h : eval::ReadSiteHeights(path.string())) {
      const auto key = std::make_pair(h.site_id, h.session);
      if (!by_key.count(key)) order.push_back(key);
      SiteResult& r = by_key[key];
      r.site_id = h.site_id;
      r.session = h.session;
      if (!h.date.empty() && !ParseDate(h.date, &r.date)) {
        throw InputError(path.string(), h.line, "not a date (YYYY-MM-DD): '" + h.date + "'");
      }
      analysis::SiteCanopy& c = ours ? r.ours : r.single_plane;
      c.height_m = h.height_m;
      c.cover = h.cover;
      c.volume_m3 = h.volume_m3;
      c.n_points = h.n_points >= 0 ? static_cast<int>(h.n_points) : 0;
    }
  }
  std::vector<SiteResult> out;
  for (const auto& key : order) out.push_back(by_key[key]);
  return out;
}

}  // namespace

bool AnalyzeStageOptions::Check() const {
  return (cloud == "auto" || cloud == "dense" || cloud == "sparse") && vegetation.Check() &&
         terrain.Check() && canopy.Check() && plants.Check() && plane.Check() && growth.Check() &&
         raster_cell_m > 0.0 && margin_m >= 0.0 && lone_point_radius_m >= 0.0;
}

std::vector<io::Site> ReadSitesCsv(const std::string& path, const geometry::GeodeticPoint& origin) {
  io::CsvReader reader(path);
  io::CsvRecord rec;
  std::vector<std::string> header;
  std::vector<io::Site> sites;
  std::set<std::string> ids;
  const geometry::LocalEnu enu(origin);
  bool geodetic = false;
  while (reader.Next(&rec)) {
    if (header.empty()) {
      for (std::string_view f : rec.fields) header.emplace_back(f);
      if (header == std::vector<std::string>{"site_id", "lat", "lon", "radius_m"}) {
        geodetic = true;
      } else if (header != std::vector<std::string>{"site_id", "x", "y", "radius_m"}) {
        throw InputError(path, rec.line,
                         "expected the header site_id,x,y,radius_m (ENU metres) or "
                         "site_id,lat,lon,radius_m (WGS84 degrees)");
      }
      continue;
    }
    if (rec.fields.size() != 4) {
      throw InputError(path, rec.line,
                       fmt::format("expected 4 fields, found {}", rec.fields.size()));
    }
    io::Site site;
    site.id = std::string(rec.fields[0]);
    if (site.id.empty() || site.id.find_first_of(" \t\",") != std::string::npos) {
      throw InputError(path, rec.line, "a site id is one word, not '" + site.id + "'");
    }
    if (!ids.insert(site.id).second) {
      throw InputError(path, rec.line, "site '" + site.id + "' appears twice");
    }
    double a = 0, b = 0;
    if (!io::ParseDouble(rec.fields[1], &a) || !io::ParseDouble(rec.fields[2], &b) ||
        !io::ParseDouble(rec.fields[3], &site.radius_m) || !std::isfinite(a) || !std::isfinite(b)) {
      throw InputError(path, rec.line, "expected numbers for the position and radius");
    }
    if (!(site.radius_m > 0.0 && site.radius_m < 100.0)) {
      throw InputError(path, rec.line, "the radius must be in (0, 100) metres");
    }
    if (geodetic) {
      if (std::abs(a) > 90.0 || std::abs(b) > 180.0) {
        throw InputError(path, rec.line, "latitude or longitude out of range");
      }
      site.center_enu = enu.ToEnu({a, b, origin.alt_m}).head<2>();
    } else {
      site.center_enu = {a, b};
    }
    sites.push_back(site);
  }
  if (header.empty()) throw InputError(path, 0, "empty sites file");
  return sites;
}

AnalyzeReport RunAnalyzeStage(const std::string& field_folder, const std::string& workspace,
                              const AnalyzeStageOptions& options) {
  if (!options.Check()) throw std::invalid_argument("RunAnalyzeStage: invalid options");
  const auto t0 = std::chrono::steady_clock::now();
  AnalyzeReport report;
  const io::Field field(field_folder);
  const fs::path ws(workspace);
  const fs::path out = ws / "analysis";
  const std::vector<io::Site> sites = options.sites_file.empty()
                                          ? field.info().sites
                                          : ReadSitesCsv(options.sites_file, field.info().origin);
  if (sites.empty()) {
    throw InputError(options.sites_file.empty() ? field_folder + "/field.yaml" : options.sites_file,
                     0, "no measurement sites: add `sites` to field.yaml or pass --sites FILE");
  }
  const std::vector<SessionInput> inputs = FindSessions(field, ws, options.cloud);
  if (inputs.empty()) {
    throw InputError(workspace, 0,
                     "no registered clouds (fused/<session>/sparse.ply or dense/<session>.ply): "
                     "run `crop4d fuse` first");
  }
  const fs::path measurements = fs::path(field_folder) / "ground_truth" / "site_measurements.csv";

  // Up to date?
  Fnv1aHasher fingerprint;
  fingerprint.Add(kAnalyzeStageRevision);
  fingerprint.AddString(kVersion);
  fingerprint.AddString(OptionsJson(options).dump());
  for (const io::Site& s : sites) {
    fingerprint.AddString(s.id);
    fingerprint.Add(s.center_enu.x());
    fingerprint.Add(s.center_enu.y());
    fingerprint.Add(s.radius_m);
  }
  for (const SessionInput& s : inputs) {
    fingerprint.AddString(s.id);
    fingerprint.Add(s.date);
    fingerprint.AddString(s.cloud.filename().string());
    fingerprint.AddString(workspace::FileHash(s.cloud));
  }
  // Degraded sessions (season_quality.h) are measured, but never set the terrain, the stems,
  // the growth bounds or the growth curves of the others.
  const SeasonQuality quality = ReadSeasonQuality(workspace);
  fingerprint.AddString(SeasonQualityToJson(quality).dump());
  std::vector<bool> protects(inputs.size());
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    protects[k] = quality.Protects(inputs[k].id);
    if (!protects[k]) {
      spdlog::warn(
          "analyze: {} is degraded: measured, but not used for the terrain, the plant "
          "stems, the growth bounds or the growth curves",
          inputs[k].id);
    }
  }
  fingerprint.AddString(fs::exists(measurements) ? workspace::FileHash(measurements) : "");
  const std::string stamp = std::to_string(fingerprint.hash());
  std::string why;
  if (!options.force && fs::exists(out / "site_heights.csv") &&
      fs::exists(out / "site_plants.csv") && fs::exists(out / "growth.csv") &&
      workspace::SummaryUpToDate(out / "summary.json", stamp, &why)) {
    spdlog::info("analyze: up to date, skipped (--force to analyse again)");
    report.skipped = true;
    report.sites = ReadSiteCsvs(out);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return report;
  }
  // The previous results no longer match their inputs: they go before the new ones are made,
  // so that a failure below leaves no stale heights for eval and the report to show.
  if (fs::is_directory(out)) {
    spdlog::info("analyze: the previous results in {} are removed ({})", out.string(),
                 options.force ? "--force" : (why.empty() ? "some of them are missing" : why));
    fs::remove_all(out);
  }

  // 1. Clouds and vegetation.
  const Eigen::AlignedBox2d area = AnalysedArea(field.info(), sites, options.margin_m);
  std::vector<analysis::SessionCloud> clouds(inputs.size());
  report.sessions.resize(inputs.size());
  tbb::parallel_for(std::size_t{0}, inputs.size(), [&](std::size_t k) {
    clouds[k] = LoadCloud(inputs[k], area);
    std::size_t lone = 0;
    if (inputs[k].dense && options.lone_point_radius_m > 0) {
      const std::vector<std::uint8_t> flags =
          analysis::FindLonePoints(clouds[k].points, options.lone_point_radius_m);
      std::size_t kept = 0;
      for (std::size_t i = 0; i < flags.size(); ++i) {
        if (flags[i]) continue;
        clouds[k].points[kept] = clouds[k].points[i];
        clouds[k].colors[kept] = clouds[k].colors[i];
        ++kept;
      }
      lone = flags.size() - kept;
      clouds[k].points.resize(kept);
      clouds[k].colors.resize(kept);
    }
    analysis::VegetationClassification veg =
        analysis::ClassifyVegetation(clouds[k].colors, options.vegetation);
    clouds[k].is_vegetation = veg.is_vegetation;
    veg.is_vegetation.clear();
    veg.index.clear();
    AnalyzeSessionReport& r = report.sessions[k];
    r.session = inputs[k].id;
    r.date = inputs[k].date;
    r.cloud_path = fs::relative(inputs[k].cloud, ws).string();
    r.dense = inputs[k].dense;
    r.points = clouds[k].points.size();
    r.lone_points = lone;
    r.vegetation = std::move(veg);
  });
  for (const AnalyzeSessionReport& r : report.sessions) {
    spdlog::info(
        "analyze: {} {} cloud, {} points in the area ({} lone points left out), "
        "{:.1f}% vegetation (ExG > {:.3f})",
        r.session, r.dense ? "dense" : "sparse", r.points, r.lone_points,
        100.0 * r.vegetation.num_vegetation / std::max<std::size_t>(1, r.points),
        r.vegetation.threshold);
  }

  // 2. Terrain.
  std::vector<analysis::GroundCloud> ground;
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    ground.push_back(protects[k] ? clouds[k].AsGround() : analysis::GroundCloud{});
  }
  const analysis::TerrainModel dtm =
      analysis::BuildTerrain(ground, area, options.terrain, &report.terrain);
  spdlog::info(
      "analyze: terrain {}×{} nodes of {:.0f} cm, {:.1f}% fitted, {:.1f}% filled, "
      "residual scale {:.1f} mm, {:.1f} s",
      dtm.grid().width, dtm.grid().height, 100 * options.terrain.cell_m,
      100.0 * report.terrain.nodes_fitted / std::max<std::size_t>(1, report.terrain.nodes),
      100.0 * report.terrain.nodes_filled / std::max<std::size_t>(1, report.terrain.nodes),
      1000 * report.terrain.residual_scale_m, report.terrain.seconds);

  // 3. Sites: ours above the DTM, the paper's above one plane from the earliest session that
  // has enough soil points at the site.
  const analysis::GroundFunction dtm_ground = [&](double x, double y) { return dtm.Height(x, y); };
  // Plants: islands of canopy in each session; young plants are separate islands.
  std::vector<std::vector<analysis::DetectedPlant>> detected(clouds.size());
  tbb::parallel_for(std::size_t{0}, clouds.size(), [&](std::size_t k) {
    detected[k] =
        analysis::DetectPlants(clouds[k], dtm_ground, area, options.canopy, options.plants);
  });
  for (std::size_t k = 0; k < clouds.size(); ++k) {
    report.sessions[k].plants = detected[k].size();
  }

  report.sites.resize(sites.size() * clouds.size());
  tbb::parallel_for(std::size_t{0}, sites.size(), [&](std::size_t i) {
    const io::Site& site = sites[i];
    std::optional<analysis::GroundPlane> plane;
    for (std::size_t k = 0; k < clouds.size() && !plane; ++k) {
      if (!protects[k]) continue;
      plane = analysis::FitSiteGroundPlane(clouds[k].AsGround(), site.center_enu, site.radius_m,
                                           options.plane);
    }
    const analysis::GroundFunction plane_ground = [&](double x, double y) {
      return plane ? plane->Height(x, y) : kNaN;
    };
    // The site's stems: from the earliest session in which plants are found there. Later, leaf
    // clusters of grown plants would pass for plants.
    std::vector<Eigen::Vector2d> stems;
    for (std::size_t k = 0; k < clouds.size() && stems.empty(); ++k) {
      if (!protects[k]) continue;
      for (const analysis::DetectedPlant& p : detected[k]) {
        if ((p.stem - site.center_enu).norm() <= site.radius_m) stems.push_back(p.stem);
      }
    }
    // Latest session first: each plant's top bounds its top in the session before (plants grow;
    // CanopyOptions::max_shrink_m). The paper's method measures every session alone.
    std::vector<double> max_tops(stems.size(), kNaN);
    for (std::size_t k = clouds.size(); k-- > 0;) {
      SiteResult& r = report.sites[i * clouds.size() + k];
      r.site_id = site.id;
      r.session = inputs[k].id;
      r.date = inputs[k].date;
      r.stems = stems;
      r.ours = analysis::MeasureSite(clouds[k], dtm_ground, site, options.canopy, &stems,
                                     options.canopy.max_shrink_m >= 0 ? &max_tops : nullptr);
      for (std::size_t n = 0; n < stems.size() && protects[k] && !r.ours.plant_tops.empty(); ++n) {
        if (std::isfinite(r.ours.plant_tops[n])) {
          max_tops[n] = r.ours.plant_tops[n] + options.canopy.max_shrink_m;
        }
      }
      r.single_plane = analysis::MeasureSite(clouds[k], plane_ground, site, options.canopy, &stems);
      if (!plane) r.single_plane.note = "no ground plane at the site";
    }
  });
  std::vector<std::size_t> measured(clouds.size(), 0);  // plant tops per session
  for (std::size_t n = 0; n < report.sites.size(); ++n) {
    report.sessions[n % clouds.size()].plant_tops_lowered += report.sites[n].ours.n_lowered;
    for (const double top : report.sites[n].ours.plant_tops) {
      measured[n % clouds.size()] += std::isfinite(top) ? 1 : 0;
    }
  }
  for (std::size_t k = 0; k + 1 < clouds.size(); ++k) {
    const std::size_t lowered = report.sessions[k].plant_tops_lowered;
    if (lowered == 0) continue;
    std::size_t next = k + 1;  // the session whose tops bounded these
    while (next + 1 < clouds.size() && !protects[next]) ++next;
    // A few: points floating above single plants. Many: the crop itself was taller than in the
    // next session (lodging, wilting), which the bound would hide.
    const bool many = lowered >= 5 && lowered * 5 >= measured[k];
    const std::string text = fmt::format(
        "analyze: {}: {} of {} plant tops lowered to the plant's top on {} + {:g} cm "
        "(--max-shrink){}",
        inputs[k].id, lowered, measured[k], inputs[next].id, 100.0 * options.canopy.max_shrink_m,
        many ? "; so many that the crop may have lost height (lodging, wilting): if so, raise "
               "--max-shrink (analyze.max_shrink_m of crop4d run) or set it to -1"
             : "");
    if (many) {
      spdlog::warn("{}", text);
    } else {
      spdlog::info("{}", text);
    }
  }

  // 4. Growth: days since the first session.
  const Timestamp day0 = inputs.front().date;
  for (std::size_t i = 0; i < sites.size(); ++i) {
    std::vector<analysis::GrowthObservation> obs;
    for (std::size_t k = 0; k < clouds.size(); ++k) {
      if (!protects[k]) continue;
      obs.push_back({DurationSeconds(day0, inputs[k].date) / 86400.0,
                     report.sites[i * clouds.size() + k].ours.height_m});
    }
    report.growth.push_back({sites[i].id, analysis::FitGrowth(obs, options.growth)});
  }

  // 5. Outputs.
  fs::create_directories(out);
  WriteSiteCsv(out / "site_heights.csv", report.sites, true);
  WriteSiteCsv(out / "site_heights_single_plane.csv", report.sites, false);
  WriteSitePlantsCsv(out / "site_plants.csv", report.sites);
  WriteGrowthCsv(out / "growth.csv", report.growth, inputs, day0);
  report.outputs = {"analysis/site_heights.csv", "analysis/site_heights_single_plane.csv",
                    "analysis/site_plants.csv", "analysis/growth.csv"};
  if (options.write_rasters) {
    const io::FieldUtm utm(field.info().origin);
    const io::UtmGrid grid = utm.GridCovering(area, options.raster_cell_m);
    const std::vector<Eigen::Vector2d> centres = utm.EnuCellCentres(grid);
    std::vector<float> values(centres.size());
    for (std::size_t c = 0; c < centres.size(); ++c) {
      values[c] = static_cast<float>(dtm.Height(centres[c].x(), centres[c].y()) +
                                     field.info().origin.alt_m);
    }
    io::GeoTiffWriteOptions dtm_options;
    dtm_options.description = "terrain, WGS84 ellipsoidal height [m]";
    dtm_options.metadata = {{"field", field.info().name}, {"product", "dtm"}};
    io::WriteGeoTiff((out / "dtm.tif").string(), grid, values, dtm_options);
    report.outputs.push_back("analysis/dtm.tif");
    // CHM: bin every point into the UTM cell that holds it. Over a field the ENU→UTM map is
    // affine to well below a millimetre, so it is taken from three points.
    const Eigen::Vector2d o = utm.UtmFromEnu(Eigen::Vector3d::Zero());
    Eigen::Matrix2d a;
    a.col(0) = utm.UtmFromEnu(Eigen::Vector3d(100, 0, 0)) - o;
    a.col(1) = utm.UtmFromEnu(Eigen::Vector3d(0, 100, 0)) - o;
    a /= 100.0;
    const auto cell_of = [&](const Eigen::Vector2d& xy) -> std::ptrdiff_t {
      const Eigen::Vector2d en = o + a * xy;
      const double col = std::floor((en.x() - grid.min_easting) / grid.cell_m);
      const double row = std::floor((grid.max_northing - en.y()) / grid.cell_m);
      if (col < 0 || row < 0 || col >= grid.width || row >= grid.height) return -1;
      return static_cast<std::ptrdiff_t>(row) * grid.width + static_cast<std::ptrdiff_t>(col);
    };
    // The CHM of every session, and the change of the canopy height from each session to the
    // next (dates in order) on the same grid: chm(later) − chm(earlier), nodata where either has
    // none. Only the previous CHM is kept in memory.
    std::vector<float> previous;
    for (std::size_t k = 0; k < clouds.size(); ++k) {
      std::vector<float> chm = analysis::CanopyHeightModel(clouds[k], dtm_ground, grid.num_cells(),
                                                           cell_of, options.canopy);
      io::GeoTiffWriteOptions chm_options;
      chm_options.description = "canopy height above the terrain [m]";
      chm_options.metadata = {{"field", field.info().name},
                              {"product", "chm"},
                              {"session", inputs[k].id},
                              {"date", FormatDate(inputs[k].date)}};
      const std::string name = "chm_" + inputs[k].id + ".tif";
      io::WriteGeoTiff((out / name).string(), grid, chm, chm_options);
      report.outputs.push_back("analysis/" + name);
      if (k > 0) {
        const SessionInput& earlier = inputs[k - 1];
        const SessionInput& later = inputs[k];
        io::GeoTiffWriteOptions change_options;
        change_options.description =
            fmt::format("canopy height change [m] from {} to {} (chm {} - chm {})",
                        FormatDate(earlier.date), FormatDate(later.date), later.id, earlier.id);
        change_options.metadata = {
            {"field", field.info().name},
            {"product", "chm_change"},
            {"earlier_session", earlier.id},
            {"earlier_date", FormatDate(earlier.date)},
            {"later_session", later.id},
            {"later_date", FormatDate(later.date)},
            {"days", fmt::format("{:g}", DurationSeconds(earlier.date, later.date) / 86400.0)}};
        for (const std::size_t j : {k - 1, k}) {
          if (!protects[j]) {
            change_options.metadata["note"] +=
                (change_options.metadata["note"].empty() ? "" : "; ") + inputs[j].id +
                " is degraded (season quality)";
          }
        }
        const std::string change = "chm_change_" + earlier.id + "_" + later.id + ".tif";
        io::WriteGeoTiff((out / change).string(), grid, io::RasterDifference(chm, previous),
                         change_options);
        report.outputs.push_back("analysis/" + change);
      }
      previous = std::move(chm);
    }
  }
  if (options.write_plots) {
    const std::vector<std::string> plots =
        WriteHeightPlots(out / "plots", sites, report.sites, inputs.size(),
                         fs::exists(measurements) ? measurements.string() : std::string());
    for (const std::string& p : plots) report.outputs.push_back("analysis/plots/" + p);
  }

  // Summary (last: its fingerprint marks a complete run).
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  json summary;
  summary["fingerprint"] = stamp;
  summary["version"] = kVersion;
  summary["options"] = OptionsJson(options);
  summary["area_enu"] = {{"min", {area.min().x(), area.min().y()}},
                         {"max", {area.max().x(), area.max().y()}}};
  for (const AnalyzeSessionReport& r : report.sessions) {
    summary["sessions"].push_back(
        {{"session", r.session},
         {"date", FormatDate(r.date)},
         {"cloud", r.cloud_path},
         {"dense", r.dense},
         {"points", r.points},
         {"lone_points", r.lone_points},
         {"plants", r.plants},
         {"plant_tops_lowered", r.plant_tops_lowered},
         {"vegetation_fraction",
          static_cast<double>(r.vegetation.num_vegetation) / std::max<std::size_t>(1, r.points)},
         {"vegetation_threshold", r.vegetation.threshold},
         {"vegetation_separability", r.vegetation.separability},
         {"vegetation_threshold_automatic", r.vegetation.automatic}});
  }
  summary["quality"] = SeasonQualityToJson(quality);
  const analysis::TerrainSummary& t = report.terrain;
  summary["terrain"] = {{"nodes", t.nodes},
                        {"nodes_fitted", t.nodes_fitted},
                        {"nodes_filled", t.nodes_filled},
                        {"ground_points_first", t.ground_points_first},
                        {"ground_points_later", t.ground_points_later},
                        {"residual_scale_m", t.residual_scale_m},
                        {"seconds", t.seconds}};
  json notes = json::array();
  for (const SiteResult& r : report.sites) {
    if (!r.ours.note.empty()) {
      notes.push_back({{"site_id", r.site_id}, {"session", r.session}, {"note", r.ours.note}});
    }
  }
  summary["site_notes"] = notes;
  summary["outputs"] = report.outputs;
  std::vector<std::string> written;  // report.outputs are relative to the workspace
  for (const std::string& path : report.outputs) {
    written.push_back(fs::path(path).lexically_relative("analysis").generic_string());
  }
  workspace::RecordOutputs(&summary, out, written);
  summary["seconds"] = report.seconds;
  io::WriteFileAtomic((out / "summary.json").string(), summary.dump(2) + "\n");
  return report;
}

std::string FormatAnalyzeReport(const AnalyzeReport& report) {
  std::string s;
  if (report.sites.empty()) return "analyze: no sites\n";
  std::vector<std::string> sessions;
  for (const SiteResult& r : report.sites) {
    if (std::find(sessions.begin(), sessions.end(), r.session) == sessions.end()) {
      sessions.push_back(r.session);
    }
  }
  s += report.skipped ? "Canopy height per site [m] (up to date; DTM / single plane):\n"
                      : "Canopy height per site [m] (DTM / single plane):\n";
  s += fmt::format("{:<10}", "site");
  for (const std::string& id : sessions) s += fmt::format(" {:>15}", id);
  s += "\n";
  std::string current;
  for (const SiteResult& r : report.sites) {
    if (r.site_id != current) {
      if (!current.empty()) s += "\n";
      current = r.site_id;
      s += fmt::format("{:<10}", r.site_id);
    }
    const auto cell = [](double v) {
      return std::isfinite(v) ? fmt::format("{:.3f}", v) : "  -  ";
    };
    s += fmt::format(" {:>15}", cell(r.ours.height_m) + " / " + cell(r.single_plane.height_m));
  }
  s += "\n";
  if (!report.growth.empty()) {
    s += "Growth (logistic fit per site):\n";
    for (const SiteGrowth& g : report.growth) {
      if (g.fit.ok()) {
        s += fmt::format("  {:<10} asymptote {:.3f} m, max growth {:.1f} mm/day, rmse {:.1f} mm\n",
                         g.site_id, g.fit.curve.asymptote_m, 1000 * g.fit.curve.MaxGrowthRate(),
                         1000 * g.fit.rmse_m);
      } else {
        s += fmt::format("  {:<10} {}: {}\n", g.site_id, analysis::GrowthStatusName(g.fit.status),
                         g.fit.message);
      }
    }
  }
  if (!report.skipped) {
    s += fmt::format("analyze: {} outputs in {:.1f} s\n", report.outputs.size(), report.seconds);
  }
  return s;
}

}  // namespace crop4d::pipeline
