#include "crop4d/geometry/enu.h"

#include <GeographicLib/Constants.hpp>
#include <GeographicLib/LocalCartesian.hpp>
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

}  // namespace crop4d::geometry
