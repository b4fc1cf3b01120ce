#include "crop4d/association/plane_warp.h"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::association {
namespace {

// Largest singular value of a 2×2 matrix (closed form from the trace and determinant of AᵀA).
double LargestSingularValue(const Eigen::Matrix2d& a) {
  const double t = a.squaredNorm();
  const double d = a.determinant();
  return std::sqrt(0.5 * (t + std::sqrt(std::max(t * t - 4 * d * d, 0.0))));
}

cv::Mat ToGrey(const cv::Mat& image) {
  CROP4D_CHECK_MSG(image.depth() == CV_8U, "plane warp: I1 must be an 8-bit image");
  if (image.channels() == 1) return image;
  cv::Mat grey;
  if (image.channels() == 3) {
    cv::cvtColor(image, grey, cv::COLOR_BGR2GRAY);
  } else {
    CROP4D_CHECK_MSG(image.channels() == 4, "plane warp: I1 must have 1, 3 or 4 channels");
    cv::cvtColor(image, grey, cv::COLOR_BGRA2GRAY);
  }
  return grey;
}

// Lays patches out in a mosaic and describes them with one cv::SIFT::compute call per batch.
//
// The blur to the keypoints' scale σ is applied here, once per mosaic, in 8-bit (OpenCV's
// fixed-point Gaussian, several times cheaper than the float one), and the SIFT instance is told
// that its input is already at its base blur (its sigma is SIFT's assumed camera blur, 0.5): its
// own base blur then vanishes and the upper layers of its one-octave pyramid, which the
// descriptors never read, cost little. The descriptor still reads an image blurred to σ, at scale
// size / 2 = σ, exactly as with a SIFT instance of base σ blurring a raw patch.
class PatchBatch {
 public:
  PatchBatch(int patch_side, int capacity, double sigma)
      : side_(patch_side), capacity_(capacity), sigma_(sigma) {
    columns_ = static_cast<int>(std::ceil(std::sqrt(static_cast<double>(capacity_))));
    rows_ = (capacity_ + columns_ - 1) / columns_;
    mosaic_ = cv::Mat::zeros(rows_ * side_, columns_ * side_, CV_8U);
    // Detection parameters are unused (keypoints are provided); 3 layers per octave keeps the
    // unread upper layers cheapest to blur.
    sift_ = cv::SIFT::create(0, 3, 0.04, 10, kAssumedInputBlur + 1e-3, CV_8U);
  }

  bool full() const { return static_cast<int>(keypoints_.size()) >= capacity_; }

  // The patch cell of the next keypoint.
  cv::Mat NextCell() {
    const int n = static_cast<int>(keypoints_.size());
    return mosaic_(cv::Rect((n % columns_) * side_, (n / columns_) * side_, side_, side_));
  }
  // The keypoint at the centre of the cell NextCell() returned; `request` is its output row.
  void Add(int request, float angle) {
    const int n = static_cast<int>(keypoints_.size());
    const float center = static_cast<float>(side_ / 2);
    keypoints_.emplace_back(
        cv::Point2f((n % columns_) * side_ + center, (n / columns_) * side_ + center),
        static_cast<float>(2 * sigma_), angle, 0.f, /*octave=*/0, /*class_id=*/request);
  }

  // Describes the patches and writes each descriptor to its request's row.
  void Flush(std::vector<std::uint8_t>* descriptors) {
    if (keypoints_.empty()) return;
    const int used_rows = (static_cast<int>(keypoints_.size()) + columns_ - 1) / columns_;
    cv::Mat used = mosaic_(cv::Rect(0, 0, mosaic_.cols, used_rows * side_));
    const double blur =
        std::sqrt(std::max(sigma_ * sigma_ - kAssumedInputBlur * kAssumedInputBlur, 0.01));
    cv::GaussianBlur(used, used, cv::Size(), blur, blur, cv::BORDER_REPLICATE);
    std::vector<cv::KeyPoint> keypoints = keypoints_;
    cv::Mat result;
    sift_->compute(used, keypoints, result);
    // OpenCV keeps provided keypoints as they are; class_id carries the request either way.
    CROP4D_CHECK(result.rows == static_cast<int>(keypoints.size()) &&
                 result.cols == features::kDescriptorSize && result.type() == CV_8U);
    for (int k = 0; k < result.rows; ++k) {
      std::copy_n(result.ptr<std::uint8_t>(k), features::kDescriptorSize,
                  descriptors->data() +
                      static_cast<std::size_t>(keypoints[k].class_id) * features::kDescriptorSize);
    }
    keypoints_.clear();
  }

 private:
  // SIFT's assumption about the blur of its input image, pixels (Lowe 2004, §3.3).
  static constexpr double kAssumedInputBlur = 0.5;

  int side_, capacity_, columns_ = 1, rows_ = 1;
  double sigma_;
  cv::Mat mosaic_;
  cv::Ptr<cv::SIFT> sift_;
  std::vector<cv::KeyPoint> keypoints_;
};

}  // namespace

PlaneTransfer::PlaneTransfer(const geometry::PinholeRadTan& camera_a,
                             const geometry::PinholeRadTan& camera_b,
                             const geometry::Rigid3& camera_b_from_camera_a,
                             const Eigen::Vector3d& normal_in_a, double offset)
    : camera_a_(&camera_a), camera_b_(&camera_b) {
  CROP4D_CHECK_MSG(offset != 0 && std::isfinite(offset), "PlaneTransfer: plane through camera a");
  normal_over_offset_ = normal_in_a / offset;
  // Y_b = R Y_a + t and (n/d)ᵀY_a = 1 on the plane give Y_b = (R + t nᵀ/d) Y_a.
  b_from_a_ = camera_b_from_camera_a.RotationMatrix() +
              camera_b_from_camera_a.translation() * normal_over_offset_.transpose();
  a_from_b_ = b_from_a_.inverse();
  // One camera at one pose: every plane maps each pixel onto itself, and the lens model need not
  // be undone and redone (ComputeUprightDescriptors describes I2's own keypoints this way).
  identity_ = &camera_a == &camera_b &&
              camera_b_from_camera_a.RotationMatrix() == Eigen::Matrix3d::Identity() &&
              camera_b_from_camera_a.translation() == Eigen::Vector3d::Zero();
}

bool PlaneTransfer::AToB(const Eigen::Vector2d& pixel_a, Eigen::Vector2d* pixel_b) const {
  if (identity_) {
    *pixel_b = pixel_a;
    return true;
  }
  Eigen::Vector3d ray_a;
  if (!camera_a_->Unproject(pixel_a, &ray_a)) return false;
  // The plane point is Y_a = λ ray_a with 1/λ = (n/d)ᵀ ray_a; it lies in front of camera a when
  // λ > 0, and Y_b = λ H ray_a is in front of camera b when (H ray_a).z > 0 (checked by Project).
  if (!(normal_over_offset_.dot(ray_a) > 0)) return false;
  return camera_b_->Project(b_from_a_ * ray_a, pixel_b);
}

bool PlaneTransfer::BToA(const Eigen::Vector2d& pixel_b, Eigen::Vector2d* pixel_a) const {
  if (identity_) {
    *pixel_a = pixel_b;
    return true;
  }
  Eigen::Vector3d ray_b;
  if (!camera_b_->Unproject(pixel_b, &ray_b)) return false;
  // Y_b = μ ray_b and Y_a = μ H⁻¹ ray_b, with 1/μ = (n/d)ᵀ H⁻¹ ray_b from the plane equation.
  const Eigen::Vector3d w = a_from_b_ * ray_b;
  if (!(normal_over_offset_.dot(w) > 0)) return false;
  return camera_a_->Project(w, pixel_a);
}

OptionCheck PlaneWarpOptions::Check() const {
  OptionChecker c;
  c.InRange("descriptor_sigma", descriptor_sigma, 0.6, 8.0)
      .AtLeast("patches_per_batch", patches_per_batch, 1)
      .AtLeast("map_node_spacing_px", map_node_spacing_px, 1)
      .AtLeast("min_view_cosine", min_view_cosine, 0.0)
      .Less("min_view_cosine", min_view_cosine, 1.0)
      .AtLeast("max_area_change", max_area_change, 1.0)
      .AtLeast("max_pyramid_level", max_pyramid_level, 0);
  return c.Result();
}

namespace {

// The patch that a warped keypoint is described on, and the nodes of its map: the map from
// patch pixels to I1 is computed exactly at (intervals + 1)² nodes and bilinearly between them.
struct PatchLayout {
  int half = 0, side = 0;  // side = 2 half + 1 pixels
  double keypoint_size = 0;
  int intervals = 0;
  // Patch pixel k lies in node interval cell_of[k], at fraction weight_of[k] of it (rows and
  // columns alike).
  std::vector<int> cell_of;
  std::vector<float> weight_of;
};

// Patch size: OpenCV's descriptor window has radius round(3σ·√2·(4 + 1)/2) at scale σ (the 4×4
// cells of Lowe 2004, §6.1, each 3σ wide, rotated), gradients need one more pixel, and the blur
// to σ (√(σ² − 0.5²), the input being taken as blurred by 0.5) must not bring in the next
// patch. Nodes every map_node_spacing_px pixels.
PatchLayout MakePatchLayout(const PlaneWarpOptions& options) {
  PatchLayout p;
  const double sigma = options.descriptor_sigma;
  const int window_radius = static_cast<int>(std::lround(3 * sigma * std::sqrt(2.0) * 2.5));
  const int blur_margin =
      static_cast<int>(std::ceil(3 * std::sqrt(std::max(sigma * sigma - 0.25, 0.01)))) + 1;
  p.half = window_radius + 1 + blur_margin;
  p.side = 2 * p.half + 1;
  p.keypoint_size = 2 * sigma;
  p.intervals =
      std::max(1, (p.side - 1 + options.map_node_spacing_px - 1) / options.map_node_spacing_px);
  p.cell_of.resize(p.side);
  p.weight_of.resize(p.side);
  for (int k = 0; k < p.side; ++k) {
    const double f = static_cast<double>(k) * p.intervals / (p.side - 1);
    p.cell_of[k] = std::min(static_cast<int>(f), p.intervals - 1);
    p.weight_of[k] = static_cast<float>(f - p.cell_of[k]);
  }
  return p;
}

// Whether both cameras see the plane at the keypoint at least at min_view_cosine (grazing views
// make the homography ill-conditioned); x2 is the keypoint's pixel in I2.
bool ViewsNotGrazing(const PlaneWarpInput& input, const WarpRequest& request,
                     const PlaneTransfer& transfer, const Eigen::Vector2d& x1,
                     const Eigen::Matrix3d& rotation_b_from_a, double min_view_cosine,
                     Eigen::Vector2d* x2) {
  const Eigen::Vector3d normal_a = request.normal_in_a.normalized();
  Eigen::Vector3d ray_a;
  if (!input.camera_a->Unproject(x1, &ray_a)) return false;
  if (std::abs(normal_a.dot(ray_a.normalized())) < min_view_cosine) return false;
  if (!transfer.AToB(x1, x2)) return false;
  Eigen::Vector3d ray_b;
  if (!input.camera_b->Unproject(*x2, &ray_b)) return false;
  return !(std::abs((rotation_b_from_a * normal_a).dot(ray_b.normalized())) < min_view_cosine);
}

// J = ∂x2/∂x1 by central differences of half a pixel.
bool TransferJacobian(const PlaneTransfer& transfer, const Eigen::Vector2d& x1,
                      Eigen::Matrix2d* jacobian) {
  bool ok = true;
  for (int axis = 0; axis < 2 && ok; ++axis) {
    Eigen::Vector2d step = Eigen::Vector2d::Zero();
    step[axis] = 0.5;
    Eigen::Vector2d plus, minus;
    ok = transfer.AToB(x1 + step, &plus) && transfer.AToB(x1 - step, &minus);
    if (ok) jacobian->col(axis) = (plus - minus) / (2 * step[axis]);
  }
  return ok;
}

// The keypoint's orientation in I2, degrees in [0, 360): its gradient direction carried by J⁻ᵀ;
// 0 upright or when the keypoint has none.
double WarpedAngle(const features::Keypoint& keypoint, const Eigen::Matrix2d& jacobian,
                   bool upright) {
  if (upright || !(keypoint.angle >= 0)) return 0;
  const double theta = keypoint.angle * std::numbers::pi / 180.0;
  const Eigen::Vector2d gradient =
      jacobian.inverse().transpose() * Eigen::Vector2d(std::cos(theta), std::sin(theta));
  double angle_b = std::atan2(gradient.y(), gradient.x()) * 180.0 / std::numbers::pi;
  if (angle_b < 0) angle_b += 360.0;
  if (angle_b >= 360.0) angle_b -= 360.0;
  return angle_b;
}

// The cv::remap map of the patch around x2 (`spacing` I2 pixels per patch pixel) into pyramid
// level `level` of I1: exact at the nodes (patch pixel → I2 pixel → plane → I1 pixel → level
// pixel), bilinear between them, first along the column of nodes for a row, then along the row
// (the column weights are the same for every row). False when a node does not transfer.
bool PatchMap(const PatchLayout& p, const PlaneTransfer& transfer, const Eigen::Vector2d& x2,
              double spacing, double image_scale, int level, std::vector<Eigen::Vector2f>* nodes,
              std::vector<Eigen::Vector2f>* row_nodes, cv::Mat* map) {
  const int intervals = p.intervals, side = p.side, half = p.half;
  bool ok = true;
  for (int i = 0; i <= intervals && ok; ++i) {
    for (int j = 0; j <= intervals && ok; ++j) {
      const double pr = static_cast<double>(i) * (side - 1) / intervals - half;
      const double pc = static_cast<double>(j) * (side - 1) / intervals - half;
      Eigen::Vector2d u1;
      ok = transfer.BToA(x2 + spacing * Eigen::Vector2d(pc, pr), &u1);
      if (ok) {
        (*nodes)[static_cast<std::size_t>(i) * (intervals + 1) + j] =
            (((u1.array() + 0.5) * image_scale - 0.5) / (1 << level)).matrix().cast<float>();
      }
    }
  }
  if (!ok) return false;
  for (int row = 0; row < side; ++row) {
    const int i0 = p.cell_of[row];
    const float ai = p.weight_of[row];
    const Eigen::Vector2f* top = &(*nodes)[static_cast<std::size_t>(i0) * (intervals + 1)];
    const Eigen::Vector2f* bottom = top + (intervals + 1);
    for (int j = 0; j <= intervals; ++j) (*row_nodes)[j] = (1 - ai) * top[j] + ai * bottom[j];
    cv::Vec2f* out = map->ptr<cv::Vec2f>(row);
    for (int col = 0; col < side; ++col) {
      const int j0 = p.cell_of[col];
      const float aj = p.weight_of[col];
      const Eigen::Vector2f v = (1 - aj) * (*row_nodes)[j0] + aj * (*row_nodes)[j0 + 1];
      out[col] = cv::Vec2f(v.x(), v.y());
    }
  }
  return true;
}

}  // namespace

std::vector<WarpedKeypoint> ComputeWarpedDescriptors(const PlaneWarpInput& input,
                                                     const std::vector<WarpRequest>& requests,
                                                     const PlaneWarpOptions& options,
                                                     std::vector<std::uint8_t>* descriptors) {
  CROP4D_CHECK_OPTIONS(options, "PlaneWarpOptions");
  CROP4D_CHECK(input.camera_a != nullptr && input.camera_b != nullptr &&
               input.features_a != nullptr && descriptors != nullptr);
  const std::size_t n = requests.size();
  std::vector<WarpedKeypoint> warped(n);
  descriptors->assign(n * features::kDescriptorSize, 0);
  if (n == 0) return warped;
  CROP4D_CHECK_MSG(input.image_a != nullptr && !input.image_a->empty(),
                   "plane warp: the image I1 is needed");
  const geometry::PinholeRadTan& camera_a = *input.camera_a;
  const geometry::PinholeRadTan& camera_b = *input.camera_b;
  const features::FeatureSet& features_a = *input.features_a;

  // I1 in grey and its Gaussian pyramid. cv::pyrDown centres level pixel i on pixel 2i of the
  // finer level, so level-ℓ coordinates are image coordinates / 2^ℓ.
  const cv::Mat grey = ToGrey(*input.image_a);
  const int full_width = features_a.image_width > 0 ? features_a.image_width : camera_a.width;
  const double image_scale = static_cast<double>(grey.cols) / full_width;
  int num_levels = 0;
  while (num_levels < options.max_pyramid_level &&
         std::min(grey.cols, grey.rows) >> (num_levels + 1) >= 16) {
    ++num_levels;
  }
  std::vector<cv::Mat> pyramid;
  cv::buildPyramid(grey, pyramid, num_levels);

  const PatchLayout layout = MakePatchLayout(options);
  const int capacity = std::min<int>(options.patches_per_batch, static_cast<int>(n));
  PatchBatch batch(layout.side, capacity, options.descriptor_sigma);
  std::vector<Eigen::Vector2f> nodes(static_cast<std::size_t>(layout.intervals + 1) *
                                     (layout.intervals + 1));
  std::vector<Eigen::Vector2f> row_nodes(layout.intervals + 1);
  cv::Mat map(layout.side, layout.side, CV_32FC2);
  const Eigen::Matrix3d rotation_b_from_a = input.camera_b_from_camera_a.RotationMatrix();

  for (std::size_t r = 0; r < n; ++r) {
    const WarpRequest& request = requests[r];
    CROP4D_CHECK(request.feature >= 0 &&
                 static_cast<std::size_t>(request.feature) < features_a.size());
    if (request.offset == 0 || !std::isfinite(request.offset) || !request.normal_in_a.allFinite() ||
        request.normal_in_a.squaredNorm() == 0) {
      continue;
    }
    const features::Keypoint& keypoint = features_a.keypoints[request.feature];
    const Eigen::Vector2d x1(keypoint.x, keypoint.y);
    const PlaneTransfer transfer(camera_a, camera_b, input.camera_b_from_camera_a,
                                 request.normal_in_a, request.offset);
    Eigen::Vector2d x2;
    if (!ViewsNotGrazing(input, request, transfer, x1, rotation_b_from_a, options.min_view_cosine,
                         &x2)) {
      continue;
    }
    Eigen::Matrix2d jacobian;
    if (!TransferJacobian(transfer, x1, &jacobian)) continue;
    const double det = jacobian.determinant();
    // det ≤ 0: the two cameras see opposite sides of the plane (or a fold); no warp.
    if (!(det > 1.0 / options.max_area_change && det < options.max_area_change)) continue;
    const double size_b = keypoint.size * std::sqrt(det);
    const double angle_b = WarpedAngle(keypoint, jacobian, options.upright);
    const double spacing = size_b / layout.keypoint_size;  // I2 pixels per patch pixel

    // Pyramid level: the patch pixel's largest extent in I1's image pixels, shrunk to ≤ 1.5.
    const double footprint = LargestSingularValue(image_scale * spacing * jacobian.inverse());
    int level = 0;
    while (level < num_levels && footprint / (1 << level) > 1.5) ++level;
    if (!PatchMap(layout, transfer, x2, spacing, image_scale, level, &nodes, &row_nodes, &map)) {
      continue;
    }
    cv::Mat cell = batch.NextCell();
    cv::remap(pyramid[level], cell, map, cv::noArray(), cv::INTER_LINEAR, cv::BORDER_REPLICATE);
    batch.Add(static_cast<int>(r), static_cast<float>(angle_b));

    WarpedKeypoint& w = warped[r];
    w.valid = true;
    w.pixel_b = x2;
    w.size_b = static_cast<float>(size_b);
    w.angle_b = static_cast<float>(angle_b);
    w.pyramid_level = level;
    if (batch.full()) batch.Flush(descriptors);
  }
  batch.Flush(descriptors);
  return warped;
}

std::vector<bool> ComputeUprightDescriptors(const geometry::PinholeRadTan& camera,
                                            const features::FeatureSet& features,
                                            const cv::Mat& image,
                                            const std::vector<std::int32_t>& indices,
                                            const PlaneWarpOptions& options,
                                            std::vector<std::uint8_t>* descriptors) {
  // The identity transfer: one camera at one pose, through the plane z = 1 of its frame (any
  // plane in front of it gives H = I, and PlaneTransfer then maps each pixel onto itself).
  std::vector<WarpRequest> requests(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k) {
    requests[k].feature = indices[k];
    requests[k].normal_in_a = Eigen::Vector3d::UnitZ();
    requests[k].offset = 1.0;
  }
  PlaneWarpInput input;
  input.camera_a = &camera;
  input.camera_b = &camera;
  input.camera_b_from_camera_a = geometry::Rigid3::Identity();
  input.features_a = &features;
  input.image_a = &image;
  PlaneWarpOptions upright = options;
  upright.upright = true;
  const std::vector<WarpedKeypoint> described =
      ComputeWarpedDescriptors(input, requests, upright, descriptors);
  std::vector<bool> valid(indices.size());
  for (std::size_t k = 0; k < indices.size(); ++k) valid[k] = described[k].valid;
  return valid;
}

}  // namespace crop4d::association
