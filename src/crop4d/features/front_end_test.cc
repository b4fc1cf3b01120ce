#include "crop4d/features/front_end.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <atomic>
#include <filesystem>
#include <fstream>

#include "crop4d/features/synthetic_plane_test_util.h"

namespace crop4d::features {
namespace {

namespace fs = std::filesystem;

const testing::PlaneScene& Scene() {
  static const testing::PlaneScene scene = testing::MakePlaneScene(testing::PlaneSceneOptions{});
  return scene;
}

std::vector<std::string> Keys(std::size_t n) {
  std::vector<std::string> keys;
  for (std::size_t i = 0; i < n; ++i) keys.push_back("img" + std::to_string(i));
  return keys;
}

FrontEnd::Options TestOptions(const std::string& cache_path) {
  FrontEnd::Options options;
  options.cache_path = cache_path;
  options.show_progress = false;
  options.matching_block_size = 4;            // several blocks, to exercise the index windows
  options.extraction.max_num_features = 600;  // keeps the tests fast
  return options;
}

class FrontEndTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("crop4d_front_end_test_" + std::to_string(::getpid()) + "_" +
            ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    cache_path_ = (dir_ / "features.bin").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  FrontEnd::Result Run(const FrontEnd::Options& options, std::atomic<int>* loads) const {
    const testing::PlaneScene& scene = Scene();
    return FrontEnd(options).Run(Keys(scene.views.size()), [&](std::size_t i) {
      ++*loads;
      return scene.views[i];
    });
  }

  fs::path dir_;
  std::string cache_path_;
};

TEST(FrontEndRunTest, TracksFollowTheTrueGeometryAndRunOnFeaturesAgrees) {
  const testing::PlaneScene& scene = Scene();
  const FrontEnd::Result result =
      FrontEnd(TestOptions("")).Run(Keys(scene.views.size()), [&](std::size_t i) {
        return scene.views[i];
      });
  const FrontEnd::Summary& s = result.summary;
  const int n = static_cast<int>(Scene().views.size());
  EXPECT_EQ(s.num_images, n);
  EXPECT_EQ(s.num_images_extracted, n);
  EXPECT_EQ(s.num_images_from_cache, 0);
  EXPECT_EQ(s.cache_status, FeatureCacheStatus::kMissing);
  EXPECT_FALSE(s.cache_written);
  EXPECT_EQ(s.num_pairs, static_cast<int>(SequentialPairs(n, 4).size()));
  EXPECT_EQ(s.num_verified_pairs, s.num_pairs);
  EXPECT_GT(s.num_landmarks, 100);
  EXPECT_EQ(s.num_landmarks, static_cast<int>(result.tracks.size()));
  EXPECT_GE(s.tracks.mean_accepted_track_length, 7.0);
  EXPECT_FALSE(FormatSummary(s).empty());

  // Every observation of a landmark is the same texture point, to 2 px, for ≥ 95% of them.
  int good = 0, total = 0;
  for (const Track& track : result.tracks) {
    ASSERT_GE(track.size(), 7u);
    const Observation& first = track.observations.front();
    const Eigen::Vector2d reference =
        Scene().ToTexture(first.image, result.features[first.image].Point(first.feature));
    for (std::size_t k = 0; k < track.size(); ++k) {
      const Observation& o = track.observations[k];
      if (k > 0) {
        ASSERT_LT(track.observations[k - 1].image, o.image);
      }
      const Eigen::Vector2d predicted =
          (Scene().view_from_texture[o.image] * reference.homogeneous()).hnormalized();
      ++total;
      if ((predicted - result.features[o.image].Point(o.feature)).norm() < 2.0) ++good;
    }
  }
  EXPECT_GE(good, 0.95 * total);

  // Matching features given directly, with k = 2, reproduces those pairs.
  const FrontEnd::Result& full = result;
  FrontEnd::Options options = TestOptions("");
  options.num_neighbors = 2;
  const FrontEnd::Result again = FrontEnd(options).RunOnFeatures(full.features);
  EXPECT_EQ(again.summary.num_pairs,
            static_cast<int>(SequentialPairs(full.summary.num_images, 2).size()));
  // Pairs (i, i+1) and (i, i+2) are matched exactly as in the k = 4 run.
  for (const PairMatches& pair : again.pairs) {
    const auto it = std::find_if(full.pairs.begin(), full.pairs.end(), [&](const PairMatches& p) {
      return p.image1 == pair.image1 && p.image2 == pair.image2;
    });
    ASSERT_NE(it, full.pairs.end());
    EXPECT_EQ(it->inliers, pair.inliers);
  }
  EXPECT_GT(again.summary.num_landmarks, 0);
}

TEST_F(FrontEndTest, RerunUsesTheCacheAndIsDeterministic) {
  const int n = static_cast<int>(Scene().views.size());
  std::atomic<int> loads{0};
  const FrontEnd::Result first = Run(TestOptions(cache_path_), &loads);
  EXPECT_EQ(loads.load(), n);
  ASSERT_TRUE(first.summary.cache_written);
  const FrontEnd::Result& reference = first;

  // The rerun reads the cache, with one thread and other matching blocks: same tracks.
  FrontEnd::Options single = TestOptions(cache_path_);
  single.num_threads = 1;
  single.matching_block_size = 100;
  loads = 0;
  const FrontEnd::Result second = Run(single, &loads);
  EXPECT_EQ(loads.load(), 0);
  EXPECT_EQ(second.summary.cache_status, FeatureCacheStatus::kOk);
  EXPECT_EQ(second.summary.num_images_from_cache, n);
  EXPECT_EQ(second.summary.num_images_extracted, 0);
  EXPECT_FALSE(second.summary.cache_written);
  EXPECT_EQ(second.features, reference.features);
  EXPECT_EQ(second.tracks, reference.tracks);
  ASSERT_EQ(second.pairs.size(), reference.pairs.size());
  for (std::size_t p = 0; p < reference.pairs.size(); ++p) {
    EXPECT_EQ(second.pairs[p].matches, reference.pairs[p].matches);
    EXPECT_EQ(second.pairs[p].inliers, reference.pairs[p].inliers);
  }

  // A corrupted cache is detected and the features are extracted again (the loader here
  // returns no image, so nothing is matched; only the cache handling is under test).
  {
    std::fstream file(cache_path_, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(1000);
    file.put('\x7f');
  }
  const auto no_image = [&](std::size_t) {
    ++loads;
    return cv::Mat();
  };
  loads = 0;
  const FrontEnd::Result third = FrontEnd(TestOptions(cache_path_)).Run(Keys(n), no_image);
  EXPECT_EQ(third.summary.cache_status, FeatureCacheStatus::kCorrupt);
  EXPECT_EQ(loads.load(), n);
  EXPECT_EQ(third.summary.num_images_unreadable, n);
  EXPECT_TRUE(third.tracks.empty());

  // Other extraction options invalidate the cache.
  WriteFeatureCache(cache_path_, {TestOptions("").extraction.Hash(), Keys(n), first.features});
  FrontEnd::Options other = TestOptions(cache_path_);
  other.extraction.contrast_threshold = 0.03;
  loads = 0;
  const FrontEnd::Result fourth = FrontEnd(other).Run(Keys(n), no_image);
  EXPECT_EQ(fourth.summary.cache_status, FeatureCacheStatus::kOptionsChanged);
  EXPECT_EQ(loads.load(), n);
}

TEST_F(FrontEndTest, UnreadableImagesAreSkippedAndNotCached) {
  const testing::PlaneScene& scene = Scene();
  const std::size_t n = 5;
  FrontEnd::Options options = TestOptions(cache_path_);
  options.tracks.min_track_length = 3;
  const FrontEnd front_end(options);
  const FrontEnd::Result result =
      front_end.Run(Keys(n), [&](std::size_t i) { return i == 2 ? cv::Mat() : scene.views[i]; });
  EXPECT_EQ(result.summary.num_images_unreadable, 1);
  EXPECT_EQ(result.summary.num_images_extracted, 4);
  EXPECT_TRUE(result.features[2].empty());
  EXPECT_GT(result.summary.num_landmarks, 50);
  for (const Track& track : result.tracks) {
    for (const Observation& o : track.observations) EXPECT_NE(o.image, 2);
  }
  // The rerun tries image 2 again.
  int loads = 0;
  const FrontEnd::Result rerun = front_end.Run(Keys(n), [&](std::size_t i) {
    ++loads;
    return scene.views[i];
  });
  EXPECT_EQ(loads, 1);
  EXPECT_EQ(rerun.summary.num_images_from_cache, 4);
  EXPECT_FALSE(rerun.features[2].empty());
}

}  // namespace
}  // namespace crop4d::features
