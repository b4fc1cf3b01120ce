#include "crop4d/analysis/canopy.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_map>

#include "crop4d/core/error.h"

namespace crop4d::analysis {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr float kNoCanopy = -std::numeric_limits<float>::infinity();

// Cells of `cell_m` on a square window centred on a site.
struct SiteCells {
  int half = 0;  // cells from the centre to an edge
  int side = 0;
  double cell_m = 0.0;
  Eigen::Vector2d center;
  std::vector<std::uint8_t> has_points;
  std::vector<float> canopy;  // highest canopy height, kNoCanopy if none
  std::vector<int> canopy_points;

  SiteCells(const Eigen::Vector2d& c, double reach, double cell) : cell_m(cell), center(c) {
    half = static_cast<int>(std::ceil(reach / cell)) + 1;
    side = 2 * half;
    has_points.assign(static_cast<std::size_t>(side) * side, 0);
    canopy.assign(has_points.size(), kNoCanopy);
    canopy_points.assign(has_points.size(), 0);
  }
  // Index of the cell holding (x, y), or −1 outside the window.
  int Index(double x, double y) const {
    const int i = static_cast<int>(std::floor((x - center.x()) / cell_m)) + half;
    const int j = static_cast<int>(std::floor((y - center.y()) / cell_m)) + half;
    if (i < 0 || j < 0 || i >= side || j >= side) return -1;
    return j * side + i;
  }
  Eigen::Vector2d CellCenter(int k) const {
    const int i = k % side, j = k / side;
    return center + cell_m * Eigen::Vector2d(i - half + 0.5, j - half + 0.5);
  }
};

}  // namespace

const char* CanopyTopName(CanopyTop top) {
  switch (top) {
    case CanopyTop::kPlantTops:
      return "plant-tops";
    case CanopyTop::kCrownPeaks:
      return "crown-peaks";
    case CanopyTop::kQuantile:
      return "quantile";
  }
  return "?";
}

OptionCheck CanopyOptions::Check() const {
  OptionChecker c;
  c.AtLeast("min_height_m", min_height_m, 0.0)
      .Require(min_height_any_colour_m >= min_height_m, "min_height_any_colour_m",
               "must be >= min_height_m", min_height_any_colour_m)
      .Greater("cell_m", cell_m, 0.0)
      .AtLeast("crown_radius_m", crown_radius_m, 0.0)
      .AtLeast("top_radius_m", top_radius_m, 0.0)
      .InRange("plant_top_quantile", plant_top_quantile, 0.0, 1.0)
      .Finite("max_shrink_m", max_shrink_m)
      .InRange("min_peak_fraction", min_peak_fraction, 0.0, 1.0)
      .Greater("top_quantile", top_quantile, 0.0)
      .AtMost("top_quantile", top_quantile, 1.0)
      .AtLeast("min_canopy_cells", min_canopy_cells, 1);
  return c.Result();
}

namespace {

// The cells within `reach` of the site centre: which hold points, and the highest canopy point
// above the ground in each.
SiteCells RasteriseCanopy(const SessionCloud& cloud, const GroundFunction& ground,
                          const io::Site& site, const CanopyOptions& o, double reach) {
  SiteCells cells(site.center_enu, reach, o.cell_m);
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    const Eigen::Vector2d d = p.head<2>() - site.center_enu;
    if (std::abs(d.x()) > reach || std::abs(d.y()) > reach) continue;
    const int k = cells.Index(p.x(), p.y());
    if (k < 0) continue;
    const double g = ground(p.x(), p.y());
    if (!std::isfinite(g)) continue;
    cells.has_points[k] = 1;
    const double h = p.z() - g;
    if (o.IsCanopy(cloud.is_vegetation[i], h)) {
      cells.canopy[k] = std::max(cells.canopy[k], static_cast<float>(h));
      ++cells.canopy_points[k];
    }
  }
  return cells;
}

// CanopyTop::kPlantTops: each plant's top is a quantile of the canopy cells whose centre lies
// within top_radius_m of its stem (its own cell at least), bounded by max_tops where given;
// the site's height is their mean. False when no plant of the site is seen.
bool PlantTopsHeight(const SiteCells& cells, const io::Site& site, const CanopyOptions& o,
                     const std::vector<Eigen::Vector2d>& stems, const std::vector<double>* max_tops,
                     SiteCanopy* result) {
  const int r_cells = static_cast<int>(std::ceil(o.top_radius_m / o.cell_m)) + 1;
  double sum = 0.0;
  std::vector<float> near;
  result->plant_tops.assign(stems.size(), kNaN);
  for (std::size_t n = 0; n < stems.size(); ++n) {
    const Eigen::Vector2d& stem = stems[n];
    if ((stem - site.center_enu).norm() > site.radius_m) continue;
    const int k0 = cells.Index(stem.x(), stem.y());
    if (k0 < 0) continue;
    const int i0 = k0 % cells.side, j0 = k0 / cells.side;
    near.clear();
    for (int dj = -r_cells; dj <= r_cells; ++dj) {
      for (int di = -r_cells; di <= r_cells; ++di) {
        const int i = i0 + di, j = j0 + dj;
        if (i < 0 || j < 0 || i >= cells.side || j >= cells.side) continue;
        const int k = j * cells.side + i;
        if (k != k0 && (cells.CellCenter(k) - stem).norm() > o.top_radius_m) continue;
        if (cells.canopy[k] != kNoCanopy) near.push_back(cells.canopy[k]);
      }
    }
    if (near.empty()) continue;  // the plant is not seen in this cloud
    const double bound = max_tops != nullptr ? (*max_tops)[n] : kNaN;
    if (std::isfinite(bound)) {
      const auto above =
          std::partition(near.begin(), near.end(), [&](float h) { return h <= bound; });
      if (above != near.begin() && above != near.end()) {
        near.erase(above, near.end());
        ++result->n_lowered;
      }
    }
    const auto nth = near.begin() + static_cast<std::ptrdiff_t>(
                                        std::floor(o.plant_top_quantile * (near.size() - 1) + 0.5));
    std::nth_element(near.begin(), nth, near.end());
    sum += *nth;
    result->plant_tops[n] = *nth;
    ++result->n_peaks;
  }
  if (result->n_peaks == 0) return false;
  result->height_m = sum / result->n_peaks;
  return true;
}

// Crown tops: canopy cells of the site (`inside`) at least min_peak_fraction of its highest
// (`site_max`) that are the highest canopy within crown_radius_m (ties go to the first cell in
// scan order, so a flat top counts once); the site's height is their mean.
void CrownTopsHeight(const SiteCells& cells, const std::vector<int>& inside, double site_max,
                     const CanopyOptions& o, SiteCanopy* result) {
  const int r_cells = static_cast<int>(std::floor(o.crown_radius_m / o.cell_m));
  const double r2 = (o.crown_radius_m / o.cell_m) * (o.crown_radius_m / o.cell_m);
  double peak_sum = 0.0;
  for (int k : inside) {
    const float v = cells.canopy[k];
    if (v == kNoCanopy || v < o.min_peak_fraction * site_max) continue;
    const int i = k % cells.side, j = k / cells.side;
    bool is_peak = true;
    for (int dj = -r_cells; dj <= r_cells && is_peak; ++dj) {
      for (int di = -r_cells; di <= r_cells; ++di) {
        if ((di == 0 && dj == 0) || di * di + dj * dj > r2) continue;
        const int ii = i + di, jj = j + dj;
        if (ii < 0 || jj < 0 || ii >= cells.side || jj >= cells.side) continue;
        const int kk = jj * cells.side + ii;
        const float u = cells.canopy[kk];
        if (u > v || (u == v && kk < k)) {
          is_peak = false;
          break;
        }
      }
    }
    if (is_peak) {
      peak_sum += v;
      ++result->n_peaks;
    }
  }
  result->height_m = result->n_peaks > 0 ? peak_sum / result->n_peaks : kNaN;
  if (result->n_peaks == 0) result->note = "no crown top within the site";
}

}  // namespace

SessionCloud SessionCloud::Take(const std::vector<std::size_t>& positions) const {
  SessionCloud out;
  out.session = session;
  out.points.reserve(positions.size());
  out.colors.reserve(positions.size());
  out.is_vegetation.reserve(positions.size());
  for (const std::size_t i : positions) {
    out.points.push_back(points[i]);
    out.colors.push_back(colors[i]);
    out.is_vegetation.push_back(is_vegetation[i]);
  }
  return out;
}

double SiteReach(const io::Site& site, const CanopyOptions& o) {
  return site.radius_m + std::max(o.crown_radius_m, o.top_radius_m) + o.cell_m;
}

SessionCloud SitePoints(const SessionCloud& cloud, const std::vector<io::Site>& sites,
                        const CanopyOptions& options, std::vector<std::size_t>* taken) {
  CROP4D_CHECK(cloud.is_vegetation.size() == cloud.points.size() &&
               cloud.colors.size() == cloud.points.size());
  std::vector<std::size_t> positions;
  if (sites.empty()) {
    if (taken) taken->clear();
    return cloud.Take(positions);
  }
  // The sites whose square touches each cell of a grid of the largest reach: a point is tested
  // against those of its cell only (a field has hundreds of sites, a cloud millions of points).
  double cell = 0.0;
  for (const io::Site& s : sites) cell = std::max(cell, SiteReach(s, options));
  const auto index = [cell](double v) { return static_cast<std::int64_t>(std::floor(v / cell)); };
  const auto key = [](std::int64_t i, std::int64_t j) { return (i << 32) ^ (j & 0xffffffffLL); };
  std::unordered_map<std::int64_t, std::vector<std::size_t>> near;
  for (std::size_t n = 0; n < sites.size(); ++n) {
    const Eigen::Vector2d& c = sites[n].center_enu;
    const double r = SiteReach(sites[n], options);
    for (std::int64_t i = index(c.x() - r); i <= index(c.x() + r); ++i) {
      for (std::int64_t j = index(c.y() - r); j <= index(c.y() + r); ++j) {
        near[key(i, j)].push_back(n);
      }
    }
  }
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    const auto it = near.find(key(index(p.x()), index(p.y())));
    if (it == near.end()) continue;
    for (const std::size_t n : it->second) {
      const Eigen::Vector2d d = p.head<2>() - sites[n].center_enu;
      const double r = SiteReach(sites[n], options);
      if (std::abs(d.x()) <= r && std::abs(d.y()) <= r) {
        positions.push_back(i);
        break;
      }
    }
  }
  SessionCloud out = cloud.Take(positions);
  if (taken) *taken = std::move(positions);
  return out;
}

SiteCanopy MeasureSite(const SessionCloud& cloud, const GroundFunction& ground,
                       const io::Site& site, const CanopyOptions& o,
                       const std::vector<Eigen::Vector2d>* stems,
                       const std::vector<double>* max_tops) {
  CROP4D_CHECK_OPTIONS(o, "MeasureSite");
  CROP4D_CHECK(max_tops == nullptr || (stems != nullptr && max_tops->size() == stems->size()));
  CROP4D_CHECK(cloud.is_vegetation.size() == cloud.points.size());
  SiteCanopy result;
  const double radius = site.radius_m;
  const double reach = SiteReach(site, o);
  const SiteCells cells = RasteriseCanopy(cloud, ground, site, o, reach);

  // Cover, volume and the canopy heights of the cells of the site with points.
  std::vector<int> inside;
  double site_max = 0.0, height_sum = 0.0;
  std::vector<double> canopy_heights;
  for (int k = 0; k < static_cast<int>(cells.has_points.size()); ++k) {
    if (!cells.has_points[k] || (cells.CellCenter(k) - site.center_enu).norm() > radius) continue;
    inside.push_back(k);
    ++result.n_cells;
    if (cells.canopy[k] != kNoCanopy) {
      ++result.n_canopy_cells;
      result.n_points += cells.canopy_points[k];
      site_max = std::max(site_max, static_cast<double>(cells.canopy[k]));
      canopy_heights.push_back(cells.canopy[k]);
      height_sum += cells.canopy[k];
    }
  }
  if (result.n_cells == 0) {
    result.height_m = result.cover = result.volume_m3 = kNaN;
    result.note = "no points within the site";
    return result;
  }
  result.cover = static_cast<double>(result.n_canopy_cells) / result.n_cells;
  result.volume_m3 = height_sum / result.n_cells * M_PI * radius * radius;
  if (result.n_canopy_cells < o.min_canopy_cells) {
    result.height_m = kNaN;
    result.note = result.n_canopy_cells == 0 ? "no vegetation within the site"
                                             : "too little vegetation within the site";
    return result;
  }

  // The height: a quantile of the canopy cells, the plant tops, or the crown tops (also when
  // no plant of the site is seen).
  if (o.top == CanopyTop::kQuantile) {
    const auto nth = canopy_heights.begin() +
                     static_cast<std::ptrdiff_t>(std::min<double>(
                         canopy_heights.size() - 1,
                         std::floor(o.top_quantile * (canopy_heights.size() - 1) + 0.5)));
    std::nth_element(canopy_heights.begin(), nth, canopy_heights.end());
    result.height_m = *nth;
    return result;
  }
  if (o.top == CanopyTop::kPlantTops && stems != nullptr &&
      PlantTopsHeight(cells, site, o, *stems, max_tops, &result)) {
    return result;
  }
  CrownTopsHeight(cells, inside, site_max, o, &result);
  return result;
}

std::vector<float> CanopyHeightModel(
    const SessionCloud& cloud, const GroundFunction& ground, std::size_t num_cells,
    const std::function<std::ptrdiff_t(const Eigen::Vector2d&)>& cell_of, const CanopyOptions& o) {
  std::vector<float> chm(num_cells, std::numeric_limits<float>::quiet_NaN());
  AddToCanopyHeightModel(cloud, ground, cell_of, o, &chm);
  return chm;
}

void AddToCanopyHeightModel(const SessionCloud& cloud, const GroundFunction& ground,
                            const std::function<std::ptrdiff_t(const Eigen::Vector2d&)>& cell_of,
                            const CanopyOptions& o, std::vector<float>* chm) {
  CROP4D_CHECK_OPTIONS(o, "CanopyHeightModel");
  CROP4D_CHECK(cloud.is_vegetation.size() == cloud.points.size());
  const std::size_t num_cells = chm->size();
  for (std::size_t n = 0; n < cloud.points.size(); ++n) {
    const Eigen::Vector3d& p = cloud.points[n];
    const std::ptrdiff_t c = cell_of(p.head<2>());
    if (c < 0 || static_cast<std::size_t>(c) >= num_cells) continue;
    const double g = ground(p.x(), p.y());
    if (!std::isfinite(g)) continue;
    float& cell = (*chm)[c];
    if (!std::isfinite(cell)) cell = 0.0f;
    const double h = p.z() - g;
    if (o.IsCanopy(cloud.is_vegetation[n], h)) cell = std::max(cell, static_cast<float>(h));
  }
}

std::vector<float> CanopyHeightModel(const SessionCloud& cloud, const TerrainModel& terrain,
                                     const GridSpec& grid, const CanopyOptions& o) {
  CROP4D_CHECK_OPTIONS(grid, "CanopyHeightModel");
  const auto cell_of = [&](const Eigen::Vector2d& xy) -> std::ptrdiff_t {
    const long i = std::lround((xy.x() - grid.origin.x()) / grid.cell_m);
    const long j = std::lround((xy.y() - grid.origin.y()) / grid.cell_m);
    if (i < 0 || j < 0 || i >= grid.width || j >= grid.height) return -1;
    return static_cast<std::ptrdiff_t>(j) * grid.width + i;
  };
  const GroundFunction ground = [&](double x, double y) { return terrain.Height(x, y); };
  return CanopyHeightModel(cloud, ground, grid.size(), cell_of, o);
}

}  // namespace crop4d::analysis
