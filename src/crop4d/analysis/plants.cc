#include "crop4d/analysis/plants.h"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::analysis {

OptionCheck PlantDetectionOptions::Check() const {
  OptionChecker c;
  c.Greater("cell_m", cell_m, 0.0)
      .AtLeast("min_cells", min_cells, 1)
      .Greater("max_area_m2", max_area_m2, 0.0)
      .Greater("top_fraction", top_fraction, 0.0)
      .AtMost("top_fraction", top_fraction, 1.0)
      .AtLeast("min_spacing_m", min_spacing_m, 0.0)
      .AtLeast("min_prominence_m", min_prominence_m, 0.0)
      .AtLeast("min_prominence_fraction", min_prominence_fraction, 0.0)
      .AtLeast("max_row_offset_m", max_row_offset_m, 0.0);
  return c.Result();
}

namespace {

// The peaks of the islands after the split at their saddles (see DetectPlants).
struct Peaks {
  cv::Mat filled;                // heights, the cells the closing filled at their highest neighbour
  std::vector<int> order;        // the island cells (r · cols + c), highest first
  cv::Mat owner;                 // the peak whose component a cell joined
  std::vector<int> merged_into;  // where an insignificant peak's cells go (−1: a plant)
  std::vector<int> first_cell;   // of each peak: its top
  int cols = 0;
  float Value(int k) const { return filled.at<float>(k / cols, k % cols); }
};

// Topological persistence over the island cells: the cells, highest first, join the components
// of their already visited neighbours; where two components meet, the one with the lower peak
// ends there, and it stays a plant of its own when its peak rises at least the prominence above
// that saddle. Peaks are numbered as they appear.
Peaks SplitAtSaddles(const cv::Mat& height, const cv::Mat& mask, const PlantDetectionOptions& o) {
  const int rows = height.rows, cols = height.cols;
  Peaks out;
  out.cols = cols;
  cv::dilate(height, out.filled, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* mr = mask.ptr<std::uint8_t>(r);
    for (int c = 0; c < cols; ++c) {
      if (mr[c] == 0) continue;
      if (height.at<float>(r, c) > 0.0f) out.filled.at<float>(r, c) = height.at<float>(r, c);
      out.order.push_back(r * cols + c);
    }
  }
  const auto value = [&](int k) { return out.Value(k); };
  std::stable_sort(out.order.begin(), out.order.end(),
                   [&](int a, int b) { return value(a) > value(b); });
  // parent: union-find over peaks.
  out.owner = cv::Mat(rows, cols, CV_32S, cv::Scalar(-1));
  std::vector<int> parent;
  std::vector<int>& merged_into = out.merged_into;
  std::vector<int>& first_cell = out.first_cell;
  const auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const int k : out.order) {
    const int r = k / cols, c = k % cols;
    std::array<int, 8> roots{};
    int num_roots = 0, best = -1;
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        const int rr = r + dr, cc = c + dc;
        if ((dr == 0 && dc == 0) || rr < 0 || cc < 0 || rr >= rows || cc >= cols) continue;
        const int peak = out.owner.at<int>(rr, cc);
        if (peak < 0) continue;
        const int root = find(peak);
        if (std::find(roots.begin(), roots.begin() + num_roots, root) !=
            roots.begin() + num_roots) {
          continue;
        }
        roots[num_roots++] = root;
        if (best < 0 || value(first_cell[root]) > value(first_cell[best])) best = root;
      }
    }
    if (best < 0) {  // a new peak
      out.owner.at<int>(r, c) = static_cast<int>(parent.size());
      parent.push_back(static_cast<int>(parent.size()));
      merged_into.push_back(-1);
      first_cell.push_back(k);
      continue;
    }
    const float saddle = value(k);
    for (int i = 0; i < num_roots; ++i) {
      const int root = roots[i];
      if (root == best) continue;
      const float peak = value(first_cell[root]);
      if (peak - saddle < std::max(o.min_prominence_m, o.min_prominence_fraction * peak)) {
        merged_into[root] = best;
      }
      parent[root] = best;
    }
    out.owner.at<int>(r, c) = best;
  }
  return out;
}

// The plants of the significant peaks whose island and own cells are large enough (and the
// island not too large): the stem is the centre of the cells within top_fraction of the
// peak's height.
std::vector<DetectedPlant> PlantsOfPeaks(const Peaks& peaks, const cv::Mat& height,
                                         const cv::Mat& labels, const cv::Mat& stats,
                                         const Eigen::AlignedBox2d& area,
                                         const PlantDetectionOptions& o) {
  const int cols = peaks.cols;
  struct Peak {
    int island = 0;
    int cells = 0;
    Eigen::Vector3d sums = Eigen::Vector3d::Zero();  // x, y, count of top cells
  };
  std::vector<Peak> by_peak(peaks.first_cell.size());
  for (const int k : peaks.order) {
    int p = peaks.owner.at<int>(k / cols, k % cols);
    // The plant an insignificant peak is part of.
    while (peaks.merged_into[p] >= 0) p = peaks.merged_into[p];
    Peak& peak = by_peak[p];
    peak.island = labels.at<int>(k / cols, k % cols);
    ++peak.cells;
    if (height.at<float>(k / cols, k % cols) >= o.top_fraction * peaks.Value(peaks.first_cell[p])) {
      peak.sums += Eigen::Vector3d(k % cols + 0.5, k / cols + 0.5, 1.0);
    }
  }
  const double cell_area = o.cell_m * o.cell_m;
  std::vector<DetectedPlant> plants;
  for (std::size_t p = 0; p < by_peak.size(); ++p) {
    const Peak& peak = by_peak[p];
    if (peaks.merged_into[p] >= 0) continue;  // part of another plant
    const int island_cells = stats.at<int>(peak.island, cv::CC_STAT_AREA);
    if (island_cells < o.min_cells || island_cells * cell_area > o.max_area_m2 ||
        peak.cells < o.min_cells || peak.sums.z() == 0) {
      continue;
    }
    DetectedPlant plant;
    plant.stem = area.min() + o.cell_m * peak.sums.head<2>() / peak.sums.z();
    plant.height_m = peaks.Value(peaks.first_cell[p]);
    plant.area_m2 = peak.cells * cell_area;
    plants.push_back(plant);
  }
  return plants;
}

}  // namespace

PlantRaster::PlantRaster(const Eigen::AlignedBox2d& area, const CanopyOptions& canopy,
                         const PlantDetectionOptions& options)
    : area_(area), canopy_(canopy), options_(options) {
  CROP4D_CHECK_OPTIONS(options_, "PlantRaster");
  CROP4D_CHECK_OPTIONS(canopy_, "PlantRaster");
  if (area_.isEmpty()) return;
  cols_ = static_cast<int>(std::ceil(area_.sizes().x() / options_.cell_m)) + 1;
  rows_ = static_cast<int>(std::ceil(area_.sizes().y() / options_.cell_m)) + 1;
  height_.assign(static_cast<std::size_t>(rows_) * cols_, 0.0f);
}

void PlantRaster::Add(const SessionCloud& cloud, const GroundFunction& ground) {
  CROP4D_CHECK(cloud.is_vegetation.size() == cloud.points.size());
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    const int c = static_cast<int>((p.x() - area_.min().x()) / options_.cell_m);
    const int r = static_cast<int>((p.y() - area_.min().y()) / options_.cell_m);
    if (c < 0 || r < 0 || c >= cols_ || r >= rows_) continue;
    const double g = ground(p.x(), p.y());
    if (!std::isfinite(g)) continue;
    const double h = p.z() - g;
    if (!canopy_.IsCanopy(cloud.is_vegetation[i], h)) continue;
    float& cell = height_[static_cast<std::size_t>(r) * cols_ + c];
    cell = std::max(cell, static_cast<float>(h));
  }
}

std::vector<DetectedPlant> PlantRaster::Detect() const {
  std::vector<DetectedPlant> plants;
  if (height_.empty()) return plants;
  const PlantDetectionOptions& o = options_;
  // A header on the raster, read only.
  const cv::Mat height(rows_, cols_, CV_32F, const_cast<float*>(height_.data()));
  // Islands: the mask closed by one cell (a sparse or dense cloud leaves gaps inside a plant),
  // 8-connected.
  cv::Mat mask = height > 0.0f;
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::Mat labels, stats, centroids;
  cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Peaks: two young plants whose leaves touch make one island, and its one stem would lose the
  // smaller plant. Each island is split at its saddles by topological persistence (see
  // PlantDetectionOptions for the prominence). Cells the closing filled take the highest of
  // their neighbours, so that a gap in the cloud is no saddle.
  const Peaks peaks = SplitAtSaddles(height, mask, o);
  plants = PlantsOfPeaks(peaks, height, labels, stats, area_, o);
  // Largest plants first, then drop those within min_spacing_m of a kept one.
  std::sort(plants.begin(), plants.end(),
            [](const DetectedPlant& a, const DetectedPlant& b) { return a.area_m2 > b.area_m2; });
  std::vector<DetectedPlant> kept;
  for (const DetectedPlant& p : plants) {
    const bool near = std::any_of(kept.begin(), kept.end(), [&](const DetectedPlant& q) {
      return (q.stem - p.stem).norm() < o.min_spacing_m;
    });
    if (!near) kept.push_back(p);
  }
  return kept;
}

std::vector<DetectedPlant> DetectPlants(const SessionCloud& cloud, const GroundFunction& ground,
                                        const Eigen::AlignedBox2d& area,
                                        const CanopyOptions& canopy,
                                        const PlantDetectionOptions& o) {
  PlantRaster raster(area, canopy, o);
  raster.Add(cloud, ground);
  return raster.Detect();
}

std::vector<DetectedPlant> PlantsOnRows(std::vector<DetectedPlant> plants,
                                        const std::vector<io::RowDeclaration>& rows,
                                        const PlantDetectionOptions& options) {
  if (rows.empty() || !(options.max_row_offset_m > 0)) return plants;
  const auto off_rows = [&](const DetectedPlant& p) {
    for (const io::RowDeclaration& row : rows) {
      const Eigen::Vector2d d = row.end_enu - row.start_enu;
      const double length2 = d.squaredNorm();
      const double t =
          length2 > 0 ? std::clamp((p.stem - row.start_enu).dot(d) / length2, 0.0, 1.0) : 0.0;
      if ((p.stem - (row.start_enu + t * d)).norm() <= options.max_row_offset_m) return false;
    }
    return true;
  };
  plants.erase(std::remove_if(plants.begin(), plants.end(), off_rows), plants.end());
  return plants;
}

}  // namespace crop4d::analysis
