#pragma once

// Drawing helpers shared by the figures of the report (cross_section.h, plots.h): one text style
// (OpenCV Hershey fonts, anti-aliased; they render ASCII only), one set of colours for frames,
// grids and notes, and axis ticks at 1, 2 or 5 × 10^k.

#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace crop4d::report::canvas {

inline constexpr double kTickFontScale = 0.45;
inline constexpr double kLabelFontScale = 0.55;
inline constexpr double kTitleFontScale = 0.7;
// Length of an axis tick, pixels.
inline constexpr int kTickLength = 5;

inline const cv::Scalar kBlack(0, 0, 0);
inline const cv::Scalar kWhite(255, 255, 255);
inline const cv::Scalar kGrid(225, 225, 225);
inline const cv::Scalar kNoteGray(120, 120, 120);

// Size of `text` in cv::FONT_HERSHEY_SIMPLEX (width, height above the baseline); *baseline (if not
// null) gets the depth below it.
cv::Size TextSize(const std::string& text, double scale, int thickness, int* baseline = nullptr);

// Draws `text` with its left end at x and its vertical centre at y (anti-aliased).
void PutText(cv::Mat& image, const std::string& text, cv::Point left_middle, double scale,
             const cv::Scalar& color, int thickness = 1);

// Draws `text` turned 90° counter-clockwise (reading upwards; a vertical axis label) on a white
// band `band_width` pixels wide whose left edge is column x, centred vertically on the rows
// [span_top, span_top + span_height); clipped to the image.
void PutTextVertical(cv::Mat& image, const std::string& text, int x, int span_top, int span_height,
                     int band_width, double scale, const cv::Scalar& color);

// `text` shortened with ".." at its end so that it is at most max_width pixels wide.
std::string FitText(const std::string& text, int max_width, double scale, int thickness = 1);

// The smallest of 1, 2, 5 × 10^k that is ≥ min_step (> 0, finite: CHECK).
double NiceStep(double min_step);

// The multiples k · step inside [lo, hi] (0 printed as 0, never −0), ascending.
std::vector<double> Ticks(double lo, double hi, double step);

// Decimals that print the multiples of a 1-2-5 step exactly (0 for steps ≥ 1).
int Decimals(double step);

}  // namespace crop4d::report::canvas
