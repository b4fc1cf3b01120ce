#include "crop4d/geometry/enu.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <numbers>

#include "crop4d/core/error.h"

namespace crop4d::geometry {
namespace {

// WGS84 defining parameters (NIMA TR8350.2, "Department of Defense World Geodetic System
// 1984", §3).
constexpr double kA = 6378137.0;
constexpr double kF = 1.0 / 298.257223563;
constexpr double kE2 = kF * (2.0 - kF);

double Radians(double deg) { return deg * std::numbers::pi / 180.0; }

// Meridional radius of curvature M(φ) = a (1 − e²) / (1 − e² sin²φ)^{3/2} and prime-vertical
// radius N(φ) = a / sqrt(1 − e² sin²φ) (Torge & Müller, "Geodesy", 4th ed., §4.2.2).
double MeridionalRadius(double lat_rad) {
  const double s = std::sin(lat_rad);
  return kA * (1.0 - kE2) / std::pow(1.0 - kE2 * s * s, 1.5);
}
double PrimeVerticalRadius(double lat_rad) {
  const double s = std::sin(lat_rad);
  return kA / std::sqrt(1.0 - kE2 * s * s);
}

// Geodetic to ECEF, X = (N + h) cos φ cos λ, Y = (N + h) cos φ sin λ, Z = (N (1 − e²) + h) sin φ
// (Torge & Müller, §4.1.3), an implementation independent of GeographicLib.
Eigen::Vector3d Ecef(const GeodeticPoint& p) {
  const double lat = Radians(p.lat_deg);
  const double lon = Radians(p.lon_deg);
  const double n = PrimeVerticalRadius(lat);
  return {(n + p.alt_m) * std::cos(lat) * std::cos(lon),
          (n + p.alt_m) * std::cos(lat) * std::sin(lon),
          (n * (1.0 - kE2) + p.alt_m) * std::sin(lat)};
}

// ECEF difference rotated into ENU at the origin (rows: east, north, up unit vectors).
Eigen::Vector3d EnuFromEcef(const GeodeticPoint& origin, const GeodeticPoint& p) {
  const double lat = Radians(origin.lat_deg);
  const double lon = Radians(origin.lon_deg);
  Eigen::Matrix3d enu_from_ecef;
  enu_from_ecef << -std::sin(lon), std::cos(lon), 0.0,                                //
      -std::sin(lat) * std::cos(lon), -std::sin(lat) * std::sin(lon), std::cos(lat),  //
      std::cos(lat) * std::cos(lon), std::cos(lat) * std::sin(lon), std::sin(lat);
  return enu_from_ecef * (Ecef(p) - Ecef(origin));
}

const GeodeticPoint kTifton{31.4750, -83.5300, 110.0};

TEST(EnuTest, OriginMapsToZero) {
  const LocalEnu enu(kTifton);
  EXPECT_LT(enu.ToEnu(kTifton).norm(), 1e-9);
  EXPECT_EQ(enu.origin().lat_deg, kTifton.lat_deg);
  const GeodeticPoint back = enu.ToGeodetic(Eigen::Vector3d::Zero());
  EXPECT_NEAR(back.lat_deg, kTifton.lat_deg, 1e-12);
  EXPECT_NEAR(back.lon_deg, kTifton.lon_deg, 1e-12);
  EXPECT_NEAR(back.alt_m, kTifton.alt_m, 1e-9);
}

TEST(EnuTest, NorthOffsetAt45DegreesMatchesMeridianArc) {
  const GeodeticPoint origin{45.0, 10.0, 0.0};
  const LocalEnu enu(origin);
  const Eigen::Vector3d p = enu.ToEnu({45.001, 10.0, 0.0});
  // Meridian arc over 0.001°, M at the mid latitude: 111.1318 m. The tangent-plane projection
  // differs from the arc by ~d³/(6R²) ≈ 1e-8 m.
  const double arc = MeridionalRadius(Radians(45.0005)) * Radians(0.001);
  EXPECT_NEAR(p.y(), arc, 1e-4);
  // Published value: one degree of latitude at 45° is 111.132 km.
  EXPECT_NEAR(p.y(), 111.132, 0.01);
  EXPECT_NEAR(p.x(), 0.0, 1e-9);
  // The ellipsoid curves away below the tangent plane by ~d²/(2R) ≈ 1 mm.
  EXPECT_LT(p.z(), -0.5e-3);
  EXPECT_GT(p.z(), -1.5e-3);
}

TEST(EnuTest, EastOffsetMatchesParallelArc) {
  const GeodeticPoint origin{45.0, 10.0, 0.0};
  const LocalEnu enu(origin);
  const Eigen::Vector3d p = enu.ToEnu({45.0, 10.001, 0.0});
  // Arc of the parallel: N(φ) cos φ Δλ = 78.8466 m.
  EXPECT_NEAR(p.x(), PrimeVerticalRadius(Radians(45.0)) * std::cos(Radians(45.0)) * Radians(0.001),
              1e-4);
  EXPECT_NEAR(p.y(), 0.0, 1e-3);  // the parallel bends towards the pole by ~d² tan φ / 2R
}

TEST(EnuTest, AltitudeOffsetMapsToUp) {
  const LocalEnu enu(kTifton);
  const Eigen::Vector3d p = enu.ToEnu({kTifton.lat_deg, kTifton.lon_deg, kTifton.alt_m + 12.5});
  EXPECT_LT((p - Eigen::Vector3d(0.0, 0.0, 12.5)).norm(), 1e-9);
}

TEST(EnuTest, MatchesIndependentEcefConversion) {
  const LocalEnu enu(kTifton);
  for (const GeodeticPoint& p :
       {GeodeticPoint{31.5000, -83.5000, 95.0}, GeodeticPoint{31.4400, -83.6000, 130.0},
        GeodeticPoint{31.4751, -83.5299, 110.5}}) {
    EXPECT_LT((enu.ToEnu(p) - EnuFromEcef(kTifton, p)).norm(), 1e-6);
  }
}

TEST(EnuTest, RoundTrips) {
  const LocalEnu enu(kTifton);
  for (int i = -2; i <= 2; ++i) {
    for (int j = -2; j <= 2; ++j) {
      for (const double alt : {-20.0, 110.0, 400.0}) {
        const GeodeticPoint p{kTifton.lat_deg + 0.025 * i, kTifton.lon_deg + 0.025 * j, alt};
        const GeodeticPoint back = enu.ToGeodetic(enu.ToEnu(p));
        EXPECT_NEAR(back.lat_deg, p.lat_deg, 1e-9);
        EXPECT_NEAR(back.lon_deg, p.lon_deg, 1e-9);
        EXPECT_NEAR(back.alt_m, p.alt_m, 1e-6);
      }
    }
  }
  const Eigen::Vector3d x(-1234.5, 678.9, 3.2);
  EXPECT_LT((enu.ToEnu(enu.ToGeodetic(x)) - x).norm(), 1e-8);
}

TEST(EnuTest, CopiesAreIndependent) {
  const LocalEnu a(kTifton);
  LocalEnu b(GeodeticPoint{-33.87, 151.21, 0.0});
  const LocalEnu c(a);
  b = a;
  const GeodeticPoint p{31.48, -83.52, 100.0};
  EXPECT_EQ(b.ToEnu(p), a.ToEnu(p));
  EXPECT_EQ(c.ToEnu(p), a.ToEnu(p));
  EXPECT_EQ(b.origin().lat_deg, kTifton.lat_deg);
}

TEST(EnuTest, InvalidOriginThrows) {
  EXPECT_THROW(LocalEnu(GeodeticPoint{91.0, 0.0, 0.0}), InputError);
  EXPECT_THROW(LocalEnu(GeodeticPoint{std::numeric_limits<double>::quiet_NaN(), 0.0, 0.0}),
               InputError);
}

TEST(EnuTest, UtmEpsgCodesOfKnownPlaces) {
  EXPECT_EQ(UtmEpsgCode({31.47, -83.53, 0.0}), 32617);     // Tifton, Georgia: zone 17N
  EXPECT_EQ(UtmEpsgCode({-33.87, 151.21, 0.0}), 32756);    // Sydney: zone 56S
  EXPECT_EQ(UtmEpsgCode({51.5074, -0.1278, 0.0}), 32630);  // London: zone 30N
  EXPECT_EQ(UtmEpsgCode({40.0, -88.2, 0.0}), 32616);       // Champaign, Illinois: zone 16N
  EXPECT_EQ(UtmEpsgCode({60.39, 5.32, 0.0}), 32632);       // Bergen: Norway exception, 32 not 31
  EXPECT_EQ(UtmEpsgCode({78.22, 15.65, 0.0}), 32633);      // Longyearbyen: Svalbard exception
  EXPECT_EQ(UtmEpsgCode({-0.5, 36.8, 0.0}), 32737);        // just south of the equator, Kenya
  EXPECT_THROW(UtmEpsgCode({-95.0, 0.0, 0.0}), InputError);
}

// Meridian arc length from the equator to latitude φ, ∫ M dφ by Simpson's rule.
double MeridianArc(double lat_rad) {
  constexpr int kIntervals = 2000;  // even
  const double h = lat_rad / kIntervals;
  double sum = MeridionalRadius(0.0) + MeridionalRadius(lat_rad);
  for (int i = 1; i < kIntervals; ++i) sum += (i % 2 ? 4.0 : 2.0) * MeridionalRadius(i * h);
  return sum * h / 3.0;
}

TEST(EnuTest, UtmOnTheCentralMeridianIsScaledMeridianArc) {
  // Zone 17: central meridian 81° W. On it, easting = 500 km and northing = 0.9996 × the
  // meridian arc (the transverse Mercator's scale on its central meridian).
  const Eigen::Vector2d at_45 = UtmFromGeodetic({45.0, -81.0, 0.0}, 32617);
  EXPECT_NEAR(at_45.x(), 500000.0, 1e-6);
  EXPECT_NEAR(at_45.y(), 0.9996 * MeridianArc(Radians(45.0)), 1e-3);
  const Eigen::Vector2d equator = UtmFromGeodetic({0.0, -81.0, 0.0}, 32617);
  EXPECT_NEAR(equator.x(), 500000.0, 1e-6);
  EXPECT_NEAR(equator.y(), 0.0, 1e-6);
  // Southern zones add a false northing of 10000 km.
  const Eigen::Vector2d south = UtmFromGeodetic({-30.0, -81.0, 0.0}, 32717);
  EXPECT_NEAR(south.y(), 10'000'000.0 - 0.9996 * MeridianArc(Radians(30.0)), 1e-3);
}

TEST(EnuTest, UtmEastingNearTheCentralMeridianIsScaledParallelArc) {
  // 0.001° east of the central meridian: easting − 500 km = 0.9996 N cos φ Δλ up to terms of
  // third order in Δλ (micrometres here).
  const double lat = 31.47;
  const Eigen::Vector2d p = UtmFromGeodetic({lat, -81.0 + 0.001, 0.0}, 32617);
  const double expected =
      0.9996 * PrimeVerticalRadius(Radians(lat)) * std::cos(Radians(lat)) * Radians(0.001);
  EXPECT_NEAR(p.x() - 500000.0, expected, 1e-4);
}

TEST(EnuTest, UtmRoundTripsAndKeepsTheRequestedZone) {
  // Tifton is in zone 17; a point just inside zone 18 still projects into zone 17 on request
  // (easting beyond the zone's usual range), and back.
  for (const GeodeticPoint& p :
       {kTifton, GeodeticPoint{31.47, -77.9, 0.0}, GeodeticPoint{0.2, -81.5, 0.0}}) {
    const Eigen::Vector2d utm = UtmFromGeodetic(p, 32617);
    const GeodeticPoint back = GeodeticFromUtm(utm, 12.5, 32617);
    EXPECT_NEAR(back.lat_deg, p.lat_deg, 1e-10);
    EXPECT_NEAR(back.lon_deg, p.lon_deg, 1e-10);
    EXPECT_EQ(back.alt_m, 12.5);
  }
  // The zone border (78° W) lies near easting 785 km at this latitude.
  EXPECT_GT(UtmFromGeodetic({31.47, -77.9, 0.0}, 32617).x(), 790000.0);
  // The standard zone's projection agrees with the code of UtmEpsgCode.
  const GeodeticPoint sydney{-33.87, 151.21, 0.0};
  const Eigen::Vector2d utm = UtmFromGeodetic(sydney, UtmEpsgCode(sydney));
  EXPECT_NEAR(utm.x(), 334000.0, 2000.0);  // zone 56S: central meridian 153° E
  EXPECT_NEAR(utm.y(), 6250000.0, 10000.0);
}

TEST(EnuTest, UtmRejectsCodesThatAreNotUtmZones) {
  EXPECT_TRUE(IsUtmEpsgCode(32617));
  EXPECT_TRUE(IsUtmEpsgCode(32760));
  EXPECT_FALSE(IsUtmEpsgCode(32600));
  EXPECT_FALSE(IsUtmEpsgCode(32661));
  EXPECT_FALSE(IsUtmEpsgCode(4326));
  EXPECT_THROW(UtmFromGeodetic(kTifton, 4326), InputError);
  EXPECT_THROW(GeodeticFromUtm({500000.0, 0.0}, 0.0, 32700), InputError);
  EXPECT_THROW(GeodeticFromUtm({std::numeric_limits<double>::quiet_NaN(), 0.0}, 0.0, 32617),
               InputError);
}

}  // namespace
}  // namespace crop4d::geometry
