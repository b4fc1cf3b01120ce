#pragma once

// Pairwise matching of SIFT features (DESIGN.md §2.2, front end):
//   1. approximate nearest neighbours with FLANN randomized KD-trees (Muja & Lowe, "Fast
//      Approximate Nearest Neighbors with Automatic Algorithm Configuration", VISAPP 2009), or
//      exact ones by an exhaustive search (cheaper for the ≈1000–2000 features of row SLAM);
//   2. Lowe's ratio test: keep a match when the nearest descriptor is clearly closer than the
//      second nearest, d1 < r·d2 (Lowe, IJCV 2004, §7.1; r = 0.8 rejects 90% of false matches
//      and 5% of correct ones there);
//   3. optionally a mutual (cross) check: the match must also be the best one the other way;
//   4. geometric verification: RANSAC (Fischler & Bolles 1981) on the fundamental matrix with
//      the normalised 8-point algorithm (Hartley, "In Defense of the Eight-Point Algorithm",
//      PAMI 1997; Hartley & Zisserman, Multiple View Geometry, 2nd ed., Alg. 11.1), inliers by
//      Sampson distance (H&Z eq. 11.9) below a threshold in pixels.
// Which pairs are matched is the sequential schedule "each image with its next k".

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <utility>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/geometry/camera.h"

namespace crop4d::features {

// A correspondence between feature `feature1` of the first image and `feature2` of the second.
struct FeatureMatch {
  std::int32_t feature1 = -1;
  std::int32_t feature2 = -1;
  float distance = 0;  // L2 descriptor distance (8-bit descriptor units)

  bool operator==(const FeatureMatch&) const = default;
};

// The two nearest neighbours of a query descriptor (index -1 when there are fewer).
struct TwoNearest {
  std::int32_t index1 = -1;
  float distance1 = 0;
  std::int32_t index2 = -1;
  float distance2 = 0;
};

struct DescriptorMatchOptions {
  enum class Method {
    // Approximate nearest neighbours: FLANN randomized KD-trees (num_trees, num_checks).
    kFlann,
    // Exact nearest neighbours: the distance of every descriptor pair, in integers on the 8-bit
    // descriptors (SIMD where the CPU has it; the result does not depend on it). Both
    // directions of a pair come from one pass over the pairs, so the cost is Na·Nb dot
    // products per image pair; at 2048 features it is several times cheaper than FLANN's
    // two searches with 4 trees / 64 checks, and it finds the true neighbours.
    kExhaustive,
  };
  Method method = Method::kFlann;
  // Lowe's ratio: accept when distance1 < max_ratio · distance2 (Lowe 2004 uses 0.8).
  double max_ratio = 0.8;
  // Keep only matches that are also the best match the other way (mutual nearest neighbours).
  bool cross_check = true;
  // Randomized KD-trees in the FLANN forest (kFlann).
  int num_trees = 4;
  // Leaves visited per query (kFlann); more is more exact and slower.
  int num_checks = 64;
  // Seed of the KD-trees' random split choices, so that runs are reproducible.
  std::uint32_t seed = 42;

  OptionCheck Check() const;
};

// Lowe's ratio test on nearest-neighbour results: query q gives the match (q, index1) when
// index1 >= 0, a second neighbour exists and distance1 < max_ratio · distance2. A query with
// no second neighbour is rejected (its distinctiveness cannot be judged).
std::vector<FeatureMatch> ApplyRatioTest(const std::vector<TwoNearest>& nearest, double max_ratio);

// Keeps the matches a→b whose feature2 maps back to feature1 in the b→a matches.
std::vector<FeatureMatch> MutualMatches(const std::vector<FeatureMatch>& matches_ab,
                                        const std::vector<FeatureMatch>& matches_ba);

// The descriptors of one image prepared for nearest-neighbour queries, built once and queried
// by many: a FLANN KD-tree forest (kFlann; deterministic for a given seed) or a 16-bit copy of
// the descriptors with their squared norms (kExhaustive). Queries are thread-safe.
class DescriptorIndex {
 public:
  DescriptorIndex(const FeatureSet& features, const DescriptorMatchOptions& options);
  ~DescriptorIndex();
  DescriptorIndex(const DescriptorIndex&) = delete;
  DescriptorIndex& operator=(const DescriptorIndex&) = delete;

  std::size_t size() const;
  // The two nearest indexed descriptors of every descriptor of `queries`.
  std::vector<TwoNearest> SearchTwoNearest(const FeatureSet& queries) const;

  struct Impl;  // matcher.cc

 private:
  friend std::vector<FeatureMatch> MatchDescriptors(const FeatureSet&, const DescriptorIndex&,
                                                    const FeatureSet&, const DescriptorIndex&,
                                                    const DescriptorMatchOptions&);
  std::unique_ptr<Impl> impl_;
};

// Ratio-tested (and, with cross_check, mutual) matches between two images given the indices
// of both (index_b is searched with a's descriptors and index_a with b's).
std::vector<FeatureMatch> MatchDescriptors(const FeatureSet& a, const DescriptorIndex& index_a,
                                           const FeatureSet& b, const DescriptorIndex& index_b,
                                           const DescriptorMatchOptions& options);
// Convenience: builds the indices it needs.
std::vector<FeatureMatch> MatchDescriptors(const FeatureSet& a, const FeatureSet& b,
                                           const DescriptorMatchOptions& options);

struct EpipolarVerificationOptions {
  enum class Method {
    // RANSAC with the 8-point minimal sample (OpenCV USAC_FM_8PTS: normalised 8-point, MSAC
    // score, local optimisation).
    kRansac8Point,
    // Classic RANSAC with the 7-point minimal sample (OpenCV FM_RANSAC).
    kRansac7Point,
  };
  // Robust estimator of the fundamental matrix.
  Method method = Method::kRansac8Point;
  // Largest Sampson distance of an inlier, pixels.
  double max_error_px = 2.0;
  // RANSAC confidence of having drawn an all-inlier sample.
  double confidence = 0.999;
  // RANSAC iteration cap.
  int max_num_iterations = 10000;
  // Re-estimate F with the normalised 8-point algorithm on all inliers and classify the
  // matches again with it.
  bool refine = true;
  // A pair is verified when it keeps at least this many inliers (and it needs at least 8
  // putative matches to be tried at all).
  int min_num_inliers = 20;

  OptionCheck Check() const;
};

// Result of estimating the epipolar geometry of putative correspondences.
struct EpipolarGeometry {
  // Whether RANSAC found a fundamental matrix with at least min_num_inliers inliers.
  bool verified = false;
  // F with x2ᵀ F x1 = 0 for homogeneous pixels x1 (image 1) and x2 (image 2); zero when no
  // model was found.
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  // Indices of the inlier correspondences, ascending.
  std::vector<int> inliers;
};

// Robust F between pixel correspondences points1[i] ↔ points2[i]. Deterministic.
EpipolarGeometry EstimateEpipolarGeometry(const std::vector<Eigen::Vector2d>& points1,
                                          const std::vector<Eigen::Vector2d>& points2,
                                          const EpipolarVerificationOptions& options);

// Sampson distance of a correspondence to F, pixels (H&Z eq. 11.9, square-rooted).
double SampsonDistance(const Eigen::Matrix3d& F, const Eigen::Vector2d& x1,
                       const Eigen::Vector2d& x2);

// The matches of one image pair.
struct PairMatches {
  struct Summary {
    int num_features1 = 0;
    int num_features2 = 0;
    // Matches after the ratio test (and mutual check).
    int num_putative = 0;
    // Matches consistent with the epipolar geometry.
    int num_inliers = 0;
    // Whether the pair passed geometric verification (num_inliers >= min_num_inliers).
    bool verified = false;
  };

  int image1 = -1;
  int image2 = -1;
  // Putative matches, in the order of image1's features.
  std::vector<FeatureMatch> matches;
  // Indices into `matches` of the epipolar inliers, ascending (empty when not verified).
  std::vector<int> inliers;
  // Fundamental matrix image2 ← image1 in pixels (undistorted pixels when a camera was given).
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  Summary summary;

  // The inlier matches themselves.
  std::vector<FeatureMatch> InlierMatches() const;
};

class PairMatcher {
 public:
  struct Options {
    // Descriptor matching (FLANN, ratio test, mutual check).
    DescriptorMatchOptions descriptors;
    // Geometric verification (RANSAC on F).
    EpipolarVerificationOptions verification;

    OptionCheck Check() const;
  };

  // `camera`, when given, undistorts keypoints before verification, so that the pinhole
  // epipolar constraint holds for a lens with distortion; the pointer must outlive the matcher.
  explicit PairMatcher(Options options, const geometry::PinholeRadTan* camera = nullptr);

  // Matches image `image1` (features a, index_a) with `image2` (features b, index_b).
  PairMatches Match(int image1, const FeatureSet& a, const DescriptorIndex& index_a, int image2,
                    const FeatureSet& b, const DescriptorIndex& index_b) const;
  // Convenience: builds the indices it needs.
  PairMatches Match(int image1, const FeatureSet& a, int image2, const FeatureSet& b) const;

  const Options& options() const { return options_; }

 private:
  Eigen::Vector2d PointForGeometry(const FeatureSet& features, int i) const;

  Options options_;
  const geometry::PinholeRadTan* camera_;
};

// The sequential pair schedule: every image i with images i+1 … i+num_neighbors, ordered by
// (i, j).
std::vector<std::pair<int, int>> SequentialPairs(int num_images, int num_neighbors);

}  // namespace crop4d::features
