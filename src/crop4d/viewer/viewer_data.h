#pragma once

// The data of the 4D viewer (docs/viewer.md), written from a workspace into a folder of its own
// (WS/viewer by `crop4d view`, DIR/ws/viewer by `crop4d export --viewer`):
//
//   scene.json                 sessions (id, date, cloud, trajectory), sites (position, canopy
//                              height per date, growth fit), the height grids, the report link
//   grids.bin                  float32 layers on one ENU grid: "terrain", then "top:<session>"
//   clouds/<session>/index.json   the session's octree (octree.h): nodes, cubes, counts, and the
//                                 fingerprint of the cloud it was built from
//   clouds/<session>/<node>.bin   one tile per node (octree.h)
//   clouds/<session>/low.f32, top.f32   the session's 10th and 95th percentile height per cell
//
// The cloud of a session is WS/dense/<session>.ply, or WS/fused/<session>/sparse.ply when it has
// no dense cloud. Its tiles are rebuilt only when the cloud's fingerprint (path, size,
// modification time, tile options) changed; a session's tiles are written into a temporary
// folder and renamed into place, so a reader never sees half a session.
//
// Terrain: the 10th percentile height per cell of the earliest session (plants are smallest
// then), holes filled from their neighbours; with the field folder (ViewerDataOptions::field),
// the analysis terrain model WS/analysis/dtm.tif instead where it has data (it is in the
// field's UTM zone: the field's origin places it in the ENU frame). Tops: the 95th percentile
// per cell of each session; the viewer colours the change between two dates by the difference
// of their tops.
//
// Sites: at the centres declared in FIELD/field.yaml when the field is given, else at the mean
// position of the plants found in them (WS/analysis/site_plants.csv).

#include <cstddef>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/viewer/octree.h"

namespace crop4d::viewer {

struct ViewerDataOptions {
  OctreeOptions octree;
  // Side of a cell of the terrain and top grids, metres.
  double grid_cell_m = 0.1;
  // The grid's cell side grows beyond grid_cell_m when the field would need more cells.
  std::size_t max_grid_cells = 4'000'000;
  // At most this many trajectory points per session in scene.json (evenly subsampled).
  int max_trajectory_points = 2000;
  // The field folder (optional): its origin places analysis/dtm.tif, its sites their markers.
  std::string field;

  OptionCheck Check() const;
};

struct ViewerDataSummary {
  struct Session {
    std::string id, date, source;
    std::size_t points = 0;
    std::size_t nodes = 0;
    bool rebuilt = false;  // false: the tiles of an earlier run were up to date
  };
  std::vector<Session> sessions;
  std::size_t sites = 0;
  // Where the terrain comes from: "analysis/dtm.tif" or "the earliest cloud".
  std::string terrain_source;
};

// Writes the viewer data of `workspace` into `out`. Throws InputError naming the workspace when
// it has no cloud at all, or naming a file that cannot be read.
ViewerDataSummary WriteViewerData(const std::string& workspace, const std::string& out,
                                  const ViewerDataOptions& options = {});

}  // namespace crop4d::viewer
