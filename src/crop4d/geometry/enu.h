#pragma once

// Conversion between WGS84 geodetic coordinates and the field's local East-North-Up frame
// (DESIGN.md §3), with GeographicLib's LocalCartesian (exact, not a flat-earth
// approximation).

#include <Eigen/Core>
#include <memory>

namespace crop4d::geometry {

struct GeodeticPoint {
  double lat_deg = 0.0;  // WGS84 latitude, degrees, north positive
  double lon_deg = 0.0;  // WGS84 longitude, degrees, east positive
  double alt_m = 0.0;    // ellipsoidal height, metres
};

class LocalEnu {
 public:
  explicit LocalEnu(const GeodeticPoint& origin);
  ~LocalEnu();
  LocalEnu(const LocalEnu& other);
  LocalEnu& operator=(const LocalEnu& other);

  const GeodeticPoint& origin() const { return origin_; }
  // Geodetic to ENU metres.
  Eigen::Vector3d ToEnu(const GeodeticPoint& p) const;
  // ENU metres to geodetic.
  GeodeticPoint ToGeodetic(const Eigen::Vector3d& enu) const;

 private:
  struct Impl;
  GeodeticPoint origin_;
  std::unique_ptr<Impl> impl_;
};

// The UTM zone (1..60) and hemisphere of a point, for GeoTIFF outputs; EPSG code 326xx (north)
// or 327xx (south).
int UtmEpsgCode(const GeodeticPoint& p);

// True for the EPSG code of a WGS 84 / UTM zone: 32601..32660 (north), 32701..32760 (south).
bool IsUtmEpsgCode(int epsg);

// Projects `p` into the UTM zone of `epsg` (WGS 84 / UTM zone N north or south): x easting,
// y northing, metres, with the false easting 500 km and, for a southern zone, the false northing
// 10000 km. The zone is the one of `epsg`, not the point's standard zone, so that a whole field
// stays in its origin's zone when it straddles a zone border (or the equator). Exact
// (GeographicLib TransverseMercator, Karney 2011). alt_m is ignored. Throws InputError for an
// invalid point or an epsg that is not a UTM zone.
Eigen::Vector2d UtmFromGeodetic(const GeodeticPoint& p, int epsg);

// The inverse of UtmFromGeodetic; alt_m of the result is `ellipsoidal_height_m`. Throws
// InputError for non-finite coordinates or an epsg that is not a UTM zone.
GeodeticPoint GeodeticFromUtm(const Eigen::Vector2d& easting_northing, double ellipsoidal_height_m,
                              int epsg);

}  // namespace crop4d::geometry
