// Association precision against a fake true geometry (truth_test_util.h): the depth sampling
// and its edge test, pair types, and the counting of correct, incorrect and unknown matches.

#include "crop4d/eval/association_eval.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/eval/truth_test_util.h"

namespace crop4d::eval {
namespace {

using association::CrossMatch;
using association::PassAssociation;
using association::PassRef;
using testing::FakeTruth;

TEST(SampleDepthTest, InterpolatesAPlaneSeenAtAGrazingAngle) {
  const geometry::PinholeRadTan camera = testing::TestCamera();
  const geometry::Rigid3 pose = testing::DownwardCamera(0.0, 0.0);
  const testing::FakeScene scene;
  const DepthImage depth = scene.Render(camera, pose);
  const TruePointOptions options;
  int checked = 0;
  // Sub-pixel positions over the ground part of the image, up to ~10 m away.
  for (double v = 70.3; v < 238.0; v += 7.1) {
    for (double u = 3.7; u < 316.0; u += 11.3) {
      const Eigen::Vector2d pixel(u, v);
      Eigen::Vector3d ray;
      ASSERT_TRUE(camera.Unproject(pixel, &ray));
      const double expected = scene.Depth(pose, ray);
      double z = 0.0;
      const TruePointStatus status = SampleDepth(depth, pixel, options, &z);
      if (expected > 10.0) continue;
      ASSERT_EQ(status, TruePointStatus::kOk) << u << " " << v << " depth " << expected;
      EXPECT_NEAR(z, expected, 1e-3 * expected) << u << " " << v;
      // The true point lies on the ground.
      const TruePointResult r = TruePointInImage(depth, camera, pose, pixel, options);
      ASSERT_TRUE(r.ok());
      EXPECT_NEAR(r.point_world.z(), 0.0, 2e-3 * expected);
      ++checked;
    }
  }
  EXPECT_GT(checked, 200);
}

TEST(SampleDepthTest, RejectsEdgesSkyAndTheBorder) {
  const geometry::PinholeRadTan camera = testing::TestCamera();
  testing::FakeScene scene;
  scene.box_min = Eigen::Vector2d(-0.25, 1.8);
  scene.box_max = Eigen::Vector2d(0.25, 2.3);
  const geometry::Rigid3 pose = testing::DownwardCamera(0.0, 0.0);
  const DepthImage depth = scene.Render(camera, pose);
  const TruePointOptions options;
  double z = 0.0;
  // The box's far edge: its top corner projects onto the ground behind it.
  Eigen::Vector2d edge;
  ASSERT_TRUE(camera.Project(pose.Inverse() * Eigen::Vector3d(0.0, 2.3, 0.3), &edge));
  EXPECT_EQ(SampleDepth(depth, edge, options, &z), TruePointStatus::kDepthEdge);
  // The middle of the box's top is one surface.
  Eigen::Vector2d top;
  ASSERT_TRUE(camera.Project(pose.Inverse() * Eigen::Vector3d(0.0, 2.05, 0.3), &top));
  ASSERT_EQ(SampleDepth(depth, top, options, &z), TruePointStatus::kOk);
  const TruePointResult r = TruePointInImage(depth, camera, pose, top, options);
  EXPECT_NEAR(r.point_world.z(), 0.3, 2e-3);
  // Sky at the top of the image, pixels without a 3×3 neighbourhood, NaN.
  EXPECT_EQ(SampleDepth(depth, Eigen::Vector2d(160, 2), options, &z), TruePointStatus::kNoSurface);
  EXPECT_EQ(SampleDepth(depth, Eigen::Vector2d(0.2, 200), options, &z),
            TruePointStatus::kNoSurface);
  EXPECT_EQ(SampleDepth(depth, Eigen::Vector2d(319.0, 200), options, &z),
            TruePointStatus::kNoSurface);
  EXPECT_EQ(SampleDepth(depth, Eigen::Vector2d(NAN, 200), options, &z),
            TruePointStatus::kNoSurface);
  // A camera of another size than the depth map has no truth.
  geometry::PinholeRadTan other = camera;
  other.width = 640;
  EXPECT_EQ(TruePointInImage(depth, other, pose, top, options).status, TruePointStatus::kNoTruth);
}

TEST(PairTypeTest, ClassifiesRowsSessionsAndRain) {
  SessionTimeline timeline;
  timeline.sessions = {"s1", "s2", "s3", "s4"};
  timeline.rain_before = {true, false, true, false};  // rain before s1 (irrelevant) and s3
  EXPECT_FALSE(timeline.RainBetween("s1", "s2"));
  EXPECT_TRUE(timeline.RainBetween("s2", "s3"));
  EXPECT_TRUE(timeline.RainBetween("s3", "s2"));
  EXPECT_TRUE(timeline.RainBetween("s1", "s4"));
  EXPECT_FALSE(timeline.RainBetween("s3", "s4"));
  EXPECT_FALSE(timeline.RainBetween("s3", "s3"));
  EXPECT_FALSE(timeline.RainBetween("s1", "unknown"));
  EXPECT_EQ(timeline.IndexOf("s3"), 2);
  EXPECT_EQ(timeline.IndexOf("x"), -1);

  const PassLayout north{0, 1}, north2{1, 1}, south{1, -1};
  EXPECT_EQ(ClassifyPair({"s1", "row00"}, north, {"s1", "row01"}, north2, timeline),
            PairType::kCrossRowSameDirection);
  EXPECT_EQ(ClassifyPair({"s1", "row00"}, north, {"s1", "row01"}, south, timeline),
            PairType::kCrossRowOppositeDirection);
  EXPECT_EQ(ClassifyPair({"s1", "row00"}, north, {"s2", "row00"}, south, timeline),
            PairType::kCrossSession);
  EXPECT_EQ(ClassifyPair({"s2", "row00"}, north, {"s3", "row00"}, north, timeline),
            PairType::kCrossSessionAfterRain);
  EXPECT_EQ(ClassifyPair({"s4", "row00"}, north, {"s3", "row00"}, north, timeline),
            PairType::kCrossSession);
  EXPECT_STREQ(PairTypeName(PairType::kCrossSessionAfterRain), "cross_session_after_rain");
  EXPECT_STREQ(PairTypeName(PairType::kCrossRowOppositeDirection), "cross_row_opposite_direction");
}

class AssociationEvalTest : public ::testing::Test {
 protected:
  AssociationEvalTest() {
    timeline_.sessions = {"s1", "s2"};
    timeline_.rain_before = {false, true};
    // Session s1: two rows driven north (row00) and south (row01); s2: row00 north.
    truth_.AddImage("s1", 100, testing::DownwardCamera(0.0, 0.0));
    truth_.AddImage("s1", 101, testing::DownwardCamera(0.0, 0.3));
    truth_.AddImage("s1", 200, testing::DownwardCamera(0.9, 4.5, M_PI));
    truth_.AddImage("s2", 100, testing::DownwardCamera(0.05, 0.1));
  }

  // A match between the pixels of world points pa (in image a) and pb (in image b).
  CrossMatch Match(const std::string& sa, Timestamp ta, const Eigen::Vector3d& pa,
                   const std::string& sb, Timestamp tb, const Eigen::Vector3d& pb) {
    CrossMatch m;
    m.t_a = ta;
    m.t_b = tb;
    Eigen::Vector2d xa, xb;
    EXPECT_TRUE(truth_.Project(sa, ta, pa, &xa));
    EXPECT_TRUE(truth_.Project(sb, tb, pb, &xb));
    EXPECT_TRUE(truth_.camera.IsInImage(xa, 2.0) && truth_.camera.IsInImage(xb, 2.0))
        << xa.transpose() << " / " << xb.transpose();
    m.xa = static_cast<float>(xa.x());
    m.ya = static_cast<float>(xa.y());
    m.xb = static_cast<float>(xb.x());
    m.yb = static_cast<float>(xb.y());
    return m;
  }

  AssociationInput Input(const std::string& file, const PassRef& a, const PassLayout& la,
                         const PassRef& b, const PassLayout& lb, const std::string& method) {
    AssociationInput input;
    input.file = file;
    input.association.a = a;
    input.association.b = b;
    input.association.method = method;
    input.layout_a = la;
    input.layout_b = lb;
    return input;
  }

  SessionTimeline timeline_;
  FakeTruth truth_;
};

TEST_F(AssociationEvalTest, CountsCorrectIncorrectAndUnknownMatches) {
  const PassLayout row0{0, 1}, row1{1, -1};
  // Cross-row, opposite directions (robust): 3 correct (one 1 cm off: still within 2 cm),
  // 1 incorrect (5 cm off).
  AssociationInput cross_row =
      Input("robust/a.bin", {"s1", "row00"}, row0, {"s1", "row01"}, row1, "robust");
  for (const Eigen::Vector3d& p : {Eigen::Vector3d(0.3, 2.5, 0.0), Eigen::Vector3d(0.6, 2.8, 0.0),
                                   Eigen::Vector3d(0.4, 3.0, 0.0)}) {
    cross_row.association.matches.push_back(Match("s1", 100, p, "s1", 200, p));
  }
  cross_row.association.matches.push_back(
      Match("s1", 101, Eigen::Vector3d(0.5, 2.6, 0), "s1", 200, Eigen::Vector3d(0.51, 2.6, 0)));
  cross_row.association.matches.push_back(
      Match("s1", 101, Eigen::Vector3d(0.5, 2.6, 0), "s1", 200, Eigen::Vector3d(0.55, 2.6, 0)));
  // Cross-session after rain (naive): 1 correct, 2 incorrect, and unknowns: an image without
  // truth, a keypoint in the sky, a keypoint outside the image.
  AssociationInput cross_session =
      Input("naive/b.bin", {"s1", "row00"}, row0, {"s2", "row00"}, row0, "naive");
  PassAssociation& cs = cross_session.association;
  cs.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(-0.2, 2.2, 0), "s2", 100, Eigen::Vector3d(-0.2, 2.2, 0)));
  cs.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(-0.2, 2.2, 0), "s2", 100, Eigen::Vector3d(0.2, 2.2, 0)));
  cs.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(0.0, 3.0, 0), "s2", 100, Eigen::Vector3d(0.0, 2.0, 0)));
  CrossMatch no_truth = cs.matches[0];
  no_truth.t_b = 999;  // no such image
  cs.matches.push_back(no_truth);
  CrossMatch sky = cs.matches[0];
  sky.ya = 1.0f;
  cs.matches.push_back(sky);
  CrossMatch outside = cs.matches[0];
  outside.xb = -20.0f;
  cs.matches.push_back(outside);
  // A file that could not be read.
  AssociationInput broken;
  broken.file = "robust/broken.bin";
  broken.error = "corrupt: checksum mismatch";

  const AssociationEval eval =
      EvaluateAssociations({cross_row, cross_session, broken}, timeline_, truth_);
  ASSERT_EQ(eval.files.size(), 3u);
  const AssociationFileEval& f0 = eval.files[0];
  ASSERT_TRUE(f0.ok()) << f0.error;
  EXPECT_EQ(f0.type, PairType::kCrossRowOppositeDirection);
  EXPECT_EQ(f0.method, "robust");
  EXPECT_EQ(f0.counts.matches, 5);
  EXPECT_EQ(f0.counts.correct, 4);
  EXPECT_EQ(f0.counts.incorrect, 1);
  EXPECT_EQ(f0.counts.unknown, 0);
  EXPECT_DOUBLE_EQ(f0.counts.Precision(), 0.8);
  EXPECT_LT(f0.median_distance_m, 0.005);
  EXPECT_GT(f0.p90_distance_m, 0.02);

  const AssociationFileEval& f1 = eval.files[1];
  ASSERT_TRUE(f1.ok()) << f1.error;
  EXPECT_EQ(f1.type, PairType::kCrossSessionAfterRain);
  EXPECT_EQ(f1.counts.matches, 6);
  EXPECT_EQ(f1.counts.correct, 1);
  EXPECT_EQ(f1.counts.incorrect, 2);
  EXPECT_EQ(f1.counts.unknown, 3);
  EXPECT_EQ(f1.counts.unknown_no_truth, 1);
  EXPECT_EQ(f1.counts.unknown_no_surface, 2);
  EXPECT_EQ(f1.counts.unknown_depth_edge, 0);
  EXPECT_NEAR(f1.counts.Precision(), 1.0 / 3.0, 1e-12);
  EXPECT_EQ(f1.counts.within_coarse, 1);  // the wrong ones are 40 cm and 1 m off
  EXPECT_NEAR(f1.counts.CoarsePrecision(), 1.0 / 3.0, 1e-12);

  EXPECT_FALSE(eval.files[2].ok());
  EXPECT_EQ(eval.num_failed, 1);

  // Pooled: one group per (type, method), in type order; one line per method.
  ASSERT_EQ(eval.groups.size(), 2u);
  EXPECT_EQ(eval.groups[0].type, PairType::kCrossRowOppositeDirection);
  EXPECT_EQ(eval.groups[0].method, "robust");
  EXPECT_EQ(eval.groups[0].counts.correct, 4);
  EXPECT_EQ(eval.groups[1].type, PairType::kCrossSessionAfterRain);
  EXPECT_EQ(eval.groups[1].method, "naive");
  ASSERT_EQ(eval.methods.size(), 2u);
  EXPECT_EQ(eval.methods[0].method, "naive");
  EXPECT_EQ(eval.methods[1].method, "robust");
  EXPECT_EQ(eval.methods[1].files, 1);

  // Each image's truth asked for once, session by session in timeline order, in time order.
  EXPECT_EQ(eval.images, 5);
  const std::vector<std::pair<std::string, Timestamp>> expected = {
      {"s1", 100}, {"s1", 101}, {"s1", 200}, {"s2", 100}};
  EXPECT_EQ(truth_.depth_calls, expected);
}

TEST_F(AssociationEvalTest, DepthEdgesAreUnknownAndTheThresholdIsAnOption) {
  truth_.scene.box_min = Eigen::Vector2d(-0.25, 1.8);
  truth_.scene.box_max = Eigen::Vector2d(0.25, 2.3);
  AssociationInput input =
      Input("robust/c.bin", {"s1", "row00"}, {0, 1}, {"s1", "row01"}, {1, 1}, "robust");
  // The far edge of the box seen from image 100 against a ground point from image 101.
  input.association.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(0.0, 2.3, 0.3), "s1", 101, Eigen::Vector3d(0.6, 2.9, 0.0)));
  // 3 cm apart on the ground.
  input.association.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(0.6, 2.9, 0.0), "s1", 101, Eigen::Vector3d(0.63, 2.9, 0.0)));
  const AssociationEval strict = EvaluateAssociations({input}, timeline_, truth_);
  ASSERT_TRUE(strict.files[0].ok());
  EXPECT_EQ(strict.files[0].type, PairType::kCrossRowSameDirection);
  EXPECT_EQ(strict.files[0].counts.unknown_depth_edge, 1);
  EXPECT_EQ(strict.files[0].counts.incorrect, 1);

  AssociationEvalOptions loose;
  loose.max_distance_m = 0.05;
  const AssociationEval eval = EvaluateAssociations({input}, timeline_, truth_, loose);
  EXPECT_EQ(eval.files[0].counts.correct, 1);
  EXPECT_EQ(eval.files[0].counts.incorrect, 0);
}

TEST_F(AssociationEvalTest, MatchesNearTheVehicleAreCountedApart) {
  AssociationInput input =
      Input("naive/d.bin", {"s1", "row00"}, {0, 1}, {"s2", "row00"}, {0, 1}, "naive");
  // Seen from image s1/100 (1.5 m up, 35° down): y = 2.3 and 2.6 m lie under 3.5 m deep, y = 4 m
  // beyond; one correct match at each, and a wrong one near.
  for (const double y : {2.3, 2.6, 4.0}) {
    const Eigen::Vector3d p(0.1, y, 0.0);
    input.association.matches.push_back(Match("s1", 100, p, "s2", 100, p));
  }
  input.association.matches.push_back(
      Match("s1", 100, Eigen::Vector3d(-0.2, 2.4, 0), "s2", 100, Eigen::Vector3d(0.1, 2.4, 0)));
  AssociationEvalOptions options;
  options.near_depth_m = 3.5;
  const AssociationEval eval = EvaluateAssociations({input}, timeline_, truth_, options);
  ASSERT_TRUE(eval.files[0].ok());
  const MatchCounts& c = eval.files[0].counts;
  EXPECT_EQ(c.correct, 3);
  EXPECT_EQ(c.incorrect, 1);
  EXPECT_EQ(c.known_near, 3);
  EXPECT_EQ(c.correct_near, 2);
  EXPECT_NEAR(c.NearPrecision(), 2.0 / 3.0, 1e-12);
  // Pooled like the other counts.
  ASSERT_EQ(eval.groups.size(), 1u);
  EXPECT_EQ(eval.groups[0].counts.correct_near, 2);
  EXPECT_EQ(eval.methods[0].counts.known_near, 3);
  // Everything is near under a deep enough bound.
  options.near_depth_m = 10.0;
  EXPECT_EQ(EvaluateAssociations({input}, timeline_, truth_, options).files[0].counts.correct_near,
            3);
  options.near_depth_m = 0;
  EXPECT_NE(options.Check(), "");
}

TEST_F(AssociationEvalTest, NoInputGivesAnEmptyEvaluation) {
  const AssociationEval eval = EvaluateAssociations({}, timeline_, truth_);
  EXPECT_TRUE(eval.files.empty());
  EXPECT_TRUE(eval.groups.empty());
  EXPECT_EQ(eval.images, 0);
  EXPECT_TRUE(std::isnan(MatchCounts{}.Precision()));
  EXPECT_TRUE(std::isnan(MatchCounts{}.NearPrecision()));
}

}  // namespace
}  // namespace crop4d::eval
