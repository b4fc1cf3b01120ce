#pragma once

// The analyze stage's rasters in WS/analysis/ (Cloud-Optimized GeoTIFFs, io/geotiff.h), each
// with the description and metadata a GIS shows:
//
//   dtm.tif                          the terrain, WGS84 ellipsoidal height [m]
//   chm_<session>.tif                canopy height above the terrain [m]
//   chm_change_<earlier>_<later>.tif chm(later) − chm(earlier) [m] with both sessions and dates,
//                                    and a note naming a degraded (untrusted) session
//
// Read back with io::ReadGeoTiff.

#include <string>
#include <vector>

#include "crop4d/analysis/site_series.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::workspace {

void WriteDtm(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
              const std::vector<float>& heights);
void WriteChm(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
              const analysis::SeasonSession& session, const std::vector<float>& chm);
void WriteChmChange(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
                    const analysis::SeasonSession& earlier, const analysis::SeasonSession& later,
                    const std::vector<float>& change);

}  // namespace crop4d::workspace
