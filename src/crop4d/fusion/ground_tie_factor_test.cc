#include "crop4d/fusion/ground_tie_factor.h"

#include <gtest/gtest.h>

#include <memory>

#include "crop4d/geometry/rotation.h"
#include "crop4d/slam/jacobian_check_test_util.h"
#include "crop4d/slam/pose_manifold.h"
#include "crop4d/slam/state_layout.h"

namespace crop4d::fusion {
namespace {

using geometry::Rigid3;

std::vector<double> Vec(const Eigen::VectorXd& v) {
  return std::vector<double>(v.data(), v.data() + v.size());
}

const Rigid3 kPoseA(geometry::ExpQuat(Eigen::Vector3d(0.02, -0.01, 0.3)),
                    Eigen::Vector3d(1.0, 2.0, 1.5));
const Rigid3 kPoseB(geometry::ExpQuat(Eigen::Vector3d(-0.01, 0.03, 2.9)),
                    Eigen::Vector3d(1.4, 5.0, 0.9));
const Eigen::Vector3d kAcross = Eigen::Vector3d(1.0, 0.2, 0.0).normalized();

TEST(GroundTieFactor, ResidualIsTheWhitenedOffsetAcrossAndVertically) {
  // The same world point through both poses, then pass b's placement moved by an offset.
  const Eigen::Vector3d world(1.3, 3.0, 0.05);
  const Eigen::Vector3d offset(0.08, 0.1, 0.03);
  const std::unique_ptr<ceres::CostFunction> cost(GroundTieFactor::Create(
      kPoseA.Inverse() * world, kPoseB.Inverse() * (world + offset), kAcross, 0.05, 0.01));
  const slam::Vector7d a = slam::PoseToBlock(kPoseA), b = slam::PoseToBlock(kPoseB);
  const double* blocks[] = {a.data(), b.data()};
  double r[2];
  ASSERT_TRUE(cost->Evaluate(blocks, r, nullptr));
  EXPECT_NEAR(r[0], offset.dot(kAcross) / 0.05, 1e-9);
  EXPECT_NEAR(r[1], offset.z() / 0.01, 1e-9);
  // Along the row the factor is blind: a displacement along it changes nothing.
  const Eigen::Vector3d along(kAcross.y(), -kAcross.x(), 0.0);
  const slam::Vector7d moved =
      slam::PoseToBlock(Rigid3(kPoseB.rotation(), kPoseB.translation() + 0.7 * along));
  const double* moved_blocks[] = {a.data(), moved.data()};
  double r_moved[2];
  ASSERT_TRUE(cost->Evaluate(moved_blocks, r_moved, nullptr));
  EXPECT_NEAR(r_moved[0], r[0], 1e-9);
  EXPECT_NEAR(r_moved[1], r[1], 1e-9);
}

TEST(GroundTieFactor, JacobiansMatchNumericalDifferences) {
  const std::unique_ptr<ceres::CostFunction> cost(GroundTieFactor::Create(
      Eigen::Vector3d(0.4, -1.2, 2.0), Eigen::Vector3d(-0.3, 0.5, 1.8), kAcross, 0.05, 0.01));
  const slam::PoseManifold manifold;
  const auto check = slam::testing::CheckJacobians(
      *cost, {Vec(slam::PoseToBlock(kPoseA)), Vec(slam::PoseToBlock(kPoseB))},
      {&manifold, &manifold});
  EXPECT_LT(check.max_relative_error, 1e-6);
}

}  // namespace
}  // namespace crop4d::fusion
