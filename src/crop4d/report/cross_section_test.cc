#include "crop4d/report/cross_section.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "crop4d/core/error.h"
#include "crop4d/io/ply.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::report {
namespace {

// A flat patch of ground at height z: points every 5 mm along x in [x0, x1], with y in
// [y0, y1] every 1 cm.
io::PlyPointCloud FlatPatch(double x0, double x1, double y0, double y1, double z) {
  io::PlyPointCloud cloud;
  for (double x = x0; x <= x1 + 1e-9; x += 0.005) {
    for (double y = y0; y <= y1 + 1e-9; y += 0.01) cloud.points.emplace_back(x, y, z);
  }
  return cloud;
}

void Append(io::PlyPointCloud* cloud, const io::PlyPointCloud& more) {
  cloud->points.insert(cloud->points.end(), more.points.begin(), more.points.end());
}

// The slice of the tests: centred at (10, 5), east–west, 0.1 m thick, 1.5 m each side.
CrossSectionOptions TestOptions() {
  CrossSectionOptions options;
  options.slice.center = {10.0, 5.0};
  options.slice.direction = {1.0, 0.0};
  options.slice.thickness_m = 0.1;
  options.slice.half_length_m = 1.5;
  options.title = "test";
  return options;
}

cv::Vec3b PixelAt(const CrossSectionFigure& figure, double along, double z) {
  const cv::Point2d p = figure.ToPixel(along, z);
  return figure.image.at<cv::Vec3b>(cvRound(p.y), cvRound(p.x));
}

// Number of pixels of `color` inside the plot area.
int CountColor(const CrossSectionFigure& figure, const cv::Vec3b& color) {
  cv::Mat mask;
  cv::inRange(figure.image(cv::Rect(figure.plot_origin, figure.plot_size)), color, color, mask);
  return cv::countNonZero(mask);
}

TEST(CrossSectionTest, PointsInSliceUsesAlongAndAcrossCoordinates) {
  CrossSectionSlice slice;
  slice.center = {1.0, 2.0};
  slice.direction = {0.0, 2.0};  // north; normalised
  slice.thickness_m = 0.2;
  slice.half_length_m = 1.0;
  io::PlyPointCloud cloud;
  cloud.points = {{1.05, 2.5, 0.3},   // along 0.5, across −0.05: in
                  {0.91, 1.2, -0.1},  // along −0.8, across 0.09: in
                  {1.15, 2.0, 0.0},   // across −0.15: out
                  {1.0, 3.2, 0.0},    // along 1.2: out
                  {1.0, 2.0, NAN}};   // not finite: out
  const std::vector<Eigen::Vector2d> points = PointsInSlice(cloud, slice);
  ASSERT_EQ(points.size(), 2u);
  EXPECT_NEAR(points[0].x(), 0.5, 1e-12);
  EXPECT_EQ(points[0].y(), 0.3);
  EXPECT_NEAR(points[1].x(), -0.8, 1e-12);
  EXPECT_EQ(points[1].y(), -0.1);
}

TEST(CrossSectionTest, EachSessionIsDrawnInItsColourWhereItsPointsAre) {
  // Session A: ground at z = 0; session B: ground at z = 0.1, both across the whole slice.
  // A also has points outside the slice: 0.2 m north of it at z = 0.05, and beyond its end.
  io::PlyPointCloud a = FlatPatch(8.6, 11.4, 4.97, 5.03, 0.0);
  Append(&a, FlatPatch(8.6, 11.4, 5.18, 5.22, 0.05));
  Append(&a, FlatPatch(11.6, 12.0, 4.99, 5.01, 0.05));
  const io::PlyPointCloud b = FlatPatch(8.6, 11.4, 4.97, 5.03, 0.1);
  const std::vector<std::string> labels = {"2016-06-01", "2016-06-10"};
  const CrossSectionFigure figure = DrawCrossSection({a, b}, labels, TestOptions());

  ASSERT_EQ(figure.series.size(), 2u);
  EXPECT_EQ(figure.series[0].label, "2016-06-01");
  const int per_session = static_cast<int>(b.points.size());
  EXPECT_EQ(figure.series[0].num_points, per_session);  // the outside points are not counted
  EXPECT_EQ(figure.series[1].num_points, per_session);
  EXPECT_EQ(figure.num_points, 2 * per_session);
  const cv::Vec3b color_a = figure.series[0].color_bgr, color_b = figure.series[1].color_bgr;
  EXPECT_EQ(color_a, SessionColor(0, 2));
  EXPECT_EQ(color_b, SessionColor(1, 2));
  EXPECT_NE(color_a, color_b);

  // Equal aspect ratio: 1 m is as many pixels across as up; the slice fills the plot width.
  const cv::Point2d origin = figure.ToPixel(0, 0);
  EXPECT_NEAR(figure.ToPixel(1, 0).x - origin.x, origin.y - figure.ToPixel(0, 1).y, 1e-9);
  EXPECT_NEAR(figure.plot_size.width, 3.0 * figure.pixels_per_metre, 1.0);
  EXPECT_LE(figure.z_min, 0.0);
  EXPECT_GE(figure.z_max, 0.1);

  for (double along : {-1.2, -0.5, 0.0, 0.33, 1.4}) {
    EXPECT_EQ(PixelAt(figure, along, 0.0), color_a) << along;
    EXPECT_EQ(PixelAt(figure, along, 0.1), color_b) << along;
    // The points outside the slice (z = 0.05) are not drawn.
    const cv::Vec3b between = PixelAt(figure, along, 0.05);
    EXPECT_NE(between, color_a) << along;
    EXPECT_NE(between, color_b) << along;
  }
  // Every pixel of A's colour in the plot is within the point radius of z = 0, B's of z = 0.1.
  const cv::Mat plot = figure.image(cv::Rect(figure.plot_origin, figure.plot_size));
  for (int r = 0; r < plot.rows; ++r) {
    for (int c = 0; c < plot.cols; ++c) {
      const cv::Vec3b v = plot.at<cv::Vec3b>(r, c);
      const double z = figure.z_max - r / figure.pixels_per_metre;
      if (v == color_a) {
        ASSERT_LT(std::abs(z - 0.0) * figure.pixels_per_metre, 3.5) << r;
      }
      if (v == color_b) {
        ASSERT_LT(std::abs(z - 0.1) * figure.pixels_per_metre, 3.5) << r;
      }
    }
  }
  // Both colours are in the legend too (outside the plot area).
  cv::Mat mask;
  cv::inRange(figure.image, color_a, color_a, mask);
  EXPECT_GT(cv::countNonZero(mask), CountColor(figure, color_a));
}

TEST(CrossSectionTest, EarliestSessionIsOnTopWhereSessionsOverlap) {
  const io::PlyPointCloud ground = FlatPatch(9.0, 11.0, 4.99, 5.01, 0.02);
  const CrossSectionFigure figure =
      DrawCrossSection({ground, ground, ground}, {"a", "b", "c"}, TestOptions());
  EXPECT_EQ(PixelAt(figure, 0.2, 0.02), figure.series[0].color_bgr);
  EXPECT_EQ(CountColor(figure, figure.series[1].color_bgr), 0);
  EXPECT_EQ(CountColor(figure, figure.series[2].color_bgr), 0);
}

TEST(CrossSectionTest, FixedHeightRangeAndTallProfilesKeepEqualAspect) {
  CrossSectionOptions options = TestOptions();
  options.z_min = -0.5;
  options.z_max = 2.5;  // 3 m high: 1200 px at the width's scale, more than 900
  const CrossSectionFigure figure =
      DrawCrossSection({FlatPatch(9.0, 11.0, 5.0, 5.0, 1.0)}, {"a"}, options);
  EXPECT_EQ(figure.plot_size.height, 900);
  EXPECT_EQ(figure.plot_size.width, 900);
  EXPECT_DOUBLE_EQ(figure.z_min, -0.5);
  EXPECT_DOUBLE_EQ(figure.z_max, 2.5);
  EXPECT_EQ(PixelAt(figure, 0.0, 1.0), figure.series[0].color_bgr);
}

TEST(CrossSectionTest, EmptyInputStillMakesAFigure) {
  // No cloud at all.
  const CrossSectionFigure none = DrawCrossSection({}, {}, TestOptions());
  EXPECT_FALSE(none.image.empty());
  EXPECT_EQ(none.num_points, 0);
  EXPECT_TRUE(none.series.empty());
  // Clouds with no point in the slice: the legend lists them with 0 points, the plot is empty
  // of their colours.
  const io::PlyPointCloud far = FlatPatch(20.0, 21.0, 5.0, 5.0, 0.0);
  const CrossSectionFigure empty =
      DrawCrossSection({far, io::PlyPointCloud()}, {"a", "b"}, TestOptions());
  EXPECT_EQ(empty.num_points, 0);
  ASSERT_EQ(empty.series.size(), 2u);
  EXPECT_EQ(empty.series[0].num_points, 0);
  EXPECT_EQ(CountColor(empty, empty.series[0].color_bgr), 0);
  EXPECT_EQ(CountColor(empty, empty.series[1].color_bgr), 0);
  // The "no points" note is drawn in the plot (gray text pixels).
  cv::Mat gray;
  cv::cvtColor(empty.image(cv::Rect(empty.plot_origin, empty.plot_size)), gray, cv::COLOR_BGR2GRAY);
  cv::Mat dark;
  cv::threshold(gray, dark, 200, 255, cv::THRESH_BINARY_INV);
  EXPECT_GT(cv::countNonZero(dark), 50);
}

TEST(CrossSectionTest, SessionColorsRunAlongASequentialColormap) {
  // Viridis gets lighter from the earliest to the latest session.
  int previous = -1;
  for (int i = 0; i < 5; ++i) {
    const cv::Vec3b c = SessionColor(i, 5);
    const int luma = 299 * c[2] + 587 * c[1] + 114 * c[0];
    EXPECT_GT(luma, previous) << i;
    previous = luma;
  }
  EXPECT_EQ(SessionColor(0, 1), SessionColor(0, 7));
}

TEST(CrossSectionTest, PngIsDeterministicAndReadable) {
  io::testing::TempDir dir;
  const io::PlyPointCloud a = FlatPatch(8.5, 11.5, 4.97, 5.03, 0.0);
  const io::PlyPointCloud b = FlatPatch(9.0, 10.0, 4.97, 5.03, 0.3);
  const CrossSectionFigure first = DrawCrossSection({a, b}, {"a", "b"}, TestOptions());
  const CrossSectionFigure second = DrawCrossSection({a, b}, {"a", "b"}, TestOptions());
  WriteCrossSectionPng(dir / "one.png", first);
  WriteCrossSectionPng(dir / "sub/two.png", second);
  EXPECT_EQ(io::testing::ReadText(dir / "one.png"), io::testing::ReadText(dir / "sub/two.png"));
  const cv::Mat back = cv::imread(dir / "one.png", cv::IMREAD_COLOR);
  ASSERT_FALSE(back.empty());
  EXPECT_EQ(cv::norm(back, first.image, cv::NORM_INF), 0.0);
}

// ---- workspace inputs ---------------------------------------------------------------------

TEST(CrossSectionTest, LoadsFusedCloudsOrTheUnionOfRowClouds) {
  io::testing::TempDir ws;
  for (const char* s : {"2016-06-10", "2016-06-01", "2016-06-20"}) {
    std::filesystem::create_directories(ws / (std::string("sessions/") + s));
  }
  io::WritePly(ws / "sessions/2016-06-01/rows/row00/landmarks.ply", FlatPatch(0, 0.1, 0, 0, 0));
  io::WritePly(ws / "sessions/2016-06-01/rows/row01/landmarks.ply", FlatPatch(1, 1.2, 0, 0, 0));
  io::WritePly(ws / "sessions/2016-06-10/rows/row00/landmarks.ply", FlatPatch(0, 1, 0, 0, 0));
  io::WritePly(ws / "fused/2016-06-10/sparse.ply", FlatPatch(0, 0.05, 0, 0, 0.5));

  const std::vector<std::string> sessions = ListWorkspaceSessions(ws.path());
  EXPECT_EQ(sessions, (std::vector<std::string>{"2016-06-01", "2016-06-10", "2016-06-20"}));
  std::vector<std::string> missing;
  const std::vector<SessionCloud> clouds = LoadSessionClouds(ws.path(), sessions, &missing);
  ASSERT_EQ(clouds.size(), 2u);
  EXPECT_EQ(clouds[0].session, "2016-06-01");
  EXPECT_EQ(clouds[0].files.size(), 2u);
  EXPECT_EQ(clouds[0].cloud.size(), 21u + 41u);
  EXPECT_NE(clouds[0].source.find("rows/*/landmarks.ply"), std::string::npos);
  EXPECT_EQ(clouds[1].session, "2016-06-10");
  EXPECT_EQ(clouds[1].source, ws / "fused/2016-06-10/sparse.ply");
  EXPECT_EQ(clouds[1].cloud.size(), 11u);
  EXPECT_EQ(missing, std::vector<std::string>{"2016-06-20"});

  io::testing::TempDir empty;
  EXPECT_THROW(ListWorkspaceSessions(empty.path()), InputError);
  io::testing::WriteText(ws / "sessions/2016-06-20/rows/row00/landmarks.ply", "not a ply\n");
  EXPECT_THROW(LoadSessionClouds(ws.path(), {"2016-06-20"}), InputError);
}

TEST(CrossSectionTest, SliceAcrossARow) {
  io::RowDeclaration row;
  row.index = 3;
  row.start_enu = {2.7, 0.0};
  row.end_enu = {2.7, 30.0};
  CrossSectionSlice slice = SliceAcrossRow(row, std::nullopt, 0.1, 1.5);
  EXPECT_EQ(slice.center, Eigen::Vector2d(2.7, 15.0));
  EXPECT_LT((slice.direction - Eigen::Vector2d(1, 0)).norm(), 1e-12);
  EXPECT_EQ(slice.thickness_m, 0.1);
  EXPECT_EQ(slice.half_length_m, 1.5);
  // Driven the other way: still pointing east.
  std::swap(row.start_enu, row.end_enu);
  slice = SliceAcrossRow(row, 12.0, 0.1, 1.5);
  EXPECT_LT((slice.center - Eigen::Vector2d(2.7, 12.0)).norm(), 1e-12);
  EXPECT_LT((slice.direction - Eigen::Vector2d(1, 0)).norm(), 1e-12);
  // A slanted row: the slice is perpendicular to it, centred where it crosses y.
  row.start_enu = {0.0, 0.0};
  row.end_enu = {3.0, 30.0};
  slice = SliceAcrossRow(row, 10.0, 0.1, 1.5);
  EXPECT_LT((slice.center - Eigen::Vector2d(1.0, 10.0)).norm(), 1e-12);
  EXPECT_NEAR(slice.direction.normalized().dot(Eigen::Vector2d(3, 30).normalized()), 0.0, 1e-12);
  EXPECT_GT(slice.direction.x(), 0.0);
  // An east–west row does not cross a given y at one point.
  row.end_enu = {30.0, 1.0};
  EXPECT_THROW(SliceAcrossRow(row, 10.0, 0.1, 1.5), InputError);
  EXPECT_NO_THROW(SliceAcrossRow(row, std::nullopt, 0.1, 1.5));
}

}  // namespace
}  // namespace crop4d::report
