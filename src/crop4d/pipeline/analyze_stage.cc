#include "crop4d/pipeline/analyze_stage.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <functional>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <optional>
#include <set>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/core/version.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/ply.h"
#include "crop4d/pipeline/analyze_plots.h"
#include "crop4d/pipeline/analyze_tiles.h"
#include "crop4d/pipeline/season_quality.h"
#include "crop4d/pipeline/stage_option_fields.h"
#include "crop4d/workspace/analysis_rasters.h"
#include "crop4d/workspace/analysis_results.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/layout.h"
#include "crop4d/workspace/stage_files.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

// Bump when the stage's outputs change for the same inputs and options.
// 2: touching plants split; 3: tops bounded by the next session's; 4: lone points left out;
// 5: ground filter; 6: Cloud-Optimized GeoTIFFs and the height-change rasters; 7: the sessions
// read one at a time, the later sessions' ground points thinned per session; 8: the sessions read
// in tiles, the ground filter's cells on one grid of the plane, the vegetation threshold from the
// colour counts.
constexpr int kAnalyzeStageRevision = 8;

// The sessions with a registered cloud (dense when there is one and `which` allows it), in date
// order. Throws InputError when there is none.
std::vector<SessionInput> FindSessions(const io::Field& field, const workspace::Layout& ws,
                                       const std::string& which) {
  std::vector<SessionInput> out;
  for (const std::string& id : field.session_ids()) {
    SessionInput s;
    s.id = id;
    const fs::path dense = ws.DenseCloud(id);
    const fs::path sparse = ws.FusedSparse(id);
    if (which != "sparse" && fs::exists(dense)) {
      s.cloud = dense;
      s.dense = true;
    } else if (which != "dense" && fs::exists(sparse)) {
      s.cloud = sparse;
    } else {
      spdlog::warn("analyze: session {} has no {} cloud in {}, skipped", id,
                   which == "auto" ? "registered" : which, ws.root().string());
      continue;
    }
    s.date = field.OpenSession(id).info().date;
    out.push_back(s);
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const SessionInput& a, const SessionInput& b) { return a.date < b.date; });
  if (out.empty()) {
    throw InputError(ws.root().string(), 0,
                     "no registered clouds (fused/<session>/sparse.ply or dense/<session>.ply): "
                     "run `crop4d fuse` first");
  }
  return out;
}

// The sites of the sites file, else of field.yaml. Throws InputError when there is none.
std::vector<io::Site> StageSites(const io::Field& field, const std::string& field_folder,
                                 const AnalyzeStageOptions& options) {
  std::vector<io::Site> sites = options.sites_file.empty()
                                    ? field.info().sites
                                    : ReadSitesCsv(options.sites_file, field.info().origin);
  if (sites.empty()) {
    throw InputError(options.sites_file.empty() ? field_folder + "/field.yaml" : options.sites_file,
                     0, "no measurement sites: add `sites` to field.yaml or pass --sites FILE");
  }
  return sites;
}

// The sessions for the analysis maths. Degraded sessions (season_quality.h) are measured, but
// never set the terrain, the stems, the growth bounds or the growth curves of the others: not
// trusted.
std::vector<analysis::SeasonSession> SeasonSessions(const std::vector<SessionInput>& inputs,
                                                    const SeasonQuality& quality) {
  std::vector<analysis::SeasonSession> sessions;
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    sessions.push_back({inputs[k].id, inputs[k].date, quality.Protects(inputs[k].id)});
    if (!sessions[k].trusted) {
      spdlog::warn(
          "analyze: {} is degraded: measured, but not used for the terrain, the plant "
          "stems, the growth bounds or the growth curves",
          inputs[k].id);
    }
  }
  return sessions;
}

// The fingerprint of everything the outputs depend on: options, sites, clouds, season quality
// and the measurements the plots show.
std::string InputsFingerprint(const AnalyzeStageOptions& options,
                              const std::vector<io::Site>& sites,
                              const std::vector<SessionInput>& inputs, const SeasonQuality& quality,
                              const fs::path& measurements) {
  Fnv1aHasher fingerprint;
  fingerprint.Add(kAnalyzeStageRevision);
  fingerprint.AddString(kVersion);
  fingerprint.AddString(AnalyzeOptionsJson(options).dump());
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
  fingerprint.AddString(SeasonQualityToJson(quality).dump());
  fingerprint.AddString(fs::exists(measurements) ? workspace::FileHash(measurements) : "");
  return std::to_string(fingerprint.hash());
}

// The tiles of the analysed area: strips of at most tile_m across its longer side, each read
// with the reach that the lone points, the ground filter and the vegetation clearance need.
analysis::AreaTiling StageTiling(const Eigen::AlignedBox2d& area,
                                 const AnalyzeStageOptions& options) {
  const double reach =
      std::max(analysis::TerrainBuilder::TileReach(options.terrain), options.lone_point_radius_m) +
      0.01;
  return analysis::TileArea(area, options.tile_m, reach);
}

// A session's points at the sites, gathered tile by tile: kept in the order of the file, as
// from the whole cloud (the paper's plane per site samples them by position).
class SitePointsGatherer {
 public:
  SitePointsGatherer(const std::vector<io::Site>& sites, const AnalyzeStageOptions& options)
      : sites_(sites), options_(options) {}

  void Add(const TileCloud& tile) {
    std::vector<std::uint64_t> owned_index;  // of the tile's own points, in the file
    for (std::size_t i = 0; i < tile.owned.size(); ++i) {
      if (tile.owned[i]) owned_index.push_back(tile.index[i]);
    }
    std::vector<std::size_t> taken;
    const analysis::SessionCloud near =
        analysis::SitePoints(tile.Owned(), sites_, options_.canopy, &taken);
    points_.session = near.session;
    points_.points.insert(points_.points.end(), near.points.begin(), near.points.end());
    points_.colors.insert(points_.colors.end(), near.colors.begin(), near.colors.end());
    points_.is_vegetation.insert(points_.is_vegetation.end(), near.is_vegetation.begin(),
                                 near.is_vegetation.end());
    for (const std::size_t k : taken) index_.push_back(owned_index[k]);
  }

  analysis::SessionCloud Finish() {
    std::vector<std::size_t> order(index_.size());
    for (std::size_t k = 0; k < order.size(); ++k) order[k] = k;
    std::sort(order.begin(), order.end(),
              [this](std::size_t a, std::size_t b) { return index_[a] < index_[b]; });
    return points_.Take(order);
  }

 private:
  const std::vector<io::Site>& sites_;
  const AnalyzeStageOptions& options_;
  analysis::SessionCloud points_;
  std::vector<std::uint64_t> index_;
};

// Step 1, the first pass over the clouds, a session at a time in date order and each session a
// tile at a time: the sessions' surveys (lone points, vegetation threshold) and statistics, the
// terrain from the trusted sessions' ground points, and each session's points at the sites.
analysis::TerrainModel FirstPass(const std::vector<SessionInput>& inputs,
                                 const std::vector<analysis::SeasonSession>& sessions,
                                 const std::vector<io::Site>& sites,
                                 const Eigen::AlignedBox2d& area, const workspace::Layout& ws,
                                 const AnalyzeStageOptions& options,
                                 std::vector<SessionSurvey>* surveys,
                                 std::vector<analysis::SessionCloud>* site_clouds,
                                 AnalyzeReport* report) {
  report->sessions.resize(inputs.size());
  site_clouds->resize(inputs.size());
  surveys->resize(inputs.size());
  const analysis::AreaTiling tiling = StageTiling(area, options);
  analysis::TerrainBuilder terrain(area, options.terrain);
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    SessionTiles tiles(inputs[k], area, tiling);
    SessionSurvey& survey = (*surveys)[k];
    survey = tiles.Survey(options.lone_point_radius_m, options.vegetation);
    AnalyzeSessionReport& r = report->sessions[k];
    r.session = inputs[k].id;
    r.date = inputs[k].date;
    r.cloud_path = fs::relative(inputs[k].cloud, ws.root()).string();
    r.dense = inputs[k].dense;
    r.points = survey.points;
    r.lone_points = survey.lone.size();
    r.vegetation = survey.vegetation;
    if (sessions[k].trusted) terrain.BeginSession();
    SitePointsGatherer site_points(sites, options);
    for (std::size_t t = 0; t < tiles.num_tiles(); ++t) {
      const TileCloud tile = tiles.Read(t, survey, options.vegetation, /*with_reach=*/true);
      if (sessions[k].trusted) {
        terrain.AddTile(tile.cloud.AsGround(), tiles.axis(), tiles.tile(t).lo, tiles.tile(t).hi);
      }
      site_points.Add(tile);
    }
    if (sessions[k].trusted) terrain.EndSession();
    (*site_clouds)[k] = site_points.Finish();
    spdlog::info(
        "analyze: {} {} cloud, {} points in the area ({} lone points left out), "
        "{:.1f}% vegetation (ExG > {:.3f}), {} tile{} ({:.1f} reads of the file)",
        r.session, r.dense ? "dense" : "sparse", r.points, r.lone_points,
        100.0 * r.vegetation.num_vegetation / std::max<std::size_t>(1, r.points),
        r.vegetation.threshold, tiles.num_tiles(), tiles.num_tiles() == 1 ? "" : "s",
        tiles.read_fraction());
  }
  return terrain.Finish(&report->terrain);
}

// Says how many plant tops each session's successor bounded (CanopyOptions::max_shrink_m): a
// few are points floating above single plants; many, that the crop itself was taller than in
// the next session (lodging, wilting), which the bound would hide: a warning then.
void LogLoweredTops(const std::vector<analysis::SeasonSession>& sessions,
                    const AnalyzeStageOptions& options, AnalyzeReport* report) {
  const std::size_t n_sessions = sessions.size();
  std::vector<std::size_t> measured(n_sessions, 0);  // plant tops per session
  for (std::size_t n = 0; n < report->sites.size(); ++n) {
    report->sessions[n % n_sessions].plant_tops_lowered += report->sites[n].ours.n_lowered;
    for (const double top : report->sites[n].ours.plant_tops) {
      measured[n % n_sessions] += std::isfinite(top) ? 1 : 0;
    }
  }
  for (std::size_t k = 0; k + 1 < n_sessions; ++k) {
    const std::size_t lowered = report->sessions[k].plant_tops_lowered;
    if (lowered == 0) continue;
    std::size_t next = k + 1;  // the session whose tops bounded these
    while (next + 1 < n_sessions && !sessions[next].trusted) ++next;
    const bool many = lowered >= 5 && lowered * 5 >= measured[k];
    const std::string text = fmt::format(
        "analyze: {}: {} of {} plant tops lowered to the plant's top on {} + {:g} cm "
        "(--max-shrink){}",
        sessions[k].id, lowered, measured[k], sessions[next].id,
        100.0 * options.canopy.max_shrink_m,
        many ? "; so many that the crop may have lost height (lodging, wilting): if so, raise "
               "--max-shrink (analyze.max_shrink_m of crop4d run) or set it to -1"
             : "");
    if (many) {
      spdlog::warn("{}", text);
    } else {
      spdlog::info("{}", text);
    }
  }
}

// The path of a file of the workspace as the stage records it: relative to the workspace.
std::string WorkspaceRelative(const workspace::Layout& ws, const fs::path& path) {
  return path.lexically_relative(ws.root()).generic_string();
}

// The cell of `grid` that holds an ENU xy (−1 outside). Over a field the ENU→UTM map is affine
// to well below a millimetre, so it is taken from three points.
std::function<std::ptrdiff_t(const Eigen::Vector2d&)> UtmCellOf(const io::FieldUtm& utm,
                                                                const io::UtmGrid& grid) {
  const Eigen::Vector2d o = utm.UtmFromEnu(Eigen::Vector3d::Zero());
  Eigen::Matrix2d a;
  a.col(0) = utm.UtmFromEnu(Eigen::Vector3d(100, 0, 0)) - o;
  a.col(1) = utm.UtmFromEnu(Eigen::Vector3d(0, 100, 0)) - o;
  a /= 100.0;
  return [o, a, grid](const Eigen::Vector2d& xy) -> std::ptrdiff_t {
    const Eigen::Vector2d en = o + a * xy;
    const double col = std::floor((en.x() - grid.min_easting) / grid.cell_m);
    const double row = std::floor((grid.max_northing - en.y()) / grid.cell_m);
    if (col < 0 || row < 0 || col >= grid.width || row >= grid.height) return -1;
    return static_cast<std::ptrdiff_t>(row) * grid.width + static_cast<std::ptrdiff_t>(col);
  };
}

// The rasters (step 3): the terrain model, every session's canopy height model and the change
// of the canopy height from each session to the next (dates in order), on one UTM grid. Sessions
// are added in date order; only the previous CHM is kept.
class RasterWriter {
 public:
  RasterWriter(const io::FieldInfo& info, const Eigen::AlignedBox2d& area,
               const analysis::TerrainModel& dtm, const AnalyzeStageOptions& options,
               const workspace::Layout& ws)
      : info_(info),
        utm_(info.origin),
        grid_(utm_.GridCovering(area, options.raster_cell_m)),
        cell_of_(UtmCellOf(utm_, grid_)),
        dtm_(dtm),
        options_(options),
        ws_(ws) {
    const std::vector<Eigen::Vector2d> centres = utm_.EnuCellCentres(grid_);
    std::vector<float> heights(centres.size());
    for (std::size_t c = 0; c < centres.size(); ++c) {
      heights[c] =
          static_cast<float>(dtm.Height(centres[c].x(), centres[c].y()) + info.origin.alt_m);
    }
    workspace::WriteDtm(ws, info.name, grid_, heights);
    outputs_.push_back(WorkspaceRelative(ws, ws.Dtm()));
  }

  // A session's canopy height model, filled a part of its cloud at a time (AddToChm), then
  // written (WriteSession).
  std::vector<float> NewChm() const {
    return std::vector<float>(grid_.num_cells(), std::numeric_limits<float>::quiet_NaN());
  }
  void AddToChm(const analysis::SessionCloud& cloud, std::vector<float>* chm) const {
    const analysis::GroundFunction ground = [&](double x, double y) { return dtm_.Height(x, y); };
    analysis::AddToCanopyHeightModel(cloud, ground, cell_of_, options_.canopy, chm);
  }
  void WriteSession(const analysis::SeasonSession& session, std::vector<float> chm) {
    workspace::WriteChm(ws_, info_.name, grid_, session, chm);
    outputs_.push_back(WorkspaceRelative(ws_, ws_.Chm(session.id)));
    if (previous_session_) {
      workspace::WriteChmChange(ws_, info_.name, grid_, *previous_session_, session,
                                io::RasterDifference(chm, previous_));
      outputs_.push_back(WorkspaceRelative(ws_, ws_.ChmChange(previous_session_->id, session.id)));
    }
    previous_ = std::move(chm);
    previous_session_ = session;
  }

  const std::vector<std::string>& outputs() const { return outputs_; }

 private:
  const io::FieldInfo& info_;
  io::FieldUtm utm_;
  io::UtmGrid grid_;
  std::function<std::ptrdiff_t(const Eigen::Vector2d&)> cell_of_;
  const analysis::TerrainModel& dtm_;
  const AnalyzeStageOptions& options_;
  const workspace::Layout& ws_;
  std::vector<float> previous_;
  std::optional<analysis::SeasonSession> previous_session_;
  std::vector<std::string> outputs_;
};

// Step 2, the second pass over the clouds, a session at a time and each session a tile at a
// time, now that the terrain is known: each session's plants (returned) and, when asked, its
// rasters (their paths into `raster_outputs`). A tile's own points are enough: the plants'
// raster and the canopy height models keep a maximum per cell.
std::vector<std::vector<analysis::DetectedPlant>> SecondPass(
    const std::vector<SessionInput>& inputs, const std::vector<analysis::SeasonSession>& sessions,
    const std::vector<SessionSurvey>& surveys, const io::FieldInfo& info,
    const Eigen::AlignedBox2d& area, const analysis::TerrainModel& dtm, const workspace::Layout& ws,
    const AnalyzeStageOptions& options, std::vector<std::string>* raster_outputs) {
  std::optional<RasterWriter> rasters;
  if (options.write_rasters) rasters.emplace(info, area, dtm, options, ws);
  const analysis::GroundFunction ground = [&](double x, double y) { return dtm.Height(x, y); };
  const analysis::AreaTiling tiling = StageTiling(area, options);
  std::vector<std::vector<analysis::DetectedPlant>> plants(inputs.size());
  for (std::size_t k = 0; k < inputs.size(); ++k) {
    SessionTiles tiles(inputs[k], area, tiling, &surveys[k]);
    analysis::PlantRaster raster(area, options.canopy, options.plants);
    std::vector<float> chm;
    if (rasters) chm = rasters->NewChm();
    for (std::size_t t = 0; t < tiles.num_tiles(); ++t) {
      const TileCloud tile = tiles.Read(t, surveys[k], options.vegetation, /*with_reach=*/false);
      raster.Add(tile.cloud, ground);
      if (rasters) rasters->AddToChm(tile.cloud, &chm);
    }
    plants[k] = analysis::PlantsOnRows(raster.Detect(), info.rows, options.plants);
    if (rasters) rasters->WriteSession(sessions[k], std::move(chm));
    spdlog::info("analyze: {}: {} plants found{}", inputs[k].id, plants[k].size(),
                 rasters ? ", its canopy rasters written" : "");
  }
  if (rasters) *raster_outputs = rasters->outputs();
  return plants;
}

// The stage's record (written last: its fingerprint marks a complete run).
workspace::AnalysisSummary Summary(const AnalyzeReport& report, const std::string& stamp,
                                   const AnalyzeStageOptions& options,
                                   const Eigen::AlignedBox2d& area, const SeasonQuality& quality) {
  workspace::AnalysisSummary summary;
  summary.fingerprint = stamp;
  summary.version = kVersion;
  summary.options = AnalyzeOptionsJson(options);
  summary.area_min = {area.min().x(), area.min().y()};
  summary.area_max = {area.max().x(), area.max().y()};
  for (const AnalyzeSessionReport& r : report.sessions) {
    summary.sessions.push_back(
        {r.session, FormatDate(r.date), r.cloud_path, r.dense, r.points, r.lone_points, r.plants,
         r.plant_tops_lowered,
         static_cast<double>(r.vegetation.num_vegetation) / std::max<std::size_t>(1, r.points),
         r.vegetation.threshold, r.vegetation.separability, r.vegetation.automatic});
  }
  summary.quality = SeasonQualityToJson(quality);
  const analysis::TerrainSummary& t = report.terrain;
  summary.terrain = {t.nodes,
                     t.nodes_fitted,
                     t.nodes_filled,
                     t.ground_points_first,
                     t.ground_points_later,
                     t.residual_scale_m,
                     t.seconds};
  for (const SiteResult& r : report.sites) {
    if (!r.ours.note.empty()) summary.site_notes.push_back({r.site_id, r.session, r.ours.note});
  }
  summary.outputs = report.outputs;
  summary.seconds = report.seconds;
  return summary;
}

}  // namespace

OptionCheck AnalyzeStageOptions::Check() const {
  if (cloud != "auto" && cloud != "dense" && cloud != "sparse") {
    return "cloud: must be auto, dense or sparse (got '" + cloud + "')";
  }
  OptionChecker c;
  c.Greater("raster_cell_m", raster_cell_m, 0.0)
      .AtLeast("margin_m", margin_m, 0.0)
      .AtLeast("lone_point_radius_m", lone_point_radius_m, 0.0)
      .AtLeast("tile_m", tile_m, 0.0)
      .Nested("vegetation", vegetation.Check())
      .Nested("terrain", terrain.Check())
      .Nested("canopy", canopy.Check())
      .Nested("plants", plants.Check())
      .Nested("plane", plane.Check())
      .Nested("growth", growth.Check());
  return c.Result();
}

AnalyzeReport RunAnalyzeStage(const std::string& field_folder, const std::string& workspace,
                              const AnalyzeStageOptions& options) {
  if (const std::string why = options.Check(); !why.empty()) throw InputError("analyze." + why);
  const auto t0 = std::chrono::steady_clock::now();
  AnalyzeReport report;
  const io::Field field(field_folder);
  const workspace::Layout ws(workspace);
  const std::vector<io::Site> sites = StageSites(field, field_folder, options);
  const std::vector<SessionInput> inputs = FindSessions(field, ws, options.cloud);
  const fs::path measurements = fs::path(field_folder) / "ground_truth" / "site_measurements.csv";
  const SeasonQuality quality = ReadSeasonQuality(workspace);
  const std::vector<analysis::SeasonSession> sessions = SeasonSessions(inputs, quality);
  const std::string stamp = InputsFingerprint(options, sites, inputs, quality, measurements);
  std::string why;
  if (!options.force && fs::exists(ws.SiteHeights()) && fs::exists(ws.SitePlants()) &&
      fs::exists(ws.Growth()) && workspace::SummaryUpToDate(ws.AnalysisSummary(), stamp, &why)) {
    spdlog::info("analyze: up to date, skipped (--force to analyse again)");
    report.skipped = true;
    report.sites = workspace::ReadSiteResults(ws);
    report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    return report;
  }
  // The previous results no longer match their inputs: they go before the new ones are made,
  // so that a failure below leaves no stale heights for eval and the report to show.
  if (fs::is_directory(ws.AnalysisDir())) {
    spdlog::info("analyze: the previous results in {} are removed ({})", ws.AnalysisDir().string(),
                 options.force ? "--force" : (why.empty() ? "some of them are missing" : why));
    fs::remove_all(ws.AnalysisDir());
  }

  // 1. Clouds, vegetation, terrain and the points at the sites.
  const Eigen::AlignedBox2d area = analysis::AnalysedArea(field.info(), sites, options.margin_m);
  std::vector<SessionSurvey> surveys;
  std::vector<analysis::SessionCloud> site_clouds;
  const analysis::TerrainModel dtm =
      FirstPass(inputs, sessions, sites, area, ws, options, &surveys, &site_clouds, &report);
  spdlog::info(
      "analyze: terrain {}×{} nodes of {:.0f} cm, {:.1f}% fitted, {:.1f}% filled, "
      "residual scale {:.1f} mm, {:.1f} s",
      dtm.grid().width, dtm.grid().height, 100 * options.terrain.cell_m,
      100.0 * report.terrain.nodes_fitted / std::max<std::size_t>(1, report.terrain.nodes),
      100.0 * report.terrain.nodes_filled / std::max<std::size_t>(1, report.terrain.nodes),
      1000 * report.terrain.residual_scale_m, report.terrain.seconds);

  // 2. Plants and rasters (the clouds read again).
  fs::create_directories(ws.AnalysisDir());
  std::vector<std::string> raster_outputs;
  const std::vector<std::vector<analysis::DetectedPlant>> plants =
      SecondPass(inputs, sessions, surveys, field.info(), area, dtm, ws, options, &raster_outputs);
  for (std::size_t k = 0; k < plants.size(); ++k) report.sessions[k].plants = plants[k].size();

  // 3. Sites: ours above the DTM, the paper's above one plane per site.
  const analysis::GroundFunction dtm_ground = [&](double x, double y) { return dtm.Height(x, y); };
  report.sites = analysis::MeasureSeasonSites(sites, sessions, site_clouds, plants, dtm_ground,
                                              options.canopy, options.plane);
  LogLoweredTops(sessions, options, &report);

  // 4. Growth: days since the first session.
  report.growth = analysis::FitSeasonGrowth(sites, sessions, report.sites, options.growth);

  // 5. Outputs.
  workspace::WriteSiteHeights(ws.SiteHeights(), workspace::SiteHeightRows(report.sites, true));
  workspace::WriteSiteHeights(ws.SiteHeightsSinglePlane(),
                              workspace::SiteHeightRows(report.sites, false));
  workspace::WriteSitePlants(ws.SitePlants(), workspace::SitePlantRows(report.sites));
  workspace::WriteGrowth(ws.Growth(), workspace::GrowthRows(report.growth, sessions));
  for (const fs::path& p :
       {ws.SiteHeights(), ws.SiteHeightsSinglePlane(), ws.SitePlants(), ws.Growth()}) {
    report.outputs.push_back(WorkspaceRelative(ws, p));
  }
  report.outputs.insert(report.outputs.end(), raster_outputs.begin(), raster_outputs.end());
  if (options.write_plots) {
    const std::vector<std::string> plots =
        WriteHeightPlots(ws.PlotsDir(), sites, report.sites, inputs.size(),
                         fs::exists(measurements) ? measurements.string() : std::string());
    for (const std::string& p : plots) {
      report.outputs.push_back(WorkspaceRelative(ws, ws.PlotsDir() / p));
    }
  }
  report.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  workspace::WriteAnalysisSummary(ws, Summary(report, stamp, options, area, quality));
  return report;
}

}  // namespace crop4d::pipeline
