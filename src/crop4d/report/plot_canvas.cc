#include "crop4d/report/plot_canvas.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"

namespace crop4d::report::canvas {
namespace {

constexpr int kFont = cv::FONT_HERSHEY_SIMPLEX;

}  // namespace

cv::Size TextSize(const std::string& text, double scale, int thickness, int* baseline) {
  int unused = 0;
  return cv::getTextSize(text, kFont, scale, thickness, baseline ? baseline : &unused);
}

void PutText(cv::Mat& image, const std::string& text, cv::Point left_middle, double scale,
             const cv::Scalar& color, int thickness) {
  const cv::Size size = TextSize(text, scale, thickness);
  cv::putText(image, text, {left_middle.x, left_middle.y + size.height / 2}, kFont, scale, color,
              thickness, cv::LINE_AA);
}

void PutTextVertical(cv::Mat& image, const std::string& text, int x, int span_top, int span_height,
                     int band_width, double scale, const cv::Scalar& color) {
  if (text.empty() || band_width <= 0) return;
  const cv::Size size = TextSize(text, scale, 1);
  cv::Mat band(band_width, size.width + 4, image.type(), kWhite);
  PutText(band, text, {2, band_width / 2}, scale, color);
  cv::Mat rotated;
  cv::rotate(band, rotated, cv::ROTATE_90_COUNTERCLOCKWISE);
  const int y = std::max(0, span_top + (span_height - rotated.rows) / 2);
  const int width = std::min(rotated.cols, image.cols - x);
  const int height = std::min(rotated.rows, image.rows - y);
  if (x < 0 || width <= 0 || height <= 0) return;
  rotated(cv::Rect(0, 0, width, height)).copyTo(image(cv::Rect(x, y, width, height)));
}

std::string FitText(const std::string& text, int max_width, double scale, int thickness) {
  if (TextSize(text, scale, thickness).width <= max_width) return text;
  std::string shortened = text;
  while (!shortened.empty() && TextSize(shortened + "..", scale, thickness).width > max_width) {
    shortened.pop_back();
  }
  return shortened.empty() ? std::string() : shortened + "..";
}

double NiceStep(double min_step) {
  CROP4D_CHECK(std::isfinite(min_step) && min_step > 0.0);
  const double magnitude = std::pow(10.0, std::floor(std::log10(min_step)));
  for (double m : {1.0, 2.0, 5.0, 10.0}) {
    if (m * magnitude >= min_step * (1 - 1e-9)) return m * magnitude;
  }
  return 10.0 * magnitude;
}

std::vector<double> Ticks(double lo, double hi, double step) {
  std::vector<double> ticks;
  for (double k = std::ceil(lo / step - 1e-9); k * step <= hi + 1e-9 * step; k += 1.0) {
    ticks.push_back(k == 0.0 ? 0.0 : k * step);  // no "-0"
  }
  return ticks;
}

int Decimals(double step) { return std::max(0, int(std::ceil(-std::log10(step) - 1e-9))); }

}  // namespace crop4d::report::canvas
