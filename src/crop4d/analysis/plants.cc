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
      .AtLeast("min_prominence_fraction", min_prominence_fraction, 0.0);
  return c.Result();
}

std::vector<DetectedPlant> DetectPlants(const SessionCloud& cloud, const GroundFunction& ground,
                                        const Eigen::AlignedBox2d& area,
                                        const CanopyOptions& canopy,
                                        const PlantDetectionOptions& o) {
  CROP4D_CHECK(o.Check() && canopy.Check());
  CROP4D_CHECK(cloud.is_vegetation.size() == cloud.points.size());
  std::vector<DetectedPlant> plants;
  if (area.isEmpty()) return plants;
  const int cols = static_cast<int>(std::ceil(area.sizes().x() / o.cell_m)) + 1;
  const int rows = static_cast<int>(std::ceil(area.sizes().y() / o.cell_m)) + 1;
  // The canopy height of each cell (0: none).
  cv::Mat height(rows, cols, CV_32F, cv::Scalar(0));
  for (std::size_t i = 0; i < cloud.points.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points[i];
    const int c = static_cast<int>((p.x() - area.min().x()) / o.cell_m);
    const int r = static_cast<int>((p.y() - area.min().y()) / o.cell_m);
    if (c < 0 || r < 0 || c >= cols || r >= rows) continue;
    const double g = ground(p.x(), p.y());
    if (!std::isfinite(g)) continue;
    const double h = p.z() - g;
    if (!canopy.IsCanopy(cloud.is_vegetation[i], h)) continue;
    float& cell = height.at<float>(r, c);
    cell = std::max(cell, static_cast<float>(h));
  }
  // Islands: the mask closed by one cell (a sparse or dense cloud leaves gaps inside a plant),
  // 8-connected.
  cv::Mat mask = height > 0.0f;
  cv::morphologyEx(mask, mask, cv::MORPH_CLOSE,
                   cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  cv::Mat labels, stats, centroids;
  cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

  // Peaks: two young plants whose leaves touch make one island, and its one stem would lose the
  // smaller plant. Each island is split at its saddles by topological persistence: the cells,
  // highest first, join the components of their already visited neighbours; where two
  // components meet, the one with the lower peak ends there, and it stays a plant of its own
  // when its peak rises at least the prominence (see PlantDetectionOptions) above that saddle.
  // Cells the closing filled take the highest of their neighbours, so that a gap in the cloud is
  // no saddle.
  cv::Mat filled;
  cv::dilate(height, filled, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
  std::vector<int> order;
  for (int r = 0; r < rows; ++r) {
    const std::uint8_t* mr = mask.ptr<std::uint8_t>(r);
    for (int c = 0; c < cols; ++c) {
      if (mr[c] == 0) continue;
      if (height.at<float>(r, c) > 0.0f) filled.at<float>(r, c) = height.at<float>(r, c);
      order.push_back(r * cols + c);
    }
  }
  const auto value = [&](int k) { return filled.at<float>(k / cols, k % cols); };
  std::stable_sort(order.begin(), order.end(), [&](int a, int b) { return value(a) > value(b); });
  // Peaks are numbered as they appear. owner: the peak whose component a cell joined (−1: not
  // visited); parent: union-find over peaks; merged_into: where an insignificant peak's cells go
  // (−1: the peak is a plant of its own).
  cv::Mat owner(rows, cols, CV_32S, cv::Scalar(-1));
  std::vector<int> parent, merged_into, first_cell;
  const auto find = [&](int a) {
    while (parent[a] != a) a = parent[a] = parent[parent[a]];
    return a;
  };
  for (const int k : order) {
    const int r = k / cols, c = k % cols;
    std::array<int, 8> roots{};
    int num_roots = 0, best = -1;
    for (int dr = -1; dr <= 1; ++dr) {
      for (int dc = -1; dc <= 1; ++dc) {
        const int rr = r + dr, cc = c + dc;
        if ((dr == 0 && dc == 0) || rr < 0 || cc < 0 || rr >= rows || cc >= cols) continue;
        const int peak = owner.at<int>(rr, cc);
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
      owner.at<int>(r, c) = static_cast<int>(parent.size());
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
    owner.at<int>(r, c) = best;
  }

  struct Peak {
    int island = 0;
    int cells = 0;
    Eigen::Vector3d sums = Eigen::Vector3d::Zero();  // x, y, count of top cells
  };
  std::vector<Peak> peaks(parent.size());
  for (const int k : order) {
    int p = owner.at<int>(k / cols, k % cols);
    while (merged_into[p] >= 0) p = merged_into[p];  // the plant an insignificant peak is part of
    Peak& peak = peaks[p];
    peak.island = labels.at<int>(k / cols, k % cols);
    ++peak.cells;
    if (height.at<float>(k / cols, k % cols) >= o.top_fraction * value(first_cell[p])) {
      peak.sums += Eigen::Vector3d(k % cols + 0.5, k / cols + 0.5, 1.0);
    }
  }
  const double cell_area = o.cell_m * o.cell_m;
  for (std::size_t p = 0; p < peaks.size(); ++p) {
    const Peak& peak = peaks[p];
    if (merged_into[p] >= 0) continue;  // part of another plant
    const int island_cells = stats.at<int>(peak.island, cv::CC_STAT_AREA);
    if (island_cells < o.min_cells || island_cells * cell_area > o.max_area_m2 ||
        peak.cells < o.min_cells || peak.sums.z() == 0) {
      continue;
    }
    DetectedPlant plant;
    plant.stem = area.min() + o.cell_m * peak.sums.head<2>() / peak.sums.z();
    plant.height_m = value(first_cell[p]);
    plant.area_m2 = peak.cells * cell_area;
    plants.push_back(plant);
  }
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

}  // namespace crop4d::analysis
