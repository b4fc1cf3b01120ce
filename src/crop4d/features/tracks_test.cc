#include "crop4d/features/tracks.h"

#include <gtest/gtest.h>

namespace crop4d::features {
namespace {

TrackEdge Edge(int image_a, int feature_a, int image_b, int feature_b, float distance = 1) {
  return {{image_a, feature_a}, {image_b, feature_b}, distance};
}

TrackBuilder::Options MinLength(int n) {
  TrackBuilder::Options options;
  options.min_track_length = n;
  return options;
}

TEST(TracksTest, DefaultAcceptsLandmarksSeenInMoreThanSixImages) {
  const TrackBuilder::Options options;
  EXPECT_EQ(options.min_track_length, 7);
  // A chain over 7 images is accepted, one over 6 is not.
  std::vector<TrackEdge> edges;
  for (int i = 0; i < 6; ++i) edges.push_back(Edge(i, 0, i + 1, 0));  // 7 images
  for (int i = 0; i < 5; ++i) edges.push_back(Edge(i, 1, i + 1, 1));  // 6 images
  TrackBuilder::Summary summary;
  const std::vector<Track> tracks =
      TrackBuilder(options).Build(std::vector<int>(7, 2), edges, &summary);
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_EQ(tracks[0].size(), 7u);
  EXPECT_EQ(tracks[0].observations[0], (Observation{0, 0}));
  EXPECT_EQ(summary.num_tracks, 2);
  EXPECT_EQ(summary.num_accepted_tracks, 1);
  EXPECT_DOUBLE_EQ(summary.mean_accepted_track_length, 7.0);
}

TEST(TracksTest, UnionIsTransitive) {
  // 0:3 ↔ 1:5 and 1:5 ↔ 2:0 and 2:0 ↔ 4:1 (3 never sees it); a separate 0:1 ↔ 3:2.
  const std::vector<TrackEdge> edges = {Edge(0, 3, 1, 5), Edge(2, 0, 4, 1), Edge(1, 5, 2, 0),
                                        Edge(0, 1, 3, 2)};
  TrackBuilder::Summary summary;
  const std::vector<Track> tracks =
      TrackBuilder(MinLength(2)).Build(std::vector<int>(5, 6), edges, &summary);
  ASSERT_EQ(tracks.size(), 2u);
  // Sorted by first observation: (0,1) before (0,3).
  EXPECT_EQ(tracks[0].observations, (std::vector<Observation>{{0, 1}, {3, 2}}));
  EXPECT_EQ(tracks[1].observations, (std::vector<Observation>{{0, 3}, {1, 5}, {2, 0}, {4, 1}}));
  EXPECT_EQ(summary.num_components, 2);
  EXPECT_EQ(summary.num_inconsistent_components, 0);
}

TEST(TracksTest, MinLengthFilter) {
  const std::vector<TrackEdge> edges = {Edge(0, 0, 1, 0), Edge(1, 0, 2, 0), Edge(0, 1, 1, 1)};
  EXPECT_EQ(TrackBuilder(MinLength(2)).Build({2, 2, 2}, edges).size(), 2u);
  EXPECT_EQ(TrackBuilder(MinLength(3)).Build({2, 2, 2}, edges).size(), 1u);
  EXPECT_EQ(TrackBuilder(MinLength(4)).Build({2, 2, 2}, edges).size(), 0u);
}

// A chain 0:0 – 1:0 – 2:0 – 3:0 plus a weak wrong match 2:0 – 1:1, and 1:1 – 0:1 making the
// component hold features 0 and 1 of images 0 and 1.
std::vector<TrackEdge> ConflictingEdges() {
  return {Edge(0, 0, 1, 0, 10), Edge(1, 0, 2, 0, 12), Edge(2, 0, 3, 0, 11), Edge(2, 0, 1, 1, 90),
          Edge(1, 1, 0, 1, 20)};
}

TEST(TracksTest, InconsistentComponentIsSplitAtItsWeakestLink) {
  TrackBuilder::Summary summary;
  const std::vector<Track> tracks =
      TrackBuilder(MinLength(2)).Build({2, 2, 3, 1}, ConflictingEdges(), &summary);
  EXPECT_EQ(summary.num_components, 1);
  EXPECT_EQ(summary.num_inconsistent_components, 1);
  EXPECT_EQ(summary.num_tracks_from_splits, 2);
  ASSERT_EQ(tracks.size(), 2u);
  EXPECT_EQ(tracks[0].observations, (std::vector<Observation>{{0, 0}, {1, 0}, {2, 0}, {3, 0}}));
  EXPECT_EQ(tracks[1].observations, (std::vector<Observation>{{0, 1}, {1, 1}}));
  for (const Track& track : tracks) {
    for (std::size_t k = 1; k < track.size(); ++k) {
      EXPECT_LT(track.observations[k - 1].image, track.observations[k].image);
    }
  }
}

TEST(TracksTest, InconsistentComponentIsDroppedOnRequest) {
  TrackBuilder::Options options = MinLength(2);
  options.conflict_policy = TrackBuilder::ConflictPolicy::kDrop;
  std::vector<TrackEdge> edges = ConflictingEdges();
  edges.push_back(Edge(0, 2, 3, 1));  // an unrelated, consistent track survives
  TrackBuilder::Summary summary;
  const std::vector<Track> tracks = TrackBuilder(options).Build({3, 2, 3, 2}, edges, &summary);
  ASSERT_EQ(tracks.size(), 1u);
  EXPECT_EQ(tracks[0].observations, (std::vector<Observation>{{0, 2}, {3, 1}}));
  EXPECT_EQ(summary.num_inconsistent_components, 1);
  EXPECT_EQ(summary.num_dropped_observations, 6);
}

TEST(TracksTest, SameImageMatchIsNeverUnited) {
  // A match between two features of one image (e.g. a repeated pattern) cannot join them.
  const std::vector<TrackEdge> edges = {Edge(0, 0, 1, 0), Edge(1, 0, 1, 1, 5), Edge(1, 1, 2, 1)};
  TrackBuilder::Summary summary;
  const std::vector<Track> tracks = TrackBuilder(MinLength(2)).Build({1, 2, 2}, edges, &summary);
  EXPECT_EQ(summary.num_inconsistent_components, 1);
  ASSERT_EQ(tracks.size(), 2u);
  EXPECT_EQ(tracks[0].observations, (std::vector<Observation>{{0, 0}, {1, 0}}));
  EXPECT_EQ(tracks[1].observations, (std::vector<Observation>{{1, 1}, {2, 1}}));
}

TEST(TracksTest, ResultDoesNotDependOnEdgeOrderForConsistentInput) {
  std::vector<TrackEdge> edges;
  for (int t = 0; t < 20; ++t) {
    for (int i = 0; i < 7; ++i) {
      edges.push_back(Edge(i, (t * 3 + i) % 20, i + 1, (t * 3 + i + 1) % 20));
    }
  }
  std::vector<TrackEdge> reversed(edges.rbegin(), edges.rend());
  const TrackBuilder builder(MinLength(2));
  const std::vector<int> counts(8, 20);
  const std::vector<Track> a = builder.Build(counts, edges);
  const std::vector<Track> b = builder.Build(counts, reversed);
  EXPECT_EQ(a, b);
  EXPECT_EQ(a.size(), 20u);
}

TEST(TracksTest, EdgesFromPairsUsesOnlyVerifiedInliers) {
  PairMatches verified;
  verified.image1 = 0;
  verified.image2 = 1;
  verified.matches = {{0, 4, 1.0f}, {1, 5, 2.0f}, {2, 6, 3.0f}};
  verified.inliers = {0, 2};
  verified.summary.verified = true;
  PairMatches rejected = verified;
  rejected.image1 = 1;
  rejected.image2 = 2;
  rejected.summary.verified = false;
  const std::vector<TrackEdge> edges = EdgesFromPairs({verified, rejected});
  ASSERT_EQ(edges.size(), 2u);
  EXPECT_EQ(edges[0].a, (Observation{0, 0}));
  EXPECT_EQ(edges[0].b, (Observation{1, 4}));
  EXPECT_EQ(edges[1].a, (Observation{0, 2}));
  EXPECT_EQ(edges[1].b, (Observation{1, 6}));
  EXPECT_FLOAT_EQ(edges[1].distance, 3.0f);
}

}  // namespace
}  // namespace crop4d::features
