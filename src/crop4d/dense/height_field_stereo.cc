#include "crop4d/dense/height_field_stereo.h"

#include <spdlog/spdlog.h>
#include <tbb/parallel_for.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <numeric>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "crop4d/core/color.h"
#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/core/stopwatch.h"
#include "crop4d/dense/cell_window.h"

namespace crop4d::dense {
namespace {

using Clock = std::chrono::steady_clock;

// The undistorted pinhole camera that the images are resampled to once when they are loaded,
// so that the inner loops project with a pinhole (a plane maps to an image by a homography)
// instead of evaluating the lens polynomial for every sample. Its canvas is enlarged to hold the
// whole image (barrel distortion pushes the corners and the bottom edge outwards).
struct Rectification {
  float fx = 0, fy = 0, cx = 0, cy = 0;
  int width = 0, height = 0;
  cv::Mat map_x, map_y;  // undistorted pixel → original pixel (cv::remap)
  // For a bilinear sample whose top-left pixel is (u0, v0): valid when v0 + 1 < height and
  // lo[v0] <= u0 <= hi[v0] (rows v0 and v0 + 1 both inside the eroded image).
  std::vector<int> lo, hi;
};

Rectification MakeRectification(const geometry::PinholeRadTan& camera, int erode_px) {
  Rectification rect;
  double x0 = INFINITY, x1 = -INFINITY, y0 = INFINITY, y1 = -INFINITY;
  auto extend = [&](double u, double v) {
    Eigen::Vector3d ray;
    if (!camera.Unproject(Eigen::Vector2d(u, v), &ray)) return;
    x0 = std::min(x0, ray.x());
    x1 = std::max(x1, ray.x());
    y0 = std::min(y0, ray.y());
    y1 = std::max(y1, ray.y());
  };
  for (int u = 0; u < camera.width; u += 2) {
    extend(u, 0);
    extend(u, camera.height - 1);
  }
  for (int v = 0; v < camera.height; v += 2) {
    extend(0, v);
    extend(camera.width - 1, v);
  }
  // At most 1.5× the original size in each direction (a wide-angle lens keeps its centre).
  const double max_w = 1.5 * camera.width / camera.fx, max_h = 1.5 * camera.height / camera.fy;
  if (x1 - x0 > max_w) {
    const double c = -(camera.cx / camera.fx) + 0.5 * camera.width / camera.fx;
    x0 = c - 0.5 * max_w;
    x1 = c + 0.5 * max_w;
  }
  if (y1 - y0 > max_h) {
    const double c = -(camera.cy / camera.fy) + 0.5 * camera.height / camera.fy;
    y0 = c - 0.5 * max_h;
    y1 = c + 0.5 * max_h;
  }
  rect.fx = static_cast<float>(camera.fx);
  rect.fy = static_cast<float>(camera.fy);
  rect.cx = static_cast<float>(-x0 * camera.fx);
  rect.cy = static_cast<float>(-y0 * camera.fy);
  rect.width = static_cast<int>(std::ceil((x1 - x0) * camera.fx)) + 1;
  rect.height = static_cast<int>(std::ceil((y1 - y0) * camera.fy)) + 1;
  rect.map_x.create(rect.height, rect.width, CV_32F);
  rect.map_y.create(rect.height, rect.width, CV_32F);
  cv::Mat valid(rect.height, rect.width, CV_8U);
  const Eigen::Matrix3d K = camera.K();
  for (int v = 0; v < rect.height; ++v) {
    for (int u = 0; u < rect.width; ++u) {
      const Eigen::Vector2d xy((u - rect.cx) / rect.fx, (v - rect.cy) / rect.fy);
      const Eigen::Vector2d d = camera.Distort(xy);
      const double pu = K(0, 0) * d.x() + K(0, 2), pv = K(1, 1) * d.y() + K(1, 2);
      rect.map_x.at<float>(v, u) = static_cast<float>(pu);
      rect.map_y.at<float>(v, u) = static_cast<float>(pv);
      valid.at<std::uint8_t>(v, u) = camera.IsRegularRoot(xy) && pu >= 0 && pv >= 0 &&
                                             pu <= camera.width - 1 && pv <= camera.height - 1
                                         ? 255
                                         : 0;
    }
  }
  if (erode_px > 0) {
    cv::erode(
        valid, valid,
        cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * erode_px + 1, 2 * erode_px + 1)));
  }
  std::vector<int> row_lo(rect.height), row_hi(rect.height);
  for (int v = 0; v < rect.height; ++v) {
    row_lo[v] = rect.width;
    row_hi[v] = -1;
    for (int u = 0; u < rect.width; ++u) {
      if (!valid.at<std::uint8_t>(v, u)) continue;
      row_lo[v] = std::min(row_lo[v], u);
      row_hi[v] = u;
    }
  }
  rect.lo.assign(rect.height, rect.width);
  rect.hi.assign(rect.height, -1);
  for (int v = 0; v + 1 < rect.height; ++v) {
    rect.lo[v] = std::max(row_lo[v], row_lo[v + 1]);
    rect.hi[v] = std::min(row_hi[v], row_hi[v + 1]) - 1;
  }
  return rect;
}

// An image ready for matching: the high-passed grey levels on the rectified canvas (+128,
// 8 bits), and the original colour image when it is some tile's reference.
struct ViewImage {
  bool ok = false;
  std::vector<std::uint8_t> grey;
  int width = 0, height = 0;  // of the original image
  std::vector<std::uint8_t> rgb;

  bool SampleRgb(float u, float v, std::array<std::uint8_t, 3>* out) const {
    if (rgb.empty() || !(u >= 0.0f && v >= 0.0f && u < width - 1.0f && v < height - 1.0f)) {
      return false;
    }
    const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
    const float a = u - u0, b = v - v0;
    for (int c = 0; c < 3; ++c) {
      const std::uint8_t* p = rgb.data() + (static_cast<std::size_t>(v0) * width + u0) * 3 + c;
      const float top = p[0] + a * (p[3] - p[0]);
      const float bottom = p[width * 3] + a * (p[width * 3 + 3] - p[width * 3]);
      (*out)[c] =
          static_cast<std::uint8_t>(std::clamp(top + b * (bottom - top) + 0.5f, 0.f, 255.f));
    }
    return true;
  }
};

struct ViewGeometry {
  Eigen::Matrix3d camera_from_world;
  Eigen::Vector3d center;
  double time_s = 0;
};

// The views of one tile: the references first.
struct TileViews {
  std::vector<int> views;
  int num_references = 0;
};

// A regular grid of samples for a sweep: sample (a, b) lies at origin + (a, b) * spacing; the
// cells are the samples at least `r` from the border.
struct SampleGrid {
  Eigen::Vector2d origin;
  double spacing = 0;
  int nx = 0, ny = 0;
  int r = 0;
  int cells_x() const { return nx - 2 * r; }
  int cells_y() const { return ny - 2 * r; }
};

// Sums over the (2r+1)² windows of an nx × ny array: out is (nx − 2r) × (ny − 2r).
void BoxSum(const float* in, int nx, int ny, int r, float* tmp, float* out) {
  const int w = 2 * r + 1, mx = nx - 2 * r, my = ny - 2 * r;
  // Horizontal: direct sums of w values (vectorised across x).
  for (int y = 0; y < ny; ++y) {
    const float* row = in + static_cast<std::ptrdiff_t>(y) * nx;
    float* __restrict t = tmp + static_cast<std::ptrdiff_t>(y) * mx;
    for (int x = 0; x < mx; ++x) t[x] = row[x];
    for (int d = 1; d < w; ++d) {
      const float* shifted = row + d;
      for (int x = 0; x < mx; ++x) t[x] += shifted[x];
    }
  }
  // Vertical: running sums over rows.
  for (int x = 0; x < mx; ++x) out[x] = 0;
  for (int y = 0; y < w; ++y) {
    const float* t = tmp + static_cast<std::ptrdiff_t>(y) * mx;
    for (int x = 0; x < mx; ++x) out[x] += t[x];
  }
  for (int y = 1; y < my; ++y) {
    const float* add = tmp + static_cast<std::ptrdiff_t>(y + w - 1) * mx;
    const float* sub = tmp + static_cast<std::ptrdiff_t>(y - 1) * mx;
    const float* prev = out + static_cast<std::ptrdiff_t>(y - 1) * mx;
    float* __restrict o = out + static_cast<std::ptrdiff_t>(y) * mx;
    for (int x = 0; x < mx; ++x) o[x] = prev[x] + add[x] - sub[x];
  }
}

// The sweep of one tile at one resolution: for every level l and cell c, the aggregated score
// (−2 when no reference could be scored), the reference that gave it and the views it used.
struct SweepVolume {
  int levels = 0, cells = 0;
  std::vector<float> score;
  // The score of each reference alone: [reference][level][cell].
  std::vector<float> score_by_reference;
  std::vector<std::uint8_t> reference;  // index into TileViews::views
  std::vector<std::uint8_t> num_views;  // other views that were scored
  // Cells that had a full reference patch but too little texture at every level.
  std::vector<std::uint8_t> low_texture;
};

constexpr float kNoScore = -2.0f;
// Added to an invalid sample in the sums that detect incomplete windows: a window sum above
// kInvalidWindow holds one (valid sums stay below 49 · 128).
constexpr float kInvalidSample = 1.0e5f;
constexpr float kInvalidWindow = 5.0e4f;

class Sweeper {
 public:
  Sweeper(const HeightFieldStereo::Options& options, const Rectification& rect,
          const std::vector<ViewGeometry>& geometry, const std::vector<ViewImage>& images)
      : options_(options), rect_(rect), geometry_(geometry), images_(images) {}

  // Sweeps the grid's samples through heights base_z[sample] + offsets[l] in the views of `tv`.
  SweepVolume Run(const SampleGrid& grid, const std::vector<float>& base_z,
                  const std::vector<float>& offsets, const TileViews& tv) const {
    const int nv = static_cast<int>(tv.views.size());
    const int nr = tv.num_references;
    const int ns = grid.nx * grid.ny;
    const int mx = grid.cells_x(), my = grid.cells_y(), nc = mx * my;
    const int r = grid.r;
    const float n = static_cast<float>((2 * r + 1) * (2 * r + 1));
    const float min_var = static_cast<float>(options_.min_texture * options_.min_texture) * n * n;

    SweepVolume vol;
    vol.levels = static_cast<int>(offsets.size());
    vol.cells = nc;
    vol.score.assign(static_cast<std::size_t>(vol.levels) * nc, kNoScore);
    vol.reference.assign(vol.score.size(), 0);
    vol.score_by_reference.assign(static_cast<std::size_t>(nr) * vol.levels * nc, kNoScore);
    vol.num_views.assign(vol.score.size(), 0);
    vol.low_texture.assign(nc, 1);
    std::vector<std::uint8_t> any_reference(nc, 0);

    // Homogeneous pixel (U, V, W) of sample (a, b) at height z on the rectified canvas: linear,
    // p0 + a pa + b pb + z pz, with u = U / W, v = V / W.
    struct Linear {
      float p0[3], pa[3], pb[3], pz[3];
    };
    std::vector<Linear> linear(nv);
    Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
    K(0, 0) = rect_.fx;
    K(1, 1) = rect_.fy;
    K(0, 2) = rect_.cx;
    K(1, 2) = rect_.cy;
    for (int k = 0; k < nv; ++k) {
      const ViewGeometry& g = geometry_[tv.views[k]];
      const Eigen::Matrix3d P = K * g.camera_from_world;
      const Eigen::Vector3d p0 =
          P * (Eigen::Vector3d(grid.origin.x(), grid.origin.y(), 0) - g.center);
      const Eigen::Vector3d pa = P.col(0) * grid.spacing;
      const Eigen::Vector3d pb = P.col(1) * grid.spacing;
      const Eigen::Vector3d pz = P.col(2);
      for (int i = 0; i < 3; ++i) {
        linear[k].p0[i] = static_cast<float>(p0(i));
        linear[k].pa[i] = static_cast<float>(pa(i));
        linear[k].pb[i] = static_cast<float>(pb(i));
        linear[k].pz[i] = static_cast<float>(pz(i));
      }
    }

    std::vector<float> z(ns), warped(static_cast<std::size_t>(nv) * ns),
        valid(static_cast<std::size_t>(nv) * ns), product(ns), tmp(static_cast<std::size_t>(ns));
    std::vector<float> sum(static_cast<std::size_t>(nv) * nc), sum_sq(sum.size()),
        inv_sd(sum.size()), pixel_u(ns), pixel_v(ns), pixel_w(ns),
        cross(static_cast<std::size_t>(nr) * nv * nc);
    std::vector<float> zncc(static_cast<std::size_t>(nv) * nc), agg_sum(nc), agg_count(nc),
        level_best(nc);
    std::vector<std::uint8_t> level_ref(nc), level_views(nc);
    const int width = rect_.width, height = rect_.height;
    const int* lo = rect_.lo.data();
    const int* hi = rect_.hi.data();

    for (int l = 0; l < vol.levels; ++l) {
      for (int s = 0; s < ns; ++s) z[s] = base_z[s] + offsets[l];
      for (int k = 0; k < nv; ++k) {
        const Linear& A = linear[k];
        const std::uint8_t* img = images_[tv.views[k]].grey.data();
        float* __restrict w = warped.data() + static_cast<std::size_t>(k) * ns;
        float* __restrict m = valid.data() + static_cast<std::size_t>(k) * ns;
        // Pixel of every sample (vectorised), then the bilinear samples (gathers).
        float* __restrict pu = pixel_u.data();
        float* __restrict pv = pixel_v.data();
        float* __restrict pw = pixel_w.data();
        const float pa0 = A.pa[0], pa1 = A.pa[1], pa2 = A.pa[2];
        const float pz0 = A.pz[0], pz1 = A.pz[1], pz2 = A.pz[2];
        for (int b = 0; b < grid.ny; ++b) {
          const float U0 = A.p0[0] + b * A.pb[0], V0 = A.p0[1] + b * A.pb[1],
                      W0 = A.p0[2] + b * A.pb[2];
          const float* __restrict zr = z.data() + static_cast<std::ptrdiff_t>(b) * grid.nx;
          float* __restrict ur = pu + static_cast<std::ptrdiff_t>(b) * grid.nx;
          float* __restrict vr = pv + static_cast<std::ptrdiff_t>(b) * grid.nx;
          float* __restrict wr = pw + static_cast<std::ptrdiff_t>(b) * grid.nx;
          const int nx = grid.nx;
          for (int a = 0; a < nx; ++a) {
            const float fa = static_cast<float>(a);
            const float W = W0 + fa * pa2 + zr[a] * pz2;
            const float iw = 1.0f / W;
            wr[a] = W;
            ur[a] = (U0 + fa * pa0 + zr[a] * pz0) * iw;
            vr[a] = (V0 + fa * pa1 + zr[a] * pz1) * iw;
          }
        }
        const float max_u = width - 1.0f, max_v = height - 1.0f;
        for (int s = 0; s < ns; ++s) {
          const float u = pu[s], v = pv[s];
          float value = 0.0f, invalid = kInvalidSample;
          // In front of the camera (not too close) and inside the image.
          if (pw[s] > 0.05f && v >= 0.0f && v < max_v && u >= 0.0f && u < max_u) {
            const int u0 = static_cast<int>(u), v0 = static_cast<int>(v);
            if (u0 >= lo[v0] && u0 <= hi[v0]) {
              const float fa = u - u0, fb = v - v0;
              const std::uint8_t* p = img + static_cast<std::ptrdiff_t>(v0) * width + u0;
              const float top = p[0] + fa * (p[1] - p[0]);
              const float bottom = p[width] + fa * (p[width + 1] - p[width]);
              value = top + fb * (bottom - top) - 128.0f;
              invalid = 0.0f;
            }
          }
          w[s] = value;
          m[s] = value + invalid;  // a window's sum is large where it holds an invalid sample
        }
        float* sq = product.data();
        for (int s = 0; s < ns; ++s) sq[s] = w[s] * w[s];
        BoxSum(m, grid.nx, grid.ny, r, tmp.data(), sum.data() + static_cast<std::size_t>(k) * nc);
        BoxSum(sq, grid.nx, grid.ny, r, tmp.data(),
               sum_sq.data() + static_cast<std::size_t>(k) * nc);
      }
      for (int ref = 0; ref < nr; ++ref) {
        const float* wr = warped.data() + static_cast<std::size_t>(ref) * ns;
        for (int k = 0; k < nv; ++k) {
          if (k == ref) continue;
          const float* wk = warped.data() + static_cast<std::size_t>(k) * ns;
          for (int s = 0; s < ns; ++s) product[s] = wr[s] * wk[s];
          BoxSum(product.data(), grid.nx, grid.ny, r, tmp.data(),
                 cross.data() + (static_cast<std::size_t>(ref) * nv + k) * nc);
        }
      }
      for (std::size_t i = 0; i < inv_sd.size(); ++i) {
        const float var = n * sum_sq[i] - sum[i] * sum[i];
        const bool usable = (sum[i] < kInvalidWindow) & (var > 1.0f);
        inv_sd[i] = usable ? 1.0f / std::sqrt(std::max(var, 1.0f)) : 0.0f;
      }
      float* best = level_best.data();
      std::fill(best, best + nc, kNoScore);
      std::fill(level_ref.begin(), level_ref.end(), std::uint8_t{0});
      std::fill(level_views.begin(), level_views.end(), std::uint8_t{0});
      for (int ref = 0; ref < nr; ++ref) {
        const float* sr = sum.data() + static_cast<std::size_t>(ref) * nc;
        const float* qr = sum_sq.data() + static_cast<std::size_t>(ref) * nc;

        const float* ir = inv_sd.data() + static_cast<std::size_t>(ref) * nc;
        // The ZNCC with every other view (−2 where either patch is incomplete), then sorted per
        // cell, best first, by an odd-even transposition network over the arrays (branch-free,
        // vectorised across cells).
        int no = 0;
        for (int k = 0; k < nv; ++k) {
          if (k == ref) continue;
          const float* sk = sum.data() + static_cast<std::size_t>(k) * nc;
          const float* ik = inv_sd.data() + static_cast<std::size_t>(k) * nc;
          const float* xk = cross.data() + (static_cast<std::size_t>(ref) * nv + k) * nc;
          float* z = zncc.data() + static_cast<std::size_t>(no) * nc;
          for (int c = 0; c < nc; ++c) {
            const float value = (n * xk[c] - sr[c] * sk[c]) * ir[c] * ik[c];
            z[c] = (ir[c] > 0.0f) & (ik[c] > 0.0f) ? value : kNoScore;
          }
          ++no;
        }
        for (int pass = 0; pass < no; ++pass) {
          for (int i = pass % 2; i + 1 < no; i += 2) {
            float* a = zncc.data() + static_cast<std::size_t>(i) * nc;
            float* b = a + nc;
            for (int c = 0; c < nc; ++c) {
              const float hi = std::max(a[c], b[c]), lo = std::min(a[c], b[c]);
              a[c] = hi;
              b[c] = lo;
            }
          }
        }
        // The mean of the best half of the valid ZNCCs: views that see something else (a leaf
        // in front) drop out.
        float* valid_n = agg_count.data();
        float* agg = agg_sum.data();
        std::fill(valid_n, valid_n + nc, 0.0f);
        for (int i = 0; i < no; ++i) {
          const float* z = zncc.data() + static_cast<std::size_t>(i) * nc;
          for (int c = 0; c < nc; ++c) valid_n[c] += z[c] > -1.5f ? 1.0f : 0.0f;
        }
        std::fill(agg, agg + nc, 0.0f);
        for (int i = 0; i < no; ++i) {
          const float* z = zncc.data() + static_cast<std::size_t>(i) * nc;
          const float rank = static_cast<float>(i);
          // Kept when rank < ceil(valid / 2), i.e. 2 rank < valid.
          for (int c = 0; c < nc; ++c) agg[c] += 2.0f * rank < valid_n[c] ? z[c] : 0.0f;
        }
        float* by_ref =
            vol.score_by_reference.data() + (static_cast<std::size_t>(ref) * vol.levels + l) * nc;
        const float min_count = static_cast<float>(options_.min_views) - 0.5f;
        for (int c = 0; c < nc; ++c) {
          const bool complete = sr[c] < kInvalidWindow;
          const float var_r = n * qr[c] - sr[c] * sr[c];
          const bool textured = complete && var_r >= min_var;
          any_reference[c] |= complete;
          if (textured) vol.low_texture[c] = 0;
          const float keep = std::floor(0.5f * (valid_n[c] + 1.0f));
          const float value = textured && valid_n[c] > min_count ? agg[c] / keep : kNoScore;
          by_ref[c] = value;
          if (value > best[c]) {
            best[c] = value;
            level_ref[c] = static_cast<std::uint8_t>(ref);
            level_views[c] = static_cast<std::uint8_t>(valid_n[c]);
          }
        }
      }
      const std::size_t offset = static_cast<std::size_t>(l) * nc;
      std::copy(best, best + nc, vol.score.begin() + static_cast<std::ptrdiff_t>(offset));
      std::copy(level_ref.begin(), level_ref.end(),
                vol.reference.begin() + static_cast<std::ptrdiff_t>(offset));
      std::copy(level_views.begin(), level_views.end(),
                vol.num_views.begin() + static_cast<std::ptrdiff_t>(offset));
    }
    for (int c = 0; c < nc; ++c) {
      if (!any_reference[c]) vol.low_texture[c] = 0;
    }
    return vol;
  }

 private:
  const HeightFieldStereo::Options& options_;
  const Rectification& rect_;
  const std::vector<ViewGeometry>& geometry_;
  const std::vector<ViewImage>& images_;
};

// Sub-step position of a peak from the scores before, at and after it (parabola through three
// points), in [−0.5, 0.5].
double ParabolicOffset(double before, double at, double after) {
  const double d = before - 2 * at + after;
  if (!(d < 0)) return 0;
  return std::clamp(0.5 * (before - after) / d, -0.5, 0.5);
}

// Median of the valid values among `values`.
float Median(std::vector<float>* values) {
  if (values->empty()) return std::numeric_limits<float>::quiet_NaN();
  const std::size_t m = values->size() / 2;
  std::nth_element(values->begin(), values->begin() + static_cast<std::ptrdiff_t>(m),
                   values->end());
  return (*values)[m];
}

ViewImage PrepareImage(const RgbImage& source, const geometry::PinholeRadTan& camera,
                       const Rectification& rect, bool keep_colour, double vegetation_weight,
                       double highpass_sigma, double highpass_gain) {
  ViewImage out;
  if (source.width != camera.width || source.height != camera.height ||
      source.rgb.size() != static_cast<std::size_t>(source.width) * source.height * 3) {
    return out;
  }
  const cv::Mat rgb(source.height, source.width, CV_8UC3,
                    const_cast<std::uint8_t*>(source.rgb.data()));
  // The matched channel: grey + w · max(0, 2G − R − B) (excess green). Leaves have about the
  // grey level of the soil; with their excess green they stand out from it, so that a small
  // plant dominates the patches that hold it.
  cv::Mat channel;
  cv::cvtColor(rgb, channel, cv::COLOR_RGB2GRAY);
  channel.convertTo(channel, CV_32F);
  if (vegetation_weight > 0) {
    std::vector<cv::Mat> c;
    cv::split(rgb, c);
    cv::Mat exg;
    cv::addWeighted(c[1], 2.0, c[0], -1.0, 0.0, exg, CV_32F);
    cv::subtract(exg, c[2], exg, cv::noArray(), CV_32F);
    cv::max(exg, 0.0, exg);
    cv::scaleAdd(exg, vegetation_weight, channel, channel);
  }
  cv::Mat rectified;
  cv::remap(channel, rectified, rect.map_x, rect.map_y, cv::INTER_LINEAR, cv::BORDER_REPLICATE);
  if (highpass_sigma > 0) {
    cv::Mat blurred;
    cv::GaussianBlur(rectified, blurred, cv::Size(0, 0), highpass_sigma);
    rectified -= blurred;
  }
  rectified.convertTo(rectified, CV_8U, highpass_gain, highpass_sigma > 0 ? 128.0 : 0.0);
  CROP4D_CHECK(rectified.isContinuous());
  out.grey.assign(rectified.data,
                  rectified.data + static_cast<std::size_t>(rectified.cols) * rectified.rows);
  out.width = source.width;
  out.height = source.height;
  if (keep_colour) out.rgb = source.rgb;
  out.ok = true;
  return out;
}

}  // namespace

bool DenseRegion::Contains(const Eigen::Vector2d& xy) const {
  if (!bounds.contains(xy)) return false;
  if (boxes.empty() && centers.empty()) return true;
  for (const Eigen::AlignedBox2d& box : boxes) {
    if (box.contains(xy)) return true;
  }
  for (const Eigen::Vector2d& c : centers) {
    if ((xy - c).squaredNorm() <= radius_m * radius_m) return true;
  }
  return false;
}

OptionCheck HeightFieldStereo::Options::Check() const {
  OptionChecker c;
  c.Greater("cell_m", cell_m, 0.0)
      .AtLeast("tile_cells", tile_cells, 4)
      .InRange("patch_radius", patch_radius, 1, 5)
      .InRange("fine_patch_radius", fine_patch_radius, 1, 5)
      .AtLeast("top_surface_margin", top_surface_margin, 0.0)
      .InRange("top_surface_min_reference_score", top_surface_min_reference_score, -1.0, 1.0)
      .AtLeast("top_surface_min_height_m", top_surface_min_height_m, 0.0)
      .AtLeast("top_surface_min_excess_green", top_surface_min_excess_green, -1.0)
      .AtLeast("below_ground_m", below_ground_m, 0.0)
      .Greater("max_canopy_height_m", max_canopy_height_m, 0.0)
      .Greater("coarse_step_m", coarse_step_m, 0.0)
      .Greater("fine_half_range_m", fine_half_range_m, 0.0)
      .Greater("fine_step_m", fine_step_m, 0.0)
      .Require(fine_step_m < fine_half_range_m, "fine_step_m", "must be < fine_half_range_m",
               fine_step_m)
      .InRange("max_views", max_views, 2, 32)
      .AtLeast("near_time_s", near_time_s, 0.0)
      .Between("near_time_min_green", near_time_min_green, 0.0, 1.0)
      .Greater("max_view_distance_m", max_view_distance_m, 0.0)
      .Greater("load_block_m", load_block_m, 0.0)
      .AtLeast("image_margin_px", image_margin_px, 0.0)
      .AtLeast("min_reference_separation_m", min_reference_separation_m, 0.0)
      .AtLeast("min_views", min_views, 1)
      .Require(min_views < max_views, "min_views", "must be < max_views", min_views)
      .Between("min_score", min_score, -1.0, 1.0)
      .AtLeast("min_texture", min_texture, 0.0)
      .InRange("min_neighbours", min_neighbours, 0, 8)
      .Greater("neighbour_tolerance_m", neighbour_tolerance_m, 0.0)
      .Require((max_canopy_height_m + below_ground_m) / coarse_step_m < 2000, "coarse_step_m",
               "must leave < 2000 levels from below_ground_m to max_canopy_height_m",
               coarse_step_m);
  return c.Result();
}

HeightFieldStereo::HeightFieldStereo(const Options& options) : options_(options) {
  CROP4D_CHECK_OPTIONS(options, "HeightFieldStereo");
}

io::PlyLayout HeightFieldStereo::CloudLayout() {
  io::PlyLayout layout;
  layout.colors = true;
  layout.scalars = {{"score", io::PlyType::kFloat32},
                    {"num_views", io::PlyType::kUint8},
                    {"uniqueness", io::PlyType::kFloat32}};
  return layout;
}

namespace {

using Options = HeightFieldStereo::Options;
using Summary = HeightFieldStereo::Summary;

// A tile of at most tile_cells × tile_cells cells, matched as one: its cells (i0, j0) ..
// (i0 + nx − 1, j0 + ny − 1) and the views that match them.
struct Tile {
  int i0 = 0, j0 = 0, nx = 0, ny = 0;
  TileViews views;
  // The views near the first reference in time alone (Options::near_time_s; empty when off);
  // they replace `views` where the tile holds plants (ChooseViewsInTime).
  TileViews near_views;
};

// The tiles that hold cells of the region; `num_cells`: how many cells of the region they hold.
std::vector<Tile> MakeTiles(const CellWindow& grid, const DenseRegion& region, int tile_cells,
                            std::int64_t* num_cells) {
  const int T = tile_cells;
  std::vector<Tile> tiles;
  for (int j0 = 0; j0 < grid.gy; j0 += T) {
    for (int i0 = 0; i0 < grid.gx; i0 += T) {
      Tile tile;
      tile.i0 = i0;
      tile.j0 = j0;
      tile.nx = std::min(T, grid.gx - i0);
      tile.ny = std::min(T, grid.gy - j0);
      std::int64_t inside = 0;
      for (int j = j0; j < j0 + tile.ny; ++j) {
        for (int i = i0; i < i0 + tile.nx; ++i) inside += region.Contains(grid.Centre(i, j));
      }
      *num_cells += inside;
      if (inside > 0) tiles.push_back(tile);
    }
  }
  return tiles;
}

std::vector<ViewGeometry> MakeViewGeometry(const std::vector<DenseView>& views) {
  std::vector<ViewGeometry> geometry(views.size());
  for (std::size_t v = 0; v < views.size(); ++v) {
    geometry[v].camera_from_world = views[v].world_from_camera.RotationMatrix().transpose();
    geometry[v].center = views[v].world_from_camera.translation();
    geometry[v].time_s = views[v].time_s;
  }
  return geometry;
}

// A view that sees a tile.
struct ViewCandidate {
  int view;
  Eigen::Vector2d parallax;  // (camera xy − point xy) / (camera z − point z)
};

// Keeps the first candidate (the reference) and the others captured within near_time_s of it;
// where fewer than min_views + 2 are (a slow camera, a tile at the edge of a pass), the nearest
// in time up to that many.
void KeepViewsNearInTime(const Options& o, const std::vector<ViewGeometry>& geometry,
                         std::vector<ViewCandidate>* candidates) {
  if (candidates->size() < 2) return;
  const double t0 = geometry[(*candidates)[0].view].time_s;
  auto gap = [&](const ViewCandidate& c) { return std::abs(geometry[c.view].time_s - t0); };
  std::vector<ViewCandidate> by_time(candidates->begin() + 1, candidates->end());
  std::stable_sort(by_time.begin(), by_time.end(),
                   [&](const ViewCandidate& a, const ViewCandidate& b) { return gap(a) < gap(b); });
  const std::size_t least = static_cast<std::size_t>(o.min_views) + 1;
  std::vector<int> kept;
  for (std::size_t k = 0; k < by_time.size(); ++k) {
    if (gap(by_time[k]) <= o.near_time_s || k < least) kept.push_back(by_time[k].view);
  }
  std::sort(kept.begin(), kept.end());
  candidates->erase(std::remove_if(candidates->begin() + 1, candidates->end(),
                                   [&](const ViewCandidate& c) {
                                     return !std::binary_search(kept.begin(), kept.end(), c.view);
                                   }),
                    candidates->end());
}

// The views by the horizontal position of their camera, in square buckets of
// max_view_distance_m: the views within that distance of a point lie in the 3 × 3 buckets around
// it. (Testing every view of the session for every tile would cost the square of its length.)
class ViewIndex {
 public:
  ViewIndex(const std::vector<ViewGeometry>& geometry, double bucket_m) : bucket_m_(bucket_m) {
    for (std::size_t v = 0; v < geometry.size(); ++v) {
      buckets_[Key(geometry[v].center.head<2>())].push_back(static_cast<int>(v));
    }
  }

  // The views whose camera lies within bucket_m of `xy` horizontally, and some farther ones.
  std::vector<int> Near(const Eigen::Vector2d& xy) const {
    const auto [bx, by] = Key(xy);
    std::vector<int> views;
    for (std::int64_t dy = -1; dy <= 1; ++dy) {
      for (std::int64_t dx = -1; dx <= 1; ++dx) {
        const auto it = buckets_.find({bx + dx, by + dy});
        if (it != buckets_.end()) views.insert(views.end(), it->second.begin(), it->second.end());
      }
    }
    return views;
  }

 private:
  std::pair<std::int64_t, std::int64_t> Key(const Eigen::Vector2d& xy) const {
    return {static_cast<std::int64_t>(std::floor(xy.x() / bucket_m_)),
            static_cast<std::int64_t>(std::floor(xy.y() / bucket_m_))};
  }

  double bucket_m_;
  std::map<std::pair<std::int64_t, std::int64_t>, std::vector<int>> buckets_;
};

// The views that could serve a tile, from the poses alone: those that see the tile's ground
// corners (with a margin), at most max_view_distance_m away; the most top-down first.
std::vector<ViewCandidate> FindViewCandidates(const Options& o,
                                              const geometry::PinholeRadTan& camera,
                                              const std::vector<ViewGeometry>& geometry,
                                              const ViewIndex& index, const CellWindow& grid,
                                              const GroundLevels& ground, const Tile& tile) {
  const double s = grid.s;
  const double margin = o.image_margin_px + o.patch_radius;
  const Eigen::Vector2d lo = grid.origin + Eigen::Vector2d(tile.i0, tile.j0) * s;
  const Eigen::Vector2d hi = lo + Eigen::Vector2d(tile.nx, tile.ny) * s;
  const Eigen::Vector2d mid = 0.5 * (lo + hi);
  const Eigen::Vector3d center(mid.x(), mid.y(), ground.At(mid.x(), mid.y()));
  std::vector<Eigen::Vector3d> corners;
  for (const Eigen::Vector2d& c :
       {lo, Eigen::Vector2d(hi.x(), lo.y()), Eigen::Vector2d(lo.x(), hi.y()), hi}) {
    corners.emplace_back(c.x(), c.y(), ground.At(c.x(), c.y()));
  }
  std::vector<ViewCandidate> candidates;
  for (const int v : index.Near(mid)) {
    const ViewGeometry& g = geometry[v];
    const Eigen::Vector3d d = g.center - center;
    if (d.norm() > o.max_view_distance_m || d.z() < 0.2) continue;
    bool inside = true;
    for (const Eigen::Vector3d& c : corners) {
      Eigen::Vector2d pixel;
      inside = inside && camera.Project(g.camera_from_world * (c - g.center), &pixel) &&
               camera.IsInImage(pixel, margin);
    }
    if (inside) candidates.push_back({v, d.head<2>() / d.z()});
  }
  std::sort(candidates.begin(), candidates.end(),
            [](const ViewCandidate& a, const ViewCandidate& b) {
              const double na = a.parallax.squaredNorm(), nb = b.parallax.squaredNorm();
              return na != nb ? na < nb : a.view < b.view;
            });
  return candidates;
}

// A tile's views among its candidates (FindViewCandidates): the references are the most
// top-down view and the next most top-down one at least min_reference_separation_m from it; the
// others are chosen greedily for parallax. No views when fewer than min_views besides a
// reference are found.
TileViews PickTileViews(const Options& o, const std::vector<ViewGeometry>& geometry,
                        const std::vector<ViewCandidate>& candidates) {
  if (candidates.size() < 2) return {};
  std::vector<ViewCandidate> chosen{candidates[0]};
  std::vector<char> used(candidates.size(), 0);
  used[0] = 1;
  for (std::size_t k = 1; k < candidates.size(); ++k) {
    if ((geometry[candidates[k].view].center - geometry[candidates[0].view].center).norm() >=
        o.min_reference_separation_m) {
      chosen.push_back(candidates[k]);
      used[k] = 1;
      break;
    }
  }
  TileViews views;
  views.num_references = static_cast<int>(chosen.size());
  // The others: greedily the candidate farthest (in parallax) from those chosen, distances
  // capped so that beyond a useful parallax the more top-down (sharper) view wins.
  constexpr double kParallaxCap = 0.3;
  constexpr double kTopDownWeight = 0.5;
  while (static_cast<int>(chosen.size()) < o.max_views) {
    double best = -1e9;
    int best_k = -1;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      if (used[k]) continue;
      double nearest = 1e9;
      for (const ViewCandidate& c : chosen) {
        nearest = std::min(nearest, (candidates[k].parallax - c.parallax).norm());
      }
      const double score =
          std::min(nearest, kParallaxCap) - kTopDownWeight * candidates[k].parallax.norm();
      if (score > best) {
        best = score;
        best_k = static_cast<int>(k);
      }
    }
    if (best_k < 0) break;
    used[best_k] = 1;
    chosen.push_back(candidates[best_k]);
  }
  for (const ViewCandidate& c : chosen) views.views.push_back(c.view);
  if (static_cast<int>(views.views.size()) - 1 < o.min_views) views = {};
  return views;
}

// The blocks of one band across the region (each block: its tiles, indices into `tiles`, in
// their order). Once they and the bands before them are matched, every cell below `along_end`
// is.
struct BlockBand {
  int along_end = 0;
  std::vector<std::vector<int>> blocks;
};

// The tiles in blocks (Options::load_block_m): squares of the grid, in bands across its longer
// (along) side, one band after the other, so that the cells are matched in order along it
// (CellFilters).
std::vector<BlockBand> TileBlocks(const CellWindow& grid, const std::vector<Tile>& tiles,
                                  double block_m, int tile_cells) {
  const int block_cells = std::max(1, static_cast<int>(std::lround(block_m / grid.s)));
  std::map<std::pair<int, int>, std::vector<int>> blocks;  // (along, across) → tiles
  for (std::size_t t = 0; t < tiles.size(); ++t) {
    const int ba = grid.Along(tiles[t].i0, tiles[t].j0) / block_cells;
    const int bc = (grid.along_y ? tiles[t].i0 : tiles[t].j0) / block_cells;
    blocks[{ba, bc}].push_back(static_cast<int>(t));
  }
  std::vector<BlockBand> bands;
  int band = -1;
  for (auto& [key, block] : blocks) {
    if (key.first != band) {
      band = key.first;
      // The tiles start at multiples of tile_cells: those of the next band at the first one at
      // or past this band's end, so every cell below it lies in this band's tiles or before.
      const int end = (band + 1) * block_cells;
      bands.push_back(
          {std::min(grid.along_size(), (end + tile_cells - 1) / tile_cells * tile_cells), {}});
    }
    bands.back().blocks.push_back(std::move(block));
  }
  return bands;
}

// The images of the views while the blocks are matched: those the current block's tiles select.
struct BlockImages {
  std::vector<ViewImage> images;  // by view; not ok where not loaded
  std::vector<char> colour;       // kept in colour: some tile's reference
  std::vector<char> tried, failed;

  // `colour` from every tile's references.
  BlockImages(std::size_t num_views, const std::vector<Tile>& tiles)
      : images(num_views), colour(num_views, 0), tried(num_views, 0), failed(num_views, 0) {
    for (const Tile& tile : tiles) {
      for (const TileViews* tv : {&tile.views, &tile.near_views}) {
        for (int k = 0; k < tv->num_references; ++k) colour[tv->views[k]] = 1;
      }
    }
  }
};

// Makes `state` hold the images that the tiles of `block` select (prepared, in colour where
// some tile uses one as a reference): the others are freed, the missing ones loaded. Drops
// unreadable images from the block's tiles (and a tile's views when too few are left).
void LoadBlockImages(const Options& o, const geometry::PinholeRadTan& camera,
                     const Rectification& rect, const std::vector<DenseView>& views,
                     const HeightFieldStereo::ImageLoader& load, const std::vector<int>& block,
                     std::vector<Tile>* tiles, BlockImages* state, Summary* summary) {
  std::vector<char> needed(views.size(), 0);
  for (const int t : block) {
    for (const TileViews* tv : {&(*tiles)[t].views, &(*tiles)[t].near_views}) {
      for (const int v : tv->views) needed[v] = 1;
    }
  }
  std::vector<int> to_load;
  for (std::size_t v = 0; v < views.size(); ++v) {
    if (!needed[v]) {
      state->images[v] = ViewImage();
    } else if (!state->images[v].ok && !state->failed[v]) {
      to_load.push_back(static_cast<int>(v));
    }
  }
  tbb::parallel_for(std::size_t{0}, to_load.size(), [&](std::size_t k) {
    const int v = to_load[k];
    state->images[v] = PrepareImage(load(v), camera, rect, state->colour[v] != 0,
                                    o.vegetation_weight, o.highpass_sigma_px, o.highpass_gain);
  });
  summary->num_image_loads += static_cast<int>(to_load.size());
  for (const int v : to_load) {
    if (!state->tried[v]) ++summary->num_images_used;
    state->tried[v] = 1;
    if (!state->images[v].ok) {
      state->failed[v] = 1;
      ++summary->num_images_failed;
      spdlog::warn("densify: image {} could not be read or has the wrong size; not used",
                   views[v].name);
    }
  }
  const int in_memory = static_cast<int>(std::count_if(state->images.begin(), state->images.end(),
                                                       [](const ViewImage& i) { return i.ok; }));
  summary->max_images_loaded = std::max(summary->max_images_loaded, in_memory);
  for (const int t : block) {
    for (TileViews* tv : {&(*tiles)[t].views, &(*tiles)[t].near_views}) {
      TileViews kept;
      for (std::size_t k = 0; k < tv->views.size(); ++k) {
        if (state->failed[tv->views[k]]) continue;
        kept.views.push_back(tv->views[k]);
        if (static_cast<int>(k) < tv->num_references) ++kept.num_references;
      }
      if (kept.num_references == 0 || static_cast<int>(kept.views.size()) - 1 < o.min_views) {
        kept = {};
      }
      *tv = kept;
    }
  }
}

// Where a tile holds plants — at least near_time_min_green of its ground, as its first reference
// sees it, is green (excess green ≥ top_surface_min_excess_green) — its views near the first
// reference in time replace its views: leaves sway in the wind, and a view from another pass,
// tens of seconds later, sees a leaf elsewhere; the match then fails, or finds the canopy below
// (bench/RESULTS.md, "Leaves in the wind"). Bare soil keeps the views of every pass, which
// measure it more precisely. For the tiles of `block`, whose images are loaded; returns the
// number of tiles that changed.
int ChooseViewsInTime(const Options& o, const geometry::PinholeRadTan& camera,
                      const std::vector<ViewGeometry>& geometry,
                      const std::vector<ViewImage>& images, const CellWindow& grid,
                      const GroundLevels& ground, const std::vector<int>& block,
                      std::vector<Tile>* tiles) {
  std::atomic<int> changed{0};
  tbb::parallel_for(std::size_t{0}, block.size(), [&](std::size_t b) {
    Tile& tile = (*tiles)[block[b]];
    TileViews near;
    std::swap(near, tile.near_views);  // needed no more once chosen
    if (near.views.empty() || tile.views.views.empty() || near.views == tile.views.views) return;
    const int view = near.views[0];
    const ViewGeometry& g = geometry[view];
    constexpr int kStride = 4;  // cells between the samples
    int samples = 0, green = 0;
    for (int j = kStride / 2; j < tile.ny; j += kStride) {
      for (int i = kStride / 2; i < tile.nx; i += kStride) {
        const Eigen::Vector2d xy =
            grid.origin + Eigen::Vector2d(tile.i0 + i + 0.5, tile.j0 + j + 0.5) * grid.s;
        Eigen::Vector2d pixel;
        std::array<std::uint8_t, 3> colour;
        if (!camera.Project(
                g.camera_from_world *
                    (Eigen::Vector3d(xy.x(), xy.y(), ground.At(xy.x(), xy.y())) - g.center),
                &pixel) ||
            !images[view].SampleRgb(static_cast<float>(pixel.x()), static_cast<float>(pixel.y()),
                                    &colour)) {
          continue;
        }
        ++samples;
        green += ExcessGreen(colour) >= o.top_surface_min_excess_green;
      }
    }
    if (samples > 0 && green >= o.near_time_min_green * samples) {
      tile.views = std::move(near);
      ++changed;
    }
  });
  return changed;
}

// Per cell of a tile, two candidate surfaces from the coarse sweep: [0] the best coarse peak,
// [1] the top surface (a peak above it, see Options::top_surface_margin; the best where there
// is none).
struct CoarseSurfaces {
  std::vector<float> z[2], score[2], uniqueness[2], refdiff[2];
  std::vector<char> inconsistent[2];
  std::vector<char> top_surface;  // the two differ
};

// A cell's fine result from one candidate surface.
struct FineResult {
  CellState state = kNoViews;
  double z = 0;
  float score = 0;
  int reference = -1;  // view index
  std::uint8_t num_views = 0;
  std::array<std::uint8_t, 3> rgb{0, 0, 0};
};

// Matches the tiles one at a time (Match is called in parallel on different tiles): a coarse
// sweep over the whole height range finds each cell's candidate surfaces, a fine sweep around
// them refines them, and the tile's cells of the grid receive the results.
class TileMatcher {
 public:
  TileMatcher(const Options& o, const geometry::PinholeRadTan& camera, const GroundLevels& ground,
              const std::vector<ViewGeometry>& geometry, const std::vector<ViewImage>& images,
              const Sweeper& sweeper, CellWindow* cells)
      : o_(o),
        camera_(camera),
        ground_(ground),
        geometry_(geometry),
        images_(images),
        sweeper_(sweeper),
        cells_(*cells),
        exclusion_(std::max(1, static_cast<int>(std::lround(0.02 / o.coarse_step_m)))) {}

  void Match(const Tile& tile) const;

 private:
  CoarseSurfaces FindCoarseSurfaces(const Tile& tile, const Eigen::Vector2d& lo,
                                    const SweepVolume& cv,
                                    const std::vector<float>& coarse_levels) const;
  int FindTopSurface(const Tile& tile, const Eigen::Vector2d& lo, const SweepVolume& cv,
                     const std::vector<float>& coarse_levels, int c, int best) const;
  void FineSweep(const Tile& tile, const CoarseSurfaces& coarse, const SweepVolume& cv, int k,
                 const SampleGrid& fine, const std::vector<float>& fine_offsets, float tile_median,
                 std::vector<float>* window, std::vector<FineResult>* results) const;
  void StoreTile(const Tile& tile, const CoarseSurfaces& coarse,
                 const std::vector<FineResult>& fine_best,
                 const std::vector<FineResult>& fine_top) const;

  const Options& o_;
  const geometry::PinholeRadTan& camera_;
  const GroundLevels& ground_;
  const std::vector<ViewGeometry>& geometry_;
  const std::vector<ViewImage>& images_;
  const Sweeper& sweeper_;
  // The window the tiles' results go to (it holds their cells while they are matched).
  CellWindow& cells_;
  // Levels closer than 2 cm to a peak belong to it (uniqueness, top surface, cross-check).
  const int exclusion_;
};

void TileMatcher::Match(const Tile& tile) const {
  if (tile.views.views.empty()) return;
  const Options& o = o_;
  const double s = cells_.s;
  const int r = o.patch_radius;
  const Eigen::Vector2d lo = cells_.origin + Eigen::Vector2d(tile.i0, tile.j0) * s;
  double ground_lo, ground_hi;
  ground_.Range(Eigen::AlignedBox2d(lo, lo + Eigen::Vector2d(tile.nx, tile.ny) * s), &ground_lo,
                &ground_hi);
  const double z_lo = ground_lo - o.below_ground_m, z_hi = ground_hi + o.max_canopy_height_m;

  // Coarse: every height of the range in steps of coarse_step_m, horizontal patches.
  SampleGrid grid;
  grid.spacing = s;
  grid.r = r;
  grid.nx = tile.nx + 2 * r;
  grid.ny = tile.ny + 2 * r;
  grid.origin = lo + Eigen::Vector2d::Constant((0.5 - r) * s);
  const int ns = grid.nx * grid.ny;
  std::vector<float> coarse_levels;
  for (double z = z_lo; z <= z_hi + 1e-9; z += o.coarse_step_m) {
    coarse_levels.push_back(static_cast<float>(z));
  }
  const SweepVolume cv =
      sweeper_.Run(grid, std::vector<float>(ns, 0.0f), coarse_levels, tile.views);
  const int fcells_c = tile.nx * tile.ny;
  const CoarseSurfaces coarse = FindCoarseSurfaces(tile, lo, cv, coarse_levels);

  // The tile's typical height, for cells without a confident coarse height near them: the
  // median of the confident coarse heights (of all when none is confident).
  std::vector<float> all, window;
  for (int c = 0; c < fcells_c; ++c) {
    if (coarse.score[0][c] >= o.min_score) all.push_back(coarse.z[0][c]);
  }
  if (all.empty()) {
    for (int c = 0; c < fcells_c; ++c) {
      if (!std::isnan(coarse.z[0][c])) all.push_back(coarse.z[0][c]);
    }
  }
  if (all.empty()) {
    for (int j = 0; j < tile.ny; ++j) {
      for (int i = 0; i < tile.nx; ++i) {
        const std::size_t g = cells_.At(tile.i0 + i, tile.j0 + j);
        if (cells_.state[g] != kOutside) {
          cells_.state[g] = cv.low_texture[j * tile.nx + i] ? kLowTexture : kNoViews;
        }
      }
    }
    return;
  }
  const float tile_median = Median(&all);
  SampleGrid fine = grid;
  const int rf = o.fine_patch_radius;
  fine.r = rf;
  fine.nx = tile.nx + 2 * rf;
  fine.ny = tile.ny + 2 * rf;
  fine.origin = lo + Eigen::Vector2d::Constant((0.5 - rf) * s);
  std::vector<float> fine_offsets;
  const int half_levels = static_cast<int>(std::lround(o.fine_half_range_m / o.fine_step_m));
  for (int k = -half_levels; k <= half_levels; ++k) {
    fine_offsets.push_back(static_cast<float>(k * o.fine_step_m));
  }
  std::vector<FineResult> fine_best, fine_top;
  FineSweep(tile, coarse, cv, 0, fine, fine_offsets, tile_median, &window, &fine_best);
  if (std::find(coarse.top_surface.begin(), coarse.top_surface.end(), 1) !=
      coarse.top_surface.end()) {
    // The top surfaces (the best heights elsewhere) make the surface of a second fine sweep.
    FineSweep(tile, coarse, cv, 1, fine, fine_offsets, tile_median, &window, &fine_top);
  }
  StoreTile(tile, coarse, fine_best, fine_top);
}

// Per cell: the best coarse peak and the top surface, each with its score, its uniqueness,
// whether the two references alone agree on it, and its height refined by a parabola.
CoarseSurfaces TileMatcher::FindCoarseSurfaces(const Tile& tile, const Eigen::Vector2d& lo,
                                               const SweepVolume& cv,
                                               const std::vector<float>& coarse_levels) const {
  const Options& o = o_;
  const int exclusion = exclusion_;
  const int fcells_c = tile.nx * tile.ny;
  CoarseSurfaces out;
  for (int k = 0; k < 2; ++k) {
    out.z[k].assign(fcells_c, std::numeric_limits<float>::quiet_NaN());
    out.score[k].assign(fcells_c, kNoScore);
    out.uniqueness[k].assign(fcells_c, 0.0f);
    out.refdiff[k].assign(fcells_c, -1.0f);
    out.inconsistent[k].assign(fcells_c, 0);
  }
  out.top_surface.assign(fcells_c, 0);
  const float* by_reference[2] = {
      cv.score_by_reference.data(),
      cv.score_by_reference.data() + static_cast<std::size_t>(cv.levels) * fcells_c};
  for (int c = 0; c < fcells_c; ++c) {
    auto at = [&](int l) { return cv.score[static_cast<std::size_t>(l) * fcells_c + c]; };
    auto ref_at = [&](int ref, int l) {
      return by_reference[ref][static_cast<std::size_t>(l) * fcells_c + c];
    };
    int best = -1;
    for (int l = 0; l < cv.levels; ++l) {
      if (at(l) > kNoScore && (best < 0 || at(l) > at(best))) best = l;
    }
    if (best < 0) continue;
    const int top = FindTopSurface(tile, lo, cv, coarse_levels, c, best);
    out.top_surface[c] = top != best;
    for (int k = 0; k < 2; ++k) {
      const int peak = k == 0 ? best : top;
      // Uniqueness: the margin over the best score more than 2 cm away (for a top surface,
      // the best above it: the surface below it is expected).
      float second = -1.0f;
      for (int l = 0; l < cv.levels; ++l) {
        if (std::abs(l - peak) > exclusion && (peak == best || l > peak)) {
          second = std::max(second, at(l));
        }
      }
      out.uniqueness[k][c] = at(peak) - second;
      out.score[k][c] = at(peak);
      if (tile.views.num_references > 1) {
        // Each reference alone must find the same height (where both see the cell); for a
        // top surface, the same height from it up.
        const int first = peak == best ? 0 : peak - exclusion;
        int arg[2] = {-1, -1};
        for (int ref = 0; ref < 2; ++ref) {
          for (int l = first; l < cv.levels; ++l) {
            const float v = ref_at(ref, l);
            if (v > kNoScore && (arg[ref] < 0 || v > ref_at(ref, arg[ref]))) arg[ref] = l;
          }
        }
        if (arg[0] >= 0 && arg[1] >= 0)
          out.refdiff[k][c] = static_cast<float>(std::abs(arg[0] - arg[1]) * o.coarse_step_m);
        if (o.cross_check_m > 0 && arg[0] >= 0 && arg[1] >= 0 &&
            std::abs(arg[0] - arg[1]) * o.coarse_step_m > o.cross_check_m) {
          out.inconsistent[k][c] = 1;
        }
      }
      double offset = 0;
      if (peak > 0 && peak + 1 < cv.levels && at(peak - 1) > kNoScore && at(peak + 1) > kNoScore) {
        offset = ParabolicOffset(at(peak - 1), at(peak), at(peak + 1));
      }
      out.z[k][c] = static_cast<float>(coarse_levels[peak] + offset * o.coarse_step_m);
    }
  }
  return out;
}

// The coarse level of cell c's top surface: from the top down, the first local peak above the
// best one (`best`) that scores within top_surface_margin of it, that each reference alone
// scores at least top_surface_min_reference_score, that lies top_surface_min_height_m above the
// ground and that is green in both references (a leaf); `best` when there is none.
int TileMatcher::FindTopSurface(const Tile& tile, const Eigen::Vector2d& lo, const SweepVolume& cv,
                                const std::vector<float>& coarse_levels, int c, int best) const {
  const Options& o = o_;
  if (!(o.top_surface_margin > 0 && tile.views.num_references > 1)) return best;
  const int fcells_c = tile.nx * tile.ny;
  const double s = cells_.s;
  const float* by_reference[2] = {
      cv.score_by_reference.data(),
      cv.score_by_reference.data() + static_cast<std::size_t>(cv.levels) * fcells_c};
  auto at = [&](int l) { return cv.score[static_cast<std::size_t>(l) * fcells_c + c]; };
  auto ref_at = [&](int ref, int l) {
    return by_reference[ref][static_cast<std::size_t>(l) * fcells_c + c];
  };
  const float least = at(best) - static_cast<float>(o.top_surface_margin);
  const float least_reference = static_cast<float>(o.top_surface_min_reference_score);
  const Eigen::Vector2d xy = lo + Eigen::Vector2d(c % tile.nx + 0.5, c / tile.nx + 0.5) * s;
  const double lowest = ground_.At(xy.x(), xy.y()) + o.top_surface_min_height_m;
  for (int l = cv.levels - 2; l > best + exclusion_; --l) {
    if (at(l) < least || at(l) < at(l - 1) || at(l) < at(l + 1)) continue;
    if (coarse_levels[l] < lowest) break;
    if (ref_at(0, l) < least_reference || ref_at(1, l) < least_reference) continue;
    // A leaf: green where both references see it (a soil cell beside a leaf, whose
    // patch holds the leaf, is not).
    bool green = true;
    for (int ref = 0; ref < 2 && green; ++ref) {
      const int view = tile.views.views[ref];
      std::array<std::uint8_t, 3> colour;
      Eigen::Vector2d pixel;
      green = camera_.Project(
                  geometry_[view].camera_from_world *
                      (Eigen::Vector3d(xy.x(), xy.y(), coarse_levels[l]) - geometry_[view].center),
                  &pixel) &&
              images_[view].SampleRgb(static_cast<float>(pixel.x()), static_cast<float>(pixel.y()),
                                      &colour) &&
              ExcessGreen(colour) >= o.top_surface_min_excess_green;
    }
    if (!green) continue;
    return l;
  }
  return best;
}

// The fine sweep that follows candidate surface k ± fine_half_range_m, and per cell its
// outcome: kept with the refined height, score, reference and colour, or why not.
void TileMatcher::FineSweep(const Tile& tile, const CoarseSurfaces& coarse, const SweepVolume& cv,
                            int k, const SampleGrid& fine, const std::vector<float>& fine_offsets,
                            float tile_median, std::vector<float>* window,
                            std::vector<FineResult>* results) const {
  const Options& o = o_;
  const double s = cells_.s;
  const int rf = fine.r;
  const int fcells = tile.nx * tile.ny;
  // The surface the fine sweep follows: 3 × 3 median of the confident coarse heights (holes
  // take their neighbours' median, or the tile's).
  std::vector<float> base(static_cast<std::size_t>(fine.nx) * fine.ny);
  for (int b = 0; b < fine.ny; ++b) {
    for (int a = 0; a < fine.nx; ++a) {
      const int i = std::clamp(a - rf, 0, tile.nx - 1), j = std::clamp(b - rf, 0, tile.ny - 1);
      float& out = base[static_cast<std::size_t>(b) * fine.nx + a];
      window->clear();
      for (int dj = -1; dj <= 1; ++dj) {
        for (int di = -1; di <= 1; ++di) {
          const int ii = i + di, jj = j + dj;
          if (ii < 0 || jj < 0 || ii >= tile.nx || jj >= tile.ny) continue;
          const int c = jj * tile.nx + ii;
          if (coarse.score[k][c] >= o.min_score) window->push_back(coarse.z[k][c]);
        }
      }
      out = window->empty() ? tile_median : Median(window);
    }
  }
  // Fine: ± fine_half_range_m around that surface.
  const SweepVolume fv = sweeper_.Run(fine, base, fine_offsets, tile.views);
  results->assign(fcells, FineResult{});
  for (int j = 0; j < tile.ny; ++j) {
    for (int i = 0; i < tile.nx; ++i) {
      const int c = j * tile.nx + i;
      FineResult& res = (*results)[c];
      auto at = [&](int l) { return fv.score[static_cast<std::size_t>(l) * fcells + c]; };
      int best = -1;
      for (int l = 0; l < fv.levels; ++l) {
        if (at(l) > kNoScore && (best < 0 || at(l) > at(best))) best = l;
      }
      if (best < 0) {
        res.state = (fv.low_texture[c] || cv.low_texture[c]) ? kLowTexture : kNoViews;
        continue;
      }
      if (at(best) < o.min_score) {
        res.state = kLowScore;
        continue;
      }
      if (coarse.uniqueness[k][c] < o.min_uniqueness || coarse.inconsistent[k][c]) {
        res.state = kNotUnique;
        continue;
      }
      if (best == 0 || best + 1 == fv.levels || at(best - 1) <= kNoScore ||
          at(best + 1) <= kNoScore) {
        res.state = kAtRangeEdge;
        continue;
      }
      const double offset = ParabolicOffset(at(best - 1), at(best), at(best + 1));
      res.state = kKept;
      res.z = base[static_cast<std::size_t>(j + rf) * fine.nx + i + rf] + fine_offsets[best] +
              offset * o.fine_step_m;
      res.score = at(best);
      const std::size_t ib = static_cast<std::size_t>(best) * fcells + c;
      res.num_views = static_cast<std::uint8_t>(fv.num_views[ib] + 1);
      res.reference = tile.views.views[fv.reference[ib]];
      const Eigen::Vector2d xy =
          cells_.origin + Eigen::Vector2d(tile.i0 + i + 0.5, tile.j0 + j + 0.5) * s;
      const ViewGeometry& view = geometry_[res.reference];
      Eigen::Vector2d pixel;
      if (camera_.Project(
              view.camera_from_world * (Eigen::Vector3d(xy.x(), xy.y(), res.z) - view.center),
              &pixel)) {
        images_[res.reference].SampleRgb(static_cast<float>(pixel.x()),
                                         static_cast<float>(pixel.y()), &res.rgb);
      }
    }
  }
}

// Writes the tile's cells: the top surface where its fine sweep confirms it and it is still
// green (a leaf), else the best surface.
void TileMatcher::StoreTile(const Tile& tile, const CoarseSurfaces& coarse,
                            const std::vector<FineResult>& fine_best,
                            const std::vector<FineResult>& fine_top) const {
  for (int j = 0; j < tile.ny; ++j) {
    for (int i = 0; i < tile.nx; ++i) {
      const std::size_t g = cells_.At(tile.i0 + i, tile.j0 + j);
      if (cells_.state[g] == kOutside) continue;
      const int c = j * tile.nx + i;
      int k = 0;
      if (coarse.top_surface[c] && fine_top[c].state == kKept &&
          ExcessGreen(fine_top[c].rgb) >= o_.top_surface_min_excess_green) {
        k = 1;
      }
      const FineResult& res = k == 1 ? fine_top[c] : fine_best[c];
      cells_.state[g] = res.state;
      if (res.state != kKept) continue;
      cells_.height[g] = static_cast<float>(res.z);
      cells_.score[g] = res.score;
      cells_.unique[g] = coarse.uniqueness[k][c];
      cells_.disagreement[g] = coarse.refdiff[k][c];
      cells_.num_views[g] = res.num_views;
      cells_.reference_of[g] = res.reference;
      cells_.rgb[g] = res.rgb;
      cells_.on_top_surface[g] = static_cast<std::uint8_t>(k);
    }
  }
}

// The farthest any cell lies, horizontally, from a reference camera of its tile: the reach of
// the visibility rays (CellFilters). Every reference a tile can end up with is among these.
double ReferenceReach(const CellWindow& grid, const std::vector<ViewGeometry>& geometry,
                      const std::vector<Tile>& tiles) {
  double reach = 0;
  for (const Tile& tile : tiles) {
    const Eigen::Vector2d lo = grid.origin + Eigen::Vector2d(tile.i0, tile.j0) * grid.s;
    const Eigen::Vector2d hi = lo + Eigen::Vector2d(tile.nx, tile.ny) * grid.s;
    for (const TileViews* tv : {&tile.views, &tile.near_views}) {
      for (int k = 0; k < tv->num_references; ++k) {
        const Eigen::Vector2d c = geometry[tv->views[k]].center.head<2>();
        const Eigen::Vector2d far(std::max(std::abs(c.x() - lo.x()), std::abs(c.x() - hi.x())),
                                  std::max(std::abs(c.y() - lo.y()), std::abs(c.y() - hi.y())));
        reach = std::max(reach, far.norm());
      }
    }
  }
  return reach;
}

}  // namespace

HeightFieldStereo::Result HeightFieldStereo::Run(const geometry::PinholeRadTan& camera,
                                                 const std::vector<DenseView>& views,
                                                 const ImageLoader& load, const DenseRegion& region,
                                                 const GroundLevels& ground,
                                                 const PointSink& sink) const {
  const Clock::time_point start = Clock::now();
  const Options& o = options_;
  Result result;
  Summary& summary = result.summary;
  summary.num_views = static_cast<int>(views.size());
  CROP4D_CHECK_OPTIONS(camera, "HeightFieldStereo::Run");
  if (region.bounds.isEmpty() || !ground.valid() || views.empty()) {
    summary.total_seconds = SecondsSince(start);
    return result;
  }
  CellWindow cells = CellWindow::ForRegion(o.cell_m, region);
  std::vector<Tile> tiles = MakeTiles(cells, region, o.tile_cells, &summary.num_cells);
  summary.num_tiles = static_cast<int>(tiles.size());
  const std::vector<ViewGeometry> geometry = MakeViewGeometry(views);
  const ViewIndex index(geometry, o.max_view_distance_m);
  tbb::parallel_for(std::size_t{0}, tiles.size(), [&](std::size_t t) {
    std::vector<ViewCandidate> candidates =
        FindViewCandidates(o, camera, geometry, index, cells, ground, tiles[t]);
    tiles[t].views = PickTileViews(o, geometry, candidates);
    if (o.near_time_s > 0) {
      KeepViewsNearInTime(o, geometry, &candidates);
      tiles[t].near_views = PickTileViews(o, geometry, candidates);
    }
  });
  std::vector<Eigen::Vector3d> centres;
  for (const ViewGeometry& g : geometry) centres.push_back(g.center);
  summary.reference_reach_m = ReferenceReach(cells, geometry, tiles);
  CellFilters filters(o, region, &cells, std::move(centres), summary.reference_reach_m, sink,
                      &result.cloud, &summary);

  // The sweeps, band by band and block by block: the images of a block's tiles loaded, then its
  // tiles matched; after each band, the filters and the points of what is final.
  const Clock::time_point match_start = Clock::now();
  const Rectification rect = MakeRectification(
      camera, static_cast<int>(std::ceil(2 * std::max(0.0, o.highpass_sigma_px))) + 1);
  const std::vector<BlockBand> bands = TileBlocks(cells, tiles, o.load_block_m, o.tile_cells);
  {
    BlockImages state(views.size(), tiles);
    const Sweeper sweeper(o, rect, geometry, state.images);
    const TileMatcher matcher(o, camera, ground, geometry, state.images, sweeper, &cells);
    std::unique_ptr<Progress> progress;
    if (o.show_progress)
      progress = std::make_unique<Progress>("densify: match", tiles.size(), "tile");
    for (const BlockBand& band : bands) {
      filters.Hold(band.along_end);
      for (const std::vector<int>& block : band.blocks) {
        ++summary.num_blocks;
        const Clock::time_point load_start = Clock::now();
        LoadBlockImages(o, camera, rect, views, load, block, &tiles, &state, &summary);
        summary.num_tiles_near_in_time +=
            ChooseViewsInTime(o, camera, geometry, state.images, cells, ground, block, &tiles);
        summary.load_seconds += SecondsSince(load_start);
        tbb::parallel_for(std::size_t{0}, block.size(), [&](std::size_t b) {
          matcher.Match(tiles[block[b]]);
          if (progress) progress->Add();
        });
      }
      filters.Matched(band.along_end);
    }
  }  // (the images freed)
  double view_sum = 0;
  for (const Tile& tile : tiles) view_sum += static_cast<double>(tile.views.views.size());
  summary.mean_views_per_tile = tiles.empty() ? 0 : view_sum / static_cast<double>(tiles.size());
  filters.Finish();
  summary.match_seconds = SecondsSince(match_start) - summary.load_seconds;
  summary.total_seconds = SecondsSince(start);
  return result;
}

}  // namespace crop4d::dense
