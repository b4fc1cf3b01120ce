#include "crop4d/pipeline/export_stage.h"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <filesystem>
#include <map>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/colmap_text.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/las.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/analysis_summary.h"
#include "crop4d/workspace/analysis_tables.h"

namespace crop4d::pipeline {
namespace {

namespace fs = std::filesystem;
using io::testing::ReadText;
using io::testing::TempDir;
using io::testing::WriteText;

const geometry::GeodeticPoint kOrigin{31.47, -83.53, 100.0};  // UTM zone 17N
const std::string kFused = "2016-06-10";                      // fused, with a dense cloud
const std::string kRows = "2016-06-24";                       // row SLAM only

io::PlyPointCloud SomeCloud(int n, double x0, bool scalars = true) {
  io::PlyPointCloud cloud;
  io::PlyScalarField track{"track_length", io::PlyType::kInt32, {}};
  io::PlyScalarField error{"reprojection_error", io::PlyType::kFloat32, {}};
  for (int i = 0; i < n; ++i) {
    cloud.points.emplace_back(x0 + 0.013 * i, 0.5 + 0.071 * i, 0.01 * (i % 7) - 0.02);
    cloud.colors.push_back({std::uint8_t(i * 5), std::uint8_t(255 - i), 17});
    track.values.push_back(3 + i % 5);
    error.values.push_back(0.25 * (i % 4));
  }
  if (scalars) cloud.scalars = {track, error};
  return cloud;
}

std::vector<io::StampedPose> SomePoses(int n, Timestamp t0, double x) {
  std::vector<io::StampedPose> poses;
  for (int i = 0; i < n; ++i) {
    poses.push_back(
        {t0 + i * 133'333'333LL,
         geometry::Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ())),
                          Eigen::Vector3d(x, 0.2 * i, 1.1))});
  }
  return poses;
}

io::ColmapModel SomeModel() {
  io::ColmapModel model;
  geometry::PinholeRadTan camera;
  camera.width = 640;
  camera.height = 480;
  camera.fx = camera.fy = 500;
  camera.cx = 320;
  camera.cy = 240;
  camera.k1 = -0.01;
  model.cameras = {{1, camera}};
  for (std::uint32_t id : {1u, 2u}) {
    io::ColmapImage image;
    image.image_id = id;
    image.camera_id = 1;
    image.name = kFused + "/row00/" + std::to_string(id) + ".png";
    image.world_from_camera =
        geometry::Rigid3(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.1 * id, 0.0, 1.2));
    image.points2d = {{{100.0 + id, 200.0}, 5}};
    model.images.push_back(image);
  }
  model.points = {{5, {0.1, 0.2, 0.0}, {10, 20, 30}, 0.5, {{1, 0}, {2, 0}}}};
  return model;
}

// A field folder (field.yaml and two empty session folders) and a workspace with the outputs of
// every stage, the second session having row SLAM only.
struct TestWorkspace {
  TempDir dir;
  std::string field = dir / "field";
  std::string ws = dir / "ws";
  std::string out = dir / "out";
  io::PlyPointCloud fused_sparse = SomeCloud(40, 0.0);
  io::PlyPointCloud dense = SomeCloud(300, 0.0, /*scalars=*/false);
  io::PlyPointCloud row0 = SomeCloud(20, 0.9), row1 = SomeCloud(25, 1.8);
  std::vector<io::StampedPose> fused_poses = SomePoses(6, 1465570348146793805LL, 0.0);
  std::vector<io::StampedPose> row0_poses = SomePoses(4, 1466783878906384766LL, 0.9);
  std::vector<io::StampedPose> row1_poses = SomePoses(5, 1466783896239718099LL, 1.8);

  TestWorkspace() {
    WriteText(field + "/field.yaml",
              "name: test\norigin: {lat: 31.47, lon: -83.53, alt: 100}\n"
              "sessions: [\"" +
                  kFused + "\", \"" + kRows + "\"]\n");
    fs::create_directories(field + "/sessions/" + kFused);
    fs::create_directories(field + "/sessions/" + kRows);
    io::WritePly(ws + "/fused/" + kFused + "/sparse.ply", fused_sparse);
    io::WriteTum(ws + "/fused/" + kFused + "/poses.tum", fused_poses, "world_from_camera");
    io::WritePly(ws + "/dense/" + kFused + ".ply", dense);
    io::WritePly(ws + "/sessions/" + kRows + "/rows/row00/landmarks.ply", row0);
    io::WritePly(ws + "/sessions/" + kRows + "/rows/row01/landmarks.ply", row1);
    io::WriteTum(ws + "/sessions/" + kRows + "/rows/row00/poses.tum", row0_poses);
    io::WriteTum(ws + "/sessions/" + kRows + "/rows/row01/poses.tum", row1_poses);
    io::WriteColmapText(ws + "/fused/colmap", SomeModel());
    const io::FieldUtm utm(kOrigin);
    const io::UtmGrid grid =
        utm.GridCovering(Eigen::AlignedBox2d(Eigen::Vector2d(-1, -1), Eigen::Vector2d(3, 9)), 0.5);
    std::vector<float> values(grid.num_cells());
    for (std::size_t i = 0; i < values.size(); ++i) values[i] = 0.01f * float(i);
    io::WriteGeoTiff(ws + "/analysis/dtm.tif", grid, values);
    workspace::SiteHeight early{"r00s1", "2016-06-10", "2016-06-10", 0.0784};
    workspace::SiteHeight late{"r00s1", "2016-06-24", "2016-06-24", 0.1491};
    workspace::WriteSiteHeights(ws + "/analysis/site_heights.csv", {early, late});
  }
};

ExportOptions AllFormats() {
  ExportOptions options;
  options.formats = ExportFormatNames();
  options.show_progress = false;
  return options;
}

const ExportedFile* FindFile(const ExportReport& report, const std::string& path) {
  for (const ExportedFile& f : report.files) {
    if (f.path == path) return &f;
  }
  return nullptr;
}

void ExpectSamePoints(const io::PlyPointCloud& a, const io::PlyPointCloud& b) {
  ASSERT_EQ(a.size(), b.size());
  for (std::size_t i = 0; i < a.size(); ++i) {
    EXPECT_EQ(a.points[i], b.points[i]) << i;
    EXPECT_EQ(a.colors[i], b.colors[i]) << i;
  }
}

// The LAS points, back in ENU, equal the PLY points within the LAS millimetre.
void ExpectLasMatchesPly(const std::string& las_path, const io::PlyPointCloud& cloud) {
  const io::LasFile las = io::ReadLas(las_path);
  ASSERT_EQ(las.points.size(), cloud.size());
  EXPECT_NE(las.Wkt().find("UTM zone 17N"), std::string::npos);
  EXPECT_EQ(las.header.point_format, 7);
  const io::FieldUtm utm(kOrigin);
  for (std::size_t i = 0; i < cloud.size(); ++i) {
    const Eigen::Vector3d& p = las.points[i].xyz;
    const Eigen::Vector3d enu = utm.EnuFromUtm(p.x(), p.y(), p.z());
    EXPECT_LE((enu - cloud.points[i]).cwiseAbs().maxCoeff(), 0.0006) << i;
    EXPECT_NEAR(p.z(), 100.0 + cloud.points[i].z(), 0.002) << i;  // ellipsoidal height
    EXPECT_EQ(las.points[i].rgb[0], cloud.colors[i][0] * 257) << i;
  }
}

TEST(ExportTest, WritesEveryFormatWithTheWorkspaceContent) {
  const TestWorkspace t;
  const ExportReport report = RunExport(t.field, t.ws, t.out, AllFormats());
  EXPECT_EQ(report.epsg, 32617);

  // PLY: the fused cloud as it is, the row clouds merged with their pass.
  ExpectSamePoints(io::ReadPly(t.out + "/ply/" + kFused + "_sparse.ply"), t.fused_sparse);
  ExpectSamePoints(io::ReadPly(t.out + "/ply/" + kFused + "_dense.ply"), t.dense);
  const io::PlyPointCloud merged = io::ReadPly(t.out + "/ply/" + kRows + "_sparse.ply");
  ASSERT_EQ(merged.size(), t.row0.size() + t.row1.size());
  EXPECT_EQ(merged.points[0], t.row0.points[0]);
  EXPECT_EQ(merged.points[t.row0.size()], t.row1.points[0]);
  const io::PlyScalarField* pass = merged.FindScalar("pass");
  ASSERT_NE(pass, nullptr);
  EXPECT_EQ(pass->values.front(), 1.0);
  EXPECT_EQ(pass->values.back(), 2.0);
  ASSERT_NE(merged.FindScalar("track_length"), nullptr);
  EXPECT_EQ(merged.FindScalar("track_length")->values[t.row0.size()], t.row1.scalars[0].values[0]);
  EXPECT_FALSE(fs::exists(t.out + "/ply/" + kRows + "_dense.ply"));

  // LAS: the same points in UTM.
  ExpectLasMatchesPly(t.out + "/las/" + kFused + "_sparse.las", t.fused_sparse);
  ExpectLasMatchesPly(t.out + "/las/" + kFused + "_dense.las", t.dense);
  ExpectLasMatchesPly(t.out + "/las/" + kRows + "_sparse.las", merged);
  const io::LasFile rows_las = io::ReadLas(t.out + "/las/" + kRows + "_sparse.las");
  EXPECT_EQ(rows_las.points.front().point_source_id, 1);
  EXPECT_EQ(rows_las.points.back().point_source_id, 2);

  // TUM: the fused trajectory, else one per pass; the poses equal.
  auto expect_poses = [](const std::string& path, const std::vector<io::StampedPose>& poses) {
    const std::vector<io::StampedPose> back = io::ReadTum(path);
    ASSERT_EQ(back.size(), poses.size()) << path;
    for (std::size_t i = 0; i < poses.size(); ++i) {
      EXPECT_EQ(back[i].t, poses[i].t);
      EXPECT_LE((back[i].pose.translation() - poses[i].pose.translation()).norm(), 1e-6);
      EXPECT_LE(back[i].pose.rotation().angularDistance(poses[i].pose.rotation()), 1e-8);
    }
  };
  expect_poses(t.out + "/tum/" + kFused + ".tum", t.fused_poses);
  expect_poses(t.out + "/tum/" + kRows + "_row00.tum", t.row0_poses);
  expect_poses(t.out + "/tum/" + kRows + "_row01.tum", t.row1_poses);
  EXPECT_FALSE(fs::exists(t.out + "/tum/" + kRows + ".tum"));

  // COLMAP, GeoTIFF and CSV: the same files.
  for (const char* name : {"cameras.txt", "images.txt", "points3D.txt"}) {
    EXPECT_EQ(ReadText(t.out + "/colmap/" + name), ReadText(t.ws + "/fused/colmap/" + name));
  }
  EXPECT_EQ(io::ReadColmapText(t.out + "/colmap").images.size(), 2u);
  const io::GeoTiffRaster dtm = io::ReadGeoTiff(t.out + "/geotiff/dtm.tif");
  const io::GeoTiffRaster original = io::ReadGeoTiff(t.ws + "/analysis/dtm.tif");
  EXPECT_EQ(dtm.values, original.values);
  EXPECT_EQ(dtm.grid.epsg, 32617);
  EXPECT_EQ(ReadText(t.out + "/csv/site_heights.csv"),
            ReadText(t.ws + "/analysis/site_heights.csv"));

  // The report and export.json list every file, with its size and source.
  const std::vector<std::string> expected = {"ply/" + kFused + "_sparse.ply",
                                             "ply/" + kRows + "_sparse.ply",
                                             "ply/" + kFused + "_dense.ply",
                                             "las/" + kFused + "_sparse.las",
                                             "las/" + kRows + "_sparse.las",
                                             "las/" + kFused + "_dense.las",
                                             "colmap/cameras.txt",
                                             "colmap/images.txt",
                                             "colmap/points3D.txt",
                                             "tum/" + kFused + ".tum",
                                             "tum/" + kRows + "_row00.tum",
                                             "tum/" + kRows + "_row01.tum",
                                             "geotiff/dtm.tif",
                                             "csv/site_heights.csv"};
  EXPECT_EQ(report.files.size(), expected.size());
  for (const std::string& path : expected) {
    const ExportedFile* f = FindFile(report, path);
    ASSERT_NE(f, nullptr) << path;
    EXPECT_EQ(f->bytes, fs::file_size(t.out + "/" + path)) << path;
  }
  EXPECT_EQ(FindFile(report, "ply/" + kFused + "_sparse.ply")->source,
            "fused/" + kFused + "/sparse.ply");
  EXPECT_EQ(FindFile(report, "ply/" + kFused + "_sparse.ply")->items, 40u);
  EXPECT_EQ(FindFile(report, "csv/site_heights.csv")->items, 2u);
  const nlohmann::json manifest = nlohmann::json::parse(ReadText(t.out + "/export.json"));
  ASSERT_EQ(manifest["files"].size(), expected.size());
  for (const nlohmann::json& f : manifest["files"]) {
    const std::string path = f["path"];
    EXPECT_EQ(f["bytes"].get<std::uint64_t>(), fs::file_size(t.out + "/" + path)) << path;
    EXPECT_FALSE(f["source"].get<std::string>().empty()) << path;
  }
  EXPECT_EQ(manifest["crs"]["utm_epsg"], 32617);

  // The session without a dense cloud is named in a skip message; no temporary file is left.
  ASSERT_EQ(report.skipped.size(), 1u);
  EXPECT_EQ(report.skipped[0].format, "ply, las");
  EXPECT_NE(report.skipped[0].message.find(kRows), std::string::npos);
  EXPECT_NE(report.skipped[0].message.find("dense"), std::string::npos);
  EXPECT_EQ(manifest["skipped"].size(), 1u);
  for (const auto& entry : fs::recursive_directory_iterator(t.out)) {
    EXPECT_EQ(entry.path().string().find(".tmp."), std::string::npos) << entry.path();
  }
  const std::string table = FormatExportReport(report);
  EXPECT_NE(table.find("las/" + kRows + "_sparse.las"), std::string::npos);
  EXPECT_NE(table.find("skipped ply, las"), std::string::npos);
}

// The LAS points carry their session's date as GPS time and the class the analysis gives them.
TEST(ExportTest, LasPointsCarryTheSessionDateAndTheAnalysisClasses) {
  const TestWorkspace t;
  // The analysis: a flat terrain at the origin's height (ENU z = 0) over x, y in [-1, 3] ×
  // [-1, 9], the analysis' options and the vegetation threshold of the fused session only.
  const io::FieldUtm utm(kOrigin);
  const io::UtmGrid grid =
      utm.GridCovering(Eigen::AlignedBox2d(Eigen::Vector2d(-1, -1), Eigen::Vector2d(3, 9)), 0.02);
  io::WriteGeoTiff(t.ws + "/analysis/dtm.tif", grid, std::vector<float>(grid.num_cells(), 100.0f));
  workspace::AnalysisSummary summary;
  summary.options = {{"vegetation", {{"index", "ExG"}}},
                     {"canopy", {{"min_height_m", 0.02}, {"min_height_any_colour_m", 0.04}}},
                     {"lone_point_radius_m", 0.05}};
  workspace::AnalysisSessionRecord session;
  session.session = kFused;
  session.vegetation_threshold = 0.1;
  summary.sessions = {session};
  WriteText(t.ws + "/analysis/summary.json", workspace::AnalysisSummaryJson(summary).dump(2));
  // A dense cloud with two points 1 cm apart for each case, and one lone point.
  const std::array<std::uint8_t, 3> soil = {149, 126, 103}, leaf = {62, 85, 44};  // ExG 0, 0.33
  struct Case {
    Eigen::Vector3d p;
    std::array<std::uint8_t, 3> colour;
    std::uint8_t expected;
  };
  const std::vector<Case> cases = {
      {{0.5, 1.0, 0.0}, soil, io::kAsprsGround},
      {{0.5, 1.5, 0.001}, leaf, io::kAsprsGround},  // green, but below min_height_m
      {{0.5, 2.0, 0.1}, leaf, io::kAsprsLowVegetation},
      {{0.5, 2.5, 0.03}, soil, io::kAsprsGround},           // soil-coloured below 4 cm
      {{0.5, 3.0, 0.06}, soil, io::kAsprsLowVegetation},    // any colour from 4 cm
      {{0.5, 3.5, 1.0}, leaf, io::kAsprsMediumVegetation},  // 0.5 to 2 m
      {{0.5, 4.0, 2.5}, leaf, io::kAsprsHighVegetation},    // 2 m and above
      {{0.5, 4.5, -0.3}, soil, io::kAsprsUnclassified},     // well below the terrain
      {{0.5, 20.0, 0.0}, soil, io::kAsprsUnclassified},     // outside the terrain model
  };
  io::PlyPointCloud dense;
  for (const Case& c : cases) {
    for (const double dx : {0.0, 0.01}) {
      dense.points.push_back(c.p + Eigen::Vector3d(dx, 0, 0));
      dense.colors.push_back(c.colour);
    }
  }
  dense.points.emplace_back(2.0, 6.0, 0.1);  // a lone point: left out by the analysis
  dense.colors.push_back(leaf);
  io::WritePly(t.ws + "/dense/" + kFused + ".ply", dense);

  ExportOptions options;
  options.show_progress = false;
  options.formats = {"las"};
  RunExport(t.field, t.ws, t.out, options);
  const double fused_time = io::AdjustedStandardGpsTime(FromDate(2016, 6, 10));
  const io::LasFile las = io::ReadLas(t.out + "/las/" + kFused + "_dense.las");
  EXPECT_EQ(las.header.global_encoding & io::kLasGpsTimeAdjustedStandard,
            io::kLasGpsTimeAdjustedStandard);
  EXPECT_NE(las.Wkt().find("UTM zone 17N"), std::string::npos);
  ASSERT_EQ(las.points.size(), dense.size());
  for (std::size_t i = 0; i < cases.size(); ++i) {
    for (std::size_t k = 2 * i; k < 2 * i + 2; ++k) {
      EXPECT_EQ(las.points[k].classification, cases[i].expected) << "case " << i;
    }
  }
  EXPECT_EQ(las.points.back().classification, io::kAsprsUnclassified);
  for (const io::LasPoint& p : las.points) {
    EXPECT_EQ(p.gps_time, fused_time);
    EXPECT_EQ(io::UtcFromAdjustedStandardGpsTime(p.gps_time), FromDate(2016, 6, 10));
  }
  // The fused sparse cloud of the session: classified too (points 0 to 6 cm up, some green).
  const io::LasFile sparse = io::ReadLas(t.out + "/las/" + kFused + "_sparse.las");
  for (const io::LasPoint& p : sparse.points) {
    EXPECT_EQ(p.gps_time, fused_time);
    EXPECT_NE(p.classification, io::kAsprsCreatedNeverClassified);
  }
  // The session the analysis does not have: its own date, unclassified.
  const io::LasFile rows = io::ReadLas(t.out + "/las/" + kRows + "_sparse.las");
  ASSERT_FALSE(rows.points.empty());
  for (const io::LasPoint& p : rows.points) {
    EXPECT_EQ(p.gps_time, io::AdjustedStandardGpsTime(FromDate(2016, 6, 24)));
    EXPECT_EQ(p.classification, io::kAsprsUnclassified);
  }
  nlohmann::json manifest = nlohmann::json::parse(ReadText(t.out + "/export.json"));
  EXPECT_NE(manifest["las_points"]["classification"].get<std::string>().find("ASPRS"),
            std::string::npos);

  // Without the analysis: every point unclassified, and export.json says why.
  fs::remove_all(t.ws + "/analysis");
  RunExport(t.field, t.ws, t.out, options);
  for (const io::LasPoint& p : io::ReadLas(t.out + "/las/" + kFused + "_dense.las").points) {
    EXPECT_EQ(p.classification, io::kAsprsUnclassified);
    EXPECT_EQ(p.gps_time, fused_time);
  }
  manifest = nlohmann::json::parse(ReadText(t.out + "/export.json"));
  EXPECT_NE(manifest["las_points"]["classification"].get<std::string>().find("dtm.tif"),
            std::string::npos);
}

TEST(ExportTest, DefaultsLeaveOutLasAndCloudsOptionSelects) {
  const TestWorkspace t;
  ExportOptions options;
  options.show_progress = false;
  options.clouds = "sparse";
  const ExportReport report = RunExport(t.field, t.ws, t.out, options);
  EXPECT_FALSE(fs::exists(t.out + "/las"));
  EXPECT_TRUE(fs::exists(t.out + "/ply/" + kFused + "_sparse.ply"));
  EXPECT_FALSE(fs::exists(t.out + "/ply/" + kFused + "_dense.ply"));
  EXPECT_TRUE(report.skipped.empty());

  const TestWorkspace u;
  options.formats = {"las"};
  options.clouds = "dense";
  const ExportReport dense = RunExport(u.field, u.ws, u.out, options);
  ASSERT_EQ(dense.files.size(), 1u);
  EXPECT_EQ(dense.files[0].path, "las/" + kFused + "_dense.las");
  EXPECT_FALSE(fs::exists(u.out + "/ply"));
}

TEST(ExportTest, FormatsWithoutInputsAreSkippedWithWhatIsMissing) {
  const TestWorkspace t;
  fs::remove_all(t.ws + "/analysis");
  fs::remove(t.ws + "/fused/colmap/images.txt");
  ExportOptions options = AllFormats();
  options.clouds = "sparse";
  const ExportReport report = RunExport(t.field, t.ws, t.out, options);
  std::map<std::string, std::string> skipped;
  for (const ExportSkip& s : report.skipped) skipped[s.format] = s.message;
  ASSERT_EQ(skipped.size(), 3u);
  EXPECT_NE(skipped["colmap"].find("fused/colmap/images.txt"), std::string::npos);
  EXPECT_NE(skipped["geotiff"].find("analysis"), std::string::npos);
  EXPECT_NE(skipped["csv"].find("analysis"), std::string::npos);
  EXPECT_FALSE(fs::exists(t.out + "/colmap"));
  EXPECT_TRUE(fs::exists(t.out + "/tum/" + kFused + ".tum"));
  const nlohmann::json manifest = nlohmann::json::parse(ReadText(t.out + "/export.json"));
  EXPECT_EQ(manifest["skipped"].size(), 3u);
}

TEST(ExportTest, NothingToExportIsAnError) {
  const TestWorkspace t;
  // Only the rasters asked for, and there are none.
  fs::remove_all(t.ws + "/analysis");
  ExportOptions options;
  options.show_progress = false;
  options.formats = {"geotiff", "csv"};
  try {
    RunExport(t.field, t.ws, t.out, options);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("nothing to export"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("analysis"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(fs::exists(t.out + "/export.json"));

  // An empty workspace.
  fs::create_directories(t.dir / "empty_ws");
  EXPECT_THROW(RunExport(t.field, t.dir / "empty_ws", t.out, AllFormats()), InputError);
  // A missing workspace, a missing field, the workspace as output, bad options.
  EXPECT_THROW(RunExport(t.field, t.dir / "nope", t.out, AllFormats()), InputError);
  EXPECT_THROW(RunExport(t.dir / "nope", t.ws, t.out, AllFormats()), InputError);
  EXPECT_THROW(RunExport(t.field, t.ws, t.ws, AllFormats()), InputError);
  ExportOptions bad = AllFormats();
  bad.formats = {"ply", "obj"};
  std::string why;
  EXPECT_FALSE(bad.Check(&why));
  EXPECT_NE(why.find("obj"), std::string::npos);
  EXPECT_THROW(RunExport(t.field, t.ws, t.out, bad), InputError);
  bad = AllFormats();
  bad.clouds = "all";
  EXPECT_THROW(RunExport(t.field, t.ws, t.out, bad), InputError);
}

TEST(ExportTest, MalformedInputNamesTheFile) {
  const TestWorkspace t;
  const std::string broken = t.ws + "/fused/" + kFused + "/sparse.ply";
  WriteText(broken, "ply\nformat binary_little_endian 1.0\nelement vertex 10\n");
  ExportOptions options;
  options.show_progress = false;
  options.formats = {"ply"};
  try {
    RunExport(t.field, t.ws, t.out, options);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_NE(std::string(e.what()).find("sparse.ply"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace crop4d::pipeline
