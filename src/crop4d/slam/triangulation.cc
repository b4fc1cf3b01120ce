#include "crop4d/slam/triangulation.h"

#include <Eigen/Cholesky>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <numbers>
#include <optional>

#include "crop4d/core/error.h"

namespace crop4d::slam {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;
// Tracks up to this length compare all pairs of rays for the parallax.
constexpr int kAllPairsMaxViews = 30;
// Step halvings tried when a Gauss-Newton step raises the cost.
constexpr int kMaxStepHalvings = 10;

// Angle between two vectors, accurate also for small angles.
double Angle(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// Largest angle between two of `rays` (see the header comment): all pairs for short tracks,
// a two-sweep search for long ones.
double MaxAngle(const std::vector<Eigen::Vector3d>& rays) {
  const int n = static_cast<int>(rays.size());
  double best = 0.0;
  if (n <= kAllPairsMaxViews) {
    for (int i = 0; i < n; ++i) {
      for (int j = i + 1; j < n; ++j) best = std::max(best, Angle(rays[i], rays[j]));
    }
    return best;
  }
  int far = 0;
  for (int sweep = 0; sweep < 2; ++sweep) {
    const int from = far;
    for (int j = 0; j < n; ++j) {
      const double angle = Angle(rays[from], rays[j]);
      if (angle > best) {
        best = angle;
        far = j;
      }
    }
  }
  return best;
}

struct View {
  Eigen::Matrix3d camera_from_world_rotation;  // R_iᵀ
  Eigen::Vector3d center_world;                // t_i
  Eigen::Vector2d pixel;
};

// Pixel residual of one view and, if `jacobian` is not null, its derivative with respect to
// the world point (header comment, step 3). Returns false when the point is not in front.
bool Residual(const geometry::PinholeRadTan& camera, const View& view,
              const Eigen::Vector3d& point_world, Eigen::Vector2d* residual,
              Eigen::Matrix<double, 2, 3>* jacobian) {
  const Eigen::Vector3d p = view.camera_from_world_rotation * (point_world - view.center_world);
  if (!(p.z() > 0.0)) return false;
  const double inv_z = 1.0 / p.z();
  const Eigen::Vector2d xy = p.head<2>() * inv_z;
  const Eigen::Vector2d xd = camera.Distort(xy);
  *residual = Eigen::Vector2d(camera.fx * xd.x() + camera.cx - view.pixel.x(),
                              camera.fy * xd.y() + camera.cy - view.pixel.y());
  if (jacobian != nullptr) {
    Eigen::Matrix<double, 2, 3> dxy_dp;
    dxy_dp << inv_z, 0.0, -xy.x() * inv_z,  //
        0.0, inv_z, -xy.y() * inv_z;
    const Eigen::Matrix2d duv_dxd = Eigen::Vector2d(camera.fx, camera.fy).asDiagonal();
    *jacobian = duv_dxd * camera.DistortJacobian(xy) * dxy_dp * view.camera_from_world_rotation;
  }
  return true;
}

// Sum of squared pixel residuals; +infinity when the point is not in front of every camera.
double Cost(const geometry::PinholeRadTan& camera, const std::vector<View>& views,
            const Eigen::Vector3d& point_world) {
  double cost = 0.0;
  Eigen::Vector2d r;
  for (const View& view : views) {
    if (!Residual(camera, view, point_world, &r, nullptr)) {
      return std::numeric_limits<double>::infinity();
    }
    cost += r.squaredNorm();
  }
  return cost;
}

}  // namespace

OptionCheck TriangulationOptions::Check() const {
  OptionChecker c;
  c.AtLeast("min_parallax_deg", min_parallax_deg, 0.0)
      .Less("min_parallax_deg", min_parallax_deg, 180.0)
      .Greater("max_reprojection_error_px", max_reprojection_error_px, 0.0)
      .AtLeast("min_depth_m", min_depth_m, 0.0)
      .Require(max_depth_m > min_depth_m, "max_depth_m", "must be > min_depth_m", max_depth_m)
      .AtLeast("refine_iterations", refine_iterations, 0);
  return c.Result();
}

const char* ToString(TriangulationStatus status) {
  switch (status) {
    case TriangulationStatus::kOk:
      return "ok";
    case TriangulationStatus::kTooFewViews:
      return "too few views";
    case TriangulationStatus::kLowParallax:
      return "low parallax";
    case TriangulationStatus::kBehindCamera:
      return "behind camera";
    case TriangulationStatus::kTooFar:
      return "too far";
    case TriangulationStatus::kLargeError:
      return "large reprojection error";
    case TriangulationStatus::kDegenerate:
      return "degenerate";
  }
  return "?";
}

namespace {

// Step 2, the DLT in centred, scaled world coordinates X' = (X − c) / s (H&Z §12.2, §4.4.4),
// c the mean camera centre; nothing when the solution is at infinity or not finite.
std::optional<Eigen::Vector3d> LinearTriangulation(const std::vector<View>& views,
                                                   const std::vector<Eigen::Vector3d>& normalised,
                                                   const Eigen::Vector3d& mean_center) {
  const int n = static_cast<int>(views.size());
  double scale = 0.0;
  for (const View& view : views) scale += (view.center_world - mean_center).norm();
  scale /= n;
  if (!(scale > 0.0)) scale = 1.0;
  Eigen::MatrixXd A(2 * n, 4);
  for (int i = 0; i < n; ++i) {
    // P'_i = [R_iᵀ s | R_iᵀ (c − t_i)] maps X' to the camera frame (up to the factor s).
    Eigen::Matrix<double, 3, 4> P;
    P.leftCols<3>() = views[i].camera_from_world_rotation * scale;
    P.col(3) = views[i].camera_from_world_rotation * (mean_center - views[i].center_world);
    A.row(2 * i) = normalised[i].x() * P.row(2) - P.row(0);
    A.row(2 * i + 1) = normalised[i].y() * P.row(2) - P.row(1);
    const double norm = std::sqrt(A.row(2 * i).squaredNorm() + A.row(2 * i + 1).squaredNorm());
    if (norm > 0.0) A.middleRows(2 * i, 2) /= norm;
  }
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeThinV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (!X.allFinite() || std::abs(X.w()) <= 1e-12 * X.head<3>().norm()) return std::nullopt;
  return Eigen::Vector3d(mean_center + scale * X.head<3>() / X.w());
}

// Step 3, Gauss-Newton on the pixel reprojection error with step halving, at most
// `max_iterations`; returns the iterations taken.
int RefinePoint(const geometry::PinholeRadTan& camera, const std::vector<View>& views,
                int max_iterations, Eigen::Vector3d* point) {
  int iterations = 0;
  double cost = Cost(camera, views, *point);
  for (int iteration = 0; iteration < max_iterations && std::isfinite(cost); ++iteration) {
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    Eigen::Vector3d g = Eigen::Vector3d::Zero();
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 3> J;
    for (const View& view : views) {
      Residual(camera, view, *point, &r, &J);
      H += J.transpose() * J;
      g += J.transpose() * r;
    }
    const Eigen::LDLT<Eigen::Matrix3d> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    Eigen::Vector3d step = -ldlt.solve(g);
    if (!step.allFinite()) break;
    ++iterations;
    bool improved = false;
    for (int halving = 0; halving <= kMaxStepHalvings; ++halving, step *= 0.5) {
      const double new_cost = Cost(camera, views, *point + step);
      if (new_cost < cost) {
        *point += step;
        cost = new_cost;
        improved = true;
        break;
      }
    }
    if (!improved || step.norm() <= 1e-12 * (1.0 + point->norm())) break;
  }
  return iterations;
}

// Step 4, the checks of result->point_world: depth in every view, parallax at the point,
// reprojection errors; sets the status and the error statistics.
void CheckPoint(const geometry::PinholeRadTan& camera, const std::vector<View>& views,
                const TriangulationOptions& options, TriangulationResult* result) {
  const int n = static_cast<int>(views.size());
  const Eigen::Vector3d& point = result->point_world;
  for (const View& view : views) {
    const double depth = (view.camera_from_world_rotation * (point - view.center_world)).z();
    if (!(depth >= options.min_depth_m)) {
      result->status = TriangulationStatus::kBehindCamera;
      return;
    }
    if (depth > options.max_depth_m) {
      result->status = TriangulationStatus::kTooFar;
      return;
    }
  }
  std::vector<Eigen::Vector3d> rays_at_point(n);
  for (int i = 0; i < n; ++i) rays_at_point[i] = point - views[i].center_world;
  const double parallax = MaxAngle(rays_at_point);
  result->max_parallax_deg = parallax * kRadToDeg;
  double sum = 0.0;
  result->max_reprojection_error_px = 0.0;
  for (int i = 0; i < n; ++i) {
    Eigen::Vector2d r;
    Residual(camera, views[i], point, &r, nullptr);
    const double error = r.norm();
    sum += error;
    if (error >= result->max_reprojection_error_px) {
      result->max_reprojection_error_px = error;
      result->worst_view = i;
    }
  }
  result->mean_reprojection_error_px = sum / n;
  if (parallax < options.min_parallax_deg / kRadToDeg) {
    result->status = TriangulationStatus::kLowParallax;
  } else if (result->max_reprojection_error_px > options.max_reprojection_error_px) {
    result->status = TriangulationStatus::kLargeError;
  } else {
    result->status = TriangulationStatus::kOk;
  }
}

}  // namespace

TriangulationResult TriangulatePoint(const geometry::PinholeRadTan& camera,
                                     const std::vector<geometry::Rigid3>& world_from_camera,
                                     const std::vector<Eigen::Vector2d>& pixels,
                                     const TriangulationOptions& options) {
  CROP4D_CHECK(world_from_camera.size() == pixels.size());
  CROP4D_CHECK_OPTIONS(options, "TriangulatePoint options");
  CROP4D_CHECK_OPTIONS(camera, "TriangulatePoint camera");
  TriangulationResult result;
  const int n = static_cast<int>(pixels.size());
  if (n < 2) {
    result.status = TriangulationStatus::kTooFewViews;
    return result;
  }

  // 1. Normalised undistorted coordinates, and the observed rays in the world frame.
  std::vector<View> views(n);
  std::vector<Eigen::Vector3d> normalised(n), rays_world(n);
  Eigen::Vector3d mean_center = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) {
    if (!camera.Unproject(pixels[i], &normalised[i]) || !normalised[i].allFinite()) {
      return result;  // kDegenerate
    }
    const Eigen::Matrix3d world_from_camera_rotation = world_from_camera[i].RotationMatrix();
    views[i] = {world_from_camera_rotation.transpose(), world_from_camera[i].translation(),
                pixels[i]};
    rays_world[i] = world_from_camera_rotation * normalised[i];
    mean_center += views[i].center_world;
  }
  mean_center /= n;
  // Rays that are (nearly) parallel: no reliable depth, and no unique DLT solution when the
  // centres coincide.
  const double min_parallax_rad = options.min_parallax_deg / kRadToDeg;
  const double observed_parallax = MaxAngle(rays_world);
  result.max_parallax_deg = observed_parallax * kRadToDeg;
  if (observed_parallax < min_parallax_rad) {
    result.status = TriangulationStatus::kLowParallax;
    return result;
  }

  // 2. DLT.
  const std::optional<Eigen::Vector3d> linear = LinearTriangulation(views, normalised, mean_center);
  if (!linear) return result;  // kDegenerate
  Eigen::Vector3d point = *linear;
  // 3. Gauss-Newton, from the DLT point if it lies in front of every camera (otherwise the
  // depth check rejects it).
  result.iterations = RefinePoint(camera, views, options.refine_iterations, &point);
  result.point_world = point;
  // 4. Checks.
  CheckPoint(camera, views, options, &result);
  return result;
}

TriangulationResult TriangulateDroppingWorstViews(
    const geometry::PinholeRadTan& camera, const std::vector<geometry::Rigid3>& world_from_camera,
    const std::vector<Eigen::Vector2d>& pixels, const TriangulationOptions& options,
    int max_dropped_views, int min_views, std::vector<bool>* kept) {
  const std::size_t n = pixels.size();
  kept->assign(n, true);
  int remaining = static_cast<int>(n);
  TriangulationResult result;
  for (int attempt = 0; attempt <= max_dropped_views; ++attempt) {
    std::vector<geometry::Rigid3> poses;
    std::vector<Eigen::Vector2d> used;
    std::vector<std::size_t> index;
    for (std::size_t o = 0; o < n; ++o) {
      if (!(*kept)[o]) continue;
      poses.push_back(world_from_camera[o]);
      used.push_back(pixels[o]);
      index.push_back(o);
    }
    result = TriangulatePoint(camera, poses, used, options);
    if (result.status != TriangulationStatus::kLargeError || result.worst_view < 0 ||
        remaining - 1 < min_views) {
      break;
    }
    (*kept)[index[result.worst_view]] = false;
    --remaining;
  }
  return result;
}

}  // namespace crop4d::slam
