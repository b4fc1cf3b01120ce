#include "crop4d/analysis/plants.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::analysis {

bool PlantDetectionOptions::Check() const {
  return cell_m > 0.0 && min_cells >= 1 && max_area_m2 > 0.0 && top_fraction > 0.0 &&
         top_fraction <= 1.0 && min_spacing_m >= 0.0;
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
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  std::vector<float> top(n, 0.0f);
  for (int r = 0; r < rows; ++r) {
    const int* lr = labels.ptr<int>(r);
    const float* hr = height.ptr<float>(r);
    for (int c = 0; c < cols; ++c) top[lr[c]] = std::max(top[lr[c]], hr[c]);
  }
  std::vector<Eigen::Vector3d> sums(n, Eigen::Vector3d::Zero());  // x, y, count of top cells
  for (int r = 0; r < rows; ++r) {
    const int* lr = labels.ptr<int>(r);
    const float* hr = height.ptr<float>(r);
    for (int c = 0; c < cols; ++c) {
      const int l = lr[c];
      if (l == 0 || hr[c] < o.top_fraction * top[l]) continue;
      sums[l] += Eigen::Vector3d(c + 0.5, r + 0.5, 1.0);
    }
  }
  const double cell_area = o.cell_m * o.cell_m;
  for (int l = 1; l < n; ++l) {
    const int cells = stats.at<int>(l, cv::CC_STAT_AREA);
    if (cells < o.min_cells || cells * cell_area > o.max_area_m2 || sums[l].z() == 0) continue;
    DetectedPlant p;
    p.stem = area.min() + o.cell_m * sums[l].head<2>() / sums[l].z();
    p.height_m = top[l];
    p.area_m2 = cells * cell_area;
    plants.push_back(p);
  }
  // Largest islands first, then drop those within min_spacing_m of a kept one.
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
