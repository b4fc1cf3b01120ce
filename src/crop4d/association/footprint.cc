#include "crop4d/association/footprint.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::association {
namespace {

// The image border as pixels, clockwise on screen from the top-left corner, each corner once.
// OpenCV pixel convention: the image spans [−0.5, w − 0.5] × [−0.5, h − 0.5].
std::vector<Eigen::Vector2d> BorderPixels(const geometry::PinholeRadTan& camera, int per_side) {
  const double x0 = -0.5, y0 = -0.5, x1 = camera.width - 0.5, y1 = camera.height - 0.5;
  const Eigen::Vector2d corners[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
  std::vector<Eigen::Vector2d> pixels;
  pixels.reserve(4 * per_side);
  for (int side = 0; side < 4; ++side) {
    const Eigen::Vector2d& from = corners[side];
    const Eigen::Vector2d& to = corners[(side + 1) % 4];
    for (int k = 0; k < per_side; ++k) {
      pixels.push_back(from + (to - from) * (static_cast<double>(k) / per_side));
    }
  }
  return pixels;
}

double PolygonArea(const std::vector<Eigen::Vector2d>& polygon) {
  double twice = 0;
  for (std::size_t i = 0; i < polygon.size(); ++i) {
    const Eigen::Vector2d& p = polygon[i];
    const Eigen::Vector2d& q = polygon[(i + 1) % polygon.size()];
    twice += p.x() * q.y() - q.x() * p.y();
  }
  return 0.5 * twice;
}

// Polygon vertices relative to `origin`, in float for OpenCV's polygon routines (metres relative
// to a nearby origin keep float's 1e-7 relative precision at the micrometre level).
std::vector<cv::Point2f> ToCv(const std::vector<Eigen::Vector2d>& polygon,
                              const Eigen::Vector2d& origin) {
  std::vector<cv::Point2f> points;
  points.reserve(polygon.size());
  for (const Eigen::Vector2d& p : polygon) {
    points.emplace_back(static_cast<float>(p.x() - origin.x()),
                        static_cast<float>(p.y() - origin.y()));
  }
  return points;
}

// Image a's view of the ground for the view overlap: the ground points of a grid of its pixels
// (within the footprint range) and their distances from its centre.
struct GroundView {
  std::vector<Eigen::Vector3d> points;
  std::vector<double> distances;
};

GroundView SampleGroundView(const geometry::PinholeRadTan& camera,
                            const geometry::Rigid3& world_from_camera, double ground_z,
                            const PairSelectionOptions& options) {
  GroundView view;
  const Eigen::Vector3d center = world_from_camera.translation();
  const double height = center.z() - ground_z;
  if (!(height > 0)) return view;
  const Eigen::Matrix3d rotation = world_from_camera.RotationMatrix();
  const int columns = options.view_samples;
  const int rows = std::max(1, static_cast<int>(std::lround(static_cast<double>(columns) *
                                                            camera.height / camera.width)));
  for (int r = 0; r < rows; ++r) {
    for (int c = 0; c < columns; ++c) {
      // Cell centres; OpenCV's convention: the image spans [−0.5, w − 0.5] × [−0.5, h − 0.5].
      const Eigen::Vector2d pixel((c + 0.5) * camera.width / columns - 0.5,
                                  (r + 0.5) * camera.height / rows - 0.5);
      Eigen::Vector3d ray;
      if (!camera.Unproject(pixel, &ray)) continue;
      const Eigen::Vector3d direction = rotation * ray;
      if (!(direction.z() < 0)) continue;
      const Eigen::Vector3d offset = direction * (height / -direction.z());
      if (offset.head<2>().norm() > options.footprint.max_range_m) continue;
      view.points.push_back(center + offset);
      view.distances.push_back(offset.norm());
    }
  }
  return view;
}

double ViewOverlapOf(const GroundView& view_a, const geometry::PinholeRadTan& camera_b,
                     const geometry::Rigid3& world_from_camera_b,
                     const PairSelectionOptions& options) {
  if (view_a.points.empty()) return 0;
  const geometry::Rigid3 camera_from_world = world_from_camera_b.Inverse();
  const double max_change = options.max_scale_change;
  int shared = 0;
  for (std::size_t k = 0; k < view_a.points.size(); ++k) {
    const Eigen::Vector3d point = camera_from_world * view_a.points[k];
    if (!(point.z() > 0)) continue;
    if (max_change > 0) {
      const double ratio = point.norm() / view_a.distances[k];
      if (ratio > max_change || ratio * max_change < 1) continue;
    }
    Eigen::Vector2d pixel;
    if (camera_b.IsRegularRoot(point.head<2>() / point.z()) && camera_b.Project(point, &pixel) &&
        camera_b.IsInImage(pixel)) {
      ++shared;
    }
  }
  return static_cast<double>(shared) / static_cast<double>(view_a.points.size());
}

}  // namespace

OptionCheck FootprintOptions::Check() const {
  OptionChecker c;
  c.Greater("max_range_m", max_range_m, 0.0)
      .Finite("max_range_m", max_range_m)
      .AtLeast("samples_per_side", samples_per_side, 1);
  return c.Result();
}

OptionCheck PairSelectionOptions::Check() const {
  OptionChecker c;
  c.Nested("footprint", footprint.Check())
      .InRange("min_overlap", min_overlap, 0.0, 1.0)
      .AtLeast("max_pairs_per_image", max_pairs_per_image, 1)
      .AtLeast("stride", stride, 1)
      .Greater("max_axis_angle_deg", max_axis_angle_deg, 0.0)
      .Require(max_scale_change == 0 || max_scale_change >= 1, "max_scale_change",
               "must be 0 (off) or >= 1", max_scale_change)
      .AtLeast("view_samples", view_samples, 1);
  return c.Result();
}

Footprint GroundFootprint(const geometry::PinholeRadTan& camera,
                          const geometry::Rigid3& world_from_camera, double ground_z,
                          const FootprintOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "FootprintOptions");
  Footprint footprint;
  const Eigen::Vector3d center = world_from_camera.translation();
  const double height = center.z() - ground_z;
  if (!(height > 0)) return footprint;
  const Eigen::Matrix3d world_from_camera_rotation = world_from_camera.RotationMatrix();
  const geometry::Rigid3 camera_from_world = world_from_camera.Inverse();
  const Eigen::Vector2d center_xy = center.head<2>();
  const double range = options.max_range_m;

  // Whether the ground point at `offset` (xy from the camera) is seen: it projects into the
  // image through a regular part of the lens model (a strong barrel distortion folds far-off
  // points back into the image otherwise).
  const auto visible = [&](const Eigen::Vector2d& offset) {
    const Eigen::Vector3d point =
        camera_from_world *
        Eigen::Vector3d(center.x() + offset.x(), center.y() + offset.y(), ground_z);
    Eigen::Vector2d pixel;
    return point.z() > 0 && camera.IsRegularRoot(point.head<2>() / point.z()) &&
           camera.Project(point, &pixel) && camera.IsInImage(pixel, -1.0);
  };

  // The footprint is the part of the disc of radius `range` that the image sees. Its boundary is
  // made of the image border's trace on the ground (rays that meet the ground within the range)
  // and of the range circle where the ground beyond the range is seen (the horizon is in view):
  // both are sampled, each point checked to be seen, and the convex hull taken. Rays above the
  // horizon contribute nothing, so a camera that sees no ground has no footprint.
  std::vector<cv::Point2f> ground;  // relative to the camera's xy
  for (const Eigen::Vector2d& pixel : BorderPixels(camera, options.samples_per_side)) {
    Eigen::Vector3d ray;
    if (!camera.Unproject(pixel, &ray)) continue;
    const Eigen::Vector3d direction = world_from_camera_rotation * ray;
    if (!(direction.z() < 0)) continue;
    const Eigen::Vector2d offset = direction.head<2>() * (height / -direction.z());
    if (offset.norm() <= range) {
      ground.emplace_back(static_cast<float>(offset.x()), static_cast<float>(offset.y()));
    }
  }
  const int num_azimuths = std::max(16, 8 * options.samples_per_side);
  for (int k = 0; k < num_azimuths; ++k) {
    const double azimuth = 2 * std::numbers::pi * k / num_azimuths;
    const Eigen::Vector2d offset = range * Eigen::Vector2d(std::cos(azimuth), std::sin(azimuth));
    if (visible(offset)) {
      ground.emplace_back(static_cast<float>(offset.x()), static_cast<float>(offset.y()));
    }
  }
  if (ground.size() < 3) return footprint;
  std::vector<cv::Point2f> hull;
  cv::convexHull(ground, hull, /*clockwise=*/false);
  if (hull.size() < 3) return footprint;
  footprint.polygon.reserve(hull.size());
  for (const cv::Point2f& p : hull) {
    footprint.polygon.push_back(center_xy + Eigen::Vector2d(p.x, p.y));
    footprint.bounds.extend(footprint.polygon.back());
  }
  footprint.area_m2 = PolygonArea(footprint.polygon);
  if (footprint.area_m2 < 0) {  // be sure of the orientation whatever the hull's convention
    std::reverse(footprint.polygon.begin(), footprint.polygon.end());
    footprint.area_m2 = -footprint.area_m2;
  }
  return footprint;
}

double ViewOverlap(const geometry::PinholeRadTan& camera_a,
                   const geometry::Rigid3& world_from_camera_a,
                   const geometry::PinholeRadTan& camera_b,
                   const geometry::Rigid3& world_from_camera_b, double ground_z,
                   const PairSelectionOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "PairSelectionOptions");
  return std::min(ViewOverlapOf(SampleGroundView(camera_a, world_from_camera_a, ground_z, options),
                                camera_b, world_from_camera_b, options),
                  ViewOverlapOf(SampleGroundView(camera_b, world_from_camera_b, ground_z, options),
                                camera_a, world_from_camera_a, options));
}

double FootprintOverlap(const Footprint& a, const Footprint& b) {
  if (a.empty() || b.empty() || !a.bounds.intersects(b.bounds)) return 0;
  const Eigen::Vector2d origin = a.bounds.center();
  std::vector<cv::Point2f> intersection;
  const double area =
      cv::intersectConvexConvex(ToCv(a.polygon, origin), ToCv(b.polygon, origin), intersection,
                                /*handleNested=*/true);
  if (!(area > 0)) return 0;
  return std::clamp(area / std::min(a.area_m2, b.area_m2), 0.0, 1.0);
}

std::vector<ImagePair> SelectImagePairs(const std::vector<geometry::Rigid3>& poses_a,
                                        const std::vector<geometry::Rigid3>& poses_b,
                                        const geometry::PinholeRadTan& camera_a,
                                        const geometry::PinholeRadTan& camera_b, double ground_z,
                                        const PairSelectionOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "PairSelectionOptions");
  std::vector<ImagePair> pairs;
  if (poses_a.empty() || poses_b.empty()) return pairs;

  const bool by_view = options.max_scale_change > 0;
  std::vector<Footprint> footprints_b(poses_b.size());
  std::vector<GroundView> views_b(by_view ? poses_b.size() : 0);
  Eigen::AlignedBox2d bounds_b;
  for (std::size_t j = 0; j < poses_b.size(); ++j) {
    footprints_b[j] = GroundFootprint(camera_b, poses_b[j], ground_z, options.footprint);
    if (by_view) views_b[j] = SampleGroundView(camera_b, poses_b[j], ground_z, options);
    if (!footprints_b[j].empty()) bounds_b.extend(footprints_b[j].bounds);
  }
  if (bounds_b.isEmpty()) return pairs;

  // A uniform grid over pass b's boxes, cells of the footprint's size: every image of b is listed
  // in each cell its box touches, and an image of a is tested against the images listed in the
  // cells its own box touches (a row pass is long and thin, so a grid, unlike a sort on one
  // axis, stays selective whatever the row direction).
  const double cell = std::max(options.footprint.max_range_m, 1e-3);
  const Eigen::Vector2d grid_origin = bounds_b.min();
  const int num_x = static_cast<int>(std::floor(bounds_b.sizes().x() / cell)) + 1;
  const int num_y = static_cast<int>(std::floor(bounds_b.sizes().y() / cell)) + 1;
  const auto cell_range = [&](const Eigen::AlignedBox2d& box, int* x0, int* y0, int* x1, int* y1) {
    *x0 = std::clamp(static_cast<int>(std::floor((box.min().x() - grid_origin.x()) / cell)), 0,
                     num_x - 1);
    *y0 = std::clamp(static_cast<int>(std::floor((box.min().y() - grid_origin.y()) / cell)), 0,
                     num_y - 1);
    *x1 = std::clamp(static_cast<int>(std::floor((box.max().x() - grid_origin.x()) / cell)), 0,
                     num_x - 1);
    *y1 = std::clamp(static_cast<int>(std::floor((box.max().y() - grid_origin.y()) / cell)), 0,
                     num_y - 1);
  };
  std::vector<std::vector<std::int32_t>> grid(static_cast<std::size_t>(num_x) * num_y);
  for (std::size_t j = 0; j < footprints_b.size(); ++j) {
    if (footprints_b[j].empty()) continue;
    int x0, y0, x1, y1;
    cell_range(footprints_b[j].bounds, &x0, &y0, &x1, &y1);
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        grid[static_cast<std::size_t>(y) * num_x + x].push_back(static_cast<std::int32_t>(j));
      }
    }
  }

  const double min_axis_cos = std::cos(options.max_axis_angle_deg * std::numbers::pi / 180.0);
  std::vector<int> seen(poses_b.size(), -1);
  std::vector<ImagePair> candidates;
  for (std::size_t i = 0; i < poses_a.size(); i += options.stride) {
    const Footprint footprint_a =
        GroundFootprint(camera_a, poses_a[i], ground_z, options.footprint);
    if (footprint_a.empty() || !footprint_a.bounds.intersects(bounds_b)) continue;
    const GroundView view_a =
        by_view ? SampleGroundView(camera_a, poses_a[i], ground_z, options) : GroundView();
    const Eigen::Vector3d axis_a = poses_a[i].rotation() * Eigen::Vector3d::UnitZ();
    int x0, y0, x1, y1;
    cell_range(footprint_a.bounds, &x0, &y0, &x1, &y1);
    candidates.clear();
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        for (const std::int32_t j : grid[static_cast<std::size_t>(y) * num_x + x]) {
          if (seen[j] == static_cast<int>(i)) continue;
          seen[j] = static_cast<int>(i);
          if (!footprint_a.bounds.intersects(footprints_b[j].bounds)) continue;
          if (options.max_axis_angle_deg < 180.0) {
            const Eigen::Vector3d axis_b = poses_b[j].rotation() * Eigen::Vector3d::UnitZ();
            if (axis_a.dot(axis_b) < min_axis_cos) continue;
          }
          const double overlap =
              by_view ? std::min(ViewOverlapOf(view_a, camera_b, poses_b[j], options),
                                 ViewOverlapOf(views_b[j], camera_a, poses_a[i], options))
                      : FootprintOverlap(footprint_a, footprints_b[j]);
          if (overlap >= options.min_overlap && overlap > 0) {
            candidates.push_back({static_cast<std::int32_t>(i), j, overlap});
          }
        }
      }
    }
    std::sort(candidates.begin(), candidates.end(), [](const ImagePair& p, const ImagePair& q) {
      if (p.overlap != q.overlap) return p.overlap > q.overlap;
      return p.image_b < q.image_b;
    });
    const std::size_t keep =
        std::min(candidates.size(), static_cast<std::size_t>(options.max_pairs_per_image));
    pairs.insert(pairs.end(), candidates.begin(), candidates.begin() + keep);
  }
  return pairs;
}

}  // namespace crop4d::association
