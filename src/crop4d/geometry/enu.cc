#include "crop4d/geometry/enu.h"

#include <GeographicLib/Constants.hpp>
#include <GeographicLib/LocalCartesian.hpp>
#include <GeographicLib/TransverseMercator.hpp>
#include <GeographicLib/UTMUPS.hpp>
#include <cmath>
#include <string>

#include "crop4d/core/error.h"

namespace crop4d::geometry {
namespace {

void CheckGeodetic(const GeodeticPoint& p) {
  if (!std::isfinite(p.lat_deg) || !std::isfinite(p.lon_deg) || !std::isfinite(p.alt_m) ||
      std::abs(p.lat_deg) > 90.0) {
    throw InputError("invalid geodetic point: lat " + std::to_string(p.lat_deg) + " deg, lon " +
                     std::to_string(p.lon_deg) + " deg, alt " + std::to_string(p.alt_m) + " m");
  }
}

// UTM parameters of a WGS 84 / UTM EPSG code (IsUtmEpsgCode), or throws InputError.
struct UtmZone {
  double central_meridian_deg = 0.0;
  double false_northing_m = 0.0;
};

UtmZone ZoneOfEpsg(int epsg) {
  if (!IsUtmEpsgCode(epsg)) {
    throw InputError("EPSG:" + std::to_string(epsg) +
                     " is not a WGS 84 / UTM zone (32601-32660 north, 32701-32760 south)");
  }
  const int zone = epsg % 100;
  // Zone N spans longitudes [6N - 186, 6N - 180) degrees; its central meridian is 6N - 183.
  return {6.0 * zone - 183.0, epsg >= 32701 ? 10'000'000.0 : 0.0};
}

// UTM: transverse Mercator with scale 0.9996 on the central meridian and a false easting of
// 500 km (NGA.SIG.0012_2.0.0_UTMUPS); GeographicLib's TransverseMercator::UTM() is the
// 6th-order Krüger series, accurate to 5 nm within 3900 km of the central meridian.
constexpr double kUtmFalseEasting = 500'000.0;

}  // namespace

// GeographicLib::LocalCartesian converts through geocentric ECEF coordinates with the exact
// WGS84 ellipsoid and rotates into the tangent East-North-Up frame at the origin (Karney,
// GeographicLib documentation, "LocalCartesian class").
struct LocalEnu::Impl {
  explicit Impl(const GeodeticPoint& origin)
      : local_cartesian(origin.lat_deg, origin.lon_deg, origin.alt_m,
                        GeographicLib::Geocentric::WGS84()) {}
  GeographicLib::LocalCartesian local_cartesian;
};

LocalEnu::LocalEnu(const GeodeticPoint& origin) : origin_(origin) {
  CheckGeodetic(origin);
  impl_ = std::make_unique<Impl>(origin);
}

LocalEnu::~LocalEnu() = default;

LocalEnu::LocalEnu(const LocalEnu& other)
    : origin_(other.origin_), impl_(std::make_unique<Impl>(*other.impl_)) {}

LocalEnu& LocalEnu::operator=(const LocalEnu& other) {
  if (this != &other) {
    origin_ = other.origin_;
    impl_ = std::make_unique<Impl>(*other.impl_);
  }
  return *this;
}

Eigen::Vector3d LocalEnu::ToEnu(const GeodeticPoint& p) const {
  Eigen::Vector3d enu;
  impl_->local_cartesian.Forward(p.lat_deg, p.lon_deg, p.alt_m, enu.x(), enu.y(), enu.z());
  return enu;
}

GeodeticPoint LocalEnu::ToGeodetic(const Eigen::Vector3d& enu) const {
  GeodeticPoint p;
  impl_->local_cartesian.Reverse(enu.x(), enu.y(), enu.z(), p.lat_deg, p.lon_deg, p.alt_m);
  return p;
}

int UtmEpsgCode(const GeodeticPoint& p) {
  CheckGeodetic(p);
  // UTMUPS::UTM applies the standard zone rules (with the Norway and Svalbard exceptions) and
  // extends the UTM zones to the poles instead of switching to UPS, so the zone is in [1, 60]
  // (GeographicLib, UTMUPS::zonespec). EPSG: WGS 84 / UTM zone N is 32600 + N in the north,
  // 32700 + N in the south (EPSG registry, codes 32601-32660 and 32701-32760).
  const int zone =
      GeographicLib::UTMUPS::StandardZone(p.lat_deg, p.lon_deg, GeographicLib::UTMUPS::UTM);
  return (p.lat_deg >= 0.0 ? 32600 : 32700) + zone;
}

bool IsUtmEpsgCode(int epsg) {
  return (epsg >= 32601 && epsg <= 32660) || (epsg >= 32701 && epsg <= 32760);
}

Eigen::Vector2d UtmFromGeodetic(const GeodeticPoint& p, int epsg) {
  CheckGeodetic(p);
  const UtmZone zone = ZoneOfEpsg(epsg);
  double x = 0.0, y = 0.0;
  GeographicLib::TransverseMercator::UTM().Forward(zone.central_meridian_deg, p.lat_deg, p.lon_deg,
                                                   x, y);
  return {x + kUtmFalseEasting, y + zone.false_northing_m};
}

GeodeticPoint GeodeticFromUtm(const Eigen::Vector2d& easting_northing, double ellipsoidal_height_m,
                              int epsg) {
  const UtmZone zone = ZoneOfEpsg(epsg);
  if (!easting_northing.allFinite() || !std::isfinite(ellipsoidal_height_m)) {
    throw InputError("invalid UTM coordinates: easting " + std::to_string(easting_northing.x()) +
                     " m, northing " + std::to_string(easting_northing.y()) + " m, height " +
                     std::to_string(ellipsoidal_height_m) + " m");
  }
  GeodeticPoint p;
  GeographicLib::TransverseMercator::UTM().Reverse(
      zone.central_meridian_deg, easting_northing.x() - kUtmFalseEasting,
      easting_northing.y() - zone.false_northing_m, p.lat_deg, p.lon_deg);
  p.alt_m = ellipsoidal_height_m;
  return p;
}

}  // namespace crop4d::geometry
