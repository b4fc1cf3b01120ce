#include "crop4d/analysis/sites.h"

#include <fmt/format.h>

#include <cmath>
#include <set>

#include "crop4d/core/error.h"
#include "crop4d/io/csv.h"

namespace crop4d::analysis {

std::vector<io::Site> ReadSitesCsv(const std::string& path, const geometry::GeodeticPoint& origin) {
  io::CsvReader reader(path);
  io::CsvRecord rec;
  std::vector<std::string> header;
  std::vector<io::Site> sites;
  std::set<std::string> ids;
  const geometry::LocalEnu enu(origin);
  bool geodetic = false;
  while (reader.Next(&rec)) {
    if (header.empty()) {
      for (std::string_view f : rec.fields) header.emplace_back(f);
      if (header == std::vector<std::string>{"site_id", "lat", "lon", "radius_m"}) {
        geodetic = true;
      } else if (header != std::vector<std::string>{"site_id", "x", "y", "radius_m"}) {
        throw InputError(path, rec.line,
                         "expected the header site_id,x,y,radius_m (ENU metres) or "
                         "site_id,lat,lon,radius_m (WGS84 degrees)");
      }
      continue;
    }
    if (rec.fields.size() != 4) {
      throw InputError(path, rec.line,
                       fmt::format("expected 4 fields, found {}", rec.fields.size()));
    }
    io::Site site;
    site.id = std::string(rec.fields[0]);
    if (site.id.empty() || site.id.find_first_of(" \t\",") != std::string::npos) {
      throw InputError(path, rec.line, "a site id is one word, not '" + site.id + "'");
    }
    if (!ids.insert(site.id).second) {
      throw InputError(path, rec.line, "site '" + site.id + "' appears twice");
    }
    double a = 0, b = 0;
    if (!io::ParseDouble(rec.fields[1], &a) || !io::ParseDouble(rec.fields[2], &b) ||
        !io::ParseDouble(rec.fields[3], &site.radius_m) || !std::isfinite(a) || !std::isfinite(b)) {
      throw InputError(path, rec.line, "expected numbers for the position and radius");
    }
    if (!(site.radius_m > 0.0 && site.radius_m < 100.0)) {
      throw InputError(path, rec.line, "the radius must be in (0, 100) metres");
    }
    if (geodetic) {
      if (std::abs(a) > 90.0 || std::abs(b) > 180.0) {
        throw InputError(path, rec.line, "latitude or longitude out of range");
      }
      site.center_enu = enu.ToEnu({a, b, origin.alt_m}).head<2>();
    } else {
      site.center_enu = {a, b};
    }
    sites.push_back(site);
  }
  if (header.empty()) throw InputError(path, 0, "empty sites file");
  return sites;
}

Eigen::AlignedBox2d AnalysedArea(const io::FieldInfo& info, const std::vector<io::Site>& sites,
                                 double margin) {
  Eigen::AlignedBox2d box;
  for (const io::RowDeclaration& r : info.rows) {
    box.extend(r.start_enu);
    box.extend(r.end_enu);
  }
  for (const io::Site& s : sites) {
    box.extend(s.center_enu - Eigen::Vector2d::Constant(s.radius_m));
    box.extend(s.center_enu + Eigen::Vector2d::Constant(s.radius_m));
  }
  box.extend(box.min() - Eigen::Vector2d::Constant(margin));
  box.extend(box.max() + Eigen::Vector2d::Constant(margin));
  return box;
}

}  // namespace crop4d::analysis
