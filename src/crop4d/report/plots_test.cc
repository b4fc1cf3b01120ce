#include "crop4d/report/plots.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <regex>

#include "crop4d/core/error.h"
#include "crop4d/io/test_helpers.h"
#include "crop4d/report/plot_canvas.h"

namespace crop4d::report {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
const cv::Scalar kRed(30, 30, 210);
const cv::Scalar kGreen(40, 160, 40);

cv::Vec3b Bgr(const cv::Scalar& s) { return cv::Vec3b(uchar(s[0]), uchar(s[1]), uchar(s[2])); }

cv::Vec3b PixelAt(const cv::Mat& image, const cv::Point2d& p) {
  return image.at<cv::Vec3b>(cvRound(p.y), cvRound(p.x));
}

// Largest difference of one channel between two colours.
int ColorDistance(const cv::Vec3b& a, const cv::Vec3b& b) {
  return std::max({std::abs(a[0] - b[0]), std::abs(a[1] - b[1]), std::abs(a[2] - b[2])});
}

int CountColor(const cv::Mat& image, const cv::Scalar& color) {
  cv::Mat mask;
  cv::inRange(image, color, color, mask);
  return cv::countNonZero(mask);
}

// Number of pixels within `tolerance` of `color` in every channel.
int CountNearColor(const cv::Mat& image, const cv::Scalar& color, int tolerance) {
  cv::Mat mask;
  const cv::Scalar t(tolerance, tolerance, tolerance);
  cv::inRange(image, color - t, color + t, mask);
  return cv::countNonZero(mask);
}

// Canopy heights of a site over a season: days since the epoch and metres.
LinePlot GrowthPlot() {
  LinePlot plot;
  plot.title = "site A3";
  plot.x_label = "date";
  plot.y_label = "canopy height [m]";
  plot.x_is_date = true;
  PlotSeries crop4d;
  crop4d.label = "crop4d";
  crop4d.color = kRed;
  crop4d.style = PlotSeries::Style::kMarkersOnly;
  const double start = DaysSinceEpoch(2016, 5, 25);
  for (int i = 0; i < 6; ++i) {
    crop4d.x.push_back(start + 12.0 * i);
    crop4d.y.push_back(0.1 + 0.25 * i);
  }
  plot.series.push_back(crop4d);
  return plot;
}

std::vector<double> Values(const std::vector<AxisTick>& ticks) {
  std::vector<double> v;
  for (const AxisTick& t : ticks) v.push_back(t.value);
  return v;
}
std::vector<std::string> Labels(const std::vector<AxisTick>& ticks) {
  std::vector<std::string> v;
  for (const AxisTick& t : ticks) v.push_back(t.label);
  return v;
}

TEST(PlotsTest, NumericTicksUseOneTwoFiveSteps) {
  EXPECT_EQ(Labels(NumericTicks(0.0, 1.0, 0.13)),
            (std::vector<std::string>{"0.0", "0.2", "0.4", "0.6", "0.8", "1.0"}));
  EXPECT_EQ(Values(NumericTicks(-3.0, 17.0, 3.0)), (std::vector<double>{0, 5, 10, 15}));
  EXPECT_EQ(Labels(NumericTicks(-3.0, 17.0, 3.0)),
            (std::vector<std::string>{"0", "5", "10", "15"}));
  EXPECT_EQ(Labels(NumericTicks(-0.0042, 0.0011, 0.0015)),
            (std::vector<std::string>{"-0.004", "-0.002", "0.000"}));
  EXPECT_EQ(Labels(NumericTicks(1000.0, 3000.0, 700.0)),
            (std::vector<std::string>{"1000", "2000", "3000"}));
  // Never more than 1000 ticks.
  EXPECT_LE(NumericTicks(0.0, 1e6, 1e-3).size(), 1001u);
  EXPECT_TRUE(NumericTicks(0.25, 0.26, 1.0).empty());
}

TEST(PlotsTest, DatesConvertBothWays) {
  EXPECT_EQ(DaysSinceEpoch(1970, 1, 1), 0.0);
  EXPECT_EQ(DaysSinceEpoch(2000, 3, 1), 11017.0);
  EXPECT_EQ(DaysSinceEpoch(2016, 5, 25), 16946.0);
  EXPECT_EQ(DaysSinceEpoch(1969, 12, 31), -1.0);
  EXPECT_EQ(FormatDate(16946.0), "2016-05-25");
  EXPECT_EQ(FormatDate(16946.99), "2016-05-25");  // the day that holds it
  EXPECT_EQ(FormatDate(-0.5), "1969-12-31");
}

TEST(PlotsTest, DateTicksFallOnCalendarDaysInOrder) {
  const double lo = DaysSinceEpoch(2016, 5, 20) + 0.3, hi = DaysSinceEpoch(2016, 8, 10);
  const std::regex iso(R"(\d{4}-\d{2}-\d{2})");
  for (double min_step : {0.5, 1.5, 5.0, 12.0, 20.0, 45.0, 80.0, 150.0}) {
    const std::vector<AxisTick> ticks = DateTicks(lo, hi, min_step);
    ASSERT_FALSE(ticks.empty()) << min_step;
    for (std::size_t i = 0; i < ticks.size(); ++i) {
      EXPECT_TRUE(std::regex_match(ticks[i].label, iso)) << ticks[i].label;
      EXPECT_EQ(ticks[i].label, FormatDate(ticks[i].value));
      EXPECT_EQ(ticks[i].value, std::floor(ticks[i].value));  // midnight
      EXPECT_GE(ticks[i].value, lo);
      EXPECT_LE(ticks[i].value, hi);
      if (i > 0) {
        EXPECT_GE(ticks[i].value - ticks[i - 1].value, std::min(min_step, 14.0));
      }
    }
  }
  EXPECT_EQ(DateTicks(lo, hi, 1.0).front().label, "2016-05-21");
  EXPECT_EQ(DateTicks(lo, hi, 1.0).size(), 82u);
  // Weeks start on Mondays: 2016-05-23 was one.
  const std::vector<AxisTick> weeks = DateTicks(lo, hi, 5.0);
  EXPECT_EQ(weeks.front().label, "2016-05-23");
  for (const AxisTick& t : weeks) EXPECT_EQ(std::fmod(t.value - 4.0, 7.0), 0.0);
  EXPECT_EQ(Labels(DateTicks(lo, hi, 12.0)),
            (std::vector<std::string>{"2016-06-01", "2016-06-15", "2016-07-01", "2016-07-15",
                                      "2016-08-01"}));
  EXPECT_EQ(Labels(DateTicks(lo, hi, 20.0)),
            (std::vector<std::string>{"2016-06-01", "2016-07-01", "2016-08-01"}));
  EXPECT_EQ(Labels(DateTicks(lo, hi, 45.0)), (std::vector<std::string>{"2016-07-01"}));
  EXPECT_EQ(Labels(DateTicks(lo, hi + 200.0, 100.0)),
            (std::vector<std::string>{"2016-09-01", "2017-01-01"}));  // every 4 months
  EXPECT_EQ(Labels(DateTicks(DaysSinceEpoch(2000, 1, 1), DaysSinceEpoch(2020, 6, 1), 400.0)),
            (std::vector<std::string>{"2000-01-01", "2002-01-01", "2004-01-01", "2006-01-01",
                                      "2008-01-01", "2010-01-01", "2012-01-01", "2014-01-01",
                                      "2016-01-01", "2018-01-01", "2020-01-01"}));
  // Nonsense ranges (nanoseconds passed as days) give no ticks instead of failing.
  EXPECT_TRUE(DateTicks(1.4e18, 1.5e18, 1e16).empty());
}

TEST(PlotsTest, MarkersLandWhereTheFrameMapsTheData) {
  const LinePlot plot = GrowthPlot();
  PlotFrame frame;
  const cv::Mat image = DrawLinePlot(plot, {}, &frame);
  ASSERT_EQ(image.type(), CV_8UC3);
  EXPECT_EQ(image.size(), cv::Size(800, 500));
  // The frame is the layout's.
  const PlotFrame layout = LayoutLinePlot(plot);
  EXPECT_EQ(layout.plot_area, frame.plot_area);
  EXPECT_EQ(layout.x_min, frame.x_min);
  EXPECT_EQ(layout.y_max, frame.y_max);
  // Corners of the data range are the corners of the plot area.
  EXPECT_NEAR(frame.ToPixel(frame.x_min, frame.y_max).x, frame.plot_area.x, 1e-9);
  EXPECT_NEAR(frame.ToPixel(frame.x_min, frame.y_max).y, frame.plot_area.y, 1e-9);
  EXPECT_NEAR(frame.ToPixel(frame.x_max, frame.y_min).x, frame.plot_area.br().x - 1, 1e-9);
  EXPECT_NEAR(frame.ToPixel(frame.x_max, frame.y_min).y, frame.plot_area.br().y - 1, 1e-9);
  // Heights start at 0 and the range holds every point.
  EXPECT_EQ(frame.y_min, 0.0);
  EXPECT_GT(frame.y_max, 1.35);
  EXPECT_LT(frame.x_min, plot.series[0].x.front());
  EXPECT_GT(frame.x_max, plot.series[0].x.back());
  // Each data point has a filled disc of the series colour centred on its mapped pixel.
  for (std::size_t i = 0; i < plot.series[0].x.size(); ++i) {
    const cv::Point2d p = frame.ToPixel(plot.series[0].x[i], plot.series[0].y[i]);
    EXPECT_TRUE(frame.plot_area.contains(cv::Point(cvRound(p.x), cvRound(p.y))));
    for (const cv::Point2d d : {cv::Point2d(0, 0), cv::Point2d(2, 0), cv::Point2d(0, -2)}) {
      EXPECT_EQ(PixelAt(image, p + d), Bgr(kRed)) << "point " << i;
    }
    // 7 pixels away (beyond the radius of 4) it is background again.
    EXPECT_NE(PixelAt(image, p + cv::Point2d(7, 0)), Bgr(kRed));
  }
  EXPECT_GT(CountColor(image, kRed), 6 * 30);
}

TEST(PlotsTest, DateTickLabelsAreReadable) {
  LinePlot plot = GrowthPlot();
  plot.series[0].x.push_back(plot.series[0].x.back() + 300.0);  // almost a year
  plot.series[0].y.push_back(0.0);
  for (const PlotOptions& options : {PlotOptions{}, SmallPanelOptions()}) {
    const PlotFrame frame = LayoutLinePlot(plot, options);
    ASSERT_GE(frame.x_ticks.size(), 2u) << options.width;
    const int label_width =
        canvas::TextSize(frame.x_ticks[0].label, canvas::kTickFontScale, 1).width;
    for (std::size_t i = 1; i < frame.x_ticks.size(); ++i) {
      EXPECT_GT(frame.x_ticks[i].value, frame.x_ticks[i - 1].value);
      const double gap = frame.ToPixel(frame.x_ticks[i].value, 0).x -
                         frame.ToPixel(frame.x_ticks[i - 1].value, 0).x;
      EXPECT_GE(gap, label_width + 8) << "labels would overlap";
    }
    for (std::size_t i = 1; i < frame.y_ticks.size(); ++i) {
      EXPECT_GT(frame.y_ticks[i].value, frame.y_ticks[i - 1].value);
    }
  }
}

TEST(PlotsTest, LinesJoinPointsAndStopAtGaps) {
  LinePlot plot;
  PlotSeries s;
  s.label = "line";
  s.color = kGreen;
  s.x = {0, 1, 2, 3, 4};
  s.y = {0, 1, kNaN, 1, 0};
  plot.series.push_back(s);
  PlotOptions options;
  options.line_thickness_px = 3;
  PlotFrame frame;
  const cv::Mat image = DrawLinePlot(plot, options, &frame);
  // Halfway between points 0 and 1: on the line.
  EXPECT_LE(ColorDistance(PixelAt(image, frame.ToPixel(0.5, 0.5)), Bgr(kGreen)), 40);
  // Across the gap (x = 1 to 3 at y = 1): no line.
  for (double x : {1.5, 2.0, 2.5}) {
    EXPECT_GT(ColorDistance(PixelAt(image, frame.ToPixel(x, 1.0)), Bgr(kGreen)), 100) << x;
  }
  // Markers-only series draw no line.
  plot.series[0].style = PlotSeries::Style::kMarkersOnly;
  const cv::Mat markers = DrawLinePlot(plot, options, &frame);
  EXPECT_GT(ColorDistance(PixelAt(markers, frame.ToPixel(0.5, 0.5)), Bgr(kGreen)), 100);
  EXPECT_EQ(PixelAt(markers, frame.ToPixel(1.0, 1.0)), Bgr(kGreen));
}

TEST(PlotsTest, EveryMarkerShapeIsDrawnAtItsPoint) {
  for (PlotSeries::Marker marker : {PlotSeries::Marker::kFilledCircle, PlotSeries::Marker::kCross,
                                    PlotSeries::Marker::kSquare}) {
    LinePlot plot;
    PlotSeries s;
    s.color = kRed;
    s.style = PlotSeries::Style::kMarkersOnly;
    s.marker = marker;
    s.x = {1.0, 2.0};
    s.y = {3.0, 4.0};
    plot.series.push_back(s);
    PlotOptions options;
    options.marker_radius_px = 6;
    PlotFrame frame;
    const cv::Mat image = DrawLinePlot(plot, options, &frame);
    const cv::Point2d p = frame.ToPixel(1.0, 3.0);
    // Circle and cross cover the centre; the square outline its corners.
    const cv::Point2d probe = marker == PlotSeries::Marker::kSquare ? p + cv::Point2d(6, 0) : p;
    EXPECT_LE(ColorDistance(PixelAt(image, probe), Bgr(kRed)), 40) << int(marker);
    if (marker == PlotSeries::Marker::kSquare) {
      EXPECT_NE(PixelAt(image, p), Bgr(kRed));  // hollow
    }
  }
}

TEST(PlotsTest, EdgeCasesGiveValidImages) {
  // No series at all.
  LinePlot empty;
  empty.title = "nothing";
  PlotFrame frame;
  cv::Mat image = DrawLinePlot(empty, {}, &frame);
  EXPECT_EQ(image.size(), cv::Size(800, 500));
  EXPECT_EQ(frame.x_min, 0.0);
  EXPECT_EQ(frame.x_max, 1.0);
  EXPECT_FALSE(frame.x_ticks.empty());

  // A series with no finite point: legend only, nothing in its colour inside the plot.
  LinePlot nan_only;
  PlotSeries s;
  s.label = "all NaN";
  s.color = kRed;
  s.x = {1, 2, 3};
  s.y = {kNaN, kNaN, kNaN};
  nan_only.series.push_back(s);
  image = DrawLinePlot(nan_only, {}, &frame);
  EXPECT_EQ(image.size(), cv::Size(800, 500));
  EXPECT_EQ(CountColor(image(frame.plot_area), kRed), 0);
  EXPECT_GT(CountColor(image, kRed), 0);  // the legend sample

  // A single point (zero ranges, dates): padded, and the point inside.
  LinePlot single;
  single.x_is_date = true;
  s.label.clear();
  s.x = {DaysSinceEpoch(2016, 6, 1)};
  s.y = {0.8};
  single.series.push_back(s);
  image = DrawLinePlot(single, {}, &frame);
  EXPECT_LT(frame.x_min, s.x[0]);
  EXPECT_GT(frame.x_max, s.x[0]);
  EXPECT_EQ(frame.y_min, 0.0);
  EXPECT_GT(frame.y_max, 0.8);
  EXPECT_EQ(PixelAt(image, frame.ToPixel(s.x[0], 0.8)), Bgr(kRed));
  EXPECT_FALSE(frame.x_ticks.empty());

  // A constant negative series, explicit ranges, out-of-range data, the smallest image.
  LinePlot explicit_range;
  s.x = {0, 1, 2, 1e12};
  s.y = {-2, -2, -2, 5e11};
  explicit_range.series.push_back(s);
  explicit_range.x_min = -1.0;
  explicit_range.x_max = 3.0;
  PlotOptions tiny;
  tiny.width = 200;
  tiny.height = 150;
  image = DrawLinePlot(explicit_range, tiny, &frame);
  EXPECT_EQ(image.size(), cv::Size(200, 150));
  EXPECT_EQ(frame.x_min, -1.0);
  EXPECT_EQ(frame.x_max, 3.0);
  EXPECT_LT(frame.y_min, -2.0);
  explicit_range.series[0].y = {-2, -2, -2, -2};
  explicit_range.y_max = 0.0;
  EXPECT_EQ(LayoutLinePlot(explicit_range).y_max, 0.0);
  EXPECT_LT(LayoutLinePlot(explicit_range).y_min, -2.0);
}

TEST(PlotsTest, PlotGridHasOnePanelPerPlotAndSharedAxes) {
  std::vector<LinePlot> plots;
  for (int site = 0; site < 5; ++site) {
    LinePlot plot = GrowthPlot();
    plot.title = "site " + std::to_string(site);
    for (double& y : plot.series[0].y) y *= 1.0 + 0.2 * site;
    PlotSeries measured;
    measured.label = "measured";
    measured.color = kGreen;
    measured.style = PlotSeries::Style::kMarkersOnly;
    measured.marker = PlotSeries::Marker::kCross;
    measured.x = {plot.series[0].x[2] + 5.0};
    measured.y = {0.7};
    plot.series.push_back(measured);
    plots.push_back(plot);
  }
  std::vector<PlotFrame> frames;
  const cv::Mat image = DrawPlotGrid(plots, 2, SmallPanelOptions(), &frames);
  ASSERT_EQ(frames.size(), 5u);
  EXPECT_EQ(image.cols, 2 * 400);
  EXPECT_GT(image.rows, 3 * 300);  // three rows of panels and the legend below
  EXPECT_LT(image.rows, 3 * 300 + 100);
  for (int i = 0; i < 5; ++i) {
    const cv::Rect panel((i % 2) * 400, (i / 2) * 300, 400, 300);
    EXPECT_EQ(frames[i].plot_area & panel, frames[i].plot_area) << i;
    EXPECT_EQ(frames[i].y_min, frames[0].y_min);
    EXPECT_EQ(frames[i].y_max, frames[0].y_max);
    EXPECT_EQ(frames[i].x_min, frames[0].x_min);
    // Markers where each panel's frame puts them.
    const PlotSeries& s = plots[i].series[0];
    for (std::size_t k = 0; k < s.x.size(); ++k) {
      EXPECT_EQ(PixelAt(image, frames[i].ToPixel(s.x[k], s.y[k])), Bgr(kRed)) << i << " " << k;
    }
  }
  // The shared y range holds the tallest site.
  EXPECT_GT(frames[0].y_max, 1.35 * 1.8);
  // Both series colours in the legend strip below the panels.
  const cv::Mat legend = image(cv::Rect(0, 900, image.cols, image.rows - 900));
  EXPECT_GT(CountColor(legend, kRed), 0);
  EXPECT_GT(CountNearColor(legend, kGreen, 40), 0);

  // Without plots: a valid, panel-sized image.
  const cv::Mat none = DrawPlotGrid({}, 3, SmallPanelOptions(), &frames);
  EXPECT_EQ(none.size(), cv::Size(400, 300));
  EXPECT_TRUE(frames.empty());
  // More columns than plots: one row.
  EXPECT_EQ(DrawPlotGrid({plots[0]}, 4).cols, 400);
}

TEST(PlotsTest, WritePngWritesADecodableImageAtomically) {
  const io::testing::TempDir dir;
  const std::string path = dir / "analysis/plots/A3.png";
  const cv::Mat image = DrawLinePlot(GrowthPlot());
  WritePng(path, image);
  const cv::Mat read = cv::imread(path, cv::IMREAD_COLOR);
  ASSERT_FALSE(read.empty());
  EXPECT_EQ(read.size(), image.size());
  EXPECT_EQ(cv::norm(read, image, cv::NORM_INF), 0.0);
  int files = 0;
  for ([[maybe_unused]] const auto& e :
       std::filesystem::directory_iterator(dir / "analysis/plots")) {
    ++files;
  }
  EXPECT_EQ(files, 1);  // no temporary file left

  const std::string blocker = dir / "file";
  io::testing::WriteText(blocker, "x");
  try {
    WritePng(blocker + "/plot.png", image);
    ADD_FAILURE() << "no exception";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), blocker + "/plot.png");
  }
}

TEST(PlotsTest, DrawingIsDeterministic) {
  const LinePlot plot = GrowthPlot();
  EXPECT_EQ(cv::norm(DrawLinePlot(plot), DrawLinePlot(plot), cv::NORM_INF), 0.0);
}

}  // namespace
}  // namespace crop4d::report
