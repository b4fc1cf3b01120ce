#pragma once

// The paper's cross-section figure (Dong et al., IROS 2017): a thin vertical slice across a crop
// row, with the points of several sessions drawn in one colour per session, so that the growth of
// the plants over the season shows as nested profiles on one common ground.
//
// Slice coordinates: a slice is a vertical band of `thickness_m` around the segment
// centre ± half_length · direction (xy of the field's ENU frame). A world point p has
//   along  = (p.xy − centre) · direction           (horizontal axis of the figure, metres)
//   across = (p.xy − centre) · left(direction)      (|across| ≤ thickness / 2 to be in the slice)
// and its height p.z on the vertical axis. Both axes share one scale (equal aspect ratio).
//
//   CrossSectionOptions options;
//   options.slice.center = {12.3, 5.0};            // on row 3, halfway along it
//   options.slice.direction = {1, 0};              // east–west, across a north–south row
//   CrossSectionFigure figure = DrawCrossSection(clouds, {"2016-06-01", "2016-06-10"}, options);
//   WriteCrossSectionPng("section.png", figure);
//
// `crop4d section` (cli/section_command.cc) finds the clouds of a workspace and the slice of a
// row of field.yaml with the functions at the end of this file.

#include <Eigen/Core>
#include <limits>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/option_check.h"
#include "crop4d/io/dataset.h"
#include "crop4d/io/ply.h"

namespace crop4d::report {

struct CrossSectionSlice {
  // A point of the slice's centre line, ENU x (east), y (north), metres.
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  // Direction of the horizontal axis of the figure in the xy plane; normalised when used.
  Eigen::Vector2d direction = Eigen::Vector2d::UnitX();
  // Full width of the band across the slice, metres.
  double thickness_m = 0.1;
  // The slice runs from −half_length_m to +half_length_m along `direction`.
  double half_length_m = 1.5;

  // Finite centre, non-zero finite direction, thickness and half-length > 0.
  OptionCheck Check() const;
};

// The (along, z) coordinates of the points of `cloud` that lie in `slice`, in cloud order.
std::vector<Eigen::Vector2d> PointsInSlice(const io::PlyPointCloud& cloud,
                                           const CrossSectionSlice& slice);

struct CrossSectionOptions {
  CrossSectionSlice slice;
  // Title above the plot.
  std::string title = "Cross-section";
  // Label of the horizontal axis.
  std::string along_label = "position along the slice [m]";
  // Label of the vertical axis.
  std::string height_label = "height z [m]";
  // Width of the plot area in pixels for the whole slice length (narrower when the height range
  // needs more than max_plot_height_px at this scale: the aspect ratio stays equal).
  int plot_width_px = 1200;
  // The plot area is at least this tall (the height range grows about its middle to fill it)
  // and at most max_plot_height_px.
  int min_plot_height_px = 300;
  int max_plot_height_px = 900;
  // Height range of the plot, metres (grown to min_plot_height_px when it is smaller); NaN: from
  // the points in the slice, with a margin. Give both to compare figures with one another.
  double z_min = std::numeric_limits<double>::quiet_NaN();
  double z_max = std::numeric_limits<double>::quiet_NaN();
  // Radius of the filled disc drawn for each point, pixels (0: one pixel).
  int point_radius_px = 2;

  OptionCheck Check() const;
};

// One session's layer of the figure.
struct CrossSectionSeries {
  std::string label;
  cv::Vec3b color_bgr;  // the colour of its points and legend entry
  int num_points = 0;   // points of the cloud in the slice
};

struct CrossSectionFigure {
  cv::Mat image;                           // CV_8UC3, BGR, white background
  std::vector<CrossSectionSeries> series;  // one per input cloud, in input order
  int num_points = 0;                      // in the slice, all clouds together

  // Plot area on the image and the map from slice coordinates to pixels:
  //   pixel = plot_origin + pixels_per_metre · (along − along_min, z_max − z).
  cv::Point plot_origin;  // top-left pixel of the plot area
  cv::Size plot_size;
  double pixels_per_metre = 0.0;
  double along_min = 0.0;
  double z_min = 0.0, z_max = 0.0;

  // Pixel position (column, row) of slice coordinates (along, z), metres.
  cv::Point2d ToPixel(double along_m, double z_m) const;
};

// The colour of session `index` of `count` on a sequential colormap (viridis, from dark violet
// for the earliest through blue and green to yellow-green for the latest; the palest yellow end
// is left out so that every colour shows on white).
cv::Vec3b SessionColor(int index, int count);

// Draws the figure: the points of clouds[i] in the slice in SessionColor(i, n), labelled
// labels[i] (sizes must match: CHECK; clouds in time order, earliest first). Horizontal axis:
// along the slice, vertical: height, equal aspect ratio, ticks at 1, 2 or 5 × 10^k m with a
// light grid, axis labels, a legend (label and point count of each session) and the title.
// Later sessions are drawn first, so the earliest lies on top: the small early plants stay
// visible inside the later, larger profiles. Without any point in the slice (or without clouds)
// the axes are drawn with a "no points in the slice" note. Deterministic: the same input gives
// the same pixels. `options` must pass Check() (CHECK).
CrossSectionFigure DrawCrossSection(const std::vector<io::PlyPointCloud>& clouds,
                                    const std::vector<std::string>& labels,
                                    const CrossSectionOptions& options);

// Encodes the figure as PNG and writes it atomically (io/atomic_file.h). Throws InputError when
// the file cannot be written.
void WriteCrossSectionPng(const std::string& path, const CrossSectionFigure& figure);

// ---- workspace inputs (crop4d section) ------------------------------------------------------

// A session's cloud as found in a workspace.
struct SessionCloud {
  std::string session;
  io::PlyPointCloud cloud;
  // What was read: "WS/fused/<s>/sparse.ply", or the row SLAM clouds
  // "WS/sessions/<s>/rows/*/landmarks.ply" (see `files`).
  std::string source;
  std::vector<std::string> files;
};

// The session folders of WS/sessions, sorted by name (date names sort in time order). Throws
// InputError when WS/sessions does not exist or holds no session.
std::vector<std::string> ListWorkspaceSessions(const std::string& workspace);

// The cloud of each of `sessions` (in that order): WS/fused/<s>/sparse.ply when it exists
// (the 4D fusion's output, one frame for all sessions), else the union of the row SLAM clouds
// WS/sessions/<s>/rows/*/landmarks.ply (passes in name order). A session with neither is left
// out and named in `missing` (if not null). Throws InputError for a cloud that cannot be read.
std::vector<SessionCloud> LoadSessionClouds(const std::string& workspace,
                                            const std::vector<std::string>& sessions,
                                            std::vector<std::string>* missing = nullptr);

// The slice across `row` (a row of field.yaml): perpendicular to the row in the xy plane
// (direction with a non-negative east component: east for a north–south row), centred on the
// row where it crosses north y = *y, or at the row's middle when y is empty. Throws InputError
// when y is given and the row runs closer to east–west than to north–south (it does not cross
// a given y at one point).
CrossSectionSlice SliceAcrossRow(const io::RowDeclaration& row, const std::optional<double>& y,
                                 double thickness_m, double half_length_m);

}  // namespace crop4d::report
