#include "crop4d/slam/triangulation.h"

#include <gtest/gtest.h>

#include <Eigen/Cholesky>
#include <cmath>
#include <numbers>
#include <random>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/camera_test_util.h"

namespace crop4d::slam {
namespace {

using geometry::Rigid3;

geometry::PinholeRadTan TestCamera() { return testing::DistortedTestCamera(); }

// ENU offset of the test field: points and cameras lie ~1.7 km from the origin.
const Eigen::Vector3d kField(1500.0, -800.0, 30.0);

// world_from_camera of a camera at `center` looking at `target` (OpenCV axes: z forward,
// y down, x right; world z up).
Rigid3 LookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target) {
  const Eigen::Vector3d z = (target - center).normalized();
  Eigen::Vector3d up = Eigen::Vector3d::UnitZ();
  if (std::abs(z.dot(up)) > 0.99) up = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d x = z.cross(up).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R.col(0) = x;
  R.col(1) = y;
  R.col(2) = z;
  return Rigid3(R, center);
}

Eigen::Vector2d ProjectWorld(const geometry::PinholeRadTan& camera, const Rigid3& world_from_camera,
                             const Eigen::Vector3d& point_world) {
  Eigen::Vector2d pixel;
  const bool in_front = camera.Project(world_from_camera.Inverse() * point_world, &pixel);
  EXPECT_TRUE(in_front);
  return pixel;
}

std::vector<Eigen::Vector2d> ProjectAll(const geometry::PinholeRadTan& camera,
                                        const std::vector<Rigid3>& poses,
                                        const Eigen::Vector3d& point_world) {
  std::vector<Eigen::Vector2d> pixels;
  for (const Rigid3& pose : poses) pixels.push_back(ProjectWorld(camera, pose, point_world));
  return pixels;
}

// A camera on a vehicle driving along a crop row (world x), 1.2 m above the ground, looking
// forward and down at the row; `n` views spread over `length` metres.
std::vector<Rigid3> RowViews(int n, double length) {
  std::vector<Rigid3> poses;
  for (int i = 0; i < n; ++i) {
    const double x = n == 1 ? 0.0 : -0.5 * length + length * i / (n - 1);
    const Eigen::Vector3d center = kField + Eigen::Vector3d(x, 0.1 * std::sin(i), 1.2);
    poses.push_back(LookAt(center, center + Eigen::Vector3d(1.0, 0.05, -1.0)));
  }
  return poses;
}

// Covariance of the maximum-likelihood point for isotropic pixel noise σ: σ² (Σ JᵢᵀJᵢ)⁻¹, with
// the Jacobians of the projection by central differences (independent of the implementation).
Eigen::Matrix3d PointCovariance(const geometry::PinholeRadTan& camera,
                                const std::vector<Rigid3>& poses, const Eigen::Vector3d& point,
                                double sigma_px) {
  Eigen::Matrix3d information = Eigen::Matrix3d::Zero();
  for (const Rigid3& pose : poses) {
    Eigen::Matrix<double, 2, 3> J;
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d h = 1e-6 * Eigen::Vector3d::Unit(k);
      J.col(k) =
          (ProjectWorld(camera, pose, point + h) - ProjectWorld(camera, pose, point - h)) / 2e-6;
    }
    information += J.transpose() * J;
  }
  return sigma_px * sigma_px * information.inverse();
}

double Cost(const geometry::PinholeRadTan& camera, const std::vector<Rigid3>& poses,
            const std::vector<Eigen::Vector2d>& pixels, const Eigen::Vector3d& point) {
  double cost = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    cost += (ProjectWorld(camera, poses[i], point) - pixels[i]).squaredNorm();
  }
  return cost;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) * 180.0 / std::numbers::pi;
}

TEST(Triangulation, NoiseFreeViewsWithDistortionAreExact) {
  const geometry::PinholeRadTan camera = TestCamera();
  const std::vector<Rigid3> poses = RowViews(5, 0.3);
  // Points over the whole image, corners included (where the distortion is largest).
  int tested = 0;
  for (double u : {0.03, 0.25, 0.5, 0.75, 0.97}) {
    for (double v : {0.03, 0.25, 0.5, 0.75, 0.97}) {
      for (double depth : {1.0, 2.0, 6.0}) {
        // Back-project the pixel of the middle view to the given depth.
        Eigen::Vector3d ray;
        ASSERT_TRUE(camera.Unproject(Eigen::Vector2d(u * camera.width, v * camera.height), &ray));
        const Eigen::Vector3d point = poses[2] * (depth * ray);
        const std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
        bool visible = true;
        for (const Eigen::Vector2d& pixel : pixels) visible = visible && camera.IsInImage(pixel);
        if (!visible) continue;
        for (int iterations : {0, 5}) {
          TriangulationOptions options;
          options.refine_iterations = iterations;
          options.min_parallax_deg = 0.5;
          const TriangulationResult result = TriangulatePoint(camera, poses, pixels, options);
          ASSERT_EQ(result.status, TriangulationStatus::kOk)
              << ToString(result.status) << " u=" << u << " v=" << v << " depth=" << depth;
          EXPECT_LT((result.point_world - point).norm(), 1e-6) << u << " " << v << " " << depth;
          EXPECT_LT(result.max_reprojection_error_px, 1e-6);
          EXPECT_LE(result.mean_reprojection_error_px, result.max_reprojection_error_px);
          ++tested;
        }
      }
    }
  }
  EXPECT_GE(tested, 30);
}

TEST(Triangulation, TwoViewsAreTheMinimum) {
  const geometry::PinholeRadTan camera = TestCamera();
  const std::vector<Rigid3> poses = RowViews(2, 0.5);
  const Eigen::Vector3d point = kField + Eigen::Vector3d(1.3, 0.1, 0.05);
  const std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
  const TriangulationResult two = TriangulatePoint(camera, poses, pixels);
  ASSERT_EQ(two.status, TriangulationStatus::kOk) << ToString(two.status);
  EXPECT_LT((two.point_world - point).norm(), 1e-6);
  const double parallax = AngleDeg(point - poses[0].translation(), point - poses[1].translation());
  EXPECT_NEAR(two.max_parallax_deg, parallax, 1e-6);

  const TriangulationResult one = TriangulatePoint(camera, {poses[0]}, {pixels[0]});
  EXPECT_EQ(one.status, TriangulationStatus::kTooFewViews);
  EXPECT_EQ(TriangulatePoint(camera, {}, {}).status, TriangulationStatus::kTooFewViews);
  EXPECT_DEATH(TriangulatePoint(camera, poses, {pixels[0]}), "size");
}

TEST(Triangulation, NoisyPixelsGiveTheErrorThatTheGeometryPredicts) {
  // σ = 0.5 px on every pixel: the Mahalanobis distance² of the error under the first-order
  // covariance σ² (Σ JᵀJ)⁻¹ of the maximum-likelihood estimate follows χ²(3), mean 3.
  const geometry::PinholeRadTan camera = TestCamera();
  const std::vector<Rigid3> poses = RowViews(4, 0.6);
  const double sigma = 0.5;
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, sigma);
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  const int trials = 400;
  int ok = 0;
  double sum_d2 = 0.0, sum_d2_linear = 0.0, sum_error_m = 0.0, sum_predicted_m = 0.0;
  for (int trial = 0; trial < trials; ++trial) {
    const Eigen::Vector3d point =
        kField + Eigen::Vector3d(1.2 + 0.4 * uniform(rng), 0.5 * uniform(rng), 0.2 * uniform(rng));
    std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
    for (Eigen::Vector2d& pixel : pixels) pixel += Eigen::Vector2d(noise(rng), noise(rng));
    const TriangulationResult result = TriangulatePoint(camera, poses, pixels);
    if (!result.ok()) continue;
    ++ok;
    const Eigen::Matrix3d covariance = PointCovariance(camera, poses, point, sigma);
    const Eigen::Vector3d error = result.point_world - point;
    sum_d2 += error.dot(covariance.ldlt().solve(error));
    sum_error_m += error.norm();
    sum_predicted_m += std::sqrt(covariance.trace());
    EXPECT_LT(result.mean_reprojection_error_px, 4 * sigma);

    TriangulationOptions linear;
    linear.refine_iterations = 0;
    linear.max_reprojection_error_px = 100;
    const TriangulationResult dlt = TriangulatePoint(camera, poses, pixels, linear);
    ASSERT_TRUE(dlt.ok());
    const Eigen::Vector3d dlt_error = dlt.point_world - point;
    sum_d2_linear += dlt_error.dot(covariance.ldlt().solve(dlt_error));

    // The refined point is the least-squares minimum: no nearby point has a lower cost.
    if (trial % 20 == 0) {
      const double cost = Cost(camera, poses, pixels, result.point_world);
      for (int k = 0; k < 3; ++k) {
        for (double h : {-1e-4, 1e-4}) {
          const Eigen::Vector3d moved = result.point_world + h * Eigen::Vector3d::Unit(k);
          EXPECT_GE(Cost(camera, poses, pixels, moved), cost - 1e-9);
        }
      }
    }
  }
  EXPECT_GE(ok, trials * 97 / 100);
  const double mean_d2 = sum_d2 / ok;
  EXPECT_GT(mean_d2, 2.5);
  EXPECT_LT(mean_d2, 3.5);
  // The algebraic (DLT) solution is not the maximum-likelihood one: never better on average.
  EXPECT_GE(sum_d2_linear / ok, mean_d2 * 0.999);
  // The mean metric error agrees with the predicted standard deviation (a few mm here).
  EXPECT_LT(sum_error_m / ok, 1.2 * sum_predicted_m / ok);
  EXPECT_LT(sum_predicted_m / ok, 0.01);
}

TEST(Triangulation, LowParallaxIsRejected) {
  const geometry::PinholeRadTan camera = TestCamera();
  // Two views 1 cm apart, the point 10 m away: 0.057° of parallax.
  const Eigen::Vector3d point = kField + Eigen::Vector3d(10.0, 0.3, 0.5);
  const std::vector<Rigid3> poses = {LookAt(kField, point),
                                     LookAt(kField + Eigen::Vector3d(0, 0.01, 0), point)};
  const std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
  const TriangulationResult result = TriangulatePoint(camera, poses, pixels);
  EXPECT_EQ(result.status, TriangulationStatus::kLowParallax);
  const double parallax = AngleDeg(point - poses[0].translation(), point - poses[1].translation());
  EXPECT_NEAR(result.max_parallax_deg, parallax, 1e-6);
  EXPECT_NEAR(parallax, 0.0573, 1e-3);
  // Accepted with a lower threshold, and then exact.
  TriangulationOptions options;
  options.min_parallax_deg = 0.05;
  const TriangulationResult low = TriangulatePoint(camera, poses, pixels, options);
  ASSERT_EQ(low.status, TriangulationStatus::kOk);
  EXPECT_LT((low.point_world - point).norm(), 1e-6);

  // Pure rotation (one centre): no depth at all.
  const std::vector<Rigid3> rotated = {LookAt(kField, point),
                                       LookAt(kField, point + Eigen::Vector3d(0, 2.0, 1.0)),
                                       LookAt(kField, point + Eigen::Vector3d(0, -2.0, 0.0))};
  const TriangulationResult rotation =
      TriangulatePoint(camera, rotated, ProjectAll(camera, rotated, point));
  EXPECT_EQ(rotation.status, TriangulationStatus::kLowParallax);
  EXPECT_LT(rotation.max_parallax_deg, 1e-6);
}

TEST(Triangulation, PointBehindACameraOrOutOfDepthRangeIsRejected) {
  const geometry::PinholeRadTan camera = TestCamera();
  const Eigen::Vector3d point = kField + Eigen::Vector3d(2.0, 0.0, 0.0);
  // Two cameras see the point; a third, beyond it, looks away from it. Its pixel lies on the
  // line through its centre and the point (the projection of the point mirrored through it).
  std::vector<Rigid3> poses = {LookAt(kField + Eigen::Vector3d(0, -0.5, 0.3), point),
                               LookAt(kField + Eigen::Vector3d(0, 0.5, 0.3), point)};
  std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
  const Eigen::Vector3d beyond = kField + Eigen::Vector3d(4.0, 0.2, 0.1);
  poses.push_back(LookAt(beyond, beyond + Eigen::Vector3d(1.0, 0.1, 0.0)));
  const Eigen::Vector3d in_camera = poses.back().Inverse() * point;
  ASSERT_LT(in_camera.z(), 0.0);
  Eigen::Vector2d mirrored;
  ASSERT_TRUE(camera.Project(-in_camera, &mirrored));
  pixels.push_back(mirrored);
  const TriangulationResult behind = TriangulatePoint(camera, poses, pixels);
  EXPECT_EQ(behind.status, TriangulationStatus::kBehindCamera) << ToString(behind.status);
  EXPECT_LT((behind.point_world - point).norm(), 1e-6);  // The line geometry is consistent.

  // Closer than min_depth_m = 0.05 in both views (3 cm).
  const Eigen::Vector3d near = kField + Eigen::Vector3d(0.03, 0.0, 0.0);
  const std::vector<Rigid3> close = {LookAt(kField + Eigen::Vector3d(0, -0.01, 0), near),
                                     LookAt(kField + Eigen::Vector3d(0, 0.01, 0), near)};
  EXPECT_EQ(TriangulatePoint(camera, close, ProjectAll(camera, close, near)).status,
            TriangulationStatus::kBehindCamera);

  // Farther than max_depth_m.
  TriangulationOptions options;
  options.max_depth_m = 1.5;
  const std::vector<Rigid3> two(poses.begin(), poses.begin() + 2);
  const std::vector<Eigen::Vector2d> two_pixels(pixels.begin(), pixels.begin() + 2);
  EXPECT_EQ(TriangulatePoint(camera, two, two_pixels, options).status,
            TriangulationStatus::kTooFar);
  options.max_depth_m = 3.0;
  EXPECT_EQ(TriangulatePoint(camera, two, two_pixels, options).status, TriangulationStatus::kOk);
}

TEST(Triangulation, OutlierObservationGivesLargeError) {
  const geometry::PinholeRadTan camera = TestCamera();
  const std::vector<Rigid3> poses = RowViews(6, 1.0);
  const Eigen::Vector3d point = kField + Eigen::Vector3d(1.2, -0.2, 0.1);
  std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
  ASSERT_TRUE(TriangulatePoint(camera, poses, pixels).ok());
  pixels[3] += Eigen::Vector2d(15.0, -10.0);  // A wrong match.
  const TriangulationResult result = TriangulatePoint(camera, poses, pixels);
  EXPECT_EQ(result.status, TriangulationStatus::kLargeError);
  EXPECT_EQ(result.worst_view, 3);
  EXPECT_GT(result.max_reprojection_error_px, 2.0);
  // A small error is within the default 2 px.
  pixels[3] = ProjectWorld(camera, poses[3], point) + Eigen::Vector2d(1.0, 0.5);
  EXPECT_TRUE(TriangulatePoint(camera, poses, pixels).ok());
}

TEST(Triangulation, LongTrackOf40Views) {
  const geometry::PinholeRadTan camera = TestCamera();
  const std::vector<Rigid3> poses = RowViews(40, 1.6);
  const Eigen::Vector3d point = kField + Eigen::Vector3d(1.3, 0.05, 0.1);
  std::vector<Eigen::Vector2d> pixels = ProjectAll(camera, poses, point);
  const TriangulationResult exact = TriangulatePoint(camera, poses, pixels);
  ASSERT_EQ(exact.status, TriangulationStatus::kOk) << ToString(exact.status);
  EXPECT_LT((exact.point_world - point).norm(), 1e-6);
  // The parallax of the long track is its largest over all pairs (here first and last view).
  double all_pairs = 0.0;
  for (std::size_t i = 0; i < poses.size(); ++i) {
    for (std::size_t j = i + 1; j < poses.size(); ++j) {
      all_pairs = std::max(
          all_pairs, AngleDeg(point - poses[i].translation(), point - poses[j].translation()));
    }
  }
  EXPECT_NEAR(exact.max_parallax_deg, all_pairs, 1e-6);
  EXPECT_GT(all_pairs, 30.0);

  // With σ = 0.5 px noise the error is within the 99.9 % bound of χ²(3) (16.3).
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.5);
  for (Eigen::Vector2d& pixel : pixels) pixel += Eigen::Vector2d(noise(rng), noise(rng));
  const TriangulationResult noisy = TriangulatePoint(camera, poses, pixels);
  ASSERT_TRUE(noisy.ok()) << ToString(noisy.status);
  const Eigen::Matrix3d covariance = PointCovariance(camera, poses, point, 0.5);
  const Eigen::Vector3d error = noisy.point_world - point;
  EXPECT_LT(error.dot(covariance.ldlt().solve(error)), 16.3);
  EXPECT_LT(error.norm(), 0.005);
}

TEST(Triangulation, OptionsAndNames) {
  EXPECT_EQ(TriangulationOptions().Check(), "");
  TriangulationOptions options;
  options.max_depth_m = options.min_depth_m;
  EXPECT_NE(options.Check(), "");
  options = {};
  options.max_reprojection_error_px = 0.0;
  EXPECT_NE(options.Check(), "");
  options = {};
  options.refine_iterations = -1;
  EXPECT_NE(options.Check(), "");
  options = {};
  options.min_parallax_deg = -1.0;
  EXPECT_NE(options.Check(), "");
  EXPECT_STREQ(ToString(TriangulationStatus::kOk), "ok");
  EXPECT_STREQ(ToString(TriangulationStatus::kLargeError), "large reprojection error");
  EXPECT_STREQ(ToString(TriangulationStatus::kBehindCamera), "behind camera");
}

}  // namespace
}  // namespace crop4d::slam
