#include "crop4d/features/matcher.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/flann.hpp>

#include "crop4d/core/error.h"

namespace crop4d::features {

OptionCheck DescriptorMatchOptions::Check() const {
  OptionChecker c;
  c.Greater("max_ratio", max_ratio, 0.0)
      .AtMost("max_ratio", max_ratio, 1.0)
      .AtLeast("num_trees", num_trees, 1)
      .AtLeast("num_checks", num_checks, 1);
  return c.Result();
}

OptionCheck EpipolarVerificationOptions::Check() const {
  OptionChecker c;
  c.Greater("max_error_px", max_error_px, 0.0)
      .Finite("max_error_px", max_error_px)
      .Between("confidence", confidence, 0.0, 1.0)
      .AtLeast("max_num_iterations", max_num_iterations, 1)
      .AtLeast("min_num_inliers", min_num_inliers, 8);
  return c.Result();
}

OptionCheck PairMatcher::Options::Check() const {
  OptionChecker c;
  c.Nested("descriptors", descriptors.Check()).Nested("verification", verification.Check());
  return c.Result();
}

std::vector<FeatureMatch> ApplyRatioTest(const std::vector<TwoNearest>& nearest, double max_ratio) {
  std::vector<FeatureMatch> matches;
  for (std::size_t q = 0; q < nearest.size(); ++q) {
    const TwoNearest& n = nearest[q];
    if (n.index1 < 0 || n.index2 < 0) continue;
    if (!(n.distance1 < max_ratio * n.distance2)) continue;
    matches.push_back({static_cast<std::int32_t>(q), n.index1, n.distance1});
  }
  return matches;
}

std::vector<FeatureMatch> MutualMatches(const std::vector<FeatureMatch>& matches_ab,
                                        const std::vector<FeatureMatch>& matches_ba) {
  std::int32_t max_b = -1;
  for (const FeatureMatch& m : matches_ba) max_b = std::max(max_b, m.feature1);
  std::vector<std::int32_t> back(static_cast<std::size_t>(max_b + 1), -1);
  for (const FeatureMatch& m : matches_ba) back[m.feature1] = m.feature2;
  std::vector<FeatureMatch> mutual;
  for (const FeatureMatch& m : matches_ab) {
    if (m.feature2 <= max_b && back[m.feature2] == m.feature1) mutual.push_back(m);
  }
  return mutual;
}

// ---- DescriptorIndex ----------------------------------------------------------------------

struct DescriptorIndex::Impl {
  DescriptorMatchOptions::Method method = DescriptorMatchOptions::Method::kFlann;
  int size = 0;
  // kFlann: float copy of the descriptors (FLANN keeps a view into it) and the forest.
  cv::Mat data;
  std::unique_ptr<cv::flann::Index> index;
  int num_checks = 0;
  // kExhaustive: the descriptors widened to 16 bits (row-major size × kDescriptorSize) and
  // their squared norms.
  std::vector<std::int16_t> values;
  std::vector<std::int32_t> squared_norms;
};

namespace {

// Dot products of the na rows of `a` with the nb rows of `b` (16-bit descriptors):
// out[i · nb + j] = a_i · b_j. Exact in 32-bit integers (128 · 255² < 2³¹), so every clone
// gives the same result; GCC vectorises the inner loop (pmaddwd) and the AVX2 clone is chosen
// at load time where the CPU has it.
__attribute__((target_clones("avx2", "default"))) void DotProducts(const std::int16_t* a, int na,
                                                                   const std::int16_t* b, int nb,
                                                                   std::int32_t* out) {
  for (int i = 0; i < na; ++i) {
    const std::int16_t* ai = a + static_cast<std::size_t>(i) * kDescriptorSize;
    for (int j = 0; j < nb; ++j) {
      const std::int16_t* bj = b + static_cast<std::size_t>(j) * kDescriptorSize;
      std::int32_t sum = 0;
      for (int k = 0; k < kDescriptorSize; ++k) sum += static_cast<std::int32_t>(ai[k]) * bj[k];
      out[static_cast<std::size_t>(i) * nb + j] = sum;
    }
  }
}

// Two nearest neighbours by squared distance, ties to the lower index (scan in index order).
struct SquaredTwoNearest {
  std::int32_t index1 = -1, index2 = -1;
  std::int32_t d1 = std::numeric_limits<std::int32_t>::max();
  std::int32_t d2 = std::numeric_limits<std::int32_t>::max();

  void Add(std::int32_t index, std::int32_t d) {
    if (d < d1) {
      index2 = index1;
      d2 = d1;
      index1 = index;
      d1 = d;
    } else if (d < d2) {
      index2 = index;
      d2 = d;
    }
  }
  TwoNearest ToTwoNearest() const {
    TwoNearest n;
    if (index1 >= 0) {
      n.index1 = index1;
      n.distance1 = std::sqrt(static_cast<float>(d1));
    }
    if (index2 >= 0) {
      n.index2 = index2;
      n.distance2 = std::sqrt(static_cast<float>(d2));
    }
    return n;
  }
};

// Exact two nearest neighbours of every row of `a` among the rows of `b` (a_to_b) and, when
// b_to_a is given, of every row of `b` among the rows of `a`, from one pass over all pairs.
void ExhaustiveTwoNearest(const DescriptorIndex::Impl& a, const DescriptorIndex::Impl& b,
                          std::vector<TwoNearest>* a_to_b, std::vector<TwoNearest>* b_to_a) {
  constexpr int kBlock = 32;  // rows of a per block: the block's dot products stay in cache
  std::vector<SquaredTwoNearest> rows(a.size), columns(b_to_a != nullptr ? b.size : 0);
  std::vector<std::int32_t> dots(static_cast<std::size_t>(kBlock) * b.size);
  for (int begin = 0; begin < a.size; begin += kBlock) {
    const int count = std::min(kBlock, a.size - begin);
    DotProducts(a.values.data() + static_cast<std::size_t>(begin) * kDescriptorSize, count,
                b.values.data(), b.size, dots.data());
    for (int r = 0; r < count; ++r) {
      const int i = begin + r;
      const std::int32_t norm_i = a.squared_norms[i];
      const std::int32_t* dot = dots.data() + static_cast<std::size_t>(r) * b.size;
      SquaredTwoNearest& row = rows[i];
      for (int j = 0; j < b.size; ++j) {
        const std::int32_t d = norm_i + b.squared_norms[j] - 2 * dot[j];
        row.Add(j, d);
        if (b_to_a != nullptr) columns[j].Add(i, d);
      }
    }
  }
  a_to_b->resize(a.size);
  for (int i = 0; i < a.size; ++i) (*a_to_b)[i] = rows[i].ToTwoNearest();
  if (b_to_a != nullptr) {
    b_to_a->resize(b.size);
    for (int j = 0; j < b.size; ++j) (*b_to_a)[j] = columns[j].ToTwoNearest();
  }
}

}  // namespace

DescriptorIndex::DescriptorIndex(const FeatureSet& features, const DescriptorMatchOptions& options)
    : impl_(std::make_unique<Impl>()) {
  CROP4D_CHECK_OPTIONS(options, "DescriptorMatchOptions");
  CROP4D_CHECK(features.IsConsistent());
  impl_->method = options.method;
  impl_->num_checks = options.num_checks;
  impl_->size = static_cast<int>(features.size());
  if (features.empty()) return;
  if (options.method == DescriptorMatchOptions::Method::kExhaustive) {
    impl_->values.assign(features.descriptors.begin(), features.descriptors.end());
    impl_->squared_norms.resize(features.size());
    for (std::size_t i = 0; i < features.size(); ++i) {
      const std::uint8_t* d = features.Descriptor(i);
      std::int32_t sum = 0;
      for (int k = 0; k < kDescriptorSize; ++k) sum += static_cast<std::int32_t>(d[k]) * d[k];
      impl_->squared_norms[i] = sum;
    }
    return;
  }
  const cv::Mat bytes(static_cast<int>(features.size()), kDescriptorSize, CV_8U,
                      const_cast<std::uint8_t*>(features.descriptors.data()));
  bytes.convertTo(impl_->data, CV_32F);
  // FLANN draws its random split dimensions from OpenCV's thread-local cv::theRNG(); seeding
  // it here (and restoring it after) makes the forest, hence the matches, reproducible
  // whichever thread builds it.
  const cv::RNG saved = cv::theRNG();
  cv::theRNG() = cv::RNG(options.seed);
  impl_->index = std::make_unique<cv::flann::Index>(
      impl_->data, cv::flann::KDTreeIndexParams(options.num_trees), cvflann::FLANN_DIST_L2);
  cv::theRNG() = saved;
}

DescriptorIndex::~DescriptorIndex() = default;

std::size_t DescriptorIndex::size() const { return static_cast<std::size_t>(impl_->size); }

std::vector<TwoNearest> DescriptorIndex::SearchTwoNearest(const FeatureSet& queries) const {
  CROP4D_CHECK(queries.IsConsistent());
  std::vector<TwoNearest> result(queries.size());
  if (queries.empty() || impl_->size == 0) return result;
  if (impl_->method == DescriptorMatchOptions::Method::kExhaustive) {
    DescriptorMatchOptions options;
    options.method = DescriptorMatchOptions::Method::kExhaustive;
    const DescriptorIndex query_index(queries, options);
    ExhaustiveTwoNearest(*query_index.impl_, *impl_, &result, nullptr);
    return result;
  }
  cv::Mat query_data;
  const cv::Mat bytes(static_cast<int>(queries.size()), kDescriptorSize, CV_8U,
                      const_cast<std::uint8_t*>(queries.descriptors.data()));
  bytes.convertTo(query_data, CV_32F);
  const int knn = std::min<int>(2, impl_->data.rows);
  cv::Mat indices, squared_distances;
  impl_->index->knnSearch(query_data, indices, squared_distances, knn,
                          cv::flann::SearchParams(impl_->num_checks));
  for (int q = 0; q < query_data.rows; ++q) {
    TwoNearest& n = result[q];
    const int i1 = indices.at<int>(q, 0);
    if (i1 >= 0 && i1 < impl_->data.rows) {
      n.index1 = i1;
      n.distance1 = std::sqrt(std::max(0.0f, squared_distances.at<float>(q, 0)));
    }
    if (knn == 2) {
      const int i2 = indices.at<int>(q, 1);
      if (i2 >= 0 && i2 < impl_->data.rows && i2 != i1) {
        n.index2 = i2;
        n.distance2 = std::sqrt(std::max(0.0f, squared_distances.at<float>(q, 1)));
      }
    }
  }
  return result;
}

std::vector<FeatureMatch> MatchDescriptors(const FeatureSet& a, const DescriptorIndex& index_a,
                                           const FeatureSet& b, const DescriptorIndex& index_b,
                                           const DescriptorMatchOptions& options) {
  if (options.method == DescriptorMatchOptions::Method::kExhaustive &&
      index_a.impl_->method == options.method && index_b.impl_->method == options.method) {
    CROP4D_CHECK(index_a.size() == a.size() && index_b.size() == b.size());
    std::vector<TwoNearest> ab_nearest, ba_nearest;
    ExhaustiveTwoNearest(*index_a.impl_, *index_b.impl_, &ab_nearest,
                         options.cross_check ? &ba_nearest : nullptr);
    std::vector<FeatureMatch> ab = ApplyRatioTest(ab_nearest, options.max_ratio);
    if (!options.cross_check) return ab;
    return MutualMatches(ab, ApplyRatioTest(ba_nearest, options.max_ratio));
  }
  std::vector<FeatureMatch> ab = ApplyRatioTest(index_b.SearchTwoNearest(a), options.max_ratio);
  if (!options.cross_check) return ab;
  std::vector<FeatureMatch> ba = ApplyRatioTest(index_a.SearchTwoNearest(b), options.max_ratio);
  return MutualMatches(ab, ba);
}

std::vector<FeatureMatch> MatchDescriptors(const FeatureSet& a, const FeatureSet& b,
                                           const DescriptorMatchOptions& options) {
  const DescriptorIndex index_b(b, options);
  if (!options.cross_check) {
    return ApplyRatioTest(index_b.SearchTwoNearest(a), options.max_ratio);
  }
  const DescriptorIndex index_a(a, options);
  return MatchDescriptors(a, index_a, b, index_b, options);
}

// ---- Epipolar verification ------------------------------------------------------------------

double SampsonDistance(const Eigen::Matrix3d& F, const Eigen::Vector2d& x1,
                       const Eigen::Vector2d& x2) {
  const Eigen::Vector3d h1 = x1.homogeneous(), h2 = x2.homogeneous();
  const Eigen::Vector3d l2 = F * h1;              // epipolar line of x1 in image 2
  const Eigen::Vector3d l1 = F.transpose() * h2;  // epipolar line of x2 in image 1
  const double e = h2.dot(l2);
  const double denominator = l2.head<2>().squaredNorm() + l1.head<2>().squaredNorm();
  if (!(denominator > 0)) return std::numeric_limits<double>::infinity();
  return std::abs(e) / std::sqrt(denominator);
}

namespace {

std::vector<int> ClassifyInliers(const Eigen::Matrix3d& F,
                                 const std::vector<Eigen::Vector2d>& points1,
                                 const std::vector<Eigen::Vector2d>& points2, double max_error) {
  std::vector<int> inliers;
  for (std::size_t i = 0; i < points1.size(); ++i) {
    if (SampsonDistance(F, points1[i], points2[i]) <= max_error) {
      inliers.push_back(static_cast<int>(i));
    }
  }
  return inliers;
}

bool ToEigen(const cv::Mat& F_cv, Eigen::Matrix3d* F) {
  if (F_cv.rows != 3 || F_cv.cols != 3) return false;
  cv::Mat F64;
  F_cv.convertTo(F64, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) (*F)(r, c) = F64.at<double>(r, c);
  }
  return F->allFinite() && F->norm() > 0;
}

}  // namespace

EpipolarGeometry EstimateEpipolarGeometry(const std::vector<Eigen::Vector2d>& points1,
                                          const std::vector<Eigen::Vector2d>& points2,
                                          const EpipolarVerificationOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "EpipolarVerificationOptions");
  CROP4D_CHECK(points1.size() == points2.size());
  EpipolarGeometry result;
  const int n = static_cast<int>(points1.size());
  // The 7-point RANSAC of OpenCV needs 15 points (below that it silently switches method).
  const int min_points = options.method == EpipolarVerificationOptions::Method::kRansac7Point
                             ? std::max(15, options.min_num_inliers)
                             : std::max(8, options.min_num_inliers);
  if (n < min_points) return result;

  std::vector<cv::Point2d> cv1(n), cv2(n);
  for (int i = 0; i < n; ++i) {
    cv1[i] = cv::Point2d(points1[i].x(), points1[i].y());
    cv2[i] = cv::Point2d(points2[i].x(), points2[i].y());
  }
  const int method = options.method == EpipolarVerificationOptions::Method::kRansac8Point
                         ? static_cast<int>(cv::USAC_FM_8PTS)
                         : static_cast<int>(cv::FM_RANSAC);
  cv::Mat F_cv;
  try {
    // Both estimators seed their own generators (USAC from its parameters, RANSAC with a fixed
    // cv::RNG), so the result is reproducible.
    F_cv = cv::findFundamentalMat(cv1, cv2, method, options.max_error_px, options.confidence,
                                  options.max_num_iterations, cv::noArray());
  } catch (const cv::Exception&) {
    // Degenerate input (e.g. all points identical): an expected failure, not an error.
    return result;
  }
  Eigen::Matrix3d F;
  if (!ToEigen(F_cv, &F)) return result;
  std::vector<int> inliers = ClassifyInliers(F, points1, points2, options.max_error_px);

  // Least-squares refinement on the inliers with the normalised 8-point algorithm (OpenCV's
  // FM_8POINT normalises both point sets as Hartley 1997 prescribes), kept while it does not
  // lose inliers.
  for (int iteration = 0; options.refine && iteration < 3 && inliers.size() >= 8; ++iteration) {
    std::vector<cv::Point2d> in1, in2;
    for (int i : inliers) {
      in1.push_back(cv1[i]);
      in2.push_back(cv2[i]);
    }
    cv::Mat F_refined_cv;
    try {
      F_refined_cv = cv::findFundamentalMat(in1, in2, cv::FM_8POINT);
    } catch (const cv::Exception&) {
      break;
    }
    Eigen::Matrix3d F_refined;
    if (!ToEigen(F_refined_cv, &F_refined)) break;
    std::vector<int> refined_inliers =
        ClassifyInliers(F_refined, points1, points2, options.max_error_px);
    if (refined_inliers.size() < inliers.size()) break;
    const bool changed = refined_inliers != inliers;
    F = F_refined;
    inliers = std::move(refined_inliers);
    if (!changed) break;
  }

  result.F = F / F.norm();
  result.inliers = std::move(inliers);
  result.verified = static_cast<int>(result.inliers.size()) >= options.min_num_inliers;
  return result;
}

// ---- PairMatcher ---------------------------------------------------------------------------

std::vector<FeatureMatch> PairMatches::InlierMatches() const {
  std::vector<FeatureMatch> out;
  out.reserve(inliers.size());
  for (int i : inliers) out.push_back(matches[i]);
  return out;
}

PairMatcher::PairMatcher(Options options, const geometry::PinholeRadTan* camera)
    : options_(std::move(options)), camera_(camera) {
  CROP4D_CHECK_OPTIONS(options_, "PairMatcher::Options");
  if (camera_ != nullptr) CROP4D_CHECK_OPTIONS(*camera_, "camera");
}

Eigen::Vector2d PairMatcher::PointForGeometry(const FeatureSet& features, int i) const {
  const Eigen::Vector2d pixel = features.Point(i);
  if (camera_ == nullptr) return pixel;
  Eigen::Vector3d ray;
  if (!camera_->Unproject(pixel, &ray)) return pixel;
  return Eigen::Vector2d(camera_->fx * ray.x() + camera_->cx, camera_->fy * ray.y() + camera_->cy);
}

PairMatches PairMatcher::Match(int image1, const FeatureSet& a, const DescriptorIndex& index_a,
                               int image2, const FeatureSet& b,
                               const DescriptorIndex& index_b) const {
  PairMatches pair;
  pair.image1 = image1;
  pair.image2 = image2;
  pair.summary.num_features1 = static_cast<int>(a.size());
  pair.summary.num_features2 = static_cast<int>(b.size());
  pair.matches = MatchDescriptors(a, index_a, b, index_b, options_.descriptors);
  pair.summary.num_putative = static_cast<int>(pair.matches.size());

  std::vector<Eigen::Vector2d> points1, points2;
  points1.reserve(pair.matches.size());
  points2.reserve(pair.matches.size());
  for (const FeatureMatch& m : pair.matches) {
    points1.push_back(PointForGeometry(a, m.feature1));
    points2.push_back(PointForGeometry(b, m.feature2));
  }
  EpipolarGeometry geometry = EstimateEpipolarGeometry(points1, points2, options_.verification);
  pair.summary.verified = geometry.verified;
  if (geometry.verified) {
    pair.F = geometry.F;
    pair.inliers = std::move(geometry.inliers);
  }
  pair.summary.num_inliers = static_cast<int>(pair.inliers.size());
  return pair;
}

PairMatches PairMatcher::Match(int image1, const FeatureSet& a, int image2,
                               const FeatureSet& b) const {
  const DescriptorIndex index_a(a, options_.descriptors);
  const DescriptorIndex index_b(b, options_.descriptors);
  return Match(image1, a, index_a, image2, b, index_b);
}

std::vector<std::pair<int, int>> SequentialPairs(int num_images, int num_neighbors) {
  CROP4D_CHECK(num_images >= 0 && num_neighbors >= 0);
  std::vector<std::pair<int, int>> pairs;
  for (int i = 0; i < num_images; ++i) {
    for (int j = i + 1; j <= std::min(num_images - 1, i + num_neighbors); ++j) {
      pairs.emplace_back(i, j);
    }
  }
  return pairs;
}

}  // namespace crop4d::features
