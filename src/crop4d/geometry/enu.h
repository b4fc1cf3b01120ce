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

}  // namespace crop4d::geometry
