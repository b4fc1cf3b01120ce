#pragma once

// SIFT features of one image (Lowe, "Distinctive Image Features from Scale-Invariant
// Keypoints", IJCV 2004), extracted with OpenCV's implementation. The result is a plain
// `FeatureSet` (no OpenCV types) so that the cache, the matcher and the back end share it.
//
//   FeatureExtractor extractor(FeatureExtractor::Options{});
//   FeatureSet features = extractor.Extract(bgr_image);

#include <Eigen/Core>
#include <array>
#include <cstddef>
#include <cstdint>
#include <vector>

#include "crop4d/core/option_check.h"

namespace cv {
class Mat;
}  // namespace cv

namespace crop4d::features {

// Length of a SIFT descriptor (4×4 spatial cells × 8 orientation bins).
inline constexpr int kDescriptorSize = 128;

// One detected keypoint, in the pixel coordinates of the input image (OpenCV convention:
// integer coordinates are pixel centres).
struct Keypoint {
  float x = 0;              // column, pixels
  float y = 0;              // row, pixels
  float size = 0;           // diameter of the meaningful neighbourhood, pixels
  float angle = 0;          // orientation in degrees [0, 360), -1 when not applicable
  float response = 0;       // detector response (DoG contrast); larger is stronger
  std::int32_t octave = 0;  // OpenCV's packed octave/layer word, kept as is

  bool operator==(const Keypoint&) const = default;
};

// The features of one image: keypoints, their descriptors and their colours, all of the same
// length and in the same order (strongest response first).
struct FeatureSet {
  int image_width = 0;
  int image_height = 0;
  // How precisely the image can localise a shift in its worst direction: the smallest
  // eigenvalue of the mean structure tensor (the mean of ∇I ∇Iᵀ, grey levels² per pixel) of the
  // grey image at half resolution (ImageSharpness). A keypoint's position is known to within a
  // standard deviation ∝ 1/√(its patch's gradient energy in that direction) (the Cramér–Rao bound
  // of image registration), so an image blurred by motion (along the motion) or darkened by the
  // exposure localises its keypoints less precisely than its neighbours
  // (slam/image_quality.h). 0: not measured.
  float sharpness = 0;
  std::vector<Keypoint> keypoints;
  // Row-major size() × kDescriptorSize. OpenCV's SIFT descriptor is normalised to unit length,
  // clamped at 0.2, renormalised and scaled by 512 before it is saturated to 8 bits; storing the
  // 8-bit version loses nothing of what OpenCV computes with the CV_8U descriptor type.
  std::vector<std::uint8_t> descriptors;
  // RGB colour of the image at each keypoint (bilinear), for coloured landmark clouds.
  std::vector<std::array<std::uint8_t, 3>> colors;

  std::size_t size() const { return keypoints.size(); }
  bool empty() const { return keypoints.empty(); }
  const std::uint8_t* Descriptor(std::size_t i) const {
    return descriptors.data() + i * kDescriptorSize;
  }
  Eigen::Vector2d Point(std::size_t i) const {
    return Eigen::Vector2d(keypoints[i].x, keypoints[i].y);
  }
  // Whether the three arrays agree in length.
  bool IsConsistent() const;
  bool operator==(const FeatureSet&) const = default;
};

// The smallest eigenvalue of the mean structure tensor of an 8-bit grey image after one Gaussian
// pyramid step down (which keeps most of the pixel noise out of it): FeatureSet::sharpness, grey
// levels² per pixel. 0 for an empty or flat image, and for one textured in one direction only.
double ImageSharpness(const cv::Mat& gray);

// The sharpness of each feature set, in order (slam::RowOptimiser::Input::image_sharpness).
std::vector<double> SharpnessOf(const std::vector<FeatureSet>& sets);

class FeatureExtractor {
 public:
  struct Options {
    // Keep at most this many keypoints, the strongest by response (0 = all).
    int max_num_features = 8192;
    // Scale-space layers per octave; 3 as in Lowe (2004).
    int num_octave_layers = 3;
    // DoG contrast threshold (OpenCV's convention: divided by num_octave_layers internally;
    // 0.04 is OpenCV's default, Lowe's 0.03 corresponds to 0.09; 0.02 equals COLMAP's default
    // peak threshold 0.02/3). Lower gives more features in low-contrast areas such as soil.
    double contrast_threshold = 0.02;
    // Edge-response threshold on the ratio of principal curvatures; Lowe (2004) uses 10.
    double edge_threshold = 10.0;
    // Sigma of the Gaussian applied to the input at octave 0; Lowe (2004) uses 1.6.
    double sigma = 1.6;
    // Images larger than this (largest side, pixels) are downscaled for extraction and the
    // keypoints scaled back to full-resolution pixels (0 = never downscale).
    int max_image_size = 0;
    // Spread the max_num_features budget over a spatial_grid_cells × spatial_grid_cells grid:
    // each cell keeps its strongest keypoints up to an equal share of the budget, and the
    // budget left by cells with fewer keypoints goes to the strongest remaining ones anywhere
    // (0 = no grid: the strongest keypoints of the whole image). A grid keeps features on
    // low-contrast areas (soil) that the strongest-first rule would leave to the plants.
    int spatial_grid_cells = 0;

    OptionCheck Check() const;
    // A hash of every field that changes the extracted features, stored in the feature cache
    // so that a cache written with other options is not reused.
    std::uint64_t Hash() const;
  };

  explicit FeatureExtractor(Options options);

  // Extracts the features of an 8-bit image with 1 (grey), 3 (BGR) or 4 (BGRA) channels.
  // The output is deterministic: keypoints are sorted by decreasing response, then position.
  // An empty image gives an empty set.
  FeatureSet Extract(const cv::Mat& image) const;

  const Options& options() const { return options_; }

 private:
  Options options_;
};

}  // namespace crop4d::features
