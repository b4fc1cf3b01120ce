#pragma once

// The analysis reads a session's cloud a tile of the analysed area at a time (analysis/
// area_tiles.h, io/ply_strips.h), so that no session's cloud is ever held whole: its memory
// follows a tile (the field's width × analyze.tile_m), not the session.
//
// A session's tiles are read three times (and the file once more each time it is opened, to
// index it). The survey reads every tile to find the lone points of a dense cloud
// (analysis/lone_points.h) and to count the colours of the others, which give the session's
// vegetation threshold (analysis/vegetation.h); what it keeps is the lone points' indices in the
// file (a fraction of a percent of the points) and the threshold. The two passes of the stage
// then read the tiles again, with the lone points left out and the vegetation classified as the
// whole cloud would have them.

#include <Eigen/Geometry>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/analysis/area_tiles.h"
#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/io/ply_strips.h"

namespace crop4d::pipeline {

// A session to analyse: its id, date and cloud.
struct SessionInput {
  std::string id;
  Timestamp date = 0;
  std::filesystem::path cloud;
  bool dense = false;
};

// What the survey of a session found.
struct SessionSurvey {
  std::vector<std::uint64_t> lone;  // the lone points' indices in the file, increasing
  io::PlyStripIndex index;          // where the file's slices lie: the second opening reads it
  std::size_t points = 0;           // in the area, lone points left out
  // The threshold and num_vegetation (of those points); no flags.
  analysis::VegetationClassification vegetation;
};

// A tile's points, lone points left out, classified; their indices in the file and whether the
// tile owns them (the others lie in its reach).
struct TileCloud {
  analysis::SessionCloud cloud;
  std::vector<std::uint64_t> index;
  std::vector<std::uint8_t> owned;
  // The points the tile owns (those of no other tile).
  analysis::SessionCloud Owned() const;
};

class SessionTiles {
 public:
  // Opens the session's cloud for `tiling` of `area` (the points outside the area are never
  // read), indexing it unless `survey` (of an earlier opening) holds its index. Throws
  // InputError when it cannot be read or has no colours.
  SessionTiles(const SessionInput& input, const Eigen::AlignedBox2d& area,
               const analysis::AreaTiling& tiling, const SessionSurvey* survey = nullptr);

  std::size_t num_tiles() const { return tiling_.tiles.size(); }
  const analysis::AreaTile& tile(std::size_t t) const { return tiling_.tiles[t]; }
  int axis() const { return tiling_.axis; }

  // Reads every tile: the lone points of a dense cloud (no other point within
  // lone_radius_m; none when 0 or for a sparse cloud) and the vegetation threshold of the others.
  SessionSurvey Survey(double lone_radius_m, const analysis::VegetationOptions& vegetation);
  // Tile t with the survey applied: with its reach (the points within the tiling's reach around
  // it too), or only the points it owns.
  TileCloud Read(std::size_t t, const SessionSurvey& survey,
                 const analysis::VegetationOptions& vegetation, bool with_reach);
  // Vertices read over those of the file, the opening's indexing read included.
  double read_fraction() const { return (indexed_ ? 1.0 : 0.0) + reader_->read_fraction(); }

 private:
  SessionInput input_;
  analysis::AreaTiling tiling_;
  std::unique_ptr<io::PlyStripReader> reader_;
  bool indexed_ = true;  // the opening read the file to index it
};

}  // namespace crop4d::pipeline
