// The analysis stage on registered clouds sampled from a synthetic world's true geometry (the
// simulator's terrain with beds, furrows and tyre tracks, and its plant meshes growing over four
// sessions): heights against the world's true site heights, the outputs, the rasters, the
// skip of an unchanged workspace, and sites without vegetation or without points.

#include "crop4d/pipeline/analyze_stage.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/eval/plant_eval.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/dataset_writer.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/ply.h"
#include "crop4d/sim/plant_mesh.h"
#include "crop4d/sim/world.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;

sim::WorldOptions SmallWorld(std::uint64_t seed) {
  sim::WorldOptions w;
  w.num_rows = 3;
  w.row_length_m = 6.0;
  w.headland_m = 2.0;
  w.sowing_date = FromDate(2016, 5, 10);
  w.seed = seed;
  return w;
}

const std::vector<std::string> kSessions = {"2016-06-01", "2016-06-15", "2016-06-29", "2016-07-13"};

// The top surface of the rendered plants on `date` as a height grid of 1 cm cells over `box`:
// every triangle of every plant's mesh (sim/plant_mesh.h) sampled every few millimetres, the
// highest sample per cell; NaN where no plant is.
struct TopGrid {
  Eigen::AlignedBox2d box;
  double cell = 0.01;
  int cols = 0, rows = 0;
  std::vector<float> top;
  float At(double x, double y) const {
    const int c = static_cast<int>((x - box.min().x()) / cell);
    const int r = static_cast<int>((y - box.min().y()) / cell);
    if (c < 0 || r < 0 || c >= cols || r >= rows) return std::nanf("");
    return top[static_cast<std::size_t>(r) * cols + c];
  }
};

TopGrid PlantTops(const sim::World& world, const Eigen::AlignedBox2d& box, Timestamp date) {
  TopGrid g;
  g.box = box;
  g.cols = static_cast<int>(box.sizes().x() / g.cell) + 1;
  g.rows = static_cast<int>(box.sizes().y() / g.cell) + 1;
  g.top.assign(static_cast<std::size_t>(g.cols) * g.rows, std::nanf(""));
  for (const sim::Plant& plant : world.plants()) {
    sim::PlantMesh mesh;
    sim::AppendPlantMesh(world, plant, date, 0, sim::PlantLod::kMedium, &mesh);
    for (std::size_t t = 0; t + 2 < mesh.indices.size(); t += 3) {
      Eigen::Vector3d v[3];
      for (int k = 0; k < 3; ++k) {
        const float* p = mesh.vertices[mesh.indices[t + k]].position;
        v[k] = Eigen::Vector3d(p[0], p[1], p[2]);
      }
      const double edge =
          std::max({(v[1] - v[0]).norm(), (v[2] - v[0]).norm(), (v[2] - v[1]).norm()});
      const int n = std::max(1, static_cast<int>(std::ceil(edge / 0.003)));
      for (int a = 0; a <= n; ++a) {
        for (int b = 0; a + b <= n; ++b) {
          const Eigen::Vector3d q = v[0] + (v[1] - v[0]) * a / n + (v[2] - v[0]) * b / n;
          const int c = static_cast<int>((q.x() - box.min().x()) / g.cell);
          const int r = static_cast<int>((q.y() - box.min().y()) / g.cell);
          if (c < 0 || r < 0 || c >= g.cols || r >= g.rows) continue;
          float& cell = g.top[static_cast<std::size_t>(r) * g.cols + c];
          if (!(cell >= q.z())) cell = static_cast<float>(q.z());
        }
      }
    }
  }
  return g;
}

// A field folder (field.yaml with rows and sites, session.yaml per session) and a workspace with
// a dense cloud per session, the surface seen from above sampled every ~1 cm with 2 mm noise:
// green where a plant is, soil colours elsewhere.
void WriteTruthWorkspace(const sim::World& world, const std::string& field,
                         const std::string& workspace) {
  io::FieldInfo info;
  info.name = "truth";
  info.origin = {31.47, -83.53, 100.0};
  const sim::WorldOptions& w = world.options();
  for (int r = 0; r < w.num_rows; ++r) {
    info.rows.push_back({r, world.RowStart(r).head<2>(), world.RowEnd(r).head<2>()});
    for (const double y : {1.5, 4.5}) {
      io::Site site;
      site.id = "r" + std::to_string(r) + "y" + std::to_string(static_cast<int>(y));
      site.center_enu = {world.RowX(r), y};
      site.radius_m = 0.4;
      info.sites.push_back(site);
    }
  }
  info.sessions = kSessions;
  fs::create_directories(field);
  io::WriteFieldYaml(field + "/field.yaml", info);
  std::mt19937_64 rng(w.seed);
  std::uniform_real_distribution<double> jitter(-0.005, 0.005);
  std::normal_distribution<double> noise(0.0, 0.002);
  std::uniform_int_distribution<int> shade(-20, 20);
  for (const std::string& id : kSessions) {
    io::SessionInfo session;
    session.id = id;
    ParseDate(id, &session.date);
    fs::create_directories(field + "/sessions/" + id);
    io::WriteSessionYaml(field + "/sessions/" + id + "/session.yaml", session);
    io::PlyPointCloud cloud;
    const Eigen::AlignedBox2d box(
        Eigen::Vector2d(-1.0, -0.5),
        Eigen::Vector2d(world.RowX(w.num_rows - 1) + 1.0, w.row_length_m + 0.5));
    const TopGrid tops = PlantTops(world, box, session.date);
    for (double x = box.min().x(); x <= box.max().x(); x += 0.01) {
      for (double y = box.min().y(); y <= box.max().y(); y += 0.01) {
        const double px = x + jitter(rng), py = y + jitter(rng);
        const double top = tops.At(px, py);
        const double ground = world.TerrainHeight(px, py);
        const bool plant = std::isfinite(top) && top > ground;
        const double z = plant ? top : ground;
        cloud.points.emplace_back(px, py, z + noise(rng));
        const int s = shade(rng);
        cloud.colors.push_back(
            plant ? std::array<std::uint8_t, 3>{std::uint8_t(70 + s / 2), std::uint8_t(105 + s),
                                                std::uint8_t(50 + s / 2)}
                  : std::array<std::uint8_t, 3>{std::uint8_t(150 + s), std::uint8_t(126 + s),
                                                std::uint8_t(104 + s)});
      }
    }
    io::WritePly(workspace + "/dense/" + id + ".ply", cloud);
  }
}

class AnalyzeStageTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = (fs::path(::testing::TempDir()) /
             ("crop4d_analyze_" + std::to_string(getpid()) + "_" +
              ::testing::UnitTest::GetInstance()->current_test_info()->name()))
                .string();
    fs::remove_all(root_);
    field_ = root_ + "/field";
    workspace_ = root_ + "/ws";
  }
  void TearDown() override { fs::remove_all(root_); }

  // The plant of `world` nearest to `center`.
  static const sim::Plant& NearestPlant(const sim::World& world, const Eigen::Vector2d& center) {
    const sim::Plant* plant = nullptr;
    for (const sim::Plant& p : world.plants()) {
      if (plant == nullptr || (p.xy - center).norm() < (plant->xy - center).norm()) plant = &p;
    }
    CROP4D_CHECK(plant != nullptr);
    return *plant;
  }
  // Adds green points (false matches) to a session's dense cloud; returns its true points.
  std::size_t AddToDenseCloud(const std::string& session,
                              const std::vector<Eigen::Vector3d>& points) const {
    const std::string ply = workspace_ + "/dense/" + session + ".ply";
    io::PlyPointCloud cloud = io::ReadPly(ply);
    const std::size_t num_true = cloud.points.size();
    for (const Eigen::Vector3d& p : points) {
      cloud.points.push_back(p);
      cloud.colors.push_back({70, 110, 50});
    }
    io::WritePly(ply, cloud);
    return num_true;
  }
  // The error of a site's height (ours) in one session against `truth`; NaN and a failure when
  // the report has no such result.
  static double SiteError(const AnalyzeReport& report, const std::string& site_id,
                          const std::string& session, double truth) {
    for (const SiteResult& r : report.sites) {
      if (r.site_id == site_id && r.session == session) return r.ours.height_m - truth;
    }
    ADD_FAILURE() << "no result for " << site_id << " on " << session;
    return std::nan("");
  }

  std::string root_, field_, workspace_;
};

TEST_F(AnalyzeStageTest, HeightsMatchTheTruthOnTwoWorlds) {
  for (const std::uint64_t seed : {3u, 8u}) {
    SCOPED_TRACE("seed " + std::to_string(seed));
    fs::remove_all(root_);
    const sim::World world(SmallWorld(seed));
    WriteTruthWorkspace(world, field_, workspace_);
    AnalyzeStageOptions options;
    options.write_plots = false;
    const AnalyzeReport report = RunAnalyzeStage(field_, workspace_, options);
    ASSERT_EQ(report.sessions.size(), 4u);
    ASSERT_EQ(report.sites.size(), 6u * 4u);
    double sum2 = 0.0, worst = 0.0, plane_sum2 = 0.0, bias = 0.0;
    int n = 0;
    const io::Field field(field_);
    for (const SiteResult& r : report.sites) {
      const io::Site* site = nullptr;
      for (const io::Site& s : field.info().sites) {
        if (s.id == r.site_id) site = &s;
      }
      ASSERT_NE(site, nullptr);
      const double truth = world.TrueCanopyHeight(site->center_enu, site->radius_m, r.date);
      ASSERT_TRUE(std::isfinite(r.ours.height_m)) << r.site_id << " " << r.session;
      const double e = r.ours.height_m - truth;
      sum2 += e * e;
      bias += e;
      worst = std::max(worst, std::abs(e));
      plane_sum2 += std::pow(r.single_plane.height_m - truth, 2);
      ++n;
      EXPECT_GT(r.ours.cover, 0.0);
      EXPECT_LE(r.ours.cover, 1.0);
    }
    const double rmse = std::sqrt(sum2 / n);
    // The targets (2 cm RMSE, no site above 4 cm) on the true geometry. Measured: 9.9
    // and 13.2 mm RMSE, worst 28 and 26 mm (the clouds' 2 mm noise, and neighbours' leaves
    // reaching within 8 cm of a plant's stem late in the season).
    EXPECT_LT(rmse, 0.02);
    EXPECT_LT(worst, 0.04);
    RecordProperty("rmse_mm_seed_" + std::to_string(seed), std::to_string(1000 * rmse));
    std::printf(
        "seed %llu: canopy height RMSE %.1f mm (bias %+.1f mm, worst %.1f mm), single plane %.1f "
        "mm\n",
        static_cast<unsigned long long>(seed), 1000 * rmse, 1000 * bias / n, 1000 * worst,
        1000 * std::sqrt(plane_sum2 / n));
    // Growth: heights rise through the sessions, and four dates allow a logistic fit.
    for (const SiteGrowth& g : report.growth) {
      EXPECT_TRUE(g.fit.ok()) << g.site_id << ": " << g.fit.message;
      ASSERT_EQ(g.fit.intervals.size(), 3u);
      for (const analysis::GrowthInterval& in : g.fit.intervals) EXPECT_GT(in.rate_m_per_day, 0);
    }
  }
}

TEST_F(AnalyzeStageTest, AFalseMatchAboveAPlantIsNotItsTop) {
  // The true clouds, and in the third session a false match of 3 × 3 points (1 cm²) floating
  // above one plant of site r1y4, 10 cm above the plant's top in the last session. That top
  // bounds the plant's top in the sessions before (CanopyOptions::max_shrink_m, 5 cm).
  const sim::World world(SmallWorld(3));
  WriteTruthWorkspace(world, field_, workspace_);
  const Eigen::Vector2d center(world.RowX(1), 4.5);
  const sim::Plant& plant = NearestPlant(world, center);
  ASSERT_LT((plant.xy - center).norm(), 0.3);
  const std::string id = kSessions[2];
  Timestamp date = 0, last = 0;
  ASSERT_TRUE(ParseDate(id, &date));
  ASSERT_TRUE(ParseDate(kSessions[3], &last));
  const double top =
      world.TerrainHeight(plant.xy.x(), plant.xy.y()) + world.StateAt(plant, last).height_m;
  std::vector<Eigen::Vector3d> float_points;
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) {
      float_points.emplace_back(plant.xy.x() + 0.01 + 0.005 * i, plant.xy.y() + 0.005 * j,
                                top + 0.10);
    }
  }
  AddToDenseCloud(id, float_points);
  const double truth = world.TrueCanopyHeight(center, 0.4, date);
  AnalyzeStageOptions options;
  options.write_plots = false;
  options.write_rasters = false;
  const AnalyzeReport bounded = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_LT(std::abs(SiteError(bounded, "r1y4", id, truth)), 0.02);
  ASSERT_EQ(bounded.sessions.size(), 4u);
  EXPECT_GE(bounded.sessions[2].plant_tops_lowered, 1u);
  // Each session alone takes the false match for the plant's top.
  options.canopy.max_shrink_m = -1;
  const AnalyzeReport alone = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_GT(SiteError(alone, "r1y4", id, truth), 0.025);
  EXPECT_EQ(alone.sessions[2].plant_tops_lowered, 0u);
}

TEST_F(AnalyzeStageTest, ALonePointAboveAPlantIsLeftOut) {
  // One false match, a single point 6 cm above one plant of site r1y4 in the last session, where
  // no later session bounds the plant's top: as a point without neighbours it is left out.
  const sim::World world(SmallWorld(3));
  WriteTruthWorkspace(world, field_, workspace_);
  const Eigen::Vector2d center(world.RowX(1), 4.5);
  const sim::Plant& plant = NearestPlant(world, center);
  ASSERT_LT((plant.xy - center).norm(), 0.3);
  const std::string id = kSessions[3];
  Timestamp date = 0;
  ASSERT_TRUE(ParseDate(id, &date));
  const double top =
      world.TerrainHeight(plant.xy.x(), plant.xy.y()) + world.StateAt(plant, date).height_m;
  const std::size_t num_true =
      AddToDenseCloud(id, {Eigen::Vector3d(plant.xy.x() + 0.01, plant.xy.y(), top + 0.06)});
  const double truth = world.TrueCanopyHeight(center, 0.4, date);
  AnalyzeStageOptions options;
  options.write_plots = false;
  options.write_rasters = false;
  const AnalyzeReport filtered = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_LT(std::abs(SiteError(filtered, "r1y4", id, truth)), 0.02);
  ASSERT_EQ(filtered.sessions.size(), 4u);
  EXPECT_GE(filtered.sessions[3].lone_points, 1u);
  // The true cloud samples its surfaces densely: hardly any of its own points is lone.
  EXPECT_LT(filtered.sessions[3].lone_points, num_true / 1000 + 1);
  // Kept, the point is taken for the plant's top (measured: 0.4 cm left out, 2.2 cm kept).
  options.lone_point_radius_m = 0;
  const AnalyzeReport kept = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_GT(SiteError(kept, "r1y4", id, truth), 0.015);
  EXPECT_EQ(kept.sessions[3].lone_points, 0u);
}

// Sessions read in tiles of 1.3 m (tiles that cut through sites and plants, with a false match
// and a lone point near their ends) give what whole sessions give: the sessions' statistics,
// the terrain, every site's height, the plants and the rasters.
TEST_F(AnalyzeStageTest, TilesGiveTheResultsOfWholeSessions) {
  const sim::World world(SmallWorld(4));
  WriteTruthWorkspace(world, field_, workspace_);
  AddToDenseCloud(kSessions[2], {Eigen::Vector3d(world.RowX(1), 2.6, 0.5),
                                 Eigen::Vector3d(world.RowX(0), 3.9, 0.2),
                                 Eigen::Vector3d(world.RowX(0) + 0.01, 3.9, 0.2)});
  AnalyzeStageOptions options;
  options.write_plots = false;
  options.tile_m = 0.0;
  const AnalyzeReport whole = RunAnalyzeStage(field_, workspace_, options);
  const io::GeoTiffRaster whole_chm =
      io::ReadGeoTiff(workspace_ + "/analysis/chm_" + kSessions[2] + ".tif");
  const io::GeoTiffRaster whole_dtm = io::ReadGeoTiff(workspace_ + "/analysis/dtm.tif");
  options.tile_m = 1.3;
  const AnalyzeReport tiled = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_FALSE(tiled.skipped);  // another tile length: analysed again

  ASSERT_EQ(tiled.sessions.size(), whole.sessions.size());
  for (std::size_t k = 0; k < whole.sessions.size(); ++k) {
    SCOPED_TRACE(whole.sessions[k].session);
    EXPECT_EQ(tiled.sessions[k].points, whole.sessions[k].points);
    EXPECT_EQ(tiled.sessions[k].lone_points, whole.sessions[k].lone_points);
    EXPECT_EQ(tiled.sessions[k].plants, whole.sessions[k].plants);
    EXPECT_EQ(tiled.sessions[k].vegetation.threshold, whole.sessions[k].vegetation.threshold);
    EXPECT_EQ(tiled.sessions[k].vegetation.num_vegetation,
              whole.sessions[k].vegetation.num_vegetation);
  }
  EXPECT_GE(whole.sessions[2].lone_points, 1u);
  EXPECT_EQ(tiled.terrain.ground_points_first, whole.terrain.ground_points_first);
  EXPECT_EQ(tiled.terrain.ground_points_later, whole.terrain.ground_points_later);
  EXPECT_EQ(tiled.terrain.nodes_fitted, whole.terrain.nodes_fitted);
  const auto same = [](double a, double b, double tolerance) {
    return (std::isnan(a) && std::isnan(b)) || std::abs(a - b) <= tolerance;
  };
  ASSERT_EQ(tiled.sites.size(), whole.sites.size());
  int measured = 0;
  for (std::size_t n = 0; n < whole.sites.size(); ++n) {
    SCOPED_TRACE(whole.sites[n].site_id + " " + whole.sites[n].session);
    EXPECT_TRUE(same(tiled.sites[n].ours.height_m, whole.sites[n].ours.height_m, 1e-6))
        << tiled.sites[n].ours.height_m << " " << whole.sites[n].ours.height_m;
    measured += std::isfinite(whole.sites[n].ours.height_m) ? 1 : 0;
    EXPECT_EQ(tiled.sites[n].ours.n_points, whole.sites[n].ours.n_points);
    EXPECT_EQ(tiled.sites[n].ours.plant_tops.size(), whole.sites[n].ours.plant_tops.size());
    EXPECT_TRUE(
        same(tiled.sites[n].single_plane.height_m, whole.sites[n].single_plane.height_m, 1e-9));
  }
  EXPECT_GT(measured, static_cast<int>(whole.sites.size()) / 2);
  const io::GeoTiffRaster tiled_chm =
      io::ReadGeoTiff(workspace_ + "/analysis/chm_" + kSessions[2] + ".tif");
  const io::GeoTiffRaster tiled_dtm = io::ReadGeoTiff(workspace_ + "/analysis/dtm.tif");
  ASSERT_EQ(tiled_chm.values.size(), whole_chm.values.size());
  ASSERT_EQ(tiled_dtm.values.size(), whole_dtm.values.size());
  for (std::size_t c = 0; c < whole_chm.values.size(); ++c) {
    ASSERT_EQ(std::isnan(tiled_chm.values[c]), std::isnan(whole_chm.values[c])) << c;
    if (!std::isnan(whole_chm.values[c])) {
      ASSERT_NEAR(tiled_chm.values[c], whole_chm.values[c], 1e-5) << c;
    }
    ASSERT_EQ(std::isnan(tiled_dtm.values[c]), std::isnan(whole_dtm.values[c])) << c;
    if (!std::isnan(whole_dtm.values[c])) {
      ASSERT_NEAR(tiled_dtm.values[c], whole_dtm.values[c], 1e-5) << c;
    }
  }
}

TEST_F(AnalyzeStageTest, OutputsRastersAndRerun) {
  const sim::World world(SmallWorld(5));
  WriteTruthWorkspace(world, field_, workspace_);
  // A sites file: one site on a row, one on the bare headland, one far from any point.
  const std::string sites = root_ + "/sites.csv";
  std::ofstream(sites) << "site_id,x,y,radius_m\nrow,0.91,3.0,0.4\nbare,-0.8,3.0,0.15\n"
                          "far,30,30,0.4\n";
  AnalyzeStageOptions options;
  options.sites_file = sites;
  const AnalyzeReport report = RunAnalyzeStage(field_, workspace_, options);
  ASSERT_EQ(report.sites.size(), 3u * 4u);
  for (const SiteResult& r : report.sites) {
    if (r.site_id == "row") {
      EXPECT_TRUE(std::isfinite(r.ours.height_m));
    } else if (r.site_id == "bare") {
      EXPECT_TRUE(std::isnan(r.ours.height_m));
      EXPECT_EQ(r.ours.cover, 0.0);
      EXPECT_EQ(r.ours.note, "no vegetation within the site");
    } else {
      EXPECT_TRUE(std::isnan(r.ours.height_m));
      EXPECT_TRUE(std::isnan(r.ours.cover));
      EXPECT_EQ(r.ours.note, "no points within the site");
    }
  }
  const fs::path out = fs::path(workspace_) / "analysis";
  // site_heights.csv: header, one row per site and session, empty heights where none.
  std::ifstream csv(out / "site_heights.csv");
  std::string line;
  std::getline(csv, line);
  EXPECT_EQ(line, "site_id,session,date,height_m,cover,volume_m3,n_points");
  int rows = 0, empty_heights = 0;
  while (std::getline(csv, line)) {
    ++rows;
    empty_heights += line.find(",,") != std::string::npos;
  }
  EXPECT_EQ(rows, 12);
  EXPECT_EQ(empty_heights, 8);
  EXPECT_TRUE(fs::exists(out / "site_heights_single_plane.csv"));
  // site_plants.csv: the plants of site "row" (the others have none), each in every session,
  // each within 6 cm of a true stem, and its top in the last session within 4 cm of the plant's
  // true height.
  const std::vector<eval::SitePlantRow> plants =
      eval::ReadSitePlants((out / "site_plants.csv").string());
  ASSERT_FALSE(plants.empty());
  EXPECT_EQ(plants.size() % 4, 0u);
  Timestamp last_date = 0;
  ASSERT_TRUE(ParseDate("2016-07-13", &last_date));
  for (const eval::SitePlantRow& p : plants) {
    EXPECT_EQ(p.site_id, "row");
    const sim::Plant* nearest = nullptr;
    for (const sim::Plant& q : world.plants()) {
      if (nearest == nullptr || (q.xy - Eigen::Vector2d(p.x_m, p.y_m)).norm() <
                                    (nearest->xy - Eigen::Vector2d(p.x_m, p.y_m)).norm()) {
        nearest = &q;
      }
    }
    EXPECT_LT((nearest->xy - Eigen::Vector2d(p.x_m, p.y_m)).norm(), 0.06) << p.plant;
    if (p.session == "2016-07-13") {
      EXPECT_NEAR(p.top_m, world.StateAt(*nearest, last_date).height_m, 0.04) << p.plant;
    }
  }
  EXPECT_TRUE(fs::exists(out / "growth.csv"));
  EXPECT_TRUE(fs::exists(out / "plots" / "heights.png"));
  EXPECT_TRUE(fs::exists(out / "plots" / "height_row.png"));

  // The rasters: in the field's UTM zone; the DTM holds the terrain's ellipsoidal height and the
  // CHM the canopy above it.
  const io::GeoTiffRaster dtm = io::ReadGeoTiff((out / "dtm.tif").string());
  const io::GeoTiffRaster chm = io::ReadGeoTiff((out / "chm_2016-07-13.tif").string());
  EXPECT_EQ(dtm.grid.epsg, 32617);
  EXPECT_EQ(chm.grid.width, dtm.grid.width);
  const io::FieldUtm utm(io::Field(field_).info().origin);
  const auto value_at = [&](const io::GeoTiffRaster& r, double x, double y) {
    const Eigen::Vector2d en = utm.UtmFromEnu(Eigen::Vector3d(x, y, 0));
    const int col = static_cast<int>(std::floor((en.x() - r.grid.min_easting) / r.grid.cell_m));
    const int row = static_cast<int>(std::floor((r.grid.max_northing - en.y()) / r.grid.cell_m));
    return r.values[static_cast<std::size_t>(row) * r.grid.width + col];
  };
  EXPECT_NEAR(value_at(dtm, 0.45, 2.0), world.TerrainHeight(0.45, 2.0) + 100.0, 0.005);
  const sim::Plant& plant = world.plants()[world.RowPlantRange(1).first + 10];
  Timestamp last;
  ParseDate("2016-07-13", &last);
  // The plant's top lies near its stem: the CHM's highest value within 5 cm of the stem.
  float chm_top = 0.0f;
  for (double dx = -0.05; dx <= 0.05; dx += 0.01) {
    for (double dy = -0.05; dy <= 0.05; dy += 0.01) {
      if (dx * dx + dy * dy <= 0.0025) {
        chm_top = std::max(chm_top, value_at(chm, plant.xy.x() + dx, plant.xy.y() + dy));
      }
    }
  }
  EXPECT_NEAR(chm_top, world.StateAt(plant, last).height_m, 0.02);
  EXPECT_EQ(value_at(chm, -0.8, 3.0), 0.0f);

  // Every raster is a Cloud-Optimized GeoTIFF on the one grid, with overviews, a nodata value and
  // the field's UTM zone.
  std::vector<std::string> rasters = {"dtm.tif"};
  for (const std::string& id : kSessions) rasters.push_back("chm_" + id + ".tif");
  for (std::size_t k = 1; k < kSessions.size(); ++k) {
    rasters.push_back("chm_change_" + kSessions[k - 1] + "_" + kSessions[k] + ".tif");
  }
  for (const std::string& name : rasters) {
    const io::GeoTiffRaster r = io::ReadGeoTiff((out / name).string());
    EXPECT_EQ(r.layout, "COG") << name;
    EXPECT_GE(r.overviews, 1) << name;
    EXPECT_TRUE(r.nodata.has_value()) << name;
    EXPECT_EQ(r.grid.epsg, 32617) << name;
    EXPECT_EQ(r.grid.width, dtm.grid.width) << name;
    EXPECT_EQ(r.grid.height, dtm.grid.height) << name;
    EXPECT_EQ(r.grid.min_easting, dtm.grid.min_easting) << name;
  }
  // The change rasters: one per pair of consecutive sessions, chm(later) − chm(earlier), nodata
  // where either CHM has none; both dates in the metadata.
  for (std::size_t k = 1; k < kSessions.size(); ++k) {
    const std::string name = "chm_change_" + kSessions[k - 1] + "_" + kSessions[k] + ".tif";
    const io::GeoTiffRaster change = io::ReadGeoTiff((out / name).string());
    const io::GeoTiffRaster earlier =
        io::ReadGeoTiff((out / ("chm_" + kSessions[k - 1] + ".tif")).string());
    const io::GeoTiffRaster later =
        io::ReadGeoTiff((out / ("chm_" + kSessions[k] + ".tif")).string());
    ASSERT_EQ(change.values.size(), later.values.size());
    std::size_t finite = 0, grown = 0;
    for (std::size_t c = 0; c < change.values.size(); ++c) {
      const float a = earlier.values[c], b = later.values[c], d = change.values[c];
      if (std::isnan(a) || std::isnan(b)) {
        EXPECT_TRUE(std::isnan(d)) << name << " cell " << c;
      } else {
        EXPECT_EQ(d, b - a) << name << " cell " << c;
        ++finite;
        grown += d > 0.01f;
      }
    }
    EXPECT_GT(finite, 10000u) << name;  // the cells the clouds cover (the area reaches "far")
    EXPECT_GT(grown, 0u) << name;       // the plants grow
    EXPECT_EQ(change.metadata.at("product"), "chm_change");
    EXPECT_EQ(change.metadata.at("earlier_date"), kSessions[k - 1]);
    EXPECT_EQ(change.metadata.at("later_date"), kSessions[k]);
    EXPECT_EQ(change.metadata.at("days"), "14");
    EXPECT_NE(change.description.find(kSessions[k - 1]), std::string::npos);
    EXPECT_NE(change.description.find(kSessions[k]), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(out / ("chm_change_" + kSessions[0] + "_" + kSessions[2] + ".tif")));

  // Unchanged inputs: skipped, with the table read back. A changed cloud: analysed again.
  const AnalyzeReport again = RunAnalyzeStage(field_, workspace_, options);
  EXPECT_TRUE(again.skipped);
  ASSERT_EQ(again.sites.size(), report.sites.size());
  EXPECT_NEAR(again.sites[0].ours.height_m, report.sites[0].ours.height_m, 1e-4);
  EXPECT_NE(FormatAnalyzeReport(again).find("up to date"), std::string::npos);
  // An edited CHM: analysed again, and the change rasters on both sides of it written again.
  const fs::path edited = out / ("chm_" + kSessions[1] + ".tif");
  const fs::path before_change = out / ("chm_change_" + kSessions[0] + "_" + kSessions[1] + ".tif");
  const fs::path after_change = out / ("chm_change_" + kSessions[1] + "_" + kSessions[2] + ".tif");
  const auto before_time = fs::last_write_time(before_change);
  const auto after_time = fs::last_write_time(after_change);
  {
    io::GeoTiffRaster r = io::ReadGeoTiff(edited.string());
    for (float& v : r.values) v = std::isnan(v) ? v : v + 1.0f;
    io::WriteGeoTiff(edited.string(), r.grid, r.values);
  }
  EXPECT_FALSE(RunAnalyzeStage(field_, workspace_, options).skipped);
  EXPECT_NE(fs::last_write_time(before_change), before_time);
  EXPECT_NE(fs::last_write_time(after_change), after_time);
  {
    const io::GeoTiffRaster a = io::ReadGeoTiff(edited.string());
    const io::GeoTiffRaster b = io::ReadGeoTiff((out / ("chm_" + kSessions[2] + ".tif")).string());
    const io::GeoTiffRaster d = io::ReadGeoTiff(after_change.string());
    for (std::size_t c = 0; c < d.values.size(); ++c) {
      if (!std::isnan(d.values[c])) {
        ASSERT_EQ(d.values[c], b.values[c] - a.values[c]) << c;
      }
    }
  }
  EXPECT_TRUE(RunAnalyzeStage(field_, workspace_, options).skipped);
  // A removed output: analysed again, and written again.
  fs::remove(out / "site_plants.csv");
  EXPECT_FALSE(RunAnalyzeStage(field_, workspace_, options).skipped);
  EXPECT_TRUE(fs::exists(out / "site_plants.csv"));
  io::PlyPointCloud cloud = io::ReadPly(workspace_ + "/dense/2016-06-01.ply");
  cloud.points.resize(cloud.points.size() / 2);
  cloud.colors.resize(cloud.colors.size() / 2);
  io::WritePly(workspace_ + "/dense/2016-06-01.ply", cloud);
  EXPECT_FALSE(RunAnalyzeStage(field_, workspace_, options).skipped);
  // A damaged input: the analysis fails, and leaves no results of the inputs before (eval and
  // the report would show them as current).
  fs::resize_file(workspace_ + "/dense/2016-06-01.ply",
                  fs::file_size(workspace_ + "/dense/2016-06-01.ply") / 3);
  EXPECT_THROW(RunAnalyzeStage(field_, workspace_, options), InputError);
  EXPECT_FALSE(fs::exists(out / "site_heights.csv"));
  EXPECT_FALSE(fs::exists(out / "summary.json"));
}

TEST_F(AnalyzeStageTest, ClearErrorsForBadInput) {
  const sim::World world(SmallWorld(5));
  WriteTruthWorkspace(world, field_, workspace_);
  AnalyzeStageOptions options;
  // No clouds.
  EXPECT_THROW(RunAnalyzeStage(field_, root_ + "/empty_ws", options), InputError);
  // Sites files with a bad header, a bad number, a duplicate id.
  const std::string sites = root_ + "/sites.csv";
  const auto expect_error = [&](const std::string& text, const std::string& message) {
    std::ofstream(sites) << text;
    options.sites_file = sites;
    try {
      RunAnalyzeStage(field_, workspace_, options);
      ADD_FAILURE() << "no error for: " << text;
    } catch (const InputError& e) {
      EXPECT_NE(std::string(e.what()).find(message), std::string::npos) << e.what();
    }
  };
  expect_error("id,x,y\n", "expected the header");
  expect_error("site_id,x,y,radius_m\na,1,x,0.4\n", "expected numbers");
  expect_error("site_id,x,y,radius_m\na,1,1,0.4\na,2,2,0.4\n", "appears twice");
  expect_error("site_id,x,y,radius_m\na,1,1,-1\n", "radius");
  // Lat/lon sites are accepted.
  std::ofstream(sites) << "site_id,lat,lon,radius_m\nll,31.47002,-83.52999,0.4\n";
  const std::vector<io::Site> s = ReadSitesCsv(sites, {31.47, -83.53, 100.0});
  ASSERT_EQ(s.size(), 1u);
  EXPECT_NEAR(s[0].center_enu.y(), 2.2, 0.05);
  EXPECT_NEAR(s[0].center_enu.x(), 0.95, 0.05);
  // A cloud without colours.
  io::PlyPointCloud bare;
  bare.points = {{0, 0, 0}, {1, 1, 0}};
  io::WritePly(workspace_ + "/dense/2016-06-15.ply", bare);
  options.sites_file.clear();
  EXPECT_THROW(RunAnalyzeStage(field_, workspace_, options), InputError);
}

}  // namespace
}  // namespace crop4d::pipeline
