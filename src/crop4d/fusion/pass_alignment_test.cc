#include "crop4d/fusion/pass_alignment.h"

#include <gtest/gtest.h>

#include <random>
#include <stdexcept>

namespace crop4d::fusion {
namespace {

TEST(PassAlignment, RecoversYawAndTranslationDespiteOutliers) {
  std::mt19937 rng(2);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  const geometry::Rigid3 truth(Eigen::AngleAxisd(0.04, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                               Eigen::Vector3d(1.3, -0.8, 0.25));
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 300; ++i) {
    const Eigen::Vector3d p(2 * u(rng), 10 * u(rng), 0.1 * u(rng));
    a.push_back(p);
    Eigen::Vector3d q = truth * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    if (i % 4 == 0) q += Eigen::Vector3d(3 * u(rng), 3 * u(rng), u(rng));  // 25% wrong matches
    b.push_back(q);
  }
  const PassAlignment r = AlignPasses4Dof(a, b);
  ASSERT_TRUE(r.ok);
  EXPECT_GE(r.num_inliers, 210);
  EXPECT_LT(r.rms_m, 0.03);
  EXPECT_LT((r.b_from_a.translation() - truth.translation()).norm(), 0.01);
  EXPECT_LT(r.b_from_a.rotation().angularDistance(truth.rotation()), 0.002);
}

TEST(PassAlignment, RefusesTooFewOrInconsistentPoints) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-5.0, 5.0);
  std::vector<Eigen::Vector3d> a, b;
  for (int i = 0; i < 100; ++i) {
    a.emplace_back(u(rng), u(rng), 0);
    b.emplace_back(u(rng), u(rng), 0);  // no relation
  }
  EXPECT_FALSE(AlignPasses4Dof(a, b).ok);
  a.resize(5);
  b.resize(5);
  b = a;
  EXPECT_FALSE(AlignPasses4Dof(a, b).ok);  // below min_inliers
}

// Two passes along one row: the near ground agrees with one transform, while many more points on
// a distant tree line, misplaced alike by both passes, agree with another one. Only the ground
// within range decides.
TEST(PassAlignment, NearGroundDecidesOverADistantTreeLine) {
  std::mt19937 rng(4);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.01);
  const geometry::Rigid3 ground(
      Eigen::AngleAxisd(0.02, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
      Eigen::Vector3d(0.9, -2.1, 0.6));
  const geometry::Rigid3 trees(
      Eigen::AngleAxisd(-0.03, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
      Eigen::Vector3d(2.3, -0.5, -0.4));
  std::vector<ObservedPoint> a, b;
  const auto add = [&](const Eigen::Vector3d& camera_a, const Eigen::Vector3d& p,
                       const geometry::Rigid3& b_from_a) {
    a.push_back({p, camera_a});
    const Eigen::Vector3d q = b_from_a * p + Eigen::Vector3d(noise(rng), noise(rng), noise(rng));
    b.push_back({q, b_from_a * camera_a});
  };
  for (int i = 0; i < 400; ++i) {
    const Eigen::Vector3d camera(0.2 * u(rng), 10 * u(rng), 1.5);
    if (i % 4 == 0) {
      // Ground 1.5-4 m ahead of the camera (within 5 m of it).
      add(camera,
          camera + Eigen::Vector3d(0.8 * u(rng), 2.75 + 1.25 * u(rng), -1.5 + 0.05 * u(rng)),
          ground);
    } else {
      // The tree line, 40 m away.
      add(camera, Eigen::Vector3d(10 * u(rng), 40 + 2 * u(rng), 3 + 3 * u(rng)), trees);
    }
  }
  const PassAlignment all = AlignPasses4Dof(
      [&] {
        std::vector<Eigen::Vector3d> p;
        for (const ObservedPoint& o : a) p.push_back(o.point);
        return p;
      }(),
      [&] {
        std::vector<Eigen::Vector3d> p;
        for (const ObservedPoint& o : b) p.push_back(o.point);
        return p;
      }());
  ASSERT_TRUE(all.ok);
  EXPECT_GT((all.b_from_a.translation() - ground.translation()).norm(), 1.0);  // the trees won

  const PassAlignment near = AlignPasses4DofNear(a, b, 5.0);
  ASSERT_TRUE(near.ok);
  EXPECT_GE(near.num_inliers, 90);
  EXPECT_LT((near.b_from_a.translation() - ground.translation()).norm(), 0.02);
  EXPECT_LT(near.b_from_a.rotation().angularDistance(ground.rotation()), 0.003);

  // Nothing within range: no alignment; lists of different sizes are a programming error.
  EXPECT_FALSE(AlignPasses4DofNear(a, b, 0.5).ok);
  b.pop_back();
  EXPECT_THROW(AlignPasses4DofNear(a, b, 5.0), std::invalid_argument);
}

}  // namespace
}  // namespace crop4d::fusion
