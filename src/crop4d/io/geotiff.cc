#include "crop4d/io/geotiff.h"

#include <cpl_conv.h>
#include <cpl_error.h>
#include <cpl_string.h>
#include <gdal.h>
#include <gdal_priv.h>
#include <ogr_spatialref.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cctype>
#include <cmath>
#include <filesystem>
#include <mutex>
#include <system_error>

#include "crop4d/core/error.h"

namespace crop4d::io {
namespace {

namespace fs = std::filesystem;

// GDAL's registry of drivers is filled once per process.
void RegisterGdal() {
  static std::once_flag once;
  std::call_once(once, [] { GDALAllRegister(); });
}

// Collects the messages of GDAL/PROJ failures raised on this thread while it lives (GDAL's
// error handler stack is thread-local), instead of letting GDAL print them to stderr.
class GdalErrors {
 public:
  GdalErrors() {
    CPLErrorReset();
    CPLPushErrorHandlerEx(&GdalErrors::Handler, this);
  }
  ~GdalErrors() { CPLPopErrorHandler(); }
  GdalErrors(const GdalErrors&) = delete;
  GdalErrors& operator=(const GdalErrors&) = delete;

  bool failed() const { return !messages_.empty(); }
  // The failure messages joined, or `fallback` when there are none.
  std::string Message(const std::string& fallback) const {
    if (messages_.empty()) return fallback;
    std::string text;
    for (const std::string& m : messages_) text += (text.empty() ? "" : "; ") + m;
    return text;
  }

 private:
  static void CPL_STDCALL Handler(CPLErr error_class, CPLErrorNum, const char* message) {
    auto* self = static_cast<GdalErrors*>(CPLGetErrorHandlerUserData());
    if (self != nullptr && error_class >= CE_Failure) {
      self->messages_.emplace_back(message != nullptr ? message : "unknown GDAL error");
    }
  }

  std::vector<std::string> messages_;
};

std::string TemporaryPath(const std::string& path) {
  static std::atomic<unsigned long> counter{0};
  return path + ".tmp." + std::to_string(::getpid()) + "." + std::to_string(counter++);
}

bool ValidMetadataKey(const std::string& key) {
  if (key.empty() || key == "AREA_OR_POINT") return false;
  return std::none_of(key.begin(), key.end(), [](unsigned char c) {
    return c == '=' || std::isspace(c) != 0 || std::iscntrl(c) != 0;
  });
}

// Closes a GDAL dataset on scope exit (an error path), unless released.
struct DatasetCloser {
  void operator()(GDALDataset* dataset) const {
    if (dataset != nullptr) GDALClose(GDALDataset::ToHandle(dataset));
  }
};
using DatasetPtr = std::unique_ptr<GDALDataset, DatasetCloser>;

// The spatial reference of a WGS 84 / UTM EPSG code; PROJ finds it in proj.db. It keeps its
// EPSG authority, which the GeoTIFF writer stores as ProjectedCSTypeGeoKey.
OGRSpatialReference SrsOfEpsg(int epsg, const std::string& path, const GdalErrors& errors) {
  OGRSpatialReference srs;
  if (srs.importFromEPSG(epsg) != OGRERR_NONE) {
    throw InputError(path, 0,
                     "cannot look up the CRS EPSG:" + std::to_string(epsg) +
                         " in PROJ's database (" + errors.Message("no message") +
                         "); is proj.db installed (Debian package proj-data)?");
  }
  srs.SetAxisMappingStrategy(OAMS_TRADITIONAL_GIS_ORDER);
  return srs;
}

// Removes the temporary files of a failed write (the copy and the COG driver's overview file).
void RemoveTemporaries(const std::string& tmp_path) {
  std::error_code ignored;
  for (const char* suffix : {"", ".ovr.tmp", ".msk.ovr.tmp", ".aux.xml"}) {
    fs::remove(tmp_path + suffix, ignored);
  }
}

}  // namespace

// ---- UtmGrid, FieldUtm ----------------------------------------------------------------------

OptionCheck UtmGrid::Check() const {
  constexpr int kMaxSide = 1'000'000;
  OptionChecker c;
  c.Require(geometry::IsUtmEpsgCode(epsg), "epsg", "must be a UTM zone's EPSG code", epsg)
      .Finite("min_easting", min_easting)
      .Finite("max_northing", max_northing)
      .Finite("cell_m", cell_m)
      .Greater("cell_m", cell_m, 0.0)
      .InRange("width", width, 1, kMaxSide)
      .InRange("height", height, 1, kMaxSide);
  return c.Result();
}

Eigen::Vector2d UtmGrid::CellCentre(int col, int row) const {
  return {min_easting + (col + 0.5) * cell_m, max_northing - (row + 0.5) * cell_m};
}

FieldUtm::FieldUtm(const geometry::GeodeticPoint& origin)
    : enu_(origin), epsg_(geometry::UtmEpsgCode(origin)) {}

Eigen::Vector2d FieldUtm::UtmFromEnu(const Eigen::Vector3d& enu) const {
  return geometry::UtmFromGeodetic(enu_.ToGeodetic(enu), epsg_);
}

Eigen::Vector3d FieldUtm::EnuFromUtm(double easting, double northing,
                                     double ellipsoidal_height) const {
  return enu_.ToEnu(
      geometry::GeodeticFromUtm(Eigen::Vector2d(easting, northing), ellipsoidal_height, epsg_));
}

UtmGrid FieldUtm::GridCovering(const Eigen::AlignedBox2d& enu_box, double cell_m) const {
  CROP4D_CHECK(!enu_box.isEmpty() && enu_box.min().allFinite() && enu_box.max().allFinite());
  CROP4D_CHECK(std::isfinite(cell_m) && cell_m > 0.0);
  // The box's edges map to slightly curved, rotated lines in UTM: sample them densely (the
  // curvature is far below a micrometre over a field).
  constexpr int kSamplesPerEdge = 32;
  double e_lo = INFINITY, e_hi = -INFINITY, n_lo = INFINITY, n_hi = -INFINITY;
  const Eigen::Vector2d lo = enu_box.min(), size = enu_box.sizes();
  for (int i = 0; i <= kSamplesPerEdge; ++i) {
    const double t = double(i) / kSamplesPerEdge;
    for (const Eigen::Vector2d& p : {Eigen::Vector2d(lo.x() + t * size.x(), lo.y()),
                                     Eigen::Vector2d(lo.x() + t * size.x(), lo.y() + size.y()),
                                     Eigen::Vector2d(lo.x(), lo.y() + t * size.y()),
                                     Eigen::Vector2d(lo.x() + size.x(), lo.y() + t * size.y())}) {
      const Eigen::Vector2d utm = UtmFromEnu(Eigen::Vector3d(p.x(), p.y(), 0.0));
      e_lo = std::min(e_lo, utm.x());
      e_hi = std::max(e_hi, utm.x());
      n_lo = std::min(n_lo, utm.y());
      n_hi = std::max(n_hi, utm.y());
    }
  }
  UtmGrid grid;
  grid.epsg = epsg_;
  grid.cell_m = cell_m;
  grid.min_easting = std::floor(e_lo / cell_m) * cell_m;
  grid.max_northing = std::ceil(n_hi / cell_m) * cell_m;
  grid.width = std::max(1, int(std::ceil((e_hi - grid.min_easting) / cell_m)));
  grid.height = std::max(1, int(std::ceil((grid.max_northing - n_lo) / cell_m)));
  // Rounding of the divisions must not leave the far edges uncovered.
  while (grid.min_easting + grid.width * cell_m < e_hi) ++grid.width;
  while (grid.max_northing - grid.height * cell_m > n_lo) ++grid.height;
  CROP4D_CHECK_MSG(grid.Check().empty(), "the ENU box is too large for a grid of this cell size");
  return grid;
}

std::vector<Eigen::Vector2d> FieldUtm::EnuCellCentres(const UtmGrid& grid) const {
  CROP4D_CHECK_OPTIONS(grid, "FieldUtm::EnuCellCentres");
  CROP4D_CHECK(grid.epsg == epsg_);
  // Lattice of exactly converted cells: every `stride` cells (≤ 8 m) and the last one.
  constexpr double kLatticeSpacingM = 8.0;
  const int stride = std::max(1, int(std::floor(kLatticeSpacingM / grid.cell_m)));
  auto lattice = [stride](int n) {
    std::vector<int> nodes;
    for (int i = 0; i < n - 1; i += stride) nodes.push_back(i);
    nodes.push_back(n - 1);
    return nodes;
  };
  const std::vector<int> cols = lattice(grid.width), rows = lattice(grid.height);
  const double height = origin().alt_m;
  std::vector<Eigen::Vector2d> nodes(cols.size() * rows.size());
  for (std::size_t r = 0; r < rows.size(); ++r) {
    for (std::size_t c = 0; c < cols.size(); ++c) {
      const Eigen::Vector2d utm = grid.CellCentre(cols[c], rows[r]);
      nodes[r * cols.size() + c] = EnuFromUtm(utm.x(), utm.y(), height).head<2>();
    }
  }
  // Bilinear interpolation inside each lattice interval.
  auto interval = [stride](const std::vector<int>& nodes, int i, double* t) {
    const std::size_t k =
        std::min<std::size_t>(i / stride, nodes.size() > 1 ? nodes.size() - 2 : 0);
    if (nodes.size() == 1) {
      *t = 0.0;
      return k;
    }
    *t = double(i - nodes[k]) / double(nodes[k + 1] - nodes[k]);
    return k;
  };
  std::vector<Eigen::Vector2d> centres(grid.num_cells());
  for (int row = 0; row < grid.height; ++row) {
    double v = 0.0;
    const std::size_t r = interval(rows, row, &v);
    const std::size_t r1 = rows.size() > 1 ? r + 1 : r;
    for (int col = 0; col < grid.width; ++col) {
      double u = 0.0;
      const std::size_t c = interval(cols, col, &u);
      const std::size_t c1 = cols.size() > 1 ? c + 1 : c;
      const Eigen::Vector2d& p00 = nodes[r * cols.size() + c];
      const Eigen::Vector2d& p01 = nodes[r * cols.size() + c1];
      const Eigen::Vector2d& p10 = nodes[r1 * cols.size() + c];
      const Eigen::Vector2d& p11 = nodes[r1 * cols.size() + c1];
      centres[std::size_t(row) * grid.width + col] =
          (1 - v) * ((1 - u) * p00 + u * p01) + v * ((1 - u) * p10 + u * p11);
    }
  }
  return centres;
}

// ---- writing --------------------------------------------------------------------------------

int GeoTiffOverviewCount(int width, int height) {
  int side = std::max(width, height);
  if (side <= 1) return 0;
  int count = 0;
  while (side > kGeoTiffTileSize) {
    side = (side + 1) / 2;
    ++count;
  }
  return std::max(count, 1);
}

void WriteGeoTiff(const std::string& path, const UtmGrid& grid, const std::vector<float>& values,
                  const GeoTiffWriteOptions& options) {
  CROP4D_CHECK_OPTIONS(grid, "WriteGeoTiff");
  CROP4D_CHECK(values.size() == grid.num_cells());
  for (const auto& [key, value] : options.metadata) {
    CROP4D_CHECK_MSG(ValidMetadataKey(key), "invalid GeoTIFF metadata key '" + key + "'");
  }
  RegisterGdal();
  GdalErrors errors;

  const fs::path parent = fs::path(path).parent_path();
  std::error_code ec;
  if (!parent.empty()) {
    fs::create_directories(parent, ec);
    if (ec) {
      throw InputError(path, 0, "cannot create folder " + parent.string() + ": " + ec.message());
    }
  }
  if (fs::is_directory(path, ec)) throw InputError(path, 0, "cannot write: it is a folder");
  const OGRSpatialReference srs = SrsOfEpsg(grid.epsg, path, errors);

  GDALDriver* mem_driver = GetGDALDriverManager()->GetDriverByName("MEM");
  GDALDriver* cog_driver = GetGDALDriverManager()->GetDriverByName("COG");
  if (mem_driver == nullptr || cog_driver == nullptr) {
    throw InputError(path, 0, "GDAL has no MEM or COG driver (GDAL 3.1 or later is needed)");
  }
  const std::string tmp_path = TemporaryPath(path);
  auto fail = [&](const std::string& what) {
    RemoveTemporaries(tmp_path);
    return InputError(path, 0, what + ": " + errors.Message("unknown GDAL error"));
  };

  // The source: an in-memory dataset over `values` (no copy; only read by the COG driver, which
  // builds the overviews in a temporary file of its own).
  DatasetPtr source(mem_driver->Create("", grid.width, grid.height, 0, GDT_Float32, nullptr));
  if (!source) throw fail("cannot create the in-memory raster");
  {
    char pointer[64] = {};
    CPLPrintPointer(pointer, const_cast<float*>(values.data()), sizeof(pointer) - 1);
    CPLStringList band_options;
    band_options.SetNameValue("DATAPOINTER", pointer);
    band_options.SetNameValue("PIXELOFFSET", std::to_string(sizeof(float)).c_str());
    band_options.SetNameValue("LINEOFFSET",
                              std::to_string(sizeof(float) * std::size_t(grid.width)).c_str());
    if (source->AddBand(GDT_Float32, band_options.List()) != CE_None) {
      throw fail("cannot create the in-memory raster");
    }
  }
  double transform[6] = {grid.min_easting, grid.cell_m, 0.0, grid.max_northing, 0.0, -grid.cell_m};
  GDALRasterBand* band = source->GetRasterBand(1);
  bool ok = source->SetGeoTransform(transform) == CE_None &&
            source->SetSpatialRef(&srs) == CE_None &&
            source->SetMetadataItem("AREA_OR_POINT", "Area") == CE_None &&
            band->SetNoDataValue(double(options.nodata)) == CE_None;
  for (const auto& [key, value] : options.metadata) {
    ok = ok && source->SetMetadataItem(key.c_str(), value.c_str()) == CE_None;
  }
  if (ok && !options.description.empty()) band->SetDescription(options.description.c_str());
  if (!ok) throw fail("cannot set up the in-memory raster");

  CPLStringList create_options;
  const char* compress = options.compress ? "DEFLATE" : "NONE";
  create_options.SetNameValue("COMPRESS", compress);
  create_options.SetNameValue("OVERVIEW_COMPRESS", compress);
  if (options.compress) {
    create_options.SetNameValue("PREDICTOR", "FLOATING_POINT");  // TIFF predictor 3
    create_options.SetNameValue("OVERVIEW_PREDICTOR", "FLOATING_POINT");
  }
  create_options.SetNameValue("BLOCKSIZE", std::to_string(kGeoTiffTileSize).c_str());
  const int overviews = GeoTiffOverviewCount(grid.width, grid.height);
  if (overviews > 0) {
    create_options.SetNameValue("OVERVIEWS", "IGNORE_EXISTING");
    create_options.SetNameValue("OVERVIEW_COUNT", std::to_string(overviews).c_str());
    create_options.SetNameValue("OVERVIEW_RESAMPLING", "AVERAGE");
  } else {
    create_options.SetNameValue("OVERVIEWS", "NONE");
  }
  create_options.SetNameValue("BIGTIFF", "IF_SAFER");
  {
    DatasetPtr written(cog_driver->CreateCopy(tmp_path.c_str(), source.get(), /*bStrict=*/FALSE,
                                              create_options.List(), nullptr, nullptr));
    if (!written) throw fail("cannot write the Cloud-Optimized GeoTIFF");
    // Closing flushes the file; a failure (disk full) is reported through `errors`.
  }
  if (errors.failed()) throw fail("cannot write the Cloud-Optimized GeoTIFF");
  fs::rename(tmp_path, path, ec);
  if (ec) {
    RemoveTemporaries(tmp_path);
    throw InputError(path, 0, "cannot rename the temporary file into place: " + ec.message());
  }
}

std::vector<float> RasterDifference(const std::vector<float>& later,
                                    const std::vector<float>& earlier, float nodata) {
  CROP4D_CHECK(later.size() == earlier.size());
  const auto missing = [nodata](float v) { return std::isnan(v) || v == nodata; };
  std::vector<float> difference(later.size());
  for (std::size_t i = 0; i < later.size(); ++i) {
    difference[i] = missing(later[i]) || missing(earlier[i]) ? nodata : later[i] - earlier[i];
  }
  return difference;
}

// ---- reading --------------------------------------------------------------------------------

GeoTiffRaster ReadGeoTiff(const std::string& path) {
  RegisterGdal();
  GdalErrors errors;
  std::error_code ec;
  if (!fs::is_regular_file(path, ec)) throw InputError(path, 0, "no such file");
  const char* const allowed_drivers[] = {"GTiff", nullptr};
  DatasetPtr dataset(GDALDataset::FromHandle(GDALOpenEx(
      path.c_str(), GDAL_OF_RASTER | GDAL_OF_READONLY, allowed_drivers, nullptr, nullptr)));
  if (!dataset) {
    throw InputError(path, 0, "not a readable GeoTIFF: " + errors.Message("unknown format"));
  }
  if (dataset->GetRasterCount() != 1) {
    throw InputError(path, 0,
                     "expected one band, found " + std::to_string(dataset->GetRasterCount()));
  }
  double t[6] = {0, 1, 0, 0, 0, 1};
  if (dataset->GetGeoTransform(t) != CE_None) {
    throw InputError(path, 0, "no geotransform: the raster is not georeferenced");
  }
  if (t[2] != 0.0 || t[4] != 0.0 || !(t[1] > 0.0) || !(t[5] < 0.0)) {
    throw InputError(path, 0, "the raster is not north-up (geotransform rotated or flipped)");
  }
  if (std::abs(t[1] + t[5]) > 1e-9 * t[1]) {
    throw InputError(path, 0, "the cells are not square");
  }

  GeoTiffRaster raster;
  const OGRSpatialReference* srs = dataset->GetSpatialRef();
  if (srs == nullptr) throw InputError(path, 0, "no CRS");
  int epsg = 0;
  auto code_of = [](const OGRSpatialReference& s) {
    const char* name = s.GetAuthorityName(nullptr);
    const char* code = s.GetAuthorityCode(nullptr);
    return name != nullptr && code != nullptr && EQUAL(name, "EPSG") ? std::atoi(code) : 0;
  };
  epsg = code_of(*srs);
  if (epsg == 0) {
    OGRSpatialReference copy(*srs);
    if (copy.AutoIdentifyEPSG() == OGRERR_NONE) epsg = code_of(copy);
  }
  if (!geometry::IsUtmEpsgCode(epsg)) {
    throw InputError(path, 0,
                     "the CRS is not a WGS 84 / UTM zone (EPSG 326xx or 327xx)" +
                         (epsg != 0 ? std::string(": EPSG:") + std::to_string(epsg) : ""));
  }
  raster.grid.epsg = epsg;
  raster.grid.min_easting = t[0];
  raster.grid.max_northing = t[3];
  raster.grid.cell_m = t[1];
  raster.grid.width = dataset->GetRasterXSize();
  raster.grid.height = dataset->GetRasterYSize();
  if (const std::string why = raster.grid.Check(); !why.empty()) {
    throw InputError(path, 0, "invalid raster size or geotransform: " + why);
  }

  GDALRasterBand* band = dataset->GetRasterBand(1);
  raster.values.resize(raster.grid.num_cells());
  if (band->RasterIO(GF_Read, 0, 0, raster.grid.width, raster.grid.height, raster.values.data(),
                     raster.grid.width, raster.grid.height, GDT_Float32, 0, 0,
                     nullptr) != CE_None) {
    throw InputError(path, 0, "cannot read the raster: " + errors.Message("unknown GDAL error"));
  }
  int has_nodata = 0;
  const double nodata = band->GetNoDataValue(&has_nodata);
  if (has_nodata) raster.nodata = float(nodata);
  raster.description = band->GetDescription();
  raster.overviews = band->GetOverviewCount();
  const char* layout = dataset->GetMetadataItem("LAYOUT", "IMAGE_STRUCTURE");
  const char* compression = dataset->GetMetadataItem("COMPRESSION", "IMAGE_STRUCTURE");
  raster.layout = layout != nullptr ? layout : "";
  raster.compression = compression != nullptr ? compression : "";
  for (char** item = dataset->GetMetadata(); item != nullptr && *item != nullptr; ++item) {
    char* key = nullptr;
    const char* value = CPLParseNameValue(*item, &key);
    if (key != nullptr && value != nullptr && std::string(key) != "AREA_OR_POINT") {
      raster.metadata[key] = value;
    }
    CPLFree(key);
  }
  return raster;
}

}  // namespace crop4d::io
