#include "crop4d/features/feature_extractor.h"

#include <algorithm>
#include <cmath>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"
#include "crop4d/core/hash.h"

namespace crop4d::features {
namespace {

// Bumped when the extraction code changes in a way that changes its output, so that caches
// written by an older crop4d are not reused.
constexpr std::uint32_t kExtractorRevision = 2;
// OpenCV's SIFT (4.6; 4.8+ unless enable_precise_upscale) doubles the image with a bilinear
// resize that samples at x/2 instead of (x + 0.5)/2 − 0.5, so every keypoint it reports sits a
// quarter pixel right of and below the feature (a blob centred at (x, y) is reported at
// (x + 0.25, y + 0.25); FeatureExtractor.KeypointsAreCentredOnBlobs measures it). A quarter pixel
// is a 0.05° bias at fx = 280 and centimetres on distant ground, so it is removed.
constexpr double kSiftKeypointOffsetPx = 0.25;

// Bilinear RGB sample of an 8-bit BGR image at (x, y), clamped to the image.
std::array<std::uint8_t, 3> SampleColor(const cv::Mat& bgr, float x, float y) {
  const float xc = std::clamp(x, 0.0f, static_cast<float>(bgr.cols - 1));
  const float yc = std::clamp(y, 0.0f, static_cast<float>(bgr.rows - 1));
  const int x0 = static_cast<int>(xc), y0 = static_cast<int>(yc);
  const int x1 = std::min(x0 + 1, bgr.cols - 1), y1 = std::min(y0 + 1, bgr.rows - 1);
  const float ax = xc - x0, ay = yc - y0;
  std::array<std::uint8_t, 3> rgb;
  for (int c = 0; c < 3; ++c) {
    const float v00 = bgr.at<cv::Vec3b>(y0, x0)[c], v01 = bgr.at<cv::Vec3b>(y0, x1)[c];
    const float v10 = bgr.at<cv::Vec3b>(y1, x0)[c], v11 = bgr.at<cv::Vec3b>(y1, x1)[c];
    const float v = (1 - ay) * ((1 - ax) * v00 + ax * v01) + ay * ((1 - ax) * v10 + ax * v11);
    rgb[2 - c] = static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
  }
  return rgb;
}

// Strict weak order that makes the keypoint order independent of OpenCV's internal
// (multi-threaded) ordering: strongest first, ties broken by every other field.
bool StrongerFirst(const cv::KeyPoint& a, const cv::KeyPoint& b) {
  if (a.response != b.response) return a.response > b.response;
  if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
  if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
  if (a.size != b.size) return a.size < b.size;
  if (a.angle != b.angle) return a.angle < b.angle;
  return a.octave < b.octave;
}

// The `budget` keypoints kept from `order` (strongest first): in each cell of a cells × cells
// grid over the width × height image its strongest keypoints up to budget / cells², then the
// strongest of the rest anywhere until the budget is spent. The result keeps the order.
std::vector<int> SelectOnGrid(const std::vector<cv::KeyPoint>& keypoints,
                              const std::vector<int>& order, int width, int height, int cells,
                              int budget) {
  const int quota = std::max(1, budget / (cells * cells));
  std::vector<int> count(static_cast<std::size_t>(cells) * cells, 0);
  std::vector<char> taken(order.size(), 0);
  int num_taken = 0;
  for (std::size_t k = 0; k < order.size() && num_taken < budget; ++k) {
    const cv::Point2f& pt = keypoints[order[k]].pt;
    const int cx = std::clamp(static_cast<int>(pt.x * cells / width), 0, cells - 1);
    const int cy = std::clamp(static_cast<int>(pt.y * cells / height), 0, cells - 1);
    int& c = count[static_cast<std::size_t>(cy) * cells + cx];
    if (c < quota) {
      ++c;
      taken[k] = 1;
      ++num_taken;
    }
  }
  for (std::size_t k = 0; k < order.size() && num_taken < budget; ++k) {
    if (!taken[k]) {
      taken[k] = 1;
      ++num_taken;
    }
  }
  std::vector<int> selected;
  selected.reserve(num_taken);
  for (std::size_t k = 0; k < order.size(); ++k) {
    if (taken[k]) selected.push_back(order[k]);
  }
  return selected;
}

}  // namespace

bool FeatureSet::IsConsistent() const {
  return descriptors.size() == keypoints.size() * kDescriptorSize &&
         colors.size() == keypoints.size();
}

OptionCheck FeatureExtractor::Options::Check() const {
  OptionChecker c;
  c.AtLeast("max_num_features", max_num_features, 0)
      .AtLeast("num_octave_layers", num_octave_layers, 1)
      .Greater("contrast_threshold", contrast_threshold, 0.0)
      .Finite("contrast_threshold", contrast_threshold)
      .Greater("edge_threshold", edge_threshold, 0.0)
      .Finite("edge_threshold", edge_threshold)
      .Greater("sigma", sigma, 0.0)
      .Finite("sigma", sigma)
      .AtLeast("max_image_size", max_image_size, 0)
      .AtLeast("spatial_grid_cells", spatial_grid_cells, 0);
  return c.Result();
}

std::uint64_t FeatureExtractor::Options::Hash() const {
  Fnv1aHasher hasher;
  hasher.AddString("crop4d-sift");
  hasher.Add(kExtractorRevision);
  hasher.AddString(CV_VERSION);
  hasher.Add(max_num_features);
  hasher.Add(num_octave_layers);
  hasher.Add(contrast_threshold);
  hasher.Add(edge_threshold);
  hasher.Add(sigma);
  hasher.Add(max_image_size);
  hasher.Add(spatial_grid_cells);
  return hasher.hash();
}

FeatureExtractor::FeatureExtractor(Options options) : options_(std::move(options)) {
  CROP4D_CHECK_OPTIONS(options_, "FeatureExtractor::Options");
}

double ImageSharpness(const cv::Mat& gray) {
  if (gray.empty()) return 0.0;
  CROP4D_CHECK(gray.type() == CV_8UC1);
  cv::Mat half, gx, gy;
  cv::pyrDown(gray, half);
  cv::Sobel(half, gx, CV_32F, 1, 0, 3, 0.125);  // 1/8: the Sobel kernel's weight, grey levels/px
  cv::Sobel(half, gy, CV_32F, 0, 1, 3, 0.125);
  // The mean structure tensor [xx xy; xy yy] and its smallest eigenvalue.
  const double xx = cv::mean(gx.mul(gx))[0], yy = cv::mean(gy.mul(gy))[0];
  const double xy = cv::mean(gx.mul(gy))[0];
  const double half_trace = 0.5 * (xx + yy);
  const double root = std::sqrt(0.25 * (xx - yy) * (xx - yy) + xy * xy);
  return std::max(0.0, half_trace - root);
}

std::vector<double> SharpnessOf(const std::vector<FeatureSet>& sets) {
  std::vector<double> sharpness;
  sharpness.reserve(sets.size());
  for (const FeatureSet& set : sets) sharpness.push_back(set.sharpness);
  return sharpness;
}

FeatureSet FeatureExtractor::Extract(const cv::Mat& image) const {
  FeatureSet out;
  if (image.empty()) return out;
  CROP4D_CHECK_MSG(image.depth() == CV_8U, "FeatureExtractor needs an 8-bit image");
  CROP4D_CHECK_MSG(image.channels() == 1 || image.channels() == 3 || image.channels() == 4,
                   "FeatureExtractor needs a 1-, 3- or 4-channel image");
  out.image_width = image.cols;
  out.image_height = image.rows;

  cv::Mat bgr, gray;
  if (image.channels() == 1) {
    gray = image;
    cv::cvtColor(image, bgr, cv::COLOR_GRAY2BGR);
  } else if (image.channels() == 3) {
    bgr = image;
    cv::cvtColor(image, gray, cv::COLOR_BGR2GRAY);
  } else {
    cv::cvtColor(image, bgr, cv::COLOR_BGRA2BGR);
    cv::cvtColor(image, gray, cv::COLOR_BGRA2GRAY);
  }

  out.sharpness = static_cast<float>(ImageSharpness(gray));

  // Optional downscaling; `scale` maps full-resolution pixels to extraction pixels.
  double scale = 1.0;
  const int largest = std::max(image.cols, image.rows);
  if (options_.max_image_size > 0 && largest > options_.max_image_size) {
    scale = static_cast<double>(options_.max_image_size) / largest;
    cv::Mat small;
    cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
    gray = small;
  }

  // With a grid the keypoints are selected here, among all of them, before their descriptors.
  const bool grid = options_.spatial_grid_cells > 0 && options_.max_num_features > 0;
  cv::Ptr<cv::SIFT> sift =
      cv::SIFT::create(grid ? 0 : options_.max_num_features, options_.num_octave_layers,
                       options_.contrast_threshold, options_.edge_threshold, options_.sigma, CV_8U);
  std::vector<cv::KeyPoint> keypoints;
  cv::Mat descriptors;
  if (grid) {
    // Descriptors cost far more than detection (≈ 45 µs per keypoint against ≈ 25 ms for the
    // scale space of a 640×480 image), so only the selected keypoints get one.
    sift->detect(gray, keypoints);
    if (keypoints.empty()) return out;
    std::vector<int> order(keypoints.size());
    std::iota(order.begin(), order.end(), 0);
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return StrongerFirst(keypoints[a], keypoints[b]); });
    if (order.size() > static_cast<std::size_t>(options_.max_num_features)) {
      order = SelectOnGrid(keypoints, order, gray.cols, gray.rows, options_.spatial_grid_cells,
                           options_.max_num_features);
    }
    std::vector<cv::KeyPoint> selected;
    selected.reserve(order.size());
    for (int k : order) selected.push_back(keypoints[k]);
    keypoints = std::move(selected);
    sift->compute(gray, keypoints, descriptors);
  } else {
    sift->detectAndCompute(gray, cv::noArray(), keypoints, descriptors);
  }
  if (keypoints.empty()) return out;
  CROP4D_CHECK(descriptors.rows == static_cast<int>(keypoints.size()));
  CROP4D_CHECK(descriptors.cols == kDescriptorSize && descriptors.type() == CV_8U);

  std::vector<int> order(keypoints.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(),
            [&](int a, int b) { return StrongerFirst(keypoints[a], keypoints[b]); });
  if (options_.max_num_features > 0 &&
      order.size() > static_cast<std::size_t>(options_.max_num_features)) {
    order.resize(options_.max_num_features);
  }

  out.keypoints.reserve(order.size());
  out.colors.reserve(order.size());
  out.descriptors.resize(order.size() * kDescriptorSize);
  for (std::size_t n = 0; n < order.size(); ++n) {
    const cv::KeyPoint& kp = keypoints[order[n]];
    Keypoint k;
    // Pixel centres are at integer coordinates in both resolutions: x_full + 0.5 =
    // (x_small + 0.5) / scale. OpenCV's SIFT reports its keypoints kSiftKeypointOffsetPx too far
    // right and down (see there); corrected first.
    k.x = static_cast<float>((kp.pt.x - kSiftKeypointOffsetPx + 0.5) / scale - 0.5);
    k.y = static_cast<float>((kp.pt.y - kSiftKeypointOffsetPx + 0.5) / scale - 0.5);
    k.size = static_cast<float>(kp.size / scale);
    k.angle = kp.angle;
    k.response = kp.response;
    k.octave = kp.octave;
    out.keypoints.push_back(k);
    out.colors.push_back(SampleColor(bgr, k.x, k.y));
    std::copy_n(descriptors.ptr<std::uint8_t>(order[n]), kDescriptorSize,
                out.descriptors.data() + n * kDescriptorSize);
  }
  return out;
}

}  // namespace crop4d::features
