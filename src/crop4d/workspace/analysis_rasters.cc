#include "crop4d/workspace/analysis_rasters.h"

#include <fmt/format.h>

#include "crop4d/core/timestamp.h"

namespace crop4d::workspace {

void WriteDtm(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
              const std::vector<float>& heights) {
  io::GeoTiffWriteOptions options;
  options.description = "terrain, WGS84 ellipsoidal height [m]";
  options.metadata = {{"field", field_name}, {"product", "dtm"}};
  io::WriteGeoTiff(ws.Dtm().string(), grid, heights, options);
}

void WriteChm(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
              const analysis::SeasonSession& session, const std::vector<float>& chm) {
  io::GeoTiffWriteOptions options;
  options.description = "canopy height above the terrain [m]";
  options.metadata = {{"field", field_name},
                      {"product", "chm"},
                      {"session", session.id},
                      {"date", FormatDate(session.date)}};
  io::WriteGeoTiff(ws.Chm(session.id).string(), grid, chm, options);
}

void WriteChmChange(const Layout& ws, const std::string& field_name, const io::UtmGrid& grid,
                    const analysis::SeasonSession& earlier, const analysis::SeasonSession& later,
                    const std::vector<float>& change) {
  io::GeoTiffWriteOptions options;
  options.description =
      fmt::format("canopy height change [m] from {} to {} (chm {} - chm {})",
                  FormatDate(earlier.date), FormatDate(later.date), later.id, earlier.id);
  options.metadata = {
      {"field", field_name},
      {"product", "chm_change"},
      {"earlier_session", earlier.id},
      {"earlier_date", FormatDate(earlier.date)},
      {"later_session", later.id},
      {"later_date", FormatDate(later.date)},
      {"days", fmt::format("{:g}", DurationSeconds(earlier.date, later.date) / 86400.0)}};
  for (const analysis::SeasonSession* s : {&earlier, &later}) {
    if (!s->trusted) {
      options.metadata["note"] +=
          (options.metadata["note"].empty() ? "" : "; ") + s->id + " is degraded (season quality)";
    }
  }
  io::WriteGeoTiff(ws.ChmChange(earlier.id, later.id).string(), grid, change, options);
}

}  // namespace crop4d::workspace
