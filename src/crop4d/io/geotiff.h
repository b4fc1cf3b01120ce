#pragma once

// GeoTIFF rasters in the UTM zone of the field (DESIGN.md §5: "GeoTIFF rasters in a projected
// CRS (QGIS)"), written and read with GDAL. Every raster is written as a Cloud-Optimized GeoTIFF
// (GDAL's COG driver: 256×256 tiles, overviews, DEFLATE with the floating-point predictor, the
// nodata value, the CRS as its EPSG code), which QGIS, GDAL and web map servers open directly.
//
// crop4d works in the field's local East-North-Up frame; a north-up UTM grid is not aligned with
// it (grid convergence: the UTM grid north turns away from true north by up to a few degrees,
// and the UTM scale differs from 1 by up to 0.1 %). A raster is therefore defined on a
// UTM-aligned grid, and the caller fills each cell with the value at the ENU position of its
// centre:
//
//   const FieldUtm utm(field.origin);
//   const UtmGrid grid = utm.GridCovering(enu_box, 0.05);
//   std::vector<float> heights(grid.num_cells());
//   const std::vector<Eigen::Vector2d> centres = utm.EnuCellCentres(grid);
//   for (size_t i = 0; i < centres.size(); ++i) heights[i] = CanopyHeightAt(centres[i]);
//   GeoTiffWriteOptions options;
//   options.description = "canopy height above terrain [m]";
//   options.metadata = {{"session", "2016-05-25"}};
//   WriteGeoTiff("WS/analysis/chm_2016-05-25.tif", grid, heights, options);

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <limits>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/geometry/enu.h"

namespace crop4d::io {

// A north-up raster grid in a UTM zone, square cells. Cell (col, row) covers eastings
// [min_easting + col·cell_m, min_easting + (col+1)·cell_m) and northings
// (max_northing − (row+1)·cell_m, max_northing − row·cell_m]; row 0 is the northern edge. The
// GDAL geotransform is {min_easting, cell_m, 0, max_northing, 0, −cell_m}.
struct UtmGrid {
  // WGS 84 / UTM zone: 326zz (north) or 327zz (south).
  int epsg = 0;
  // Easting of the western edge of column 0, metres.
  double min_easting = 0.0;
  // Northing of the northern edge of row 0, metres.
  double max_northing = 0.0;
  // Side of a cell, metres.
  double cell_m = 0.05;
  // Columns (east) and rows (south).
  int width = 0;
  int height = 0;

  // A UTM EPSG code, finite edges, cell_m > 0, width and height in [1, 10^6].
  OptionCheck Check() const;
  std::size_t num_cells() const { return std::size_t(width) * std::size_t(height); }
  // UTM easting, northing of the centre of cell (col, row).
  Eigen::Vector2d CellCentre(int col, int row) const;
};

// Maps between the field's ENU frame and its UTM zone (the zone of the origin,
// geometry::UtmEpsgCode), exactly: geometry::LocalEnu (GeographicLib LocalCartesian) and
// geometry::UtmFromGeodetic (GeographicLib TransverseMercator).
class FieldUtm {
 public:
  // Throws InputError for an invalid origin.
  explicit FieldUtm(const geometry::GeodeticPoint& origin);

  int epsg() const { return epsg_; }
  const geometry::GeodeticPoint& origin() const { return enu_.origin(); }
  // UTM easting, northing of an ENU point. Its z matters only through the tilt of the ENU up
  // axis against the local vertical: ~0.16 mm per metre of height per kilometre from the
  // origin.
  Eigen::Vector2d UtmFromEnu(const Eigen::Vector3d& enu) const;
  // ENU of the point with these UTM coordinates and ellipsoidal height.
  Eigen::Vector3d EnuFromUtm(double easting, double northing, double ellipsoidal_height) const;

  // The smallest grid of cell_m cells, with edges on multiples of cell_m in UTM, that covers the
  // ENU box (xy, metres; the box's edges are mapped at z = 0). CHECKs a non-empty finite box
  // and a finite cell_m > 0.
  UtmGrid GridCovering(const Eigen::AlignedBox2d& enu_box, double cell_m) const;

  // ENU xy of the centre of every cell of `grid` (row-major, grid.num_cells()), on the ellipsoid
  // surface at the origin's height. Exact at a lattice of cells at most 8 m apart and bilinear
  // between them: the map is so smooth that this is within 0.01 mm of the exact conversion,
  // and it costs one GeographicLib call per lattice node rather than per cell. CHECKs
  // grid.Check() and grid.epsg == epsg().
  std::vector<Eigen::Vector2d> EnuCellCentres(const UtmGrid& grid) const;

 private:
  geometry::LocalEnu enu_;
  int epsg_ = 0;
};

struct GeoTiffWriteOptions {
  // Value of the cells without data, stored as the band's GDAL nodata value (NaN is allowed and
  // is the default).
  float nodata = std::numeric_limits<float>::quiet_NaN();
  // Band description (shown by QGIS and gdalinfo), e.g. "canopy height above terrain [m]".
  std::string description;
  // Dataset metadata items (gdalinfo "Metadata:"), e.g. {"session", "2016-05-25"}. Keys are
  // non-empty, without '=' or white space, and not AREA_OR_POINT (CHECK).
  std::map<std::string, std::string> metadata;
  // DEFLATE compression with the floating-point predictor (TIFF predictor 3), of the image and
  // of its overviews; false: uncompressed.
  bool compress = true;
};

// The side of the square tiles of the written COGs, cells.
inline constexpr int kGeoTiffTileSize = 256;

// The number of overviews WriteGeoTiff gives a width × height raster: halvings of the larger
// side until it fits one tile (GDAL's rule), and at least one for any raster of more than one
// cell, so that every raster has a reduced-resolution level (QGIS never offers to build
// "pyramids"). 0 for a single cell.
int GeoTiffOverviewCount(int width, int height);

// Writes a one-band Float32 Cloud-Optimized GeoTIFF of `values` (row-major, row 0 north,
// grid.num_cells(); CHECK) georeferenced by `grid`: the geotransform of UtmGrid, the CRS as its
// EPSG code (ProjectedCSTypeGeoKey, so that QGIS recognises it without asking) and pixel is area.
// The values go into an in-memory (MEM) dataset with the nodata value, description and metadata,
// which GDAL's COG driver copies into the file: kGeoTiffTileSize tiles, GeoTiffOverviewCount
// overviews averaged from the cells with data (AVERAGE resampling skips nodata), the
// compression of `options`, and the ghost header that marks the layout (gdalinfo shows
// IMAGE_STRUCTURE LAYOUT=COG). Atomic (io/atomic_file.h): GDAL writes "<path>.tmp.<pid>.<n>"
// (and, while it builds the overviews, "<that>.ovr.tmp") in the same folder, which is then
// renamed over `path`; missing parent folders are created. Throws InputError naming `path` when
// it cannot be written (the temporary files are removed).
void WriteGeoTiff(const std::string& path, const UtmGrid& grid, const std::vector<float>& values,
                  const GeoTiffWriteOptions& options = {});

// `later` − `earlier`, cell by cell (the same grid: equal sizes, CHECK), e.g. the change of the
// canopy height between two sessions. A cell that is NaN or `nodata` in either raster is
// `nodata` in the result.
std::vector<float> RasterDifference(const std::vector<float>& later,
                                    const std::vector<float>& earlier,
                                    float nodata = std::numeric_limits<float>::quiet_NaN());

struct GeoTiffRaster {
  UtmGrid grid;
  std::vector<float> values;  // row-major, grid.num_cells()
  std::optional<float> nodata;
  std::string description;  // of the band
  // Dataset metadata items of the default domain, without GDAL's AREA_OR_POINT.
  std::map<std::string, std::string> metadata;
  // How the file is laid out: GDAL's IMAGE_STRUCTURE items LAYOUT ("COG" for a Cloud-Optimized
  // GeoTIFF, "" otherwise) and COMPRESSION ("DEFLATE", "" when uncompressed), and the number of
  // overviews of the band.
  std::string layout;
  std::string compression;
  int overviews = 0;
};

// Reads a GeoTIFF written by WriteGeoTiff (or any one-band, north-up, square-celled GeoTIFF in
// a WGS 84 / UTM CRS; values converted to float). Throws InputError naming `path` for a file
// that is missing or not a GeoTIFF, more than one band, no or a rotated geotransform, cells that
// are not square, or a CRS that is not a WGS 84 / UTM zone.
GeoTiffRaster ReadGeoTiff(const std::string& path);

}  // namespace crop4d::io
