#include "crop4d/fusion/cross_pass_tracks.h"

#include <gtest/gtest.h>

#include <random>
#include <set>

namespace crop4d::fusion {
namespace {

using features::Observation;

std::vector<PassFeature> Features(std::initializer_list<PassFeature> list) { return list; }

TEST(CrossPassTracksTest, PassLandmarksAloneStayApart) {
  CrossPassTracks tracks;
  tracks.AddPassLandmark(0, {{0, 3}, {1, 4}, {2, 5}});
  tracks.AddPassLandmark(1, {{0, 7}, {1, 8}});
  const CrossPassTracks::Result r = tracks.Join();
  ASSERT_EQ(r.landmarks.size(), 2u);
  EXPECT_EQ(r.landmarks[0], Features({{0, 0, 3}, {0, 1, 4}, {0, 2, 5}}));
  EXPECT_EQ(r.landmarks[1], Features({{1, 0, 7}, {1, 1, 8}}));
  EXPECT_EQ(r.num_conflicting_matches, 0);
}

TEST(CrossPassTracksTest, CrossMatchJoinsTheTracksOfBothFeatures) {
  CrossPassTracks tracks;
  tracks.AddPassLandmark(0, {{0, 3}, {1, 4}, {2, 5}});
  tracks.AddPassLandmark(1, {{0, 7}, {1, 8}});
  // Feature (1, 4) of pass 0 is in a cloud track that also holds (3, 9), not a landmark.
  tracks.AddCrossMatch({0, 1, 4}, {1, 1, 8}, 10.0f, {{1, 4}, {3, 9}}, {{0, 7}, {1, 8}});
  const CrossPassTracks::Result r = tracks.Join();
  ASSERT_EQ(r.landmarks.size(), 1u);
  EXPECT_EQ(r.landmarks[0],
            Features({{0, 0, 3}, {0, 1, 4}, {0, 2, 5}, {0, 3, 9}, {1, 0, 7}, {1, 1, 8}}));
}

TEST(CrossPassTracksTest, TheBetterOfTwoConflictingMatchesWins) {
  CrossPassTracks tracks;
  // Feature 0 of pass 0's image 0 matched to two features of pass 1's image 0: one 3D point
  // cannot be both. Added worse first: the order of addition must not matter.
  tracks.AddCrossMatch({0, 0, 0}, {1, 0, 2}, 30.0f, {}, {});
  tracks.AddCrossMatch({0, 0, 0}, {1, 0, 1}, 20.0f, {}, {});
  const CrossPassTracks::Result r = tracks.Join();
  ASSERT_EQ(r.landmarks.size(), 1u);
  EXPECT_EQ(r.landmarks[0], Features({{0, 0, 0}, {1, 0, 1}}));
  EXPECT_EQ(r.num_conflicting_matches, 1);
}

TEST(CrossPassTracksTest, UnusedPassesAndTheirMatchesAreLeftOut) {
  CrossPassTracks tracks;
  tracks.AddPassLandmark(0, {{0, 3}, {1, 4}});
  tracks.AddPassLandmark(1, {{0, 7}, {1, 8}});
  tracks.AddPassLandmark(2, {{0, 1}, {1, 1}});
  tracks.AddCrossMatch({0, 0, 3}, {1, 0, 7}, 5.0f, {{0, 3}, {1, 4}}, {{0, 7}, {1, 8}});
  tracks.AddCrossMatch({0, 0, 3}, {2, 0, 1}, 6.0f, {{0, 3}, {1, 4}}, {{0, 1}, {1, 1}});
  const CrossPassTracks::Result all = tracks.Join();
  ASSERT_EQ(all.landmarks.size(), 1u);
  EXPECT_EQ(all.landmarks[0].size(), 6u);
  const CrossPassTracks::Result some = tracks.Join({true, false, true});
  ASSERT_EQ(some.landmarks.size(), 1u);
  EXPECT_EQ(some.landmarks[0], Features({{0, 0, 3}, {0, 1, 4}, {2, 0, 1}, {2, 1, 1}}));
}

// Random seasons: every landmark sees an image at most once, has two or more observations,
// sorted; each used node is in one landmark; the result does not depend on the order in which
// matches of distinct distances are added.
TEST(CrossPassTracksTest, RandomGraphsGiveConsistentOrderFreeLandmarks) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 20; ++trial) {
    constexpr int kPasses = 3, kImages = 6, kFeatures = 8;
    std::uniform_int_distribution<int> pass(0, kPasses - 1), image(0, kImages - 1),
        feature(0, kFeatures - 1);
    CrossPassTracks forward, backward;
    for (int p = 0; p < kPasses; ++p) {
      for (int f = 0; f < kFeatures; ++f) {
        // A track over consecutive images, one feature per image.
        const int first = image(rng);
        std::vector<Observation> obs;
        for (int i = first; i < std::min(kImages, first + 3); ++i) obs.push_back({i, f});
        forward.AddPassLandmark(p, obs);
        backward.AddPassLandmark(p, obs);
      }
    }
    struct M {
      PassFeature a, b;
      float distance;
    };
    std::vector<M> matches;
    for (int m = 0; m < 40; ++m) {
      const int pa = pass(rng);
      const int pb = (pa + 1 + pass(rng) % (kPasses - 1)) % kPasses;
      matches.push_back(
          {{pa, image(rng), feature(rng)}, {pb, image(rng), feature(rng)}, static_cast<float>(m)});
    }
    for (const M& m : matches) forward.AddCrossMatch(m.a, m.b, m.distance, {}, {});
    for (auto it = matches.rbegin(); it != matches.rend(); ++it) {
      backward.AddCrossMatch(it->a, it->b, it->distance, {}, {});
    }
    const CrossPassTracks::Result r = forward.Join();
    std::set<std::tuple<int, int, int>> seen;
    for (const std::vector<PassFeature>& landmark : r.landmarks) {
      ASSERT_GE(landmark.size(), 2u);
      for (std::size_t k = 1; k < landmark.size(); ++k) {
        const PassFeature& x = landmark[k - 1];
        const PassFeature& y = landmark[k];
        EXPECT_TRUE(x.pass < y.pass || (x.pass == y.pass && x.image < y.image));
      }
      for (const PassFeature& f : landmark) {
        EXPECT_TRUE(seen.insert({f.pass, f.image, f.feature}).second);
      }
    }
    const CrossPassTracks::Result b = backward.Join();
    EXPECT_EQ(b.num_conflicting_matches, r.num_conflicting_matches);
    std::set<std::vector<std::tuple<int, int, int>>> set_r, set_b;
    for (const auto* result : {&r, &b}) {
      auto& out = result == &r ? set_r : set_b;
      for (const auto& landmark : result->landmarks) {
        std::vector<std::tuple<int, int, int>> l;
        for (const PassFeature& f : landmark) l.emplace_back(f.pass, f.image, f.feature);
        out.insert(l);
      }
    }
    EXPECT_EQ(set_r, set_b);
  }
}

}  // namespace
}  // namespace crop4d::fusion
