#include "crop4d/viewer/viewer_data.h"

#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <limits>
#include <map>
#include <nlohmann/json.hpp>
#include <set>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/csv.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/geotiff.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/tum.h"
#include "crop4d/workspace/analysis_tables.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::viewer {
namespace {

namespace fs = std::filesystem;
using json = nlohmann::json;

constexpr int kDataFormat = 1;
constexpr float kLowQuantile = 0.10f, kTopQuantile = 0.95f;

std::string ReadFile(const fs::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw InputError(path.string(), 0, "cannot be read");
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// The cells of a lattice of `cell` metres: cell (i, j) covers [i·cell, (i+1)·cell) × ....
struct SessionGrid {
  std::int64_t ix0 = 0, iy0 = 0;
  int nx = 0, ny = 0;
  std::vector<float> low, top;  // row-major, y outer; NaN where no point fell
};

SessionGrid HeightQuantiles(const std::vector<Eigen::Vector3d>& points, double cell) {
  SessionGrid grid;
  std::int64_t x0 = std::numeric_limits<std::int64_t>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const Eigen::Vector3d& p : points) {
    const std::int64_t i = std::int64_t(std::floor(p.x() / cell));
    const std::int64_t j = std::int64_t(std::floor(p.y() / cell));
    x0 = std::min(x0, i), x1 = std::max(x1, i), y0 = std::min(y0, j), y1 = std::max(y1, j);
  }
  grid.ix0 = x0, grid.iy0 = y0, grid.nx = int(x1 - x0 + 1), grid.ny = int(y1 - y0 + 1);
  const std::size_t cells = std::size_t(grid.nx) * std::size_t(grid.ny);
  std::vector<std::pair<std::uint32_t, float>> heights(points.size());
  for (std::size_t k = 0; k < points.size(); ++k) {
    const std::int64_t i = std::int64_t(std::floor(points[k].x() / cell)) - x0;
    const std::int64_t j = std::int64_t(std::floor(points[k].y() / cell)) - y0;
    heights[k] = {std::uint32_t(j * grid.nx + i), float(points[k].z())};
  }
  std::sort(heights.begin(), heights.end());
  grid.low.assign(cells, std::numeric_limits<float>::quiet_NaN());
  grid.top = grid.low;
  for (std::size_t a = 0; a < heights.size();) {
    std::size_t b = a;
    while (b < heights.size() && heights[b].first == heights[a].first) ++b;
    const std::size_t n = b - a;
    grid.low[heights[a].first] = heights[a + std::size_t(kLowQuantile * float(n - 1))].second;
    grid.top[heights[a].first] = heights[a + std::size_t(kTopQuantile * float(n - 1))].second;
    a = b;
  }
  return grid;
}

std::string FloatBytes(const std::vector<float>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()), values.size() * sizeof(float));
}

std::vector<float> Floats(const std::string& bytes, std::size_t count, const fs::path& path) {
  if (bytes.size() != count * sizeof(float))
    throw InputError(path.string(), 0, "grid has the wrong size (a stale viewer cache?)");
  std::vector<float> values(count);
  std::memcpy(values.data(), bytes.data(), bytes.size());
  return values;
}

std::string Fingerprint(const fs::path& cloud, const ViewerDataOptions& options) {
  Fnv1aHasher hasher;
  hasher.AddString(cloud.string());
  hasher.Add<std::uint64_t>(fs::file_size(cloud));
  hasher.Add<std::int64_t>(fs::last_write_time(cloud).time_since_epoch().count());
  hasher.Add(kDataFormat);
  hasher.Add(options.octree.max_points_per_node);
  hasher.Add(options.octree.grid_cells);
  hasher.Add(options.octree.max_depth);
  hasher.Add(options.grid_cell_m);
  return std::to_string(hasher.hash());
}

// Builds (or keeps) the tiles of one session in out/clouds/<id>; returns its index.json.
json BuildSession(const fs::path& cloud_path, const fs::path& folder,
                  const ViewerDataOptions& options, bool* rebuilt) {
  const std::string fingerprint = Fingerprint(cloud_path, options);
  const fs::path index_path = folder / "index.json";
  if (fs::is_regular_file(index_path)) {
    try {
      json index = json::parse(ReadFile(index_path));
      if (index.value("fingerprint", "") == fingerprint) {
        *rebuilt = false;
        return index;
      }
    } catch (const json::exception&) {
      // A damaged index: rebuilt below.
    }
  }
  *rebuilt = true;
  // Read a slice at a time, keeping the finite points only: the file is never held beside them.
  io::PlyPointCloud cloud =
      io::ReadPlyWhere(cloud_path.string(), [](const Eigen::Vector3d& p) { return p.allFinite(); });
  const std::vector<Eigen::Vector3d> points = std::move(cloud.points);
  const std::vector<std::array<std::uint8_t, 3>> colors = std::move(cloud.colors);
  cloud = io::PlyPointCloud();
  if (points.empty()) throw InputError(cloud_path.string(), 0, "the cloud has no finite point");
  const Octree tree = BuildOctree(points, options.octree);
  const fs::path tmp = folder.string() + ".tmp." + std::to_string(::getpid());
  fs::remove_all(tmp);
  fs::create_directories(tmp);
  json nodes = json::array();
  for (const OctreeNode& node : tree.nodes) {
    io::WriteFileAtomic((tmp / (node.name + ".bin")).string(), EncodeTile(node, points, colors));
    nodes.push_back({{"name", node.name},
                     {"min", {node.min.x(), node.min.y(), node.min.z()}},
                     {"side", node.side},
                     {"count", node.points.size()},
                     {"children", node.child_mask}});
  }
  const SessionGrid grid = HeightQuantiles(points, options.grid_cell_m);
  io::WriteFileAtomic((tmp / "low.f32").string(), FloatBytes(grid.low));
  io::WriteFileAtomic((tmp / "top.f32").string(), FloatBytes(grid.top));
  json index = {{"format", kDataFormat},
                {"fingerprint", fingerprint},
                {"points", points.size()},
                {"grid",
                 {{"ix0", grid.ix0},
                  {"iy0", grid.iy0},
                  {"nx", grid.nx},
                  {"ny", grid.ny},
                  {"cell", options.grid_cell_m}}},
                {"nodes", nodes}};
  io::WriteFileAtomic((tmp / "index.json").string(), index.dump());
  fs::remove_all(folder);
  fs::create_directories(folder.parent_path());
  fs::rename(tmp, folder);
  return index;
}

// The session's fused trajectory, else the poses of its row passes in the order of their names.
json Trajectory(const workspace::Layout& ws, const std::string& id, int max_points) {
  std::vector<Eigen::Vector3d> positions;
  const fs::path fused = ws.FusedPoses(id);
  if (fs::is_regular_file(fused)) {
    for (const io::StampedPose& p : io::ReadTum(fused.string()))
      positions.push_back(p.pose.translation());
  } else if (fs::is_directory(ws.RowsDir(id))) {
    std::set<fs::path> rows;
    for (const std::string& pass : ws.PassFolders(id))
      if (fs::is_regular_file(ws.PassPoses(id, pass))) rows.insert(ws.PassPoses(id, pass));
    for (const fs::path& row : rows)
      for (const io::StampedPose& p : io::ReadTum(row.string()))
        positions.push_back(p.pose.translation());
  }
  json out = json::array();
  const std::size_t step =
      std::max<std::size_t>(1, (positions.size() + max_points - 1) / max_points);
  for (std::size_t i = 0; i < positions.size(); i += step) {
    const Eigen::Vector3d& p = positions[i];
    out.push_back({std::round(p.x() * 1000) / 1000, std::round(p.y() * 1000) / 1000,
                   std::round(p.z() * 1000) / 1000});
  }
  return out;
}

// Sites: position from the plants found in them (site_plants.csv), canopy height per date
// (site_heights.csv), growth fit (growth.csv); each table only when the analysis wrote it.
json Sites(const workspace::Layout& ws, const std::vector<io::Site>& declared) {
  std::map<std::string, json> sites;
  std::map<std::string, std::pair<Eigen::Vector2d, int>> sums;
  if (fs::is_regular_file(ws.SitePlants())) {
    for (const workspace::SitePlantRow& p : workspace::ReadSitePlants(ws.SitePlants())) {
      auto& s = sums[p.site_id];
      if (s.second == 0) s.first.setZero();
      s.first += Eigen::Vector2d(p.x_m, p.y_m);
      ++s.second;
    }
  }
  for (const auto& [id, s] : sums) {
    const Eigen::Vector2d c = s.first / s.second;
    sites[id] = {{"id", id}, {"x", c.x()}, {"y", c.y()}, {"heights", json::object()}};
  }
  for (const io::Site& site : declared) {
    sites[site.id] = {{"id", site.id},
                      {"x", site.center_enu.x()},
                      {"y", site.center_enu.y()},
                      {"radius", site.radius_m},
                      {"heights", json::object()}};
  }
  if (fs::is_regular_file(ws.SiteHeights())) {
    for (const workspace::SiteHeight& h : workspace::ReadSiteHeights(ws.SiteHeights())) {
      if (sites.count(h.site_id) && std::isfinite(h.height_m)) {
        sites[h.site_id]["heights"][h.date] = h.height_m;
      }
    }
  }
  if (fs::is_regular_file(ws.Growth())) {
    for (const workspace::GrowthRow& g : workspace::ReadGrowth(ws.Growth()).rows) {
      if (!sites.count(g.site_id) || g.status != "fitted") continue;
      sites[g.site_id]["growth"] = {{"asymptote_m", g.asymptote_m},
                                    {"rate_per_day", g.rate_per_day},
                                    {"midpoint_date", g.midpoint_date}};
    }
  }
  json out = json::array();
  for (auto& [id, site] : sites) out.push_back(site);
  return out;
}

// Session id → date, from the analysis tables; a session without one is dated by its id.
std::map<std::string, std::string> SessionDates(const workspace::Layout& ws) {
  std::map<std::string, std::string> dates;
  if (!fs::is_regular_file(ws.SiteHeights())) return dates;
  for (const workspace::SiteHeight& h : workspace::ReadSiteHeights(ws.SiteHeights())) {
    if (!h.date.empty()) dates[h.session] = h.date;
  }
  return dates;
}

// The clouds to show, by session: the dense cloud, else the fused sparse cloud. Throws when
// there is none.
std::map<std::string, fs::path> SessionClouds(const workspace::Layout& layout) {
  std::map<std::string, fs::path> clouds;
  for (const std::string& id : layout.FusedSessionFolders()) {
    if (fs::is_regular_file(layout.FusedSparse(id))) clouds[id] = layout.FusedSparse(id);
  }
  // A dense cloud replaces the session's sparse one.
  for (const std::string& id : layout.DenseCloudSessions()) clouds[id] = layout.DenseCloud(id);
  if (clouds.empty())
    throw InputError(layout.root().string(), 0,
                     "no cloud to show: neither dense/<session>.ply nor fused/<session>/sparse.ply "
                     "(run crop4d densify or crop4d fuse first)");
  return clouds;
}

// A session's octree (its index.json) and where it comes from.
struct Entry {
  std::string id, date;
  fs::path cloud;
  json index;
};

// One grid over every session's cells (lattice of `cell` metres from (x0, y0) · cell), its
// cells grouped by `factor` into gx × gy when the field needs more than max_grid_cells.
struct SharedGrid {
  std::int64_t x0 = 0, y0 = 0;
  double cell = 0.0;
  int factor = 1, gx = 0, gy = 0;
};

SharedGrid CommonGrid(const std::vector<Entry>& entries, const ViewerDataOptions& options) {
  std::int64_t x0 = std::numeric_limits<std::int64_t>::max(), y0 = x0, x1 = -x0, y1 = -x0;
  for (const Entry& e : entries) {
    const json& g = e.index["grid"];
    x0 = std::min(x0, g["ix0"].get<std::int64_t>());
    y0 = std::min(y0, g["iy0"].get<std::int64_t>());
    x1 = std::max(x1, g["ix0"].get<std::int64_t>() + g["nx"].get<std::int64_t>() - 1);
    y1 = std::max(y1, g["iy0"].get<std::int64_t>() + g["ny"].get<std::int64_t>() - 1);
  }
  SharedGrid grid;
  grid.x0 = x0, grid.y0 = y0, grid.cell = options.grid_cell_m;
  const int nx = int(x1 - x0 + 1), ny = int(y1 - y0 + 1);
  while (std::size_t((nx + grid.factor - 1) / grid.factor) *
             std::size_t((ny + grid.factor - 1) / grid.factor) >
         options.max_grid_cells)
    ++grid.factor;
  grid.gx = (nx + grid.factor - 1) / grid.factor, grid.gy = (ny + grid.factor - 1) / grid.factor;
  return grid;
}

// A session's grid layer (`file` of its octree folder) on the shared grid: per shared cell the
// lowest (`take_min`) or highest of its cells.
std::vector<float> Layer(const SharedGrid& grid, const Entry& e, const fs::path& dir,
                         const char* file, bool take_min) {
  const json& g = e.index["grid"];
  const int sx = g["nx"], sy = g["ny"];
  const fs::path path = dir / "clouds" / e.id / file;
  const std::vector<float> values = Floats(ReadFile(path), std::size_t(sx) * sy, path);
  std::vector<float> layer(std::size_t(grid.gx) * grid.gy, std::numeric_limits<float>::quiet_NaN());
  const std::int64_t ox = g["ix0"].get<std::int64_t>() - grid.x0,
                     oy = g["iy0"].get<std::int64_t>() - grid.y0;
  for (int j = 0; j < sy; ++j)
    for (int i = 0; i < sx; ++i) {
      const float v = values[std::size_t(j) * sx + i];
      if (std::isnan(v)) continue;
      float& c = layer[std::size_t((oy + j) / grid.factor) * grid.gx +
                       std::size_t((ox + i) / grid.factor)];
      c = std::isnan(c) ? v : (take_min ? std::min(c, v) : std::max(c, v));
    }
  return layer;
}

// Holes (no point of the earliest session) take the mean of their filled neighbours, pass by
// pass, so the surface is closed.
void CloseHoles(int gx, int gy, std::vector<float>* terrain) {
  for (int pass = 0; pass < gx + gy; ++pass) {
    std::vector<float> next = *terrain;
    bool hole = false;
    for (int j = 0; j < gy; ++j)
      for (int i = 0; i < gx; ++i) {
        if (!std::isnan((*terrain)[std::size_t(j) * gx + i])) continue;
        double sum = 0;
        int n = 0;
        for (int dj = -1; dj <= 1; ++dj)
          for (int di = -1; di <= 1; ++di) {
            const int a = i + di, b = j + dj;
            if (a < 0 || b < 0 || a >= gx || b >= gy) continue;
            const float v = (*terrain)[std::size_t(b) * gx + a];
            if (!std::isnan(v)) sum += v, ++n;
          }
        if (n > 0)
          next[std::size_t(j) * gx + i] = float(sum / n);
        else
          hole = true;
      }
    terrain->swap(next);
    if (!hole) break;
  }
}

// The analysis terrain model (WS/analysis/dtm.tif) where it has data, placed with the field's
// origin; returns whether any cell took it.
bool PlaceAnalysisTerrain(const SharedGrid& grid, const io::FieldInfo& field,
                          const fs::path& dtm_path, std::vector<float>* terrain) {
  const io::FieldUtm utm(field.origin);
  const io::GeoTiffRaster dtm = io::ReadGeoTiff(dtm_path.string());
  if (dtm.grid.epsg != utm.epsg())
    throw InputError(dtm_path.string(), 0,
                     "in EPSG:" + std::to_string(dtm.grid.epsg) +
                         ", the field's UTM zone is EPSG:" + std::to_string(utm.epsg()));
  const double side = grid.cell * grid.factor;
  bool placed = false;
  for (int j = 0; j < grid.gy; ++j)
    for (int i = 0; i < grid.gx; ++i) {
      float& z = (*terrain)[std::size_t(j) * grid.gx + i];
      const Eigen::Vector3d centre(double(grid.x0) * grid.cell + (i + 0.5) * side,
                                   double(grid.y0) * grid.cell + (j + 0.5) * side, z);
      const Eigen::Vector2d en = utm.UtmFromEnu(centre);
      const double col = std::floor((en.x() - dtm.grid.min_easting) / dtm.grid.cell_m);
      const double row = std::floor((dtm.grid.max_northing - en.y()) / dtm.grid.cell_m);
      if (col < 0 || row < 0 || col >= dtm.grid.width || row >= dtm.grid.height) continue;
      const float h = dtm.values[std::size_t(row) * dtm.grid.width + std::size_t(col)];
      if (!std::isfinite(h) || (dtm.nodata && h == *dtm.nodata)) continue;
      z = float(utm.EnuFromUtm(en.x(), en.y(), h).z());
      placed = true;
    }
  return placed;
}

}  // namespace

OptionCheck ViewerDataOptions::Check() const {
  OptionChecker c;
  c.Nested("octree", octree.Check())
      .Greater("grid_cell_m", grid_cell_m, 0.0)
      .Finite("grid_cell_m", grid_cell_m)
      .AtLeast("max_trajectory_points", max_trajectory_points, 2)
      .AtLeast("max_grid_cells", max_grid_cells, 1);
  return c.Result();
}

ViewerDataSummary WriteViewerData(const std::string& workspace, const std::string& out,
                                  const ViewerDataOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "WriteViewerData");
  const workspace::Layout layout(workspace);
  const fs::path& ws = layout.root();
  const fs::path dir(out);
  const std::map<std::string, fs::path> clouds = SessionClouds(layout);

  // Each session's octree, in date order.
  const std::map<std::string, std::string> dates = SessionDates(layout);
  std::vector<Entry> entries;
  ViewerDataSummary summary;
  for (const auto& [id, cloud] : clouds) {
    const auto d = dates.find(id);
    Entry e{id, d != dates.end() ? d->second : id, cloud, {}};
    bool rebuilt = false;
    e.index = BuildSession(cloud, dir / "clouds" / id, options, &rebuilt);
    summary.sessions.push_back({id, e.date, cloud.lexically_relative(ws).string(),
                                e.index["points"].get<std::size_t>(), e.index["nodes"].size(),
                                rebuilt});
    entries.push_back(std::move(e));
  }
  std::stable_sort(entries.begin(), entries.end(),
                   [](const Entry& a, const Entry& b) { return a.date < b.date; });
  std::stable_sort(summary.sessions.begin(), summary.sessions.end(),
                   [](const auto& a, const auto& b) { return a.date < b.date; });

  // One grid over every session's cells; the terrain from the earliest session, else the
  // analysis' terrain model where it has data.
  const SharedGrid grid = CommonGrid(entries, options);
  std::vector<float> terrain = Layer(grid, entries.front(), dir, "low.f32", true);
  CloseHoles(grid.gx, grid.gy, &terrain);
  summary.terrain_source = "the earliest cloud";
  std::vector<io::Site> declared_sites;
  if (!options.field.empty()) {
    const io::FieldInfo field =
        io::ReadFieldYaml((fs::path(options.field) / "field.yaml").string());
    declared_sites = field.sites;
    if (fs::is_regular_file(layout.Dtm()) &&
        PlaceAnalysisTerrain(grid, field, layout.Dtm(), &terrain)) {
      summary.terrain_source = layout.Dtm().lexically_relative(ws).generic_string();
    }
  }
  std::string grids = FloatBytes(terrain);
  json layers = json::array({"terrain"});
  for (const Entry& e : entries) {
    grids += FloatBytes(Layer(grid, e, dir, "top.f32", false));
    layers.push_back("top:" + e.id);
  }
  io::WriteFileAtomic((dir / "grids.bin").string(), grids);

  json sessions = json::array();
  for (const Entry& e : entries) {
    sessions.push_back({{"id", e.id},
                        {"date", e.date},
                        {"source", e.cloud.lexically_relative(ws).string()},
                        {"points", e.index["points"]},
                        {"octree", "clouds/" + e.id + "/index.json"},
                        {"trajectory", Trajectory(layout, e.id, options.max_trajectory_points)}});
  }
  const json sites = Sites(layout, declared_sites);
  summary.sites = sites.size();
  const json scene = {{"format", kDataFormat},
                      {"sessions", sessions},
                      {"grid",
                       {{"min", {double(grid.x0) * grid.cell, double(grid.y0) * grid.cell}},
                        {"cell", grid.cell * grid.factor},
                        {"nx", grid.gx},
                        {"ny", grid.gy},
                        {"file", "grids.bin"},
                        {"layers", layers}}},
                      {"sites", sites},
                      {"terrain", summary.terrain_source},
                      {"report", fs::is_regular_file(layout.Report())
                                     ? json(layout.Report().lexically_relative(ws).generic_string())
                                     : json(nullptr)}};
  io::WriteFileAtomic((dir / "scene.json").string(), scene.dump());
  // Sessions whose cloud is gone leave no tiles behind.
  if (fs::is_directory(dir / "clouds"))
    for (const auto& e : fs::directory_iterator(dir / "clouds"))
      if (!clouds.count(e.path().filename().string())) fs::remove_all(e.path());
  return summary;
}

}  // namespace crop4d::viewer
