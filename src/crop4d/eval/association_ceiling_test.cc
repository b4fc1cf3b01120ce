// The association ceiling against a fake true geometry (truth_test_util.h): the partner count
// against a brute-force one, the union of the methods' image pairs, the order in which the true
// geometry is asked for, and passes whose keypoints cannot be loaded.

#include "crop4d/eval/association_ceiling.h"

#include <gtest/gtest.h>

#include <map>
#include <random>

#include "crop4d/core/error.h"
#include "crop4d/eval/truth_test_util.h"

namespace crop4d::eval {
namespace {

using association::CrossMatch;
using association::PassRef;
using testing::FakeTruth;

KeypointTruth Known(double x, double y, double z, double depth) {
  return {true, Eigen::Vector3d(x, y, z), depth};
}

TEST(CountPartnersTest, CountsTheKeypointsWithAPartnerWithinTheMatchDistance) {
  const std::vector<KeypointTruth> a = {
      Known(0.0, 0.0, 0.0, 2.0),  // partner 1.58 cm away (the last of b), near
      Known(1.0, 0.0, 0.0, 6.0),  // partner 1.58 cm away, beyond 5 m
      {},                         // unknown: not counted at all
      Known(3.0, 0.0, 0.0, 1.0),  // nearest 5 cm away: no partner
  };
  // Points with the same x as a's first but far in y come first in x order: the search must
  // look past them.
  const std::vector<KeypointTruth> b = {
      Known(0.0, 1.0, 0.0, 2.0),
      Known(0.0, -1.0, 0.0, 2.0),
      Known(1.015, 0.005, 0.0, 6.0),
      Known(3.05, 0.0, 0.0, 1.0),
      {},
      Known(0.005, 0.015, 0.0, 2.0),
  };
  const AssociationEvalOptions options;
  CeilingCounts counts;
  CountPartners(a, b, Eigen::Vector3d::Zero(), false, options, &counts);
  EXPECT_EQ(counts.keypoints, 3);
  EXPECT_EQ(counts.partners, 2);
  EXPECT_EQ(counts.partners_near, 1);
  EXPECT_EQ(counts.chance_near, 0);
  // Shifted 4 cm west, b's fourth point lies 1 cm from a's last one: a partner by chance only.
  CeilingCounts chance;
  CountPartners(a, b, Eigen::Vector3d(-0.04, 0.0, 0.0), true, options, &chance);
  EXPECT_EQ(chance.chance_near, 1);
  EXPECT_EQ(chance.keypoints, 0);
  EXPECT_EQ(chance.partners, 0);
}

TEST(CountPartnersTest, EqualsABruteForceCount) {
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> xy(0.0, 0.5), z(-0.01, 0.01), depth(1.0, 9.0);
  std::vector<KeypointTruth> a(400), b(500);
  for (std::vector<KeypointTruth>* side : {&a, &b}) {
    for (KeypointTruth& p : *side) p = Known(xy(rng), xy(rng), z(rng), depth(rng));
  }
  a[7].ok = b[9].ok = false;
  const AssociationEvalOptions options;
  for (const Eigen::Vector3d& shift : {Eigen::Vector3d(0, 0, 0), Eigen::Vector3d(0.1, 0, 0)}) {
    std::int64_t expected = 0, expected_near = 0;
    for (const KeypointTruth& p : a) {
      if (!p.ok) continue;
      for (const KeypointTruth& q : b) {
        if (q.ok && (p.point - q.point - shift).norm() <= options.max_distance_m) {
          ++expected;
          if (p.depth_m <= options.near_depth_m) ++expected_near;
          break;
        }
      }
    }
    CeilingCounts counts;
    CountPartners(a, b, shift, false, options, &counts);
    EXPECT_GT(expected, 50);
    EXPECT_LT(expected, 399);
    EXPECT_EQ(counts.keypoints, 399);
    EXPECT_EQ(counts.partners, expected);
    EXPECT_EQ(counts.partners_near, expected_near);
  }
}

class AssociationCeilingTest : public ::testing::Test {
 protected:
  AssociationCeilingTest() {
    timeline_.sessions = {"s1", "s2"};
    timeline_.rain_before = {false, false};
    // Session s1: row00 north (images at t 100, 101), row01 south (t 200); s2: row00 north
    // (t 300). All look down at the same ground around (0.5, 2.5).
    AddImage({"s1", "row00"}, 100, testing::DownwardCamera(0.0, 0.0));
    AddImage({"s1", "row00"}, 101, testing::DownwardCamera(0.0, 0.3));
    AddImage({"s1", "row01"}, 200, testing::DownwardCamera(0.9, 4.5, M_PI));
    AddImage({"s2", "row00"}, 300, testing::DownwardCamera(0.05, 0.1));
  }

  void AddImage(const PassRef& pass, Timestamp t, const geometry::Rigid3& pose) {
    truth_.AddImage(pass.session, t, pose);
    keypoints_[pass].times.push_back(t);
    keypoints_[pass].pixels.emplace_back();
  }

  // Keypoints at the pixels of ground points `points` in image `image` of `pass`.
  void AddKeypoints(const PassRef& pass, int image, const std::vector<Eigen::Vector3d>& points) {
    PassKeypoints& k = keypoints_[pass];
    for (const Eigen::Vector3d& p : points) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(truth_.Project(pass.session, k.times[image], p, &pixel));
      ASSERT_TRUE(truth_.camera.IsInImage(pixel, 2.0)) << pixel.transpose();
      k.pixels[image].push_back(pixel);
    }
  }

  AssociationInput Input(const PassRef& a, const PassLayout& la, const PassRef& b,
                         const PassLayout& lb, const std::string& method,
                         const std::vector<std::pair<int, int>>& image_pairs) {
    AssociationInput input;
    input.file = method + "/" + a.session + "_" + a.pass + "~" + b.session + "_" + b.pass;
    input.association.a = a;
    input.association.b = b;
    input.association.method = method;
    input.layout_a = la;
    input.layout_b = lb;
    for (const auto& [ia, ib] : image_pairs) {
      CrossMatch m;
      m.image_a = ia;
      m.image_b = ib;
      m.t_a = keypoints_[a].times[ia];
      m.t_b = keypoints_[b].times[ib];
      input.association.matches.push_back(m);
    }
    return input;
  }

  PassKeypointsLoader Loader() {
    return [this](const PassRef& ref) {
      ++loads_[ref];
      const auto it = keypoints_.find(ref);
      if (it == keypoints_.end()) throw InputError(ref.pass + "/features.bin: no such file");
      return it->second;
    };
  }

  SessionTimeline timeline_;
  FakeTruth truth_;
  std::map<PassRef, PassKeypoints> keypoints_;
  std::map<PassRef, int> loads_;
};

TEST_F(AssociationCeilingTest, CountsThePartnersOfTheImagePairsOfAnyMethod) {
  const PassRef r0{"s1", "row00"}, r1{"s1", "row01"}, s2{"s2", "row00"};
  const PassLayout north{0, 1}, south{1, -1};
  // Image 0 of s1/row00 sees four ground points; row01 sees two of them (1 and 5 mm off) and one
  // 5 cm off; image 1 of row00 sees two others, one of which row01 also sees.
  const Eigen::Vector3d p1(0.3, 2.5, 0), p2(0.6, 2.8, 0), p3(0.4, 3.0, 0), p4(0.2, 2.2, 0);
  AddKeypoints(r0, 0, {p1, p2, p3, p4});
  AddKeypoints(r0, 1, {Eigen::Vector3d(0.1, 2.9, 0), Eigen::Vector3d(0.7, 3.2, 0)});
  AddKeypoints(r1, 0,
               {p1 + Eigen::Vector3d(0.01, 0, 0), p2 + Eigen::Vector3d(0, 0.005, 0),
                p3 + Eigen::Vector3d(0.05, 0, 0), Eigen::Vector3d(0.7, 3.2, 0)});
  // s2 sees p1 and p4 exactly.
  AddKeypoints(s2, 0, {p4, p1});

  // row00 ~ row01: robust matched image pair (0, 0), naive (0, 0) and (1, 0): the ceiling counts
  // the union, (0, 0) once.
  const AssociationInput robust = Input(r0, north, r1, south, "robust", {{0, 0}, {0, 0}});
  const AssociationInput naive = Input(r0, north, r1, south, "naive", {{0, 0}, {1, 0}});
  const AssociationInput session = Input(r0, north, s2, north, "robust", {{0, 0}});
  AssociationInput broken;
  broken.error = "corrupt";
  const AssociationCeiling ceiling =
      EvaluateCeiling({session, robust, broken, naive}, timeline_, truth_, Loader());
  EXPECT_TRUE(ceiling.errors.empty());
  ASSERT_EQ(ceiling.groups.size(), 2u);
  const CeilingGroup& rows = ceiling.groups[0];
  EXPECT_EQ(rows.type, PairType::kCrossRowOppositeDirection);
  EXPECT_EQ(rows.pass_pairs, 1);
  EXPECT_EQ(rows.counts.image_pairs, 2);
  EXPECT_EQ(rows.counts.keypoints, 4 + 2);
  EXPECT_EQ(rows.counts.partners, 2 + 1);       // p1, p2; and (0.7, 3.2)
  EXPECT_EQ(rows.counts.partners_near, 2 + 1);  // all about 3 m deep
  EXPECT_EQ(rows.counts.chance_near, 0);
  const CeilingGroup& sessions = ceiling.groups[1];
  EXPECT_EQ(sessions.type, PairType::kCrossSession);
  EXPECT_EQ(sessions.counts.image_pairs, 1);
  EXPECT_EQ(sessions.counts.keypoints, 4);
  EXPECT_EQ(sessions.counts.partners, 2);  // p1, p4

  // Each pass loaded once; each needed image's depth asked once, s1 before s2, in time order.
  for (const auto& [ref, n] : loads_) EXPECT_EQ(n, 1) << ref.pass;
  const std::vector<std::pair<std::string, Timestamp>> expected = {
      {"s1", 100}, {"s1", 101}, {"s1", 200}, {"s2", 300}};
  EXPECT_EQ(truth_.depth_calls, expected);
}

TEST_F(AssociationCeilingTest, APassWithoutKeypointsIsReportedAndTheOthersCounted) {
  const PassRef r0{"s1", "row00"}, r1{"s1", "row01"}, missing{"s2", "row07"};
  const PassLayout north{0, 1}, south{1, -1};
  AddKeypoints(r0, 0, {Eigen::Vector3d(0.3, 2.5, 0)});
  AddKeypoints(r1, 0, {Eigen::Vector3d(0.3, 2.5, 0)});
  AssociationInput to_missing = Input(r0, north, r0, north, "robust", {{0, 0}});
  to_missing.association.b = missing;
  const AssociationInput rows = Input(r0, north, r1, south, "robust", {{0, 0}});
  // An image index beyond the pass's images is an error too, not a silent zero.
  const PassRef r2{"s1", "row02"};
  AddImage(r2, 210, testing::DownwardCamera(0.3, 0.5));
  AddKeypoints(r2, 0, {Eigen::Vector3d(0.3, 2.5, 0)});
  AssociationInput beyond = Input(r1, south, r2, north, "robust", {{0, 0}});
  beyond.association.matches[0].image_b = 9;
  const AssociationCeiling ceiling =
      EvaluateCeiling({to_missing, rows, beyond}, timeline_, truth_, Loader());
  ASSERT_EQ(ceiling.errors.size(), 2u);
  EXPECT_NE(ceiling.errors[0].find("image 9"), std::string::npos) << ceiling.errors[0];
  EXPECT_NE(ceiling.errors[1].find("s2/row07"), std::string::npos) << ceiling.errors[1];
  EXPECT_NE(ceiling.errors[1].find("features.bin"), std::string::npos) << ceiling.errors[1];
  ASSERT_EQ(ceiling.groups.size(), 1u);
  EXPECT_EQ(ceiling.groups[0].counts.partners, 1);
}

}  // namespace
}  // namespace crop4d::eval
