#include "crop4d/io/geotiff.h"

#include <gdal.h>
#include <gdal_priv.h>
#include <gtest/gtest.h>
#include <ogr_spatialref.h>
#include <ogr_srs_api.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <limits>
#include <memory>
#include <string>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/geometry/enu.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;
using testing::TempDir;

// Tifton, Georgia (UTM zone 17N; 2.5° west of the zone's central meridian, so the UTM grid is
// turned by about 1.3° against ENU).
const geometry::GeodeticPoint kTifton{31.47, -83.53, 110.0};
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Projects geodetic points into a UTM zone with PROJ (through GDAL's OGR), an implementation
// independent of GeographicLib.
class ProjUtm {
 public:
  explicit ProjUtm(int epsg) {
    GDALAllRegister();
    OGRSpatialReference wgs84, utm;
    EXPECT_EQ(wgs84.importFromEPSG(4326), OGRERR_NONE);
    EXPECT_EQ(utm.importFromEPSG(epsg), OGRERR_NONE);
    wgs84.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);  // lon, lat
    utm.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
    transform_.reset(OGRCreateCoordinateTransformation(&wgs84, &utm));
    EXPECT_NE(transform_, nullptr);
  }
  Eigen::Vector2d Forward(const geometry::GeodeticPoint& p) const {
    double x = p.lon_deg, y = p.lat_deg;
    EXPECT_TRUE(transform_->Transform(1, &x, &y));
    return {x, y};
  }

 private:
  std::unique_ptr<OGRCoordinateTransformation> transform_;
};

std::unique_ptr<GDALDataset> OpenWithGdal(const std::string& path) {
  GDALAllRegister();
  return std::unique_ptr<GDALDataset>(GDALDataset::FromHandle(
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr)));
}

bool SameFloats(const std::vector<float>& a, const std::vector<float>& b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i) {
    if (!(a[i] == b[i] || (std::isnan(a[i]) && std::isnan(b[i])))) return false;
  }
  return true;
}

UtmGrid SmallGrid() {
  UtmGrid grid;
  grid.epsg = 32617;
  grid.min_easting = 261234.55;
  grid.max_northing = 3484567.80;
  grid.cell_m = 0.05;
  grid.width = 37;
  grid.height = 23;
  return grid;
}

std::vector<float> Pattern(const UtmGrid& grid) {
  std::vector<float> values(grid.num_cells());
  for (std::size_t i = 0; i < values.size(); ++i) {
    values[i] = i % 11 == 3 ? kNaN : 0.01f * float(i) - 1.5f;
  }
  return values;
}

TEST(FieldUtmTest, EpsgOfNorthernAndSouthernFields) {
  EXPECT_EQ(FieldUtm(kTifton).epsg(), 32617);
  const FieldUtm south({-33.87, 151.21, 30.0});  // Sydney: zone 56S
  EXPECT_EQ(south.epsg(), 32756);
  const Eigen::Vector2d utm = south.UtmFromEnu(Eigen::Vector3d::Zero());
  EXPECT_GT(utm.y(), 6.0e6);  // false northing 10000 km in the south
  EXPECT_LT(utm.y(), 6.5e6);
  EXPECT_THROW(FieldUtm({95.0, 0.0, 0.0}), InputError);
}

TEST(FieldUtmTest, RoundTripsWithinAMillimetreOverAKilometre) {
  const FieldUtm utm(kTifton);
  const geometry::LocalEnu enu(kTifton);
  double worst_exact = 0.0, worst_origin_height = 0.0;
  for (double x = -500.0; x <= 500.0; x += 125.0) {
    for (double y = -500.0; y <= 500.0; y += 125.0) {
      for (double z : {-5.0, 0.0, 20.0}) {
        const Eigen::Vector3d p(x, y, z);
        const Eigen::Vector2d en = utm.UtmFromEnu(p);
        const Eigen::Vector3d back = utm.EnuFromUtm(en.x(), en.y(), enu.ToGeodetic(p).alt_m);
        worst_exact = std::max(worst_exact, (back - p).norm());
        if (z == 0.0) {
          // At the origin's height instead of the point's exact ellipsoidal height.
          const Eigen::Vector3d flat = utm.EnuFromUtm(en.x(), en.y(), kTifton.alt_m);
          worst_origin_height = std::max(worst_origin_height, (flat - p).head<2>().norm());
        }
      }
    }
  }
  EXPECT_LT(worst_exact, 1e-6);
  EXPECT_LT(worst_origin_height, 1e-3);
}

TEST(FieldUtmTest, AgreesWithProj) {
  const FieldUtm utm(kTifton);
  const geometry::LocalEnu enu(kTifton);
  const ProjUtm proj(32617);
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(100, 0, 0),
                                   Eigen::Vector3d(-400, 350, 2), Eigen::Vector3d(800, -900, 0)}) {
    EXPECT_LT((utm.UtmFromEnu(p) - proj.Forward(enu.ToGeodetic(p))).norm(), 1e-3) << p.transpose();
  }
}

TEST(FieldUtmTest, GridCoveringCoversTheBoxAndIsSnapped) {
  const FieldUtm utm(kTifton);
  const Eigen::AlignedBox2d box(Eigen::Vector2d(-12.3, -3.1), Eigen::Vector2d(40.7, 100.9));
  const double cell = 0.05;
  const UtmGrid grid = utm.GridCovering(box, cell);
  ASSERT_EQ(grid.Check(), "");
  EXPECT_EQ(grid.epsg, 32617);
  EXPECT_EQ(grid.cell_m, cell);
  // Edges on multiples of the cell size.
  EXPECT_NEAR(grid.min_easting / cell, std::round(grid.min_easting / cell), 1e-6);
  EXPECT_NEAR(grid.max_northing / cell, std::round(grid.max_northing / cell), 1e-6);
  // Every point of the box's boundary (and its corners) lies inside the grid, and the grid is
  // the smallest: each side is less than one cell beyond the box's extremes.
  const double max_e = grid.min_easting + grid.width * cell;
  const double min_n = grid.max_northing - grid.height * cell;
  double e_lo = INFINITY, e_hi = -INFINITY, n_lo = INFINITY, n_hi = -INFINITY;
  for (int i = 0; i <= 200; ++i) {
    const double t = i / 200.0;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(box.min().x() + t * box.sizes().x(), -3.1),
                                     Eigen::Vector2d(box.min().x() + t * box.sizes().x(), 100.9),
                                     Eigen::Vector2d(-12.3, box.min().y() + t * box.sizes().y()),
                                     Eigen::Vector2d(40.7, box.min().y() + t * box.sizes().y())}) {
      const Eigen::Vector2d en = utm.UtmFromEnu(Eigen::Vector3d(p.x(), p.y(), 0.0));
      EXPECT_GE(en.x(), grid.min_easting);
      EXPECT_LE(en.x(), max_e);
      EXPECT_GE(en.y(), min_n);
      EXPECT_LE(en.y(), grid.max_northing);
      e_lo = std::min(e_lo, en.x());
      e_hi = std::max(e_hi, en.x());
      n_lo = std::min(n_lo, en.y());
      n_hi = std::max(n_hi, en.y());
    }
  }
  EXPECT_LT(e_lo - grid.min_easting, cell);
  EXPECT_LT(max_e - e_hi, cell);
  EXPECT_LT(n_lo - min_n, cell);
  EXPECT_LT(grid.max_northing - n_hi, cell);
  // The grid is turned by the convergence (~1.3°): wider than the box by about its height ×
  // sin(1.3°) ≈ 2.4 m.
  EXPECT_GT(grid.width * cell, 53.0 + 1.5);
}

TEST(FieldUtmTest, EnuCellCentresMatchTheExactConversion) {
  const FieldUtm utm(kTifton);
  const UtmGrid grid = utm.GridCovering(
      Eigen::AlignedBox2d(Eigen::Vector2d(-30, -5), Eigen::Vector2d(70, 12)), 0.05);
  const std::vector<Eigen::Vector2d> centres = utm.EnuCellCentres(grid);
  ASSERT_EQ(centres.size(), grid.num_cells());
  double worst = 0.0;
  for (int row = 0; row < grid.height; row += 3) {
    for (int col = 0; col < grid.width; col += 7) {
      const Eigen::Vector2d en = grid.CellCentre(col, row);
      const Eigen::Vector2d exact = utm.EnuFromUtm(en.x(), en.y(), kTifton.alt_m).head<2>();
      worst = std::max(worst, (centres[std::size_t(row) * grid.width + col] - exact).norm());
    }
  }
  EXPECT_LT(worst, 1e-5);
  // A one-cell grid works too.
  UtmGrid one = grid;
  one.width = one.height = 1;
  const Eigen::Vector2d en = one.CellCentre(0, 0);
  EXPECT_LT(
      (utm.EnuCellCentres(one)[0] - utm.EnuFromUtm(en.x(), en.y(), kTifton.alt_m).head<2>()).norm(),
      1e-9);
}

TEST(GeoTiffTest, RoundTripKeepsValuesGridAndMetadata) {
  const TempDir dir;
  const std::string path = dir / "analysis/chm/2016-05-25.tif";  // parent folders created
  const UtmGrid grid = SmallGrid();
  const std::vector<float> values = Pattern(grid);
  GeoTiffWriteOptions options;
  options.description = "canopy height above terrain [m]";
  options.metadata = {{"session", "2016-05-25"}, {"crop4d_version", "0.1.0"}};
  WriteGeoTiff(path, grid, values, options);

  const GeoTiffRaster raster = ReadGeoTiff(path);
  EXPECT_EQ(raster.grid.epsg, grid.epsg);
  EXPECT_DOUBLE_EQ(raster.grid.min_easting, grid.min_easting);
  EXPECT_DOUBLE_EQ(raster.grid.max_northing, grid.max_northing);
  EXPECT_DOUBLE_EQ(raster.grid.cell_m, grid.cell_m);
  EXPECT_EQ(raster.grid.width, grid.width);
  EXPECT_EQ(raster.grid.height, grid.height);
  EXPECT_TRUE(SameFloats(raster.values, values));
  ASSERT_TRUE(raster.nodata.has_value());
  EXPECT_TRUE(std::isnan(*raster.nodata));
  EXPECT_EQ(raster.description, options.description);
  EXPECT_EQ(raster.metadata, options.metadata);
  // Only the final file is left: no temporary file, no .aux.xml side file.
  int files = 0;
  for (const auto& entry : fs::directory_iterator(fs::path(path).parent_path())) {
    ++files;
    EXPECT_EQ(entry.path().string(), path);
  }
  EXPECT_EQ(files, 1);

  // GDAL itself sees the CRS and the compression.
  const auto dataset = OpenWithGdal(path);
  ASSERT_NE(dataset, nullptr);
  ASSERT_NE(dataset->GetSpatialRef(), nullptr);
  EXPECT_STREQ(dataset->GetSpatialRef()->GetAuthorityCode(nullptr), "32617");
  const char* compression = dataset->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  ASSERT_NE(compression, nullptr);
  EXPECT_STREQ(compression, "DEFLATE");
  EXPECT_EQ(dataset->GetRasterBand(1)->GetRasterDataType(), GDT_Float32);
}

TEST(GeoTiffTest, NodataValueRoundTripsAndOverwrites) {
  const TempDir dir;
  const std::string path = dir / "dtm.tif";
  UtmGrid grid = SmallGrid();
  grid.epsg = 32756;  // a southern zone
  grid.max_northing = 6251234.0;
  std::vector<float> values = Pattern(grid);
  for (float& v : values) v = std::isnan(v) ? -9999.0f : v;
  GeoTiffWriteOptions options;
  options.nodata = -9999.0f;
  options.compress = false;
  WriteGeoTiff(path, grid, std::vector<float>(grid.num_cells(), 1.0f), options);
  WriteGeoTiff(path, grid, values, options);  // replaces the first file
  const GeoTiffRaster raster = ReadGeoTiff(path);
  ASSERT_TRUE(raster.nodata.has_value());
  EXPECT_EQ(*raster.nodata, -9999.0f);
  EXPECT_EQ(raster.grid.epsg, 32756);
  EXPECT_TRUE(SameFloats(raster.values, values));
  EXPECT_TRUE(raster.description.empty());
  EXPECT_TRUE(raster.metadata.empty());
}

TEST(GeoTiffTest, KnownEnuOffsetLandsInTheRightCell) {
  const TempDir dir;
  const std::string path = dir / "chm.tif";
  const FieldUtm utm(kTifton);
  const double cell = 0.1;
  const UtmGrid grid = utm.GridCovering(
      Eigen::AlignedBox2d(Eigen::Vector2d(-20, -30), Eigen::Vector2d(120, 60)), cell);
  // Mark the cell whose centre is nearest to each target with the target's number.
  const std::vector<Eigen::Vector2d> targets = {{100.0, 0.0}, {0.0, 0.0}, {0.0, 50.0}};
  const std::vector<Eigen::Vector2d> centres = utm.EnuCellCentres(grid);
  std::vector<float> values(grid.num_cells(), 0.0f);
  for (std::size_t t = 0; t < targets.size(); ++t) {
    std::size_t best = 0;
    for (std::size_t i = 0; i < centres.size(); ++i) {
      if ((centres[i] - targets[t]).squaredNorm() < (centres[best] - targets[t]).squaredNorm()) {
        best = i;
      }
    }
    values[best] = float(t + 1);
  }
  WriteGeoTiff(path, grid, values);

  // Read back with GDAL alone: find the marked pixels, map their centres through the file's
  // geotransform to UTM and then to ENU, and check against the targets. Independently, PROJ
  // projects each target into UTM, which must fall inside the marked pixel.
  const auto dataset = OpenWithGdal(path);
  ASSERT_NE(dataset, nullptr);
  double gt[6];
  ASSERT_EQ(dataset->GetGeoTransform(gt), CE_None);
  const int w = dataset->GetRasterXSize(), h = dataset->GetRasterYSize();
  std::vector<float> read(std::size_t(w) * h);
  ASSERT_EQ(dataset->GetRasterBand(1)->RasterIO(GF_Read, 0, 0, w, h, read.data(), w, h, GDT_Float32,
                                                0, 0, nullptr),
            CE_None);
  const geometry::LocalEnu enu(kTifton);
  const ProjUtm proj(32617);
  for (std::size_t t = 0; t < targets.size(); ++t) {
    int found = 0;
    for (int row = 0; row < h; ++row) {
      for (int col = 0; col < w; ++col) {
        if (read[std::size_t(row) * w + col] != float(t + 1)) continue;
        ++found;
        const double easting = gt[0] + (col + 0.5) * gt[1] + (row + 0.5) * gt[2];
        const double northing = gt[3] + (col + 0.5) * gt[4] + (row + 0.5) * gt[5];
        const Eigen::Vector3d centre = utm.EnuFromUtm(easting, northing, kTifton.alt_m);
        EXPECT_LE((centre.head<2>() - targets[t]).norm(), cell * std::sqrt(0.5) + 1e-6);
        const geometry::GeodeticPoint target =
            enu.ToGeodetic(Eigen::Vector3d(targets[t].x(), targets[t].y(), 0.0));
        const Eigen::Vector2d en = proj.Forward(target);
        EXPECT_EQ(int(std::floor((en.x() - gt[0]) / gt[1])), col) << "target " << t;
        EXPECT_EQ(int(std::floor((en.y() - gt[3]) / gt[5])), row) << "target " << t;
      }
    }
    EXPECT_EQ(found, 1) << "target " << t;
  }
}

TEST(GeoTiffTest, UnwritablePathThrows) {
  const TempDir dir;
  const std::string blocker = dir / "not_a_folder";
  testing::WriteText(blocker, "a file where a folder should be");
  const UtmGrid grid = SmallGrid();
  const std::vector<float> values(grid.num_cells(), 1.0f);
  try {
    WriteGeoTiff(blocker + "/chm.tif", grid, values);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), blocker + "/chm.tif");
  }
  EXPECT_THROW(WriteGeoTiff(dir.path(), grid, values), InputError);  // a folder
  // Nothing but the blocker is left.
  int files = 0;
  for ([[maybe_unused]] const auto& entry : fs::directory_iterator(dir.path())) ++files;
  EXPECT_EQ(files, 1);
}

TEST(GeoTiffTest, ReadRejectsFilesThatAreNotUtmGeoTiffs) {
  const TempDir dir;
  const std::string text = dir / "notes.tif";
  testing::WriteText(text, "this is not a TIFF\n");
  try {
    ReadGeoTiff(text);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), text);
  }
  EXPECT_THROW(ReadGeoTiff(dir / "missing.tif"), InputError);

  // A two-band raster, a rotated one and one in geographic coordinates, written with GDAL.
  GDALAllRegister();
  GDALDriver* driver = GetGDALDriverManager()->GetDriverByName("GTiff");
  ASSERT_NE(driver, nullptr);
  auto make = [&](const std::string& name, int bands, const double* transform, int epsg) {
    const std::string path = dir / name;
    GDALDataset* dataset = driver->Create(path.c_str(), 4, 3, bands, GDT_Float32, nullptr);
    EXPECT_NE(dataset, nullptr);
    OGRSpatialReference srs;
    srs.importFromEPSG(epsg);
    dataset->SetSpatialRef(&srs);
    dataset->SetGeoTransform(const_cast<double*>(transform));
    GDALClose(GDALDataset::ToHandle(dataset));
    return path;
  };
  const double north_up[6] = {261000.0, 0.5, 0.0, 3484000.0, 0.0, -0.5};
  const double rotated[6] = {261000.0, 0.5, 0.1, 3484000.0, 0.1, -0.5};
  const double degrees[6] = {-83.6, 0.001, 0.0, 31.5, 0.0, -0.001};
  EXPECT_NO_THROW(ReadGeoTiff(make("ok.tif", 1, north_up, 32617)));
  EXPECT_THROW(ReadGeoTiff(make("two_bands.tif", 2, north_up, 32617)), InputError);
  EXPECT_THROW(ReadGeoTiff(make("rotated.tif", 1, rotated, 32617)), InputError);
  EXPECT_THROW(ReadGeoTiff(make("geographic.tif", 1, degrees, 4326)), InputError);
}

// ---- Cloud-Optimized GeoTIFF ------------------------------------------------------------------

// A grid larger than one tile (600 × 300 cells: two overviews, 300 × 150 and 150 × 75), with a
// block of nodata cells and a gradient elsewhere.
UtmGrid LargeGrid() {
  UtmGrid grid = SmallGrid();
  grid.width = 600;
  grid.height = 300;
  return grid;
}

std::vector<float> Gradient(const UtmGrid& grid) {
  std::vector<float> values(grid.num_cells());
  for (int row = 0; row < grid.height; ++row) {
    for (int col = 0; col < grid.width; ++col) {
      const bool hole = col >= 100 && col < 220 && row >= 40 && row < 90;
      values[std::size_t(row) * grid.width + col] =
          hole ? kNaN : 0.001f * float(col) + 0.002f * float(row);
    }
  }
  return values;
}

// Whether a command-line tool is on the PATH.
bool HaveTool(const std::string& name) {
  return std::system(("command -v " + name + " >/dev/null 2>&1").c_str()) == 0;
}

// The output of a shell command (stdout and stderr) and its exit status.
std::pair<int, std::string> RunCommand(const std::string& command, const TempDir& dir) {
  const std::string out = dir / "command_output.txt";
  const int status = std::system((command + " >'" + out + "' 2>&1").c_str());
  return {WIFEXITED(status) ? WEXITSTATUS(status) : -1, testing::ReadText(out)};
}

TEST(GeoTiffTest, OverviewCountHalvesToOneTileWithAtLeastOne) {
  EXPECT_EQ(GeoTiffOverviewCount(1, 1), 0);
  EXPECT_EQ(GeoTiffOverviewCount(2, 1), 1);
  EXPECT_EQ(GeoTiffOverviewCount(37, 23), 1);
  EXPECT_EQ(GeoTiffOverviewCount(256, 256), 1);
  EXPECT_EQ(GeoTiffOverviewCount(257, 10), 1);   // 129
  EXPECT_EQ(GeoTiffOverviewCount(600, 300), 2);  // 300, 150
  EXPECT_EQ(GeoTiffOverviewCount(10, 5000), 5);  // 2500, 1250, 625, 313, 157
}

TEST(GeoTiffTest, WritesACloudOptimizedGeoTiffWithOverviewsNodataAndEpsg) {
  const TempDir dir;
  const std::string path = dir / "chm_2016-05-25.tif";
  const UtmGrid grid = LargeGrid();
  const std::vector<float> values = Gradient(grid);
  GeoTiffWriteOptions options;
  options.description = "canopy height above the terrain [m]";
  options.metadata = {{"product", "chm"}, {"date", "2016-05-25"}};
  WriteGeoTiff(path, grid, values, options);

  // With GDAL's C API alone.
  GDALAllRegister();
  GDALDatasetH dataset =
      GDALOpenEx(path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, nullptr, nullptr, nullptr);
  ASSERT_NE(dataset, nullptr);
  EXPECT_STREQ(GDALGetDriverShortName(GDALGetDatasetDriver(dataset)), "GTiff");
  const char* layout = GDALGetMetadataItem(dataset, "LAYOUT", "IMAGE_STRUCTURE");
  ASSERT_NE(layout, nullptr);
  EXPECT_STREQ(layout, "COG");
  const char* compression = GDALGetMetadataItem(dataset, "COMPRESSION", "IMAGE_STRUCTURE");
  ASSERT_NE(compression, nullptr);
  EXPECT_STREQ(compression, "DEFLATE");
  const char* predictor = GDALGetMetadataItem(dataset, "PREDICTOR", "IMAGE_STRUCTURE");
  if (predictor != nullptr) {
    EXPECT_STREQ(predictor, "3");
  }
  GDALRasterBandH band = GDALGetRasterBand(dataset, 1);
  int block_x = 0, block_y = 0;
  GDALGetBlockSize(band, &block_x, &block_y);
  EXPECT_EQ(block_x, kGeoTiffTileSize);
  EXPECT_EQ(block_y, kGeoTiffTileSize);
  int has_nodata = 0;
  EXPECT_TRUE(std::isnan(GDALGetRasterNoDataValue(band, &has_nodata)));
  EXPECT_TRUE(has_nodata);
  EXPECT_STREQ(GDALGetDescription(band), options.description.c_str());
  EXPECT_STREQ(GDALGetMetadataItem(dataset, "date", nullptr), "2016-05-25");
  // The CRS is the EPSG code itself, not a WKT to be identified.
  OGRSpatialReferenceH srs = GDALGetSpatialRef(dataset);
  ASSERT_NE(srs, nullptr);
  EXPECT_STREQ(OSRGetAuthorityName(srs, nullptr), "EPSG");
  EXPECT_STREQ(OSRGetAuthorityCode(srs, nullptr), "32617");
  // Overviews: two, averaged from the cells with data (the hole stays nodata, the rest finite).
  ASSERT_EQ(GDALGetOverviewCount(band), 2);
  GDALRasterBandH overview = GDALGetOverview(band, 0);
  ASSERT_EQ(GDALGetRasterBandXSize(overview), 300);
  ASSERT_EQ(GDALGetRasterBandYSize(overview), 150);
  EXPECT_EQ(GDALGetRasterBandXSize(GDALGetOverview(band, 1)), 150);
  std::vector<float> reduced(300 * 150);
  ASSERT_EQ(
      GDALRasterIO(overview, GF_Read, 0, 0, 300, 150, reduced.data(), 300, 150, GDT_Float32, 0, 0),
      CE_None);
  EXPECT_TRUE(std::isnan(reduced[std::size_t(30) * 300 + 80]));  // inside the hole
  const float corner = reduced[std::size_t(10) * 300 + 10];      // cells 20..21 × 20..21
  EXPECT_NEAR(corner, 0.001f * 20.5f + 0.002f * 20.5f, 1e-5);
  GDALClose(dataset);

  // ReadGeoTiff reports the layout too.
  const GeoTiffRaster raster = ReadGeoTiff(path);
  EXPECT_EQ(raster.layout, "COG");
  EXPECT_EQ(raster.compression, "DEFLATE");
  EXPECT_EQ(raster.overviews, 2);
  EXPECT_TRUE(SameFloats(raster.values, values));
  EXPECT_EQ(raster.metadata, options.metadata);

  // A one-cell raster has no overview, and is still a COG.
  UtmGrid one = SmallGrid();
  one.width = one.height = 1;
  WriteGeoTiff(dir / "one.tif", one, {2.5f});
  const GeoTiffRaster single = ReadGeoTiff(dir / "one.tif");
  EXPECT_EQ(single.overviews, 0);
  EXPECT_EQ(single.layout, "COG");
  EXPECT_EQ(single.values, std::vector<float>{2.5f});
}

// gdalinfo and gdal_translate (Debian's gdal-bin, scripts/install-deps.sh) read the file, and
// GDAL's COG validator (osgeo_utils, Debian's python3-gdal, a dependency of gdal-bin) passes it.
TEST(GeoTiffTest, GdalToolsReadAndTranslateTheCog) {
  if (!HaveTool("gdal_translate") || !HaveTool("gdalinfo")) {
    GTEST_SKIP() << "gdal_translate or gdalinfo missing (Debian package gdal-bin)";
  }
  const TempDir dir;
  const std::string path = dir / "dtm.tif";
  const UtmGrid grid = LargeGrid();
  const std::vector<float> values = Gradient(grid);
  GeoTiffWriteOptions options;
  options.description = "terrain, WGS84 ellipsoidal height [m]";
  WriteGeoTiff(path, grid, values, options);

  const auto [info_status, info] = RunCommand("gdalinfo '" + path + "'", dir);
  ASSERT_EQ(info_status, 0) << info;
  EXPECT_NE(info.find("LAYOUT=COG"), std::string::npos) << info;
  EXPECT_NE(info.find("ID[\"EPSG\",32617]"), std::string::npos) << info;
  EXPECT_NE(info.find("NoData Value=nan"), std::string::npos) << info;
  EXPECT_NE(info.find("Overviews: 300x150, 150x75"), std::string::npos) << info;

  // A round trip through gdal_translate (to a plain GeoTIFF) keeps every value, the grid, the
  // nodata value and the CRS.
  const std::string copy = dir / "copy.tif";
  const auto [translate_status, translate] =
      RunCommand("gdal_translate -q -of GTiff '" + path + "' '" + copy + "'", dir);
  ASSERT_EQ(translate_status, 0) << translate;
  const GeoTiffRaster back = ReadGeoTiff(copy);
  EXPECT_TRUE(SameFloats(back.values, values));
  EXPECT_EQ(back.grid.epsg, grid.epsg);
  EXPECT_DOUBLE_EQ(back.grid.min_easting, grid.min_easting);
  EXPECT_DOUBLE_EQ(back.grid.max_northing, grid.max_northing);
  EXPECT_DOUBLE_EQ(back.grid.cell_m, grid.cell_m);
  ASSERT_TRUE(back.nodata.has_value());
  EXPECT_TRUE(std::isnan(*back.nodata));
  EXPECT_EQ(back.description, options.description);
  // ... and back to a COG with gdal_translate's COG driver: the same values again.
  const std::string cog = dir / "cog.tif";
  const auto [cog_status, cog_output] =
      RunCommand("gdal_translate -q -of COG '" + copy + "' '" + cog + "'", dir);
  ASSERT_EQ(cog_status, 0) << cog_output;
  EXPECT_TRUE(SameFloats(ReadGeoTiff(cog).values, values));

  // GDAL's validator of the COG layout (tiles, overviews and their order, the ghost header).
  const std::string python = "/usr/bin/python3";
  if (fs::exists(python) &&
      RunCommand(python + " -c 'import osgeo_utils.samples.validate_cloud_optimized_geotiff'", dir)
              .first == 0) {
    const auto [valid_status, valid] = RunCommand(
        python + " -m osgeo_utils.samples.validate_cloud_optimized_geotiff --full-check=yes '" +
            path + "'",
        dir);
    EXPECT_EQ(valid_status, 0) << valid;
    EXPECT_NE(valid.find("is a valid cloud optimized GeoTIFF"), std::string::npos) << valid;
  }
}

TEST(GeoTiffTest, RasterDifferencePropagatesNodata) {
  const std::vector<float> earlier = {0.1f, 0.2f, kNaN, 0.4f, -9999.0f, 0.0f};
  const std::vector<float> later = {0.3f, kNaN, 0.5f, 0.4f, 0.7f, -9999.0f};
  const std::vector<float> nan_nodata = RasterDifference(later, earlier);
  ASSERT_EQ(nan_nodata.size(), 6u);
  EXPECT_FLOAT_EQ(nan_nodata[0], 0.3f - 0.1f);
  EXPECT_TRUE(std::isnan(nan_nodata[1]));
  EXPECT_TRUE(std::isnan(nan_nodata[2]));
  EXPECT_EQ(nan_nodata[3], 0.0f);
  EXPECT_FLOAT_EQ(nan_nodata[4], 0.7f + 9999.0f);  // -9999 is a value when nodata is NaN
  const std::vector<float> numeric = RasterDifference(later, earlier, -9999.0f);
  EXPECT_EQ(numeric[1], -9999.0f);  // NaN is always nodata
  EXPECT_EQ(numeric[2], -9999.0f);
  EXPECT_EQ(numeric[4], -9999.0f);
  EXPECT_EQ(numeric[5], -9999.0f);
  EXPECT_FLOAT_EQ(numeric[0], 0.3f - 0.1f);
}

}  // namespace
}  // namespace crop4d::io
