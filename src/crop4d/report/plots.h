#pragma once

// Line plots for the report: canopy height versus date of one site, and small multiples (one
// panel per site) with a shared legend. Drawn with OpenCV (anti-aliased lines and markers,
// Hershey fonts: ASCII text only) in the style of the cross-section figure (cross_section.h).
//
//   LinePlot plot;
//   plot.title = "site A3";
//   plot.x_label = "date";
//   plot.y_label = "canopy height [m]";
//   plot.x_is_date = true;  // x in days since 1970-01-01 (DaysSinceEpoch)
//   plot.series.push_back({"crop4d", dates, heights, cv::Scalar(180, 119, 31)});
//   plot.series.push_back({"measured", dates, measured, cv::Scalar(14, 127, 255),
//                          PlotSeries::Style::kMarkersOnly, PlotSeries::Marker::kCross});
//   WritePng("WS/analysis/plots/A3.png", DrawLinePlot(plot));
//
// The axis mapping is exposed (PlotFrame, LayoutLinePlot) so that tests and callers can place
// things on a figure exactly where the data lies.

#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"

namespace crop4d::report {

struct PlotSeries {
  enum class Style {
    kLineAndMarkers,  // consecutive finite points joined by a line, and a marker at each
    kMarkersOnly,     // a marker at each finite point
  };
  enum class Marker {
    kFilledCircle,
    kCross,   // an "x"
    kSquare,  // outline
  };

  // Legend text (ASCII); a series with an empty label is left out of the legend.
  std::string label;
  // Data, same size (CHECK); points are joined in this order (give x ascending). A NaN (or
  // infinite) x or y is a gap: the line stops there and starts again at the next finite point.
  std::vector<double> x;
  std::vector<double> y;
  // Colour of the line and markers, BGR.
  cv::Scalar color = cv::Scalar(180, 119, 31);
  Style style = Style::kLineAndMarkers;
  Marker marker = Marker::kFilledCircle;
};

struct LinePlot {
  // Title above the plot, axis labels (ASCII; empty: none).
  std::string title;
  std::string x_label;
  std::string y_label;
  std::vector<PlotSeries> series;
  // x holds days since the Unix epoch (1970-01-01 00:00 UTC, fractions allowed): ticks fall on
  // calendar days, weeks (Mondays), months or years and are printed as YYYY-MM-DD.
  bool x_is_date = false;
  // Axis ranges; unset: from the finite data with a small margin (y from 0 when all finite y
  // are ≥ 0), or [0, 1] without data. A range of zero width is widened about its value.
  std::optional<double> x_min, x_max;
  std::optional<double> y_min, y_max;
};

struct PlotOptions {
  // Image size, pixels (a panel's size for DrawPlotGrid).
  int width = 800;
  int height = 500;
  // Marker radius (half the side of a square or cross), pixels.
  int marker_radius_px = 4;
  // Width of the lines joining the points, pixels.
  int line_thickness_px = 2;
  // DrawLinePlot: draw the legend right of the plot (when a series has a label and the plot keeps
  // at least half the image width).
  bool legend = true;
  // DrawPlotGrid: one x range and one y range for every panel (from all plots' data, or the
  // first plot's explicit ranges), so that panels compare at a glance.
  bool share_axes = true;

  // Width in [200, 10000], height in [150, 10000], marker radius in [1, 30], thickness in
  // [1, 20].
  OptionCheck Check() const;
};

// Options for the panels of DrawPlotGrid: 400 × 300 pixels, smaller markers and lines.
PlotOptions SmallPanelOptions();

// A tick of an axis: its data value and printed label.
struct AxisTick {
  double value = 0.0;
  std::string label;
};

// Where the data lies on an image: the plot area, the data range it spans and the ticks.
struct PlotFrame {
  // The plot area in image pixels; x_min is on its left column, x_max on its right column,
  // y_max on its top row and y_min on its bottom row.
  cv::Rect plot_area;
  double x_min = 0.0, x_max = 1.0;
  double y_min = 0.0, y_max = 1.0;
  // The ticks drawn on each axis, ascending.
  std::vector<AxisTick> x_ticks, y_ticks;

  // Image pixel position (column, row; sub-pixel) of data point (x, y).
  cv::Point2d ToPixel(double x, double y) const;
};

// Numeric ticks: the multiples of the smallest 1, 2 or 5 × 10^k step ≥ min_step inside
// [lo, hi], ascending, printed with just enough decimals. CHECKs finite lo ≤ hi and
// min_step > 0 (the step grows so that there are at most 1000 ticks).
std::vector<AxisTick> NumericTicks(double lo, double hi, double min_step);

// Date ticks for x in days since the Unix epoch: the finest of 1 or 2 days, 1 week (Mondays),
// half a month (1st and 15th), 1, 2, 3, 4 or 6 months (the 1st of the months whose index from
// January the step divides), 1, 2, 5, 10, ... years (1st of January) whose nominal length is
// ≥ min_step_days, at midnight inside [lo, hi], ascending, printed YYYY-MM-DD. Same CHECKs as
// NumericTicks; no ticks beyond ±10^7 days (e.g. nanoseconds passed as days).
std::vector<AxisTick> DateTicks(double lo_days, double hi_days, double min_step_days);

// Days since the Unix epoch of a calendar date (proleptic Gregorian), and the YYYY-MM-DD text
// of the day that holds `days`.
double DaysSinceEpoch(int year, int month, int day);
std::string FormatDate(double days);

// The frame that DrawLinePlot(plot, options) uses: the axis ranges and the plot area after the
// title, the tick labels, the axis labels and the legend have taken their room. CHECKs
// options.Check(), x.size() == y.size() for each series, and explicit ranges with min < max.
PlotFrame LayoutLinePlot(const LinePlot& plot, const PlotOptions& options = {});

// Draws the plot (CV_8UC3, BGR, white background): light grid lines at the ticks, the series in
// order (lines, then markers), the frame, ticks and tick labels, axis labels, the title and a
// legend (a sample of each labelled series; "(no data)" after a series without a finite point).
// Without any finite point, the axes are drawn with a "no data" note. Deterministic. `frame`
// (if not null) receives LayoutLinePlot(plot, options).
cv::Mat DrawLinePlot(const LinePlot& plot, const PlotOptions& options = {},
                     PlotFrame* frame = nullptr);

// Small multiples: one panel of `panel` size per plot, `columns` per row (clamped to
// [1, plots.size()]), left to right then top to bottom, and one legend below them all (the
// distinct labelled series of all plots, in order of first appearance). Without plots: a
// panel-sized image with a "no plots" note. `frames` (if not null) receives each panel's frame
// in the coordinates of the returned image. CHECKs columns ≥ 1 and what LayoutLinePlot checks.
cv::Mat DrawPlotGrid(const std::vector<LinePlot>& plots, int columns,
                     const PlotOptions& panel = SmallPanelOptions(),
                     std::vector<PlotFrame>* frames = nullptr);

// Encodes `image` as PNG and writes it atomically (io/atomic_file.h), creating missing parent
// folders. Throws InputError naming `path` when it cannot be written. CHECKs a non-empty image.
void WritePng(const std::string& path, const cv::Mat& image);

}  // namespace crop4d::report
