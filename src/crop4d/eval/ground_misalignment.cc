#include "crop4d/eval/ground_misalignment.h"

#include <fmt/format.h>
#include <tbb/parallel_for.h>

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <charconv>
#include <cmath>
#include <limits>
#include <map>
#include <string_view>
#include <utility>

#include "crop4d/core/error.h"
#include "crop4d/eval/grid2d.h"
#include "crop4d/eval/quantile.h"
#include "crop4d/io/csv.h"

namespace crop4d::eval {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

bool ParseDouble(std::string_view text, double* value) {
  const char* end = text.data() + text.size();
  const auto [ptr, ec] = std::from_chars(text.data(), end, *value);
  return ec == std::errc() && ptr == end && std::isfinite(*value);
}

// Whether a record is the header line of a CSV without '#' ("x,y,z", "id,row,...").
bool IsHeader(const io::CsvRecord& record) {
  double value;
  return !record.fields.empty() && !ParseDouble(record.fields[0], &value);
}

std::vector<Eigen::Vector2d> Horizontal(const std::vector<Eigen::Vector3d>& points) {
  std::vector<Eigen::Vector2d> xy;
  xy.reserve(points.size());
  for (const Eigen::Vector3d& p : points) xy.push_back(p.head<2>());
  return xy;
}

// Signed distances of `query`'s points (every stride-th) to the local ground of `surface`,
// appended to `signed_distances` with the sign multiplied by `sign`.
void Distances(const std::vector<Eigen::Vector3d>& query,
               const std::vector<Eigen::Vector3d>& surface, const Grid2d& surface_grid,
               const GroundMisalignmentOptions& options, double sign, bool leave_one_out,
               std::vector<double>* signed_distances, std::int64_t* skipped) {
  const std::size_t stride =
      query.size() > static_cast<std::size_t>(options.max_query_points)
          ? (query.size() + options.max_query_points - 1) / options.max_query_points
          : 1;
  const double r2 = options.radius_m * options.radius_m;
  const double min_normal_z = std::cos(options.max_slope_deg * M_PI / 180.0);
  std::vector<int> near;
  for (std::size_t i = 0; i < query.size(); i += stride) {
    const Eigen::Vector3d& p = query[i];
    near.clear();
    surface_grid.ForNear(p.x(), p.y(), [&](int j) {
      if ((surface[j].head<2>() - p.head<2>()).squaredNorm() <= r2 &&
          !(leave_one_out && static_cast<std::size_t>(j) == i)) {
        near.push_back(j);
      }
    });
    if (static_cast<int>(near.size()) < options.min_points) {
      ++*skipped;
      continue;
    }
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (const int j : near) centroid += surface[j];
    centroid /= static_cast<double>(near.size());
    Eigen::Matrix3d scatter = Eigen::Matrix3d::Zero();
    for (const int j : near) {
      const Eigen::Vector3d d = surface[j] - centroid;
      scatter += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(scatter);
    Eigen::Vector3d normal = solver.eigenvectors().col(0);  // least variance
    if (normal.z() < 0.0) normal = -normal;
    if (!(normal.z() >= min_normal_z)) {
      ++*skipped;
      continue;
    }
    signed_distances->push_back(sign * normal.dot(p - centroid));
  }
}

MisalignmentStats Summarise(std::vector<double> signed_distances, std::int64_t skipped) {
  MisalignmentStats s;
  s.count = static_cast<std::int64_t>(signed_distances.size());
  s.skipped = skipped;
  std::vector<double> abs_distances;
  abs_distances.reserve(signed_distances.size());
  double sum = 0.0;
  for (const double d : signed_distances) {
    abs_distances.push_back(std::abs(d));
    sum += std::abs(d);
  }
  s.median_m = Quantile(&abs_distances, 0.5);
  s.p90_m = Quantile(&abs_distances, 0.9);
  s.signed_median_m = Quantile(&signed_distances, 0.5);
  s.mean_abs_m = s.count > 0 ? sum / static_cast<double>(s.count) : kNaN;
  return s;
}

}  // namespace

std::vector<PlantFootprint> ReadPlantsCsv(const std::string& path) {
  io::CsvReader reader(path);
  io::CsvRecord record;
  std::vector<PlantFootprint> plants;
  bool first = true;
  while (reader.Next(&record)) {
    if (first && IsHeader(record)) {
      first = false;
      continue;
    }
    first = false;
    if (record.fields.size() < 6) {
      throw InputError(path, record.line,
                       fmt::format("expected 6 fields (id,row,x,y,height_m,canopy_radius_m), "
                                   "found {}",
                                   record.fields.size()));
    }
    PlantFootprint plant;
    if (!ParseDouble(record.fields[2], &plant.xy.x()) ||
        !ParseDouble(record.fields[3], &plant.xy.y()) ||
        !ParseDouble(record.fields[4], &plant.height_m) ||
        !ParseDouble(record.fields[5], &plant.canopy_radius_m) || plant.canopy_radius_m < 0.0 ||
        plant.height_m < 0.0) {
      throw InputError(path, record.line,
                       "x, y, height_m and canopy_radius_m must be numbers (height and radius "
                       "not negative)");
    }
    plants.push_back(plant);
  }
  return plants;
}

TerrainGrid::TerrainGrid(double x0, double y0, double step, int nx, int ny,
                         std::vector<double> heights)
    : x0_(x0), y0_(y0), step_(step), nx_(nx), ny_(ny), heights_(std::move(heights)) {
  CROP4D_CHECK(step > 0.0 && nx >= 1 && ny >= 1);
  CROP4D_CHECK(heights_.size() == static_cast<std::size_t>(nx) * ny);
}

TerrainGrid TerrainGrid::FromFunction(double x0, double y0, double x1, double y1, double step,
                                      const std::function<double(double, double)>& height) {
  const int nx = static_cast<int>(std::floor((x1 - x0) / step + 1e-9)) + 1;
  const int ny = static_cast<int>(std::floor((y1 - y0) / step + 1e-9)) + 1;
  std::vector<double> heights;
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) heights.push_back(height(x0 + ix * step, y0 + iy * step));
  }
  return TerrainGrid(x0, y0, step, nx, ny, std::move(heights));
}

TerrainGrid TerrainGrid::Read(const std::string& path) {
  io::CsvReader reader(path);
  io::CsvRecord record;
  std::vector<Eigen::Vector3d> nodes;
  bool first = true;
  while (reader.Next(&record)) {
    if (first && IsHeader(record)) {
      first = false;
      continue;
    }
    first = false;
    Eigen::Vector3d p;
    if (record.fields.size() != 3 || !ParseDouble(record.fields[0], &p.x()) ||
        !ParseDouble(record.fields[1], &p.y()) || !ParseDouble(record.fields[2], &p.z())) {
      throw InputError(path, record.line, "expected three numbers x,y,z");
    }
    nodes.push_back(p);
  }
  if (nodes.size() < 4) throw InputError(path, 0, "fewer than 4 terrain nodes");
  // x runs fastest: the first row ends where y changes.
  int nx = 1;
  while (nx < static_cast<int>(nodes.size()) && nodes[nx].y() == nodes[0].y()) ++nx;
  const int ny = static_cast<int>(nodes.size()) / nx;
  if (nx < 2 || ny < 2 || static_cast<std::size_t>(nx) * ny != nodes.size()) {
    throw InputError(path, 0, "the nodes do not form a full grid (x fastest, then y)");
  }
  const double step = nodes[1].x() - nodes[0].x();
  if (!(step > 0.0)) throw InputError(path, 0, "x does not increase along the first row");
  std::vector<double> heights;
  heights.reserve(nodes.size());
  for (int iy = 0; iy < ny; ++iy) {
    for (int ix = 0; ix < nx; ++ix) {
      const Eigen::Vector3d& p = nodes[static_cast<std::size_t>(iy) * nx + ix];
      if (std::abs(p.x() - (nodes[0].x() + ix * step)) > 1e-3 * step ||
          std::abs(p.y() - (nodes[0].y() + iy * step)) > 1e-3 * step) {
        throw InputError(path, 0,
                         fmt::format("node {} ({}, {}) is off the regular grid of spacing {}",
                                     iy * nx + ix + 1, p.x(), p.y(), step));
      }
      heights.push_back(p.z());
    }
  }
  return TerrainGrid(nodes[0].x(), nodes[0].y(), step, nx, ny, std::move(heights));
}

bool TerrainGrid::Height(double x, double y, double* z) const {
  if (heights_.empty()) return false;
  const double gx = (x - x0_) / step_, gy = (y - y0_) / step_;
  if (!(gx >= 0.0 && gy >= 0.0 && gx <= nx_ - 1 && gy <= ny_ - 1)) return false;
  const int ix = std::min(static_cast<int>(gx), std::max(nx_ - 2, 0));
  const int iy = std::min(static_cast<int>(gy), std::max(ny_ - 2, 0));
  const double fx = nx_ > 1 ? gx - ix : 0.0, fy = ny_ > 1 ? gy - iy : 0.0;
  const auto h = [&](int i, int j) {
    return heights_[static_cast<std::size_t>(std::min(j, ny_ - 1)) * nx_ + std::min(i, nx_ - 1)];
  };
  *z = (1.0 - fy) * ((1.0 - fx) * h(ix, iy) + fx * h(ix + 1, iy)) +
       fy * ((1.0 - fx) * h(ix, iy + 1) + fx * h(ix + 1, iy + 1));
  return true;
}

OptionCheck GroundSelectionOptions::Check() const {
  OptionChecker c;
  c.AtLeast("plant_margin_m", plant_margin_m, 0.0)
      .Finite("plant_margin_m", plant_margin_m)
      .Greater("max_terrain_distance_m", max_terrain_distance_m, 0.0)
      .Finite("max_terrain_distance_m", max_terrain_distance_m);
  return c.Result();
}

std::vector<Eigen::Vector3d> SelectGroundPoints(const std::vector<Eigen::Vector3d>& points,
                                                const std::vector<PlantFootprint>& plants,
                                                const TerrainGrid& terrain,
                                                const GroundSelectionOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "SelectGroundPoints");
  double reach = 0.0;  // the largest keep-out radius
  std::vector<Eigen::Vector2d> stems;
  std::vector<double> keep_out;
  for (const PlantFootprint& plant : plants) {
    stems.push_back(plant.xy);
    keep_out.push_back(plant.canopy_radius_m + options.plant_margin_m);
    reach = std::max(reach, keep_out.back());
  }
  const Grid2d plant_grid(stems, std::max(reach, 1e-3));
  // The cloud's vertical offset from the true terrain: the mode of the heights above it (2 cm
  // bins within ±5 m). About zero for a registered cloud; a session that a biased GPS put a
  // metre too high still has its ground found, and its misalignment measured.
  std::map<long, int> histogram;
  for (const Eigen::Vector3d& p : points) {
    double z;
    if (!p.allFinite() || !terrain.Height(p.x(), p.y(), &z) || std::abs(p.z() - z) > 5.0) continue;
    ++histogram[std::lround((p.z() - z) / 0.02)];
  }
  double offset = 0.0;
  int best = 0;
  for (const auto& [bin, count] : histogram) {
    if (count > best) {
      best = count;
      offset = 0.02 * static_cast<double>(bin);
    }
  }
  std::vector<Eigen::Vector3d> ground;
  for (const Eigen::Vector3d& p : points) {
    double z;
    if (!p.allFinite() || !terrain.Height(p.x(), p.y(), &z) ||
        std::abs(p.z() - z - offset) > options.max_terrain_distance_m) {
      continue;
    }
    bool under_plant = false;
    plant_grid.ForNear(p.x(), p.y(), [&](int i) {
      if ((stems[i] - p.head<2>()).squaredNorm() <= keep_out[i] * keep_out[i]) under_plant = true;
    });
    if (!under_plant) ground.push_back(p);
  }
  return ground;
}

OptionCheck GroundMisalignmentOptions::Check() const {
  OptionChecker c;
  c.Greater("radius_m", radius_m, 0.0)
      .Finite("radius_m", radius_m)
      .AtLeast("min_points", min_points, 3)
      .Greater("max_slope_deg", max_slope_deg, 0.0)
      .AtMost("max_slope_deg", max_slope_deg, 90.0)
      .AtLeast("max_query_points", max_query_points, 1);
  return c.Result();
}

GroundMisalignment ComputeGroundMisalignment(const std::vector<SessionGround>& sessions,
                                             const GroundMisalignmentOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "ComputeGroundMisalignment");
  std::vector<Grid2d> grids;
  grids.reserve(sessions.size());
  for (const SessionGround& s : sessions)
    grids.emplace_back(Horizontal(s.points), options.radius_m);

  // The jobs — each session against itself (every point left out of its own plane: the noise
  // floor), then every unordered pair — run in parallel, each into its own list.
  const std::size_t n = sessions.size();
  std::vector<std::pair<std::size_t, std::size_t>> jobs;
  for (std::size_t i = 0; i < n; ++i) jobs.emplace_back(i, i);
  for (std::size_t i = 0; i < n; ++i) {
    for (std::size_t j = i + 1; j < n; ++j) jobs.emplace_back(i, j);
  }
  std::vector<std::vector<double>> distances(jobs.size());
  std::vector<std::int64_t> skipped(jobs.size(), 0);
  tbb::parallel_for(std::size_t{0}, jobs.size(), [&](std::size_t k) {
    const auto [i, j] = jobs[k];
    if (i == j) {
      Distances(sessions[i].points, sessions[i].points, grids[i], options, 1.0, true, &distances[k],
                &skipped[k]);
      return;
    }
    Distances(sessions[i].points, sessions[j].points, grids[j], options, +1.0, false, &distances[k],
              &skipped[k]);
    Distances(sessions[j].points, sessions[i].points, grids[i], options, -1.0, false, &distances[k],
              &skipped[k]);
  });

  GroundMisalignment result;
  std::vector<double> all_self, all;
  std::int64_t all_self_skipped = 0, all_skipped = 0;
  for (std::size_t k = 0; k < jobs.size(); ++k) {
    const auto [i, j] = jobs[k];
    std::vector<double>& pooled = i == j ? all_self : all;
    pooled.insert(pooled.end(), distances[k].begin(), distances[k].end());
    (i == j ? all_self_skipped : all_skipped) += skipped[k];
    MisalignmentStats stats = Summarise(std::move(distances[k]), skipped[k]);
    if (i == j) {
      result.self.push_back({sessions[i].session, stats});
    } else {
      result.pairs.push_back({sessions[i].session, sessions[j].session, stats});
    }
  }
  result.pooled_self = Summarise(std::move(all_self), all_self_skipped);
  result.pooled = Summarise(std::move(all), all_skipped);
  return result;
}

}  // namespace crop4d::eval
