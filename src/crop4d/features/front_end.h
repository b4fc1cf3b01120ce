#pragma once

// The SLAM front end of one row pass (DESIGN.md §2.2): SIFT features on every image
// (extracted in parallel, cached in the workspace), every image matched with its next k images
// (FLANN, ratio test, 8-point RANSAC on F, pairs matched in parallel), and tracks by union-find;
// the tracks seen in enough images are the landmarks the back end optimises.
//
//   FrontEnd front_end(options, &camera);
//   FrontEnd::Result result = front_end.Run(keys, [&](std::size_t i) {
//     return images.LoadImage(i);
//   });
//   // result.tracks: accepted landmarks; result.features[i]: the features of image i.

#include <cstdint>
#include <functional>
#include <opencv2/core/mat.hpp>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_cache.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/features/matcher.h"
#include "crop4d/features/tracks.h"
#include "crop4d/geometry/camera.h"

namespace crop4d::features {

class FrontEnd {
 public:
  struct Options {
    // SIFT extraction.
    FeatureExtractor::Options extraction;
    // Descriptor matching and geometric verification of each pair.
    PairMatcher::Options matching;
    // Track building; tracks.min_track_length is the landmark acceptance rule.
    TrackBuilder::Options tracks;
    // Each image is matched with this many following images (the paper's "nearby pairs").
    int num_neighbors = 4;
    // Images whose descriptor indices are held in memory together while matching; bounds the
    // memory (FLANN: about 5 MB per image of 8192 features; exhaustive: 256 bytes per feature)
    // at the cost of rebuilding num_neighbors indices per block.
    int matching_block_size = 32;
    // Feature cache file (feature_cache.h); empty: no cache.
    std::string cache_path;
    // Worker threads (0: oneTBB's default, all cores).
    int num_threads = 0;
    // Show progress bars / log lines for the long phases.
    bool show_progress = true;

    OptionCheck Check() const;
  };

  struct Summary {
    int num_images = 0;
    // Images whose features came from the cache, and images extracted now.
    int num_images_from_cache = 0;
    int num_images_extracted = 0;
    // Images that could not be loaded (they get no features).
    int num_images_unreadable = 0;
    std::int64_t num_features = 0;
    // Image pairs matched, and those that passed geometric verification.
    int num_pairs = 0;
    int num_verified_pairs = 0;
    // Matches after the ratio test, and epipolar inliers of the verified pairs.
    std::int64_t num_putative_matches = 0;
    std::int64_t num_inlier_matches = 0;
    // Track building; tracks.num_accepted_tracks is the number of landmarks.
    TrackBuilder::Summary tracks;
    int num_landmarks = 0;
    // What reading the cache found (kMissing without a cache path), and whether it was
    // (re)written.
    FeatureCacheStatus cache_status = FeatureCacheStatus::kMissing;
    bool cache_written = false;
    // Wall-clock seconds per phase.
    double cache_seconds = 0;
    double extraction_seconds = 0;
    double matching_seconds = 0;
    double tracks_seconds = 0;
    double total_seconds = 0;
  };

  struct Result {
    // Features of every image (empty for unreadable images).
    std::vector<FeatureSet> features;
    // Matches of every scheduled pair, in SequentialPairs order.
    std::vector<PairMatches> pairs;
    // Accepted landmark tracks.
    std::vector<Track> tracks;
    Summary summary;
  };

  // Loads image i: an 8-bit grey, BGR or BGRA image, or an empty Mat when it cannot be read.
  // Called from several threads at once.
  using ImageLoader = std::function<cv::Mat(std::size_t)>;

  // `camera` (optional) undistorts keypoints for the epipolar verification; it must outlive
  // the front end.
  explicit FrontEnd(Options options, const geometry::PinholeRadTan* camera = nullptr);

  // Runs the front end on images identified by `image_keys` (unique, e.g. timestamps; they key
  // the cache), loading those not in the cache with `load_image`.
  Result Run(const std::vector<std::string>& image_keys, const ImageLoader& load_image) const;

  // Matching and tracks on features extracted elsewhere (no extraction, no cache).
  Result RunOnFeatures(std::vector<FeatureSet> features) const;

  const Options& options() const { return options_; }

 private:
  void MatchAndTrack(Result* result) const;

  Options options_;
  const geometry::PinholeRadTan* camera_;
};

// A one-line account of a run, for the log.
std::string FormatSummary(const FrontEnd::Summary& summary);

}  // namespace crop4d::features
