#pragma once

// The measurement sites of a field: read from a sites file (the alternative to the sites of
// field.yaml), and the area the analysis covers around them.

#include <Eigen/Geometry>
#include <string>
#include <vector>

#include "crop4d/geometry/enu.h"
#include "crop4d/io/dataset.h"

namespace crop4d::analysis {

// Reads a sites file: CSV with the header site_id,x,y,radius_m (ENU metres) or
// site_id,lat,lon,radius_m (WGS84 degrees, converted with the field's `origin`). Throws
// InputError naming the file and line for anything malformed (a site id that is not one word,
// a repeated site, a radius outside (0, 100) m, coordinates out of range, an empty file).
std::vector<io::Site> ReadSitesCsv(const std::string& path, const geometry::GeodeticPoint& origin);

// The area analysed: the rows of the field and the sites' discs, widened by `margin` metres.
Eigen::AlignedBox2d AnalysedArea(const io::FieldInfo& info, const std::vector<io::Site>& sites,
                                 double margin);

}  // namespace crop4d::analysis
