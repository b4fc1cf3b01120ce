#include "crop4d/report/plots.h"

#include <fmt/format.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/report/plot_canvas.h"

namespace crop4d::report {
namespace {

using canvas::FitText;
using canvas::kBlack;
using canvas::kGrid;
using canvas::kLabelFontScale;
using canvas::kNoteGray;
using canvas::kTickFontScale;
using canvas::kTickLength;
using canvas::kTitleFontScale;
using canvas::kWhite;
using canvas::PutText;
using canvas::PutTextVertical;
using canvas::TextSize;

namespace chrono = std::chrono;

// At most this many ticks on an axis, whatever the caller asks for.
constexpr double kMaxTicks = 1000.0;
// Horizontal ticks are at least this far apart (more when their labels need it); vertical ones
// at least kMinYTickSpacingPx.
constexpr double kMinXTickSpacingPx = 70.0;
constexpr double kMinYTickSpacingPx = 45.0;
// Dates beyond ±10^7 days (year ±27000) get no ticks: std::chrono's years end at ±32767.
constexpr double kMaxDateDays = 1e7;
// Legend layout, pixels: row height, length of the line sample, padding.
constexpr int kLegendRow = 24, kLegendSample = 28, kLegendPad = 10;
// Sub-pixel drawing: coordinates are passed to OpenCV in 1/16 pixel.
constexpr int kShift = 4;
constexpr double kSubpixel = 1 << kShift;

bool Finite(double x, double y) { return std::isfinite(x) && std::isfinite(y); }

cv::Point SubPixel(const cv::Point2d& p) {
  return {cvRound(p.x * kSubpixel), cvRound(p.y * kSubpixel)};
}

// Points far outside the image (data beyond an explicit axis range) are not drawn, so that their
// sub-pixel coordinates cannot overflow OpenCV's int.
bool OnCanvas(const cv::Point2d& p) { return std::abs(p.x) < 1e6 && std::abs(p.y) < 1e6; }

std::int64_t FloorMod(std::int64_t a, std::int64_t n) { return ((a % n) + n) % n; }

void CheckPlot(const LinePlot& plot) {
  for (const PlotSeries& s : plot.series) CROP4D_CHECK(s.x.size() == s.y.size());
  for (const std::optional<double>& v : {plot.x_min, plot.x_max, plot.y_min, plot.y_max}) {
    CROP4D_CHECK(!v || std::isfinite(*v));
  }
  CROP4D_CHECK(!(plot.x_min && plot.x_max) || *plot.x_min < *plot.x_max);
  CROP4D_CHECK(!(plot.y_min && plot.y_max) || *plot.y_min < *plot.y_max);
}

// Range of one axis. `data` is the [lo, hi] of the finite data (none without data);
// `from_zero`: start at 0 when all data are ≥ 0 (y); `margin` a fraction of the range added at
// each free end, at least `min_margin`; a zero-width range is widened by `zero_pad` (or by 10 %
// of its value if larger).
std::pair<double, double> AxisRange(std::optional<std::pair<double, double>> data,
                                    std::optional<double> set_lo, std::optional<double> set_hi,
                                    bool from_zero, double margin, double min_margin,
                                    double zero_pad) {
  if (set_lo && set_hi) return {*set_lo, *set_hi};
  double lo = 0.0, hi = 1.0;
  bool lo_is_zero = false;
  if (data) {
    std::tie(lo, hi) = *data;
    if (from_zero && lo >= 0.0) {
      lo = 0.0;
      lo_is_zero = true;
    }
    if (hi - lo <= 0.0) {
      const double pad = std::max(zero_pad, 0.1 * std::abs(hi));
      if (lo_is_zero) {
        hi = lo + 2.0 * pad;
      } else {
        lo -= pad;
        hi += pad;
      }
    }
    const double m = std::max(margin * (hi - lo), min_margin);
    if (!lo_is_zero) lo -= m;
    hi += m;
  }
  if (set_lo) lo = *set_lo;
  if (set_hi) hi = *set_hi;
  if (!(lo < hi)) {
    if (set_lo) {
      hi = lo + std::max(1.0, 0.1 * std::abs(lo));
    } else {
      lo = hi - std::max(1.0, 0.1 * std::abs(hi));
    }
  }
  return {lo, hi};
}

struct Ranges {
  double x_min = 0.0, x_max = 1.0, y_min = 0.0, y_max = 1.0;
  bool has_data = false;
};

Ranges PlotRanges(const LinePlot& plot) {
  std::optional<std::pair<double, double>> xs, ys;
  for (const PlotSeries& s : plot.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!Finite(s.x[i], s.y[i])) continue;
      xs = xs ? std::pair(std::min(xs->first, s.x[i]), std::max(xs->second, s.x[i]))
              : std::pair(s.x[i], s.x[i]);
      ys = ys ? std::pair(std::min(ys->first, s.y[i]), std::max(ys->second, s.y[i]))
              : std::pair(s.y[i], s.y[i]);
    }
  }
  Ranges r;
  r.has_data = xs.has_value();
  std::tie(r.x_min, r.x_max) = AxisRange(xs, plot.x_min, plot.x_max, /*from_zero=*/false, 0.04,
                                         plot.x_is_date ? 0.5 : 0.0, plot.x_is_date ? 1.0 : 0.5);
  std::tie(r.y_min, r.y_max) =
      AxisRange(ys, plot.y_min, plot.y_max, /*from_zero=*/true, 0.06, 0.0, 0.5);
  return r;
}

// One legend entry: a labelled series (or, in a grid, all series of that label and look).
struct LegendEntry {
  std::string label;
  cv::Scalar color;
  PlotSeries::Style style = PlotSeries::Style::kLineAndMarkers;
  PlotSeries::Marker marker = PlotSeries::Marker::kFilledCircle;
  bool has_data = false;

  std::string Text() const { return has_data ? label : label + " (no data)"; }
  bool SameLook(const PlotSeries& s) const {
    return s.label == label && s.color == color && s.style == style && s.marker == marker;
  }
};

bool SeriesHasData(const PlotSeries& s) {
  for (std::size_t i = 0; i < s.x.size(); ++i) {
    if (Finite(s.x[i], s.y[i])) return true;
  }
  return false;
}

// The distinct labelled series of `plots`, in order of first appearance.
std::vector<LegendEntry> LegendEntries(const std::vector<const LinePlot*>& plots) {
  std::vector<LegendEntry> entries;
  for (const LinePlot* plot : plots) {
    for (const PlotSeries& s : plot->series) {
      if (s.label.empty()) continue;
      auto it = std::find_if(entries.begin(), entries.end(),
                             [&](const LegendEntry& e) { return e.SameLook(s); });
      if (it == entries.end()) {
        entries.push_back({s.label, s.color, s.style, s.marker, false});
        it = entries.end() - 1;
      }
      it->has_data = it->has_data || SeriesHasData(s);
    }
  }
  return entries;
}

// Draws a marker centred on `centre` (pixels of `image`, sub-pixel).
void DrawMarker(cv::Mat& image, const cv::Point2d& centre, PlotSeries::Marker marker, int radius,
                const cv::Scalar& color) {
  const int thickness = radius >= 3 ? 2 : 1;
  switch (marker) {
    case PlotSeries::Marker::kFilledCircle:
      cv::circle(image, SubPixel(centre), cvRound(radius * kSubpixel), color, cv::FILLED,
                 cv::LINE_AA, kShift);
      break;
    case PlotSeries::Marker::kCross: {
      const cv::Point2d a(radius, radius), b(radius, -radius);
      cv::line(image, SubPixel(centre - a), SubPixel(centre + a), color, thickness, cv::LINE_AA,
               kShift);
      cv::line(image, SubPixel(centre - b), SubPixel(centre + b), color, thickness, cv::LINE_AA,
               kShift);
      break;
    }
    case PlotSeries::Marker::kSquare: {
      const cv::Point2d a(radius, radius);
      cv::rectangle(image, SubPixel(centre - a), SubPixel(centre + a), color, thickness,
                    cv::LINE_AA, kShift);
      break;
    }
  }
}

// Draws a legend entry: a sample (line and marker) with its left end at left_middle, then the
// text, at most text_width pixels.
void DrawLegendEntry(cv::Mat& image, cv::Point left_middle, const LegendEntry& entry,
                     int text_width, const PlotOptions& options) {
  const cv::Point2d a(left_middle.x, left_middle.y);
  const cv::Point2d b(left_middle.x + kLegendSample, left_middle.y);
  if (entry.style == PlotSeries::Style::kLineAndMarkers) {
    cv::line(image, SubPixel(a), SubPixel(b), entry.color, options.line_thickness_px, cv::LINE_AA,
             kShift);
  }
  DrawMarker(image, 0.5 * (a + b), entry.marker, std::min(options.marker_radius_px, 6),
             entry.color);
  PutText(image, FitText(entry.Text(), text_width, kLabelFontScale),
          {left_middle.x + kLegendSample + 8, left_middle.y}, kLabelFontScale, kBlack);
}

// Everything DrawLinePlot places: the frame, and the room of the legend.
struct Layout {
  PlotFrame frame;
  bool has_data = false;
  std::vector<LegendEntry> legend;  // empty: no legend
  int legend_text_width = 0;
  int label_height = 0, tick_height = 0, title_height = 0;
};

Layout ComputeLayout(const LinePlot& plot, const PlotOptions& options) {
  CROP4D_CHECK_OPTIONS(options, "ComputeLayout");
  CheckPlot(plot);
  Layout layout;
  const Ranges ranges = PlotRanges(plot);
  layout.has_data = ranges.has_data;
  PlotFrame& frame = layout.frame;
  frame.x_min = ranges.x_min;
  frame.x_max = ranges.x_max;
  frame.y_min = ranges.y_min;
  frame.y_max = ranges.y_max;

  layout.tick_height = TextSize("0", kTickFontScale, 1).height;
  layout.label_height = TextSize("Hg", kLabelFontScale, 1).height + 6;
  layout.title_height = plot.title.empty() ? 0 : TextSize("Hg", kTitleFontScale, 2).height;
  const int top = plot.title.empty() ? 16 : 16 + layout.title_height + 20;
  const int bottom = kTickLength + 8 + layout.tick_height + 14 +
                     (plot.x_label.empty() ? 0 : layout.label_height) + 12;
  const int plot_height = std::max(20, options.height - top - bottom);

  // Vertical ticks, then the left margin that their labels need.
  frame.y_ticks = NumericTicks(frame.y_min, frame.y_max,
                               kMinYTickSpacingPx * (frame.y_max - frame.y_min) / plot_height);
  int y_tick_width = 0;
  for (const AxisTick& t : frame.y_ticks) {
    y_tick_width = std::max(y_tick_width, TextSize(t.label, kTickFontScale, 1).width);
  }
  const int left =
      12 + (plot.y_label.empty() ? 0 : layout.label_height + 10) + y_tick_width + 6 + kTickLength;

  // Legend on the right, its text at most a quarter of the image wide.
  if (options.legend) layout.legend = LegendEntries({&plot});
  int right = 24;
  if (!layout.legend.empty()) {
    for (const LegendEntry& e : layout.legend) {
      layout.legend_text_width =
          std::max(layout.legend_text_width, TextSize(e.Text(), kLabelFontScale, 1).width);
    }
    layout.legend_text_width = std::min(layout.legend_text_width, options.width / 4);
    const int legend_width = 2 * kLegendPad + kLegendSample + 8 + layout.legend_text_width;
    right = 24 + legend_width + 16;
    if (options.width - left - right < options.width / 2) {  // no room: leave it out
      layout.legend.clear();
      right = 24;
    }
  }
  const int plot_width = std::max(20, options.width - left - right);
  frame.plot_area = cv::Rect(left, top, plot_width, plot_height);

  // Horizontal ticks, spaced for their labels.
  const double units_per_px = (frame.x_max - frame.x_min) / plot_width;
  if (plot.x_is_date) {
    const int label_width = TextSize("2000-00-00", kTickFontScale, 1).width;
    frame.x_ticks = DateTicks(frame.x_min, frame.x_max,
                              std::max(kMinXTickSpacingPx, label_width + 20.0) * units_per_px);
  } else {
    double spacing = kMinXTickSpacingPx;
    for (int attempt = 0; attempt < 3; ++attempt) {
      frame.x_ticks = NumericTicks(frame.x_min, frame.x_max, spacing * units_per_px);
      int label_width = 0;
      for (const AxisTick& t : frame.x_ticks) {
        label_width = std::max(label_width, TextSize(t.label, kTickFontScale, 1).width);
      }
      if (label_width + 16 <= spacing) break;
      spacing = label_width + 16;
    }
  }
  return layout;
}

// Draws `plot` laid out by `layout` into `image` (white, options.width × options.height).
void DrawInto(cv::Mat& image, const LinePlot& plot, const Layout& layout,
              const PlotOptions& options) {
  const PlotFrame& frame = layout.frame;
  const cv::Rect area = frame.plot_area & cv::Rect(0, 0, image.cols, image.rows);
  if (area.empty()) return;
  cv::Mat inside = image(area);  // drawing into the view clips to the plot area
  const cv::Point2d offset(area.x, area.y);

  // Grid.
  for (const AxisTick& t : frame.x_ticks) {
    const int x = cvRound(frame.ToPixel(t.value, frame.y_min).x) - area.x;
    cv::line(inside, {x, 0}, {x, inside.rows - 1}, kGrid, 1, cv::LINE_8);
  }
  for (const AxisTick& t : frame.y_ticks) {
    const int y = cvRound(frame.ToPixel(frame.x_min, t.value).y) - area.y;
    cv::line(inside, {0, y}, {inside.cols - 1, y}, kGrid, 1, cv::LINE_8);
  }

  // Lines of every series, then the markers on top.
  for (const PlotSeries& s : plot.series) {
    if (s.style != PlotSeries::Style::kLineAndMarkers) continue;
    for (std::size_t i = 1; i < s.x.size(); ++i) {
      if (!Finite(s.x[i - 1], s.y[i - 1]) || !Finite(s.x[i], s.y[i])) continue;
      const cv::Point2d a = frame.ToPixel(s.x[i - 1], s.y[i - 1]) - offset;
      const cv::Point2d b = frame.ToPixel(s.x[i], s.y[i]) - offset;
      if (!OnCanvas(a) || !OnCanvas(b)) continue;
      cv::line(inside, SubPixel(a), SubPixel(b), s.color, options.line_thickness_px, cv::LINE_AA,
               kShift);
    }
  }
  for (const PlotSeries& s : plot.series) {
    for (std::size_t i = 0; i < s.x.size(); ++i) {
      if (!Finite(s.x[i], s.y[i])) continue;
      const cv::Point2d p = frame.ToPixel(s.x[i], s.y[i]) - offset;
      if (!OnCanvas(p)) continue;
      DrawMarker(inside, p, s.marker, options.marker_radius_px, s.color);
    }
  }
  if (!layout.has_data) {
    const std::string note = "no data";
    PutText(inside, note,
            {(inside.cols - TextSize(note, kLabelFontScale, 1).width) / 2, inside.rows / 2},
            kLabelFontScale, kNoteGray);
  }

  // Frame, ticks and tick labels.
  const int left = frame.plot_area.x, top = frame.plot_area.y;
  const int plot_bottom = top + frame.plot_area.height;
  cv::rectangle(image, {left - 1, top - 1},
                {left + frame.plot_area.width, top + frame.plot_area.height}, kBlack, 1,
                cv::LINE_8);
  for (const AxisTick& t : frame.x_ticks) {
    const int x = cvRound(frame.ToPixel(t.value, frame.y_min).x);
    cv::line(image, {x, plot_bottom}, {x, plot_bottom + kTickLength}, kBlack, 1, cv::LINE_8);
    const int w = TextSize(t.label, kTickFontScale, 1).width;
    PutText(image, t.label,
            {std::clamp(x - w / 2, 0, std::max(0, image.cols - w - 1)),
             plot_bottom + kTickLength + 6 + layout.tick_height / 2},
            kTickFontScale, kBlack);
  }
  for (const AxisTick& t : frame.y_ticks) {
    const int y = cvRound(frame.ToPixel(frame.x_min, t.value).y);
    cv::line(image, {left - 1 - kTickLength, y}, {left - 1, y}, kBlack, 1, cv::LINE_8);
    const int w = TextSize(t.label, kTickFontScale, 1).width;
    PutText(image, t.label, {left - kTickLength - 6 - w, y}, kTickFontScale, kBlack);
  }

  // Axis labels and title.
  if (!plot.x_label.empty()) {
    const std::string text = FitText(plot.x_label, image.cols - 8, kLabelFontScale);
    const int w = TextSize(text, kLabelFontScale, 1).width;
    PutText(image, text,
            {std::max(4, left + (frame.plot_area.width - w) / 2),
             plot_bottom + kTickLength + 8 + layout.tick_height + 14 + layout.label_height / 2},
            kLabelFontScale, kBlack);
  }
  PutTextVertical(image, FitText(plot.y_label, image.rows - 8, kLabelFontScale), 12, top,
                  frame.plot_area.height, layout.label_height, kLabelFontScale, kBlack);
  if (!plot.title.empty()) {
    const std::string text = FitText(plot.title, image.cols - 32, kTitleFontScale, 2);
    const int w = TextSize(text, kTitleFontScale, 2).width;
    const int x =
        std::clamp(left + (frame.plot_area.width - w) / 2, 16, std::max(16, image.cols - w - 16));
    PutText(image, text, {x, 16 + layout.title_height / 2}, kTitleFontScale, kBlack, 2);
  }

  // Legend, right of the plot.
  if (!layout.legend.empty()) {
    const int n = static_cast<int>(layout.legend.size());
    const int x0 = left + frame.plot_area.width + 24;
    const int width = 2 * kLegendPad + kLegendSample + 8 + layout.legend_text_width;
    const int height = 2 * kLegendPad + n * kLegendRow - (kLegendRow - 14);
    cv::rectangle(image, {x0, top}, {x0 + width, top + height}, kBlack, 1, cv::LINE_8);
    for (int i = 0; i < n; ++i) {
      DrawLegendEntry(image, {x0 + kLegendPad, top + kLegendPad + 7 + i * kLegendRow},
                      layout.legend[i], layout.legend_text_width, options);
    }
  }
}

}  // namespace

OptionCheck PlotOptions::Check() const {
  OptionChecker c;
  c.InRange("width", width, 200, 10000)
      .InRange("height", height, 150, 10000)
      .InRange("marker_radius_px", marker_radius_px, 1, 30)
      .InRange("line_thickness_px", line_thickness_px, 1, 20);
  return c.Result();
}

PlotOptions SmallPanelOptions() {
  PlotOptions options;
  options.width = 400;
  options.height = 300;
  options.marker_radius_px = 3;
  options.line_thickness_px = 1;
  return options;
}

cv::Point2d PlotFrame::ToPixel(double x, double y) const {
  return {plot_area.x + (x - x_min) / (x_max - x_min) * (plot_area.width - 1),
          plot_area.y + (y_max - y) / (y_max - y_min) * (plot_area.height - 1)};
}

std::vector<AxisTick> NumericTicks(double lo, double hi, double min_step) {
  CROP4D_CHECK(std::isfinite(lo) && std::isfinite(hi) && lo <= hi);
  CROP4D_CHECK(std::isfinite(min_step) && min_step > 0.0);
  const double step = canvas::NiceStep(std::max(min_step, (hi - lo) / kMaxTicks));
  const int decimals = canvas::Decimals(step);
  std::vector<AxisTick> ticks;
  for (double v : canvas::Ticks(lo, hi, step)) {
    ticks.push_back({v, fmt::format("{:.{}f}", v, decimals)});
  }
  return ticks;
}

double DaysSinceEpoch(int year, int month, int day) {
  const chrono::sys_days date =
      chrono::year(year) / chrono::month(unsigned(month)) / chrono::day(unsigned(day));
  return double(date.time_since_epoch().count());
}

std::string FormatDate(double days) {
  if (!std::isfinite(days) || std::abs(days) > kMaxDateDays) return fmt::format("{}", days);
  const chrono::year_month_day date{chrono::sys_days(chrono::days(std::int64_t(std::floor(days))))};
  return fmt::format("{:04d}-{:02d}-{:02d}", int(date.year()), unsigned(date.month()),
                     unsigned(date.day()));
}

std::vector<AxisTick> DateTicks(double lo_days, double hi_days, double min_step_days) {
  CROP4D_CHECK(std::isfinite(lo_days) && std::isfinite(hi_days) && lo_days <= hi_days);
  CROP4D_CHECK(std::isfinite(min_step_days) && min_step_days > 0.0);
  std::vector<AxisTick> ticks;
  if (lo_days < -kMaxDateDays || hi_days > kMaxDateDays) return ticks;
  const double min_step = std::max(min_step_days, (hi_days - lo_days) / kMaxTicks);
  const std::int64_t first = std::int64_t(std::ceil(lo_days));
  const std::int64_t last = std::int64_t(std::floor(hi_days));
  auto add = [&ticks](std::int64_t day) {
    ticks.push_back({double(day), FormatDate(double(day))});
  };
  if (min_step <= 7.0) {
    // Every day, every other day, or Mondays (1970-01-05, day 4, was a Monday).
    const int step = min_step <= 1.0 ? 1 : min_step <= 2.0 ? 2 : 7;
    const std::int64_t phase = step == 7 ? 4 : 0;
    for (std::int64_t d = first; d <= last; ++d) {
      if (FloorMod(d - phase, step) == 0) add(d);
    }
    return ticks;
  }
  const chrono::year_month_day lo_date{chrono::sys_days(chrono::days(first))};
  const chrono::year_month_day hi_date{chrono::sys_days(chrono::days(last))};
  if (min_step <= 182.625) {
    // Half months (1st and 15th), or every 1, 2, 3, 4 or 6 months on the 1st.
    const bool half = min_step <= 15.22;
    const int months = min_step <= 30.44    ? 1
                       : min_step <= 60.88  ? 2
                       : min_step <= 91.32  ? 3
                       : min_step <= 121.75 ? 4
                                            : 6;
    const chrono::year_month end = hi_date.year() / hi_date.month();
    for (chrono::year_month ym = lo_date.year() / lo_date.month(); ym <= end;
         ym += chrono::months(1)) {
      if (!half && (unsigned(ym.month()) - 1) % months != 0) continue;
      for (unsigned day : {1u, 15u}) {
        if (day == 15 && !half) continue;
        const std::int64_t d = chrono::sys_days(ym / chrono::day(day)).time_since_epoch().count();
        if (d >= first && d <= last) add(d);
      }
    }
    return ticks;
  }
  // 1, 2, 5, 10, ... years, on the 1st of January.
  const int years = int(canvas::NiceStep(std::max(1.0, min_step / 365.25)));
  for (int y = int(lo_date.year()); y <= int(hi_date.year()); ++y) {
    if (FloorMod(y, years) != 0) continue;
    const std::int64_t d = std::int64_t(DaysSinceEpoch(y, 1, 1));
    if (d >= first && d <= last) add(d);
  }
  return ticks;
}

PlotFrame LayoutLinePlot(const LinePlot& plot, const PlotOptions& options) {
  return ComputeLayout(plot, options).frame;
}

cv::Mat DrawLinePlot(const LinePlot& plot, const PlotOptions& options, PlotFrame* frame) {
  const Layout layout = ComputeLayout(plot, options);
  cv::Mat image(options.height, options.width, CV_8UC3, kWhite);
  DrawInto(image, plot, layout, options);
  if (frame != nullptr) *frame = layout.frame;
  return image;
}

cv::Mat DrawPlotGrid(const std::vector<LinePlot>& plots, int columns, const PlotOptions& panel,
                     std::vector<PlotFrame>* frames) {
  CROP4D_CHECK(columns >= 1);
  CROP4D_CHECK_OPTIONS(panel, "DrawPlotGrid");
  if (frames != nullptr) frames->clear();
  if (plots.empty()) {
    cv::Mat image(panel.height, panel.width, CV_8UC3, kWhite);
    const std::string note = "no plots";
    PutText(image, note,
            {(image.cols - TextSize(note, kLabelFontScale, 1).width) / 2, image.rows / 2},
            kLabelFontScale, kNoteGray);
    return image;
  }
  for (const LinePlot& plot : plots) CheckPlot(plot);
  const int n = static_cast<int>(plots.size());
  const int cols = std::min(columns, n);
  const int rows = (n + cols - 1) / cols;

  // Shared axis ranges: those of all series together (the first plot's explicit ranges win).
  std::vector<LinePlot> panels = plots;
  if (panel.share_axes) {
    LinePlot all;
    all.x_is_date = plots.front().x_is_date;
    all.x_min = plots.front().x_min;
    all.x_max = plots.front().x_max;
    all.y_min = plots.front().y_min;
    all.y_max = plots.front().y_max;
    for (const LinePlot& plot : plots) {
      all.series.insert(all.series.end(), plot.series.begin(), plot.series.end());
    }
    const Ranges ranges = PlotRanges(all);
    for (LinePlot& p : panels) {
      p.x_min = ranges.x_min;
      p.x_max = ranges.x_max;
      p.y_min = ranges.y_min;
      p.y_max = ranges.y_max;
    }
  }

  // Shared legend below the panels: entries flow left to right, wrapping into rows.
  std::vector<const LinePlot*> pointers;
  for (const LinePlot& plot : plots) pointers.push_back(&plot);
  const std::vector<LegendEntry> legend = LegendEntries(pointers);
  const int image_width = cols * panel.width;
  const int max_text_width = std::max(40, image_width / 2);
  std::vector<cv::Point> legend_positions;
  std::vector<int> legend_text_widths;
  int legend_height = 0;
  if (!legend.empty()) {
    int x = 16, row = 0;
    for (const LegendEntry& e : legend) {
      const int text_width = std::min(TextSize(e.Text(), kLabelFontScale, 1).width, max_text_width);
      const int entry_width = kLegendSample + 8 + text_width + 24;
      if (x > 16 && x + entry_width > image_width - 16) {
        x = 16;
        ++row;
      }
      legend_positions.emplace_back(x, row);
      legend_text_widths.push_back(text_width);
      x += entry_width;
    }
    legend_height = 2 * kLegendPad + (row + 1) * kLegendRow;
  }

  cv::Mat image(rows * panel.height + legend_height, image_width, CV_8UC3, kWhite);
  PlotOptions panel_options = panel;
  panel_options.legend = false;
  for (int i = 0; i < n; ++i) {
    const cv::Point origin((i % cols) * panel.width, (i / cols) * panel.height);
    cv::Mat view = image(cv::Rect(origin, cv::Size(panel.width, panel.height)));
    const Layout layout = ComputeLayout(panels[i], panel_options);
    DrawInto(view, panels[i], layout, panel_options);
    if (frames != nullptr) {
      PlotFrame frame = layout.frame;
      frame.plot_area += origin;
      frames->push_back(frame);
    }
  }
  const int legend_top = rows * panel.height;
  for (std::size_t i = 0; i < legend.size(); ++i) {
    DrawLegendEntry(image,
                    {legend_positions[i].x,
                     legend_top + kLegendPad + kLegendRow / 2 + legend_positions[i].y * kLegendRow},
                    legend[i], legend_text_widths[i], panel);
  }
  return image;
}

void WritePng(const std::string& path, const cv::Mat& image) {
  CROP4D_CHECK(!image.empty());
  std::vector<std::uint8_t> png;
  bool encoded = false;
  try {
    encoded = cv::imencode(".png", image, png);
  } catch (const cv::Exception& e) {
    throw InputError(path, 0, std::string("cannot encode the image as PNG: ") + e.what());
  }
  if (!encoded) throw InputError(path, 0, "cannot encode the image as PNG");
  io::WriteFileAtomic(path, std::string(png.begin(), png.end()));
}

}  // namespace crop4d::report
