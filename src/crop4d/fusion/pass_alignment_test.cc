#include "crop4d/fusion/pass_alignment.h"

#include <gtest/gtest.h>

#include <random>

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

}  // namespace
}  // namespace crop4d::fusion
