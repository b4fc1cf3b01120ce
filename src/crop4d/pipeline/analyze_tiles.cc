#include "crop4d/pipeline/analyze_tiles.h"

#include <algorithm>

#include "crop4d/analysis/lone_points.h"
#include "crop4d/core/error.h"

namespace crop4d::pipeline {

analysis::SessionCloud TileCloud::Owned() const {
  std::vector<std::size_t> positions;
  for (std::size_t i = 0; i < owned.size(); ++i) {
    if (owned[i]) positions.push_back(i);
  }
  return cloud.Take(positions);
}

SessionTiles::SessionTiles(const SessionInput& input, const Eigen::AlignedBox2d& area,
                           const analysis::AreaTiling& tiling, const SessionSurvey* survey)
    : input_(input), tiling_(tiling) {
  CROP4D_CHECK(!tiling_.tiles.empty());
  const io::PlyStripIndex* index =
      survey != nullptr && !survey->index.ranges.empty() ? &survey->index : nullptr;
  reader_ = std::make_unique<io::PlyStripReader>(
      input_.cloud.string(), tiling_.axis,
      [area](const Eigen::Vector3d& p) { return p.allFinite() && area.contains(p.head<2>()); },
      std::size_t{1} << 16, index);
  indexed_ = index == nullptr;
  if (!reader_->layout().colors) {
    throw InputError(input_.cloud.string(), 0,
                     "the cloud has no colours: vegetation is found by colour (red, green, blue "
                     "vertex properties)");
  }
}

SessionSurvey SessionTiles::Survey(double lone_radius_m,
                                   const analysis::VegetationOptions& vegetation) {
  SessionSurvey survey;
  analysis::ColourHistogram colours;
  const bool find_lone = input_.dense && lone_radius_m > 0.0;
  for (const analysis::AreaTile& tile : tiling_.tiles) {
    std::vector<std::uint64_t> index;
    const io::PlyPointCloud part = find_lone ? reader_->Read(tile.read_lo, tile.read_hi, &index)
                                             : reader_->Read(tile.lo, tile.hi, &index);
    std::vector<std::uint8_t> lone;
    if (find_lone) lone = analysis::FindLonePoints(part.points, lone_radius_m);
    for (std::size_t i = 0; i < part.size(); ++i) {
      if (!tile.Owns(part.points[i][tiling_.axis])) continue;
      if (find_lone && lone[i]) {
        survey.lone.push_back(index[i]);
      } else {
        colours.Add(part.colors[i]);
      }
    }
  }
  std::sort(survey.lone.begin(), survey.lone.end());
  survey.index = reader_->index();
  survey.points = colours.total();
  survey.vegetation = analysis::VegetationThreshold(colours, vegetation);
  return survey;
}

TileCloud SessionTiles::Read(std::size_t t, const SessionSurvey& survey,
                             const analysis::VegetationOptions& vegetation, bool with_reach) {
  const analysis::AreaTile& tile = tiling_.tiles.at(t);
  std::vector<std::uint64_t> index;
  const io::PlyPointCloud part = with_reach ? reader_->Read(tile.read_lo, tile.read_hi, &index)
                                            : reader_->Read(tile.lo, tile.hi, &index);
  TileCloud out;
  out.cloud.session = input_.id;
  for (std::size_t i = 0; i < part.size(); ++i) {
    const bool owned = tile.Owns(part.points[i][tiling_.axis]);
    if (!with_reach && !owned) continue;
    if (std::binary_search(survey.lone.begin(), survey.lone.end(), index[i])) continue;
    out.cloud.points.push_back(part.points[i]);
    out.cloud.colors.push_back(part.colors[i]);
    out.cloud.is_vegetation.push_back(
        analysis::IsVegetationColour(survey.vegetation, vegetation.index, part.colors[i]) ? 1 : 0);
    out.index.push_back(index[i]);
    out.owned.push_back(owned ? 1 : 0);
  }
  return out;
}

}  // namespace crop4d::pipeline
