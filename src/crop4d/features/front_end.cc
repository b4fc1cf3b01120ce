#include "crop4d/features/front_end.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>
#include <tbb/task_arena.h>

#include <algorithm>
#include <chrono>
#include <memory>
#include <unordered_set>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/core/task_arena.h"

namespace crop4d::features {
namespace {

Progress::Options ProgressOptions(bool show) {
  Progress::Options options;
  options.silent = !show;
  return options;
}

}  // namespace

OptionCheck FrontEnd::Options::Check() const {
  OptionChecker c;
  c.Nested("extraction", extraction.Check())
      .Nested("matching", matching.Check())
      .Nested("tracks", tracks.Check())
      .AtLeast("num_neighbors", num_neighbors, 1)
      .AtLeast("matching_block_size", matching_block_size, 1)
      .AtLeast("num_threads", num_threads, 0);
  return c.Result();
}

FrontEnd::FrontEnd(Options options, const geometry::PinholeRadTan* camera)
    : options_(std::move(options)), camera_(camera) {
  CROP4D_CHECK_OPTIONS(options_, "FrontEnd::Options");
  if (camera_ != nullptr) CROP4D_CHECK_OPTIONS(*camera_, "camera");
}

FrontEnd::Result FrontEnd::Run(const std::vector<std::string>& image_keys,
                               const ImageLoader& load_image) const {
  const auto start = std::chrono::steady_clock::now();
  {
    std::unordered_set<std::string> unique(image_keys.begin(), image_keys.end());
    CROP4D_CHECK_MSG(unique.size() == image_keys.size(), "FrontEnd: image keys must be unique");
  }
  Result result;
  Summary& s = result.summary;
  const std::size_t n = image_keys.size();
  s.num_images = static_cast<int>(n);
  const std::uint64_t options_hash = options_.extraction.Hash();

  // 1. Cache.
  std::vector<bool> found(n, false);
  result.features.assign(n, FeatureSet());
  if (!options_.cache_path.empty()) {
    const auto cache_start = std::chrono::steady_clock::now();
    std::string detail;
    s.cache_status = LoadFeatureCache(options_.cache_path, options_hash, image_keys,
                                      &result.features, &found, &detail);
    if (s.cache_status != FeatureCacheStatus::kOk &&
        s.cache_status != FeatureCacheStatus::kMissing) {
      spdlog::warn("feature cache {}: {} ({}); extracting the features again", options_.cache_path,
                   ToString(s.cache_status), detail);
    }
    s.cache_seconds = SecondsSince(cache_start);
  }
  s.num_images_from_cache = static_cast<int>(std::count(found.begin(), found.end(), true));

  // 2. Extraction of the images the cache did not have, in parallel.
  std::vector<std::size_t> to_extract;
  for (std::size_t i = 0; i < n; ++i) {
    if (!found[i]) to_extract.push_back(i);
  }
  std::vector<char> loaded(n, 0);
  for (std::size_t i = 0; i < n; ++i) loaded[i] = found[i] ? 1 : 0;
  if (!to_extract.empty()) {
    const auto extraction_start = std::chrono::steady_clock::now();
    const FeatureExtractor extractor(options_.extraction);
    Progress progress("features", to_extract.size(), "img",
                      ProgressOptions(options_.show_progress));
    InArena(options_.num_threads, [&] {
      tbb::parallel_for(std::size_t{0}, to_extract.size(), [&](std::size_t k) {
        const std::size_t i = to_extract[k];
        const cv::Mat image = load_image(i);
        if (!image.empty()) {
          result.features[i] = extractor.Extract(image);
          loaded[i] = 1;
        }
        progress.Add();
      });
    });
    progress.Finish();
    s.extraction_seconds = SecondsSince(extraction_start);
  }
  for (std::size_t k : to_extract) {
    if (loaded[k]) {
      ++s.num_images_extracted;
    } else {
      ++s.num_images_unreadable;
    }
  }

  // 3. Cache write when anything new was extracted (unreadable images are left out so that a
  // rerun tries them again).
  if (!options_.cache_path.empty() && s.num_images_extracted > 0) {
    const auto cache_start = std::chrono::steady_clock::now();
    FeatureCache cache;
    cache.options_hash = options_hash;
    for (std::size_t i = 0; i < n; ++i) {
      if (!loaded[i]) continue;
      cache.image_keys.push_back(image_keys[i]);
      cache.features.push_back(result.features[i]);
    }
    try {
      WriteFeatureCache(options_.cache_path, cache);
      s.cache_written = true;
    } catch (const InputError& error) {
      // The cache only saves time; a run without it is still correct.
      spdlog::warn("cannot write the feature cache: {}", error.what());
    }
    s.cache_seconds += SecondsSince(cache_start);
  }

  MatchAndTrack(&result);
  s.total_seconds = SecondsSince(start);
  return result;
}

FrontEnd::Result FrontEnd::RunOnFeatures(std::vector<FeatureSet> features) const {
  const auto start = std::chrono::steady_clock::now();
  Result result;
  result.features = std::move(features);
  result.summary.num_images = static_cast<int>(result.features.size());
  MatchAndTrack(&result);
  result.summary.total_seconds = SecondsSince(start);
  return result;
}

void FrontEnd::MatchAndTrack(Result* result) const {
  Summary& s = result->summary;
  const std::vector<FeatureSet>& features = result->features;
  const int n = static_cast<int>(features.size());
  for (const FeatureSet& set : features) {
    CROP4D_CHECK(set.IsConsistent());
    s.num_features += static_cast<std::int64_t>(set.size());
  }

  // Matching, block by block: the FLANN indices of images [begin, end + k) are built in
  // parallel, then the pairs whose first image lies in [begin, end) are matched in parallel.
  const auto matching_start = std::chrono::steady_clock::now();
  const std::vector<std::pair<int, int>> schedule = SequentialPairs(n, options_.num_neighbors);
  result->pairs.assign(schedule.size(), PairMatches());
  const PairMatcher matcher(options_.matching, camera_);
  {
    Progress progress("matching", schedule.size(), "pair", ProgressOptions(options_.show_progress));
    std::size_t first_pair = 0;
    for (int begin = 0; begin < n; begin += options_.matching_block_size) {
      const int end = std::min(n, begin + options_.matching_block_size);
      const int index_end = std::min(n, end + options_.num_neighbors);
      std::size_t last_pair = first_pair;
      while (last_pair < schedule.size() && schedule[last_pair].first < end) ++last_pair;
      std::vector<std::unique_ptr<DescriptorIndex>> indices(index_end - begin);
      InArena(options_.num_threads, [&] {
        tbb::parallel_for(begin, index_end, [&](int i) {
          indices[i - begin] =
              std::make_unique<DescriptorIndex>(features[i], options_.matching.descriptors);
        });
        tbb::parallel_for(first_pair, last_pair, [&](std::size_t p) {
          const auto [i, j] = schedule[p];
          result->pairs[p] = matcher.Match(i, features[i], *indices[i - begin], j, features[j],
                                           *indices[j - begin]);
          progress.Add();
        });
      });
      first_pair = last_pair;
    }
    progress.Finish();
  }
  s.num_pairs = static_cast<int>(schedule.size());
  for (const PairMatches& pair : result->pairs) {
    s.num_putative_matches += pair.summary.num_putative;
    if (pair.summary.verified) {
      ++s.num_verified_pairs;
      s.num_inlier_matches += pair.summary.num_inliers;
    }
  }
  s.matching_seconds = SecondsSince(matching_start);

  // Tracks.
  const auto tracks_start = std::chrono::steady_clock::now();
  std::vector<int> num_features(n);
  for (int i = 0; i < n; ++i) num_features[i] = static_cast<int>(features[i].size());
  const TrackBuilder builder(options_.tracks);
  result->tracks = builder.Build(num_features, result->pairs, &s.tracks);
  s.num_landmarks = s.tracks.num_accepted_tracks;
  s.tracks_seconds = SecondsSince(tracks_start);
}

std::string FormatSummary(const FrontEnd::Summary& s) {
  return fmt::format(
      "{} images ({} cached, {} extracted, {} unreadable), {} features; {} pairs, {} verified, "
      "{} putative / {} inlier matches; {} tracks ({} inconsistent components), {} landmarks "
      "(mean length {:.1f}); times: cache {:.2f} s, extraction {:.2f} s, matching {:.2f} s, "
      "tracks {:.2f} s, total {:.2f} s",
      s.num_images, s.num_images_from_cache, s.num_images_extracted, s.num_images_unreadable,
      s.num_features, s.num_pairs, s.num_verified_pairs, s.num_putative_matches,
      s.num_inlier_matches, s.tracks.num_tracks, s.tracks.num_inconsistent_components,
      s.num_landmarks, s.tracks.mean_accepted_track_length, s.cache_seconds, s.extraction_seconds,
      s.matching_seconds, s.tracks_seconds, s.total_seconds);
}

}  // namespace crop4d::features
