#include "crop4d/report/cross_section.h"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/report/plot_canvas.h"
#include "crop4d/workspace/layout.h"

namespace crop4d::report {
namespace {

namespace fs = std::filesystem;

// Text, colours and ticks shared with the other figures of the report (plot_canvas.h).
using canvas::Decimals;
using canvas::kBlack;
using canvas::kGrid;
using canvas::kLabelFontScale;
using canvas::kNoteGray;
using canvas::kTickFontScale;
using canvas::kTickLength;
using canvas::kTitleFontScale;
using canvas::kWhite;
using canvas::NiceStep;
using canvas::PutText;
using canvas::PutTextVertical;
using canvas::TextSize;
using canvas::Ticks;

// Grid lines (and ticks) are at least this many pixels apart.
constexpr double kMinTickSpacingPx = 70.0;

}  // namespace

OptionCheck CrossSectionSlice::Check() const {
  OptionChecker c;
  c.Require(center.allFinite(), "center", "must be finite")
      .Require(direction.allFinite() && direction.norm() > 1e-12, "direction",
               "must be finite and non-zero")
      .Finite("thickness_m", thickness_m)
      .Greater("thickness_m", thickness_m, 0.0)
      .Finite("half_length_m", half_length_m)
      .Greater("half_length_m", half_length_m, 0.0);
  return c.Result();
}

OptionCheck CrossSectionOptions::Check() const {
  const bool z_auto = std::isnan(z_min) && std::isnan(z_max);
  const bool z_fixed = std::isfinite(z_min) && std::isfinite(z_max) && z_min < z_max;
  OptionChecker c;
  c.Nested("slice", slice.Check())
      .InRange("plot_width_px", plot_width_px, 50, 20000)
      .AtLeast("min_plot_height_px", min_plot_height_px, 50)
      .Require(max_plot_height_px >= min_plot_height_px, "max_plot_height_px",
               "must be >= min_plot_height_px", max_plot_height_px)
      .AtMost("max_plot_height_px", max_plot_height_px, 20000)
      .Require(z_auto || z_fixed, "z_min",
               "z_min and z_max must both be NaN (automatic) or finite with z_min < z_max")
      .InRange("point_radius_px", point_radius_px, 0, 50);
  return c.Result();
}

std::vector<Eigen::Vector2d> PointsInSlice(const io::PlyPointCloud& cloud,
                                           const CrossSectionSlice& slice) {
  CROP4D_CHECK_OPTIONS(slice, "PointsInSlice");
  const Eigen::Vector2d along_axis = slice.direction.normalized();
  const Eigen::Vector2d across_axis(-along_axis.y(), along_axis.x());
  const double half_thickness = 0.5 * slice.thickness_m;
  std::vector<Eigen::Vector2d> points;
  for (const Eigen::Vector3d& p : cloud.points) {
    const Eigen::Vector2d offset = p.head<2>() - slice.center;
    const double along = offset.dot(along_axis);
    if (std::abs(offset.dot(across_axis)) <= half_thickness &&
        std::abs(along) <= slice.half_length_m && std::isfinite(p.z())) {
      points.emplace_back(along, p.z());
    }
  }
  return points;
}

cv::Point2d CrossSectionFigure::ToPixel(double along_m, double z_m) const {
  return {plot_origin.x + pixels_per_metre * (along_m - along_min),
          plot_origin.y + pixels_per_metre * (z_max - z_m)};
}

cv::Vec3b SessionColor(int index, int count) {
  CROP4D_CHECK(count >= 1 && index >= 0 && index < count);
  // Viridis from 0 to 220 of 255: values above are pale yellow, faint on white.
  const int value = count == 1 ? 0 : int(std::lround(220.0 * index / (count - 1)));
  const cv::Mat gray(1, 1, CV_8UC1, cv::Scalar(value));
  cv::Mat color;
  cv::applyColorMap(gray, color, cv::COLORMAP_VIRIDIS);
  return color.at<cv::Vec3b>(0, 0);
}

namespace {

// The scale of the figure (pixels per metre, one for both axes) and its height range: the slice
// length fills plot_width_px, unless the height range would then be taller than
// max_plot_height_px; a height range shorter than min_plot_height_px grows about its middle.
void FitScale(const CrossSectionOptions& options, double* z_lo, double* z_hi,
              CrossSectionFigure* figure) {
  const double length = 2.0 * options.slice.half_length_m;
  double scale = options.plot_width_px / length;
  if ((*z_hi - *z_lo) * scale > options.max_plot_height_px) {
    scale = options.max_plot_height_px / (*z_hi - *z_lo);
  }
  if ((*z_hi - *z_lo) * scale < options.min_plot_height_px) {
    const double middle = 0.5 * (*z_lo + *z_hi), half = 0.5 * options.min_plot_height_px / scale;
    *z_lo = middle - half;
    *z_hi = middle + half;
  }
  figure->pixels_per_metre = scale;
  figure->along_min = -options.slice.half_length_m;
  figure->z_min = *z_lo;
  figure->z_max = *z_hi;
  figure->plot_size = cv::Size(static_cast<int>(std::lround(length * scale)),
                               static_cast<int>(std::lround((*z_hi - *z_lo) * scale)));
}

// The points into `plot` (the plot area of the image, at `origin`), latest session first so
// that the earliest ends on top. Exact colours (no anti-aliasing): a pixel of a session's colour
// is one of its points.
void DrawPoints(const std::vector<std::vector<Eigen::Vector2d>>& layers,
                const CrossSectionOptions& options, const CrossSectionFigure& figure,
                const cv::Point& origin, cv::Mat plot) {
  for (int i = static_cast<int>(layers.size()) - 1; i >= 0; --i) {
    const cv::Vec3b c = figure.series[i].color_bgr;
    const cv::Scalar color(c[0], c[1], c[2]);
    for (const Eigen::Vector2d& p : layers[i]) {
      const cv::Point2d pixel = figure.ToPixel(p.x(), p.y());
      const cv::Point centre(cvRound(pixel.x) - origin.x, cvRound(pixel.y) - origin.y);
      if (options.point_radius_px == 0) {
        if (centre.x >= 0 && centre.y >= 0 && centre.x < plot.cols && centre.y < plot.rows) {
          plot.at<cv::Vec3b>(centre) = c;
        }
      } else {
        cv::circle(plot, centre, options.point_radius_px, color, cv::FILLED, cv::LINE_8);
      }
    }
  }
  if (figure.num_points == 0) {
    const std::string note = "no points in the slice";
    const cv::Size size = TextSize(note, kLabelFontScale, 1);
    PutText(plot, note, {(plot.cols - size.width) / 2, plot.rows / 2}, kLabelFontScale, kNoteGray);
  }
}

constexpr int kLegendRow = 24, kSwatch = 14, kPad = 10;

// The legend in `box`: one swatch and "label (N points)" per session, earliest first.
void DrawLegend(const std::vector<CrossSectionSeries>& series,
                const std::vector<std::string>& texts, const cv::Rect& box, cv::Mat& image) {
  const int x0 = box.x, top = box.y;
  cv::rectangle(image, {x0, top}, {x0 + box.width, top + box.height}, kBlack, 1, cv::LINE_8);
  for (std::size_t i = 0; i < series.size(); ++i) {
    const cv::Vec3b c = series[i].color_bgr;
    const int y = top + kPad + static_cast<int>(i) * kLegendRow;
    cv::rectangle(image, {x0 + kPad, y}, {x0 + kPad + kSwatch - 1, y + kSwatch - 1},
                  cv::Scalar(c[0], c[1], c[2]), cv::FILLED, cv::LINE_8);
    PutText(image, texts[i], {x0 + kPad + kSwatch + 8, y + kSwatch / 2}, kLabelFontScale, kBlack);
  }
}

// The plot's frame, and the ticks with their labels below it (along the slice) and left of it
// (height).
void DrawFrameAndTicks(const CrossSectionFigure& figure, const std::vector<double>& along_ticks,
                       const std::vector<double>& z_ticks, int decimals, int tick_height,
                       cv::Mat& image) {
  const int left = figure.plot_origin.x, top = figure.plot_origin.y;
  const double z_lo = figure.z_min;
  auto tick_text = [decimals](double v) { return fmt::format("{:.{}f}", v, decimals); };
  cv::rectangle(image, {left - 1, top - 1},
                {left + figure.plot_size.width, top + figure.plot_size.height}, kBlack, 1,
                cv::LINE_8);
  const int plot_bottom = top + figure.plot_size.height;
  for (double a : along_ticks) {
    const int x = cvRound(figure.ToPixel(a, z_lo).x);
    cv::line(image, {x, plot_bottom}, {x, plot_bottom + kTickLength}, kBlack, 1, cv::LINE_8);
    const std::string text = tick_text(a);
    const int w = TextSize(text, kTickFontScale, 1).width;
    PutText(image, text, {x - w / 2, plot_bottom + kTickLength + 6 + tick_height / 2},
            kTickFontScale, kBlack);
  }
  for (double z : z_ticks) {
    const int y = cvRound(figure.ToPixel(0, z).y);
    cv::line(image, {left - 1 - kTickLength, y}, {left - 1, y}, kBlack, 1, cv::LINE_8);
    const std::string text = tick_text(z);
    const int w = TextSize(text, kTickFontScale, 1).width;
    PutText(image, text, {left - kTickLength - 6 - w, y}, kTickFontScale, kBlack);
  }
}

// The axis labels (along the slice centred below, height rotated and centred on the left) and
// the title centred over the plot (within the image).
void DrawLabels(const CrossSectionOptions& options, const CrossSectionFigure& figure,
                int tick_height, int label_height, int title_height, cv::Mat& image) {
  const int left = figure.plot_origin.x, top = figure.plot_origin.y, width = image.cols;
  const int plot_bottom = top + figure.plot_size.height;
  {
    const cv::Size size = TextSize(options.along_label, kLabelFontScale, 1);
    PutText(image, options.along_label,
            {left + (figure.plot_size.width - size.width) / 2,
             plot_bottom + kTickLength + 8 + tick_height + 14 + label_height / 2},
            kLabelFontScale, kBlack);
  }
  PutTextVertical(image, options.height_label, 12, top, figure.plot_size.height, label_height,
                  kLabelFontScale, kBlack);

  {
    const cv::Size size = TextSize(options.title, kTitleFontScale, 2);
    const int x = std::clamp(left + (figure.plot_size.width - size.width) / 2, 16,
                             std::max(16, width - size.width - 16));
    PutText(image, options.title, {x, 16 + title_height / 2}, kTitleFontScale, kBlack, 2);
  }
}

}  // namespace

CrossSectionFigure DrawCrossSection(const std::vector<io::PlyPointCloud>& clouds,
                                    const std::vector<std::string>& labels,
                                    const CrossSectionOptions& options) {
  CROP4D_CHECK(clouds.size() == labels.size());
  CROP4D_CHECK_OPTIONS(options, "DrawCrossSection");
  const int n = static_cast<int>(clouds.size());
  CrossSectionFigure figure;

  // Slice coordinates of every session's points, and their height range.
  std::vector<std::vector<Eigen::Vector2d>> layers(n);
  double z_lo = std::numeric_limits<double>::infinity(), z_hi = -z_lo;
  for (int i = 0; i < n; ++i) {
    layers[i] = PointsInSlice(clouds[i], options.slice);
    for (const Eigen::Vector2d& p : layers[i]) {
      z_lo = std::min(z_lo, p.y());
      z_hi = std::max(z_hi, p.y());
    }
    figure.series.push_back({labels[i], SessionColor(i, n), static_cast<int>(layers[i].size())});
    figure.num_points += static_cast<int>(layers[i].size());
  }
  if (std::isfinite(options.z_min)) {
    z_lo = options.z_min;
    z_hi = options.z_max;
  } else if (figure.num_points > 0) {
    const double margin = std::max(0.08 * (z_hi - z_lo), 0.05);
    z_lo -= margin;
    z_hi += margin;
  } else {
    z_lo = 0.0;
    z_hi = 1.0;
  }

  FitScale(options, &z_lo, &z_hi, &figure);
  const double scale = figure.pixels_per_metre;

  // Ticks on a square grid (equal aspect ratio: the same step on both axes).
  const double step = NiceStep(kMinTickSpacingPx / scale);
  const int decimals = Decimals(step);
  const std::vector<double> along_ticks =
      Ticks(-options.slice.half_length_m, options.slice.half_length_m, step);
  const std::vector<double> z_ticks = Ticks(z_lo, z_hi, step);
  auto tick_text = [decimals](double v) { return fmt::format("{:.{}f}", v, decimals); };

  // Layout: title on top; height label and tick labels left; tick labels and along label below;
  // legend right of the plot.
  int max_z_tick_width = 0;
  for (double z : z_ticks) {
    max_z_tick_width = std::max(max_z_tick_width, TextSize(tick_text(z), kTickFontScale, 1).width);
  }
  const int tick_height = TextSize("0", kTickFontScale, 1).height;
  const int label_height = TextSize("Hg", kLabelFontScale, 1).height + 6;
  const int title_height = TextSize(options.title, kTitleFontScale, 2).height;
  std::vector<std::string> legend_texts;
  int legend_text_width = 0;
  for (const CrossSectionSeries& s : figure.series) {
    legend_texts.push_back(fmt::format("{} ({} points)", s.label, s.num_points));
    legend_text_width =
        std::max(legend_text_width, TextSize(legend_texts.back(), kLabelFontScale, 1).width);
  }
  const int legend_width = n > 0 ? kPad + kSwatch + 8 + legend_text_width + kPad : 0;
  const int legend_height = n > 0 ? 2 * kPad + n * kLegendRow - (kLegendRow - kSwatch) : 0;

  const int left = 12 + label_height + 10 + max_z_tick_width + 6 + kTickLength;
  const int top = 16 + title_height + 20;
  const int right = n > 0 ? 24 + legend_width + 16 : 24;
  const int bottom = kTickLength + 8 + tick_height + 14 + label_height + 12;
  figure.plot_origin = cv::Point(left, top);
  const int width = std::max(left + figure.plot_size.width + right,
                             TextSize(options.title, kTitleFontScale, 2).width + 32);
  const int height = top + std::max(figure.plot_size.height, legend_height) + bottom;
  figure.image = cv::Mat(height, width, CV_8UC3, kWhite);
  cv::Mat& image = figure.image;
  const cv::Rect plot_rect(figure.plot_origin, figure.plot_size);
  cv::Mat plot = image(plot_rect);  // drawing into the view clips to the plot area

  // Grid.
  for (double a : along_ticks) {
    const int x = cvRound(figure.ToPixel(a, z_lo).x) - left;
    cv::line(plot, {x, 0}, {x, plot.rows - 1}, kGrid, 1, cv::LINE_8);
  }
  for (double z : z_ticks) {
    const int y = cvRound(figure.ToPixel(0, z).y) - top;
    cv::line(plot, {0, y}, {plot.cols - 1, y}, kGrid, 1, cv::LINE_8);
  }

  DrawPoints(layers, options, figure, cv::Point(left, top), plot);

  DrawFrameAndTicks(figure, along_ticks, z_ticks, decimals, tick_height, image);

  DrawLabels(options, figure, tick_height, label_height, title_height, image);

  if (n > 0) {
    DrawLegend(figure.series, legend_texts,
               cv::Rect(left + figure.plot_size.width + 24, top, legend_width, legend_height),
               image);
  }
  return figure;
}

void WriteCrossSectionPng(const std::string& path, const CrossSectionFigure& figure) {
  CROP4D_CHECK(!figure.image.empty());
  std::vector<std::uint8_t> png;
  if (!cv::imencode(".png", figure.image, png)) {
    throw InputError(path, 0, "cannot encode the figure as PNG");
  }
  io::WriteFileAtomic(path, std::string(png.begin(), png.end()));
}

// ---- workspace inputs ---------------------------------------------------------------------

std::vector<std::string> ListWorkspaceSessions(const std::string& workspace) {
  const fs::path folder = workspace::Layout(workspace).SessionsDir();
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw InputError(folder.string(), 0,
                     "the workspace has no sessions/ folder (run crop4d slam first)");
  }
  const std::vector<std::string> sessions = workspace::Layout(workspace).SessionFolders();
  if (sessions.empty()) throw InputError(folder.string(), 0, "no session folder");
  return sessions;
}

std::vector<SessionCloud> LoadSessionClouds(const std::string& workspace,
                                            const std::vector<std::string>& sessions,
                                            std::vector<std::string>* missing) {
  std::vector<SessionCloud> result;
  const workspace::Layout ws(workspace);
  for (const std::string& session : sessions) {
    SessionCloud item;
    item.session = session;
    const fs::path fused = ws.FusedSparse(session);
    std::error_code ec;
    if (fs::is_regular_file(fused, ec)) {
      item.cloud = io::ReadPly(fused.string());
      item.source = fused.string();
      item.files = {fused.string()};
    } else {
      for (const std::string& pass : ws.PassFolders(session)) {
        const fs::path ply = ws.PassLandmarks(session, pass);
        if (fs::is_regular_file(ply, ec)) item.files.push_back(ply.string());
      }
      std::sort(item.files.begin(), item.files.end());
      for (const std::string& file : item.files) {
        io::PlyPointCloud pass = io::ReadPly(file);
        // Union of the passes; colours kept only when every pass has them.
        const bool colors = pass.colors.size() == pass.points.size() &&
                            item.cloud.colors.size() == item.cloud.points.size();
        item.cloud.points.insert(item.cloud.points.end(), pass.points.begin(), pass.points.end());
        if (colors) {
          item.cloud.colors.insert(item.cloud.colors.end(), pass.colors.begin(), pass.colors.end());
        } else {
          item.cloud.colors.clear();
        }
      }
      item.source = ws.PassLandmarks(session, "*").string();
    }
    if (item.files.empty()) {
      if (missing != nullptr) missing->push_back(session);
      continue;
    }
    result.push_back(std::move(item));
  }
  return result;
}

CrossSectionSlice SliceAcrossRow(const io::RowDeclaration& row, const std::optional<double>& y,
                                 double thickness_m, double half_length_m) {
  const Eigen::Vector2d delta = row.end_enu - row.start_enu;
  CROP4D_CHECK(delta.norm() > 0);
  CrossSectionSlice slice;
  slice.thickness_m = thickness_m;
  slice.half_length_m = half_length_m;
  // Perpendicular to the row, pointing east (or, for an east–west row, north).
  const Eigen::Vector2d along_row = delta.normalized();
  slice.direction = Eigen::Vector2d(along_row.y(), -along_row.x());
  if (slice.direction.x() < 0 || (slice.direction.x() == 0 && slice.direction.y() < 0)) {
    slice.direction = -slice.direction;
  }
  if (!y) {
    slice.center = 0.5 * (row.start_enu + row.end_enu);
    return slice;
  }
  if (std::abs(delta.y()) < std::abs(delta.x())) {
    throw InputError(fmt::format(
        "row {} runs closer to east-west than to north-south: it crosses y = {} nowhere in "
        "particular (leave --y out to slice it in its middle)",
        row.index, *y));
  }
  const double t = (*y - row.start_enu.y()) / delta.y();
  if (t < 0 || t > 1) {
    spdlog::warn("y = {:.2f} m is beyond the ends of row {} (y {:.2f} to {:.2f} m)", *y, row.index,
                 row.start_enu.y(), row.end_enu.y());
  }
  slice.center = row.start_enu + t * delta;
  return slice;
}

}  // namespace crop4d::report
