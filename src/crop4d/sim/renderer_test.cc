#include "crop4d/sim/renderer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

namespace crop4d::sim {
namespace {

constexpr Timestamp kDay = 86400LL * 1'000'000'000LL;

WorldOptions SmallField() {
  WorldOptions options;
  options.num_rows = 5;
  options.row_length_m = 16.0;
  options.seed = 11;
  return options;
}

geometry::PinholeRadTan Camera(int width, int height) {
  geometry::PinholeRadTan camera;
  camera.width = width;
  camera.height = height;
  camera.fx = camera.fy = 0.85 * width;
  camera.cx = 0.5 * width - 0.5;
  camera.cy = 0.5 * height - 0.5;
  camera.k1 = -0.12;
  camera.k2 = 0.03;
  camera.p1 = 0.0004;
  camera.p2 = -0.0003;
  return camera;
}

// A camera at `position` looking north (+y), pitched down by `pitch_down_rad`.
geometry::Rigid3 LookingNorth(const Eigen::Vector3d& position, double pitch_down_rad) {
  Eigen::Matrix3d level;  // columns: camera x = east, camera y = down, camera z = north
  level.col(0) = Eigen::Vector3d::UnitX();
  level.col(1) = -Eigen::Vector3d::UnitZ();
  level.col(2) = Eigen::Vector3d::UnitY();
  const Eigen::Matrix3d pitch =
      Eigen::AngleAxisd(-pitch_down_rad, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return geometry::Rigid3(Eigen::Matrix3d(level * pitch), position);
}

// Depth at a sub-pixel position: bilinear when the four neighbours lie on one surface,
// else the nearest pixel.
float SampleDepth(const cv::Mat& depth, const Eigen::Vector2d& pixel) {
  const int u0 = static_cast<int>(std::floor(pixel.x())),
            v0 = static_cast<int>(std::floor(pixel.y()));
  const float a = static_cast<float>(pixel.x() - u0), b = static_cast<float>(pixel.y() - v0);
  const float d00 = depth.at<float>(v0, u0), d10 = depth.at<float>(v0, u0 + 1);
  const float d01 = depth.at<float>(v0 + 1, u0), d11 = depth.at<float>(v0 + 1, u0 + 1);
  const float lo = std::min({d00, d10, d01, d11}), hi = std::max({d00, d10, d01, d11});
  if (lo > 0.0f && hi < 1.05f * lo) {
    return (d00 * (1 - a) + d10 * a) * (1 - b) + (d01 * (1 - a) + d11 * a) * b;
  }
  return depth.at<float>(static_cast<int>(std::lround(pixel.y())),
                         static_cast<int>(std::lround(pixel.x())));
}

// Creates a renderer; skips the test only when no EGL/OpenGL is available at all.
#define MAKE_RENDERER(var, world, options)              \
  std::unique_ptr<Renderer> var;                        \
  try {                                                 \
    var = std::make_unique<Renderer>(world, options);   \
  } catch (const std::runtime_error& e) {               \
    GTEST_SKIP() << "no headless OpenGL: " << e.what(); \
  }

class RendererTest : public ::testing::Test {
 protected:
  RendererTest() : world_(SmallField()) {}

  RenderOptions SmallOptions() const {
    RenderOptions options;
    options.camera = Camera(320, 240);
    options.soil_texture_size = 2048;
    options.shadow_map_size = 1024;
    return options;
  }
  SessionConditions Session(double days) const {
    SessionConditions session;
    session.date = world_.options().sowing_date + static_cast<Timestamp>(days * kDay);
    session.wind_seed = 5;
    return session;
  }
  // Between rows 1 and 2, looking along them.
  geometry::Rigid3 Pose(double y = 3.0) const {
    const double x = 1.5 * world_.options().row_spacing_m;
    return LookingNorth(Eigen::Vector3d(x, y, world_.TerrainHeight(x, y) + 1.5), 35.0 * M_PI / 180);
  }

  World world_;
};

TEST_F(RendererTest, BareSoilHasManySiftKeypoints) {
  RenderOptions options;
  options.camera = Camera(1280, 960);
  MAKE_RENDERER(renderer, world_, options);
  renderer->SetSession(Session(1.0));  // before emergence: bare soil
  cv::Mat bgr;
  renderer->Render(Pose(), &bgr);
  ASSERT_EQ(bgr.type(), CV_8UC3);
  ASSERT_EQ(bgr.cols, 1280);
  ASSERT_EQ(bgr.rows, 960);
  cv::Mat gray;
  cv::cvtColor(bgr, gray, cv::COLOR_BGR2GRAY);
  std::vector<cv::KeyPoint> keypoints;
  cv::SIFT::create()->detect(gray, keypoints);
  EXPECT_GE(keypoints.size(), 1500u);
  // Spread over the image, not only in one corner: every quadrant has many.
  int quadrant[4] = {0, 0, 0, 0};
  for (const cv::KeyPoint& k : keypoints) {
    ++quadrant[(k.pt.x > 640 ? 1 : 0) + (k.pt.y > 480 ? 2 : 0)];
  }
  for (int q : quadrant) EXPECT_GT(q, 150);
}

TEST_F(RendererTest, DeterministicAndDepthConsistent) {
  const RenderOptions options = SmallOptions();
  MAKE_RENDERER(renderer, world_, options);
  renderer->SetSession(Session(60.0));
  cv::Mat bgr1, bgr2, depth1, depth2;
  renderer->Render(Pose(), &bgr1, &depth1);
  renderer->Render(Pose(5.0), &bgr2, &depth2);  // move away and back: nothing cached leaks
  renderer->Render(Pose(), &bgr2, &depth2);
  ASSERT_EQ(bgr1.size(), bgr2.size());
  EXPECT_EQ(cv::norm(bgr1, bgr2, cv::NORM_INF), 0.0);
  EXPECT_EQ(cv::norm(depth1, depth2, cv::NORM_INF), 0.0);
  {
    // A second renderer of the same world gives the same bytes.
    MAKE_RENDERER(other, world_, options);
    other->SetSession(Session(60.0));
    cv::Mat bgr3, depth3;
    other->Render(Pose(), &bgr3, &depth3);
    EXPECT_EQ(cv::norm(bgr1, bgr3, cv::NORM_INF), 0.0);
    EXPECT_EQ(cv::norm(depth1, depth3, cv::NORM_INF), 0.0);
  }

  // Depth: terrain points in the furrows (no plants there) projected with the distorted
  // camera land on pixels whose depth is their camera z.
  const geometry::Rigid3 world_from_camera = Pose();
  const geometry::Rigid3 camera_from_world = world_from_camera.Inverse();
  const geometry::PinholeRadTan& camera = options.camera;
  int checked = 0;
  for (int furrow = 0; furrow < 4; ++furrow) {
    for (double y = 4.0; y <= 8.0; y += 0.5) {
      const double x = (furrow + 0.5) * world_.options().row_spacing_m;
      const Eigen::Vector3d point(x, y, world_.TerrainHeight(x, y));
      const Eigen::Vector3d in_camera = camera_from_world * point;
      Eigen::Vector2d pixel;
      if (!camera.Project(in_camera, &pixel) || !camera.IsInImage(pixel, 2.0)) continue;
      const float d = SampleDepth(depth1, pixel);
      // The pixels around the point may show a leaf in front of the furrow, never something
      // behind it: the nearest of the four is not behind it (the interpolated depth can be, on
      // ground seen at a grazing angle next to a leaf's edge).
      const int u0 = static_cast<int>(std::floor(pixel.x())),
                v0 = static_cast<int>(std::floor(pixel.y()));
      const float nearest4 =
          std::min({depth1.at<float>(v0, u0), depth1.at<float>(v0, u0 + 1),
                    depth1.at<float>(v0 + 1, u0), depth1.at<float>(v0 + 1, u0 + 1)});
      EXPECT_LT(nearest4, in_camera.z() + 0.015) << x << " " << y;
      if (std::abs(d - in_camera.z()) < 0.015) ++checked;
    }
  }
  EXPECT_GT(checked, 12);
  // Plants stand in front of the ground: depth at a near plant's canopy top pixel is at most
  // the distance to its stem base, and not nearer than its canopy can reach — unless another
  // plant stands in front of it (a few at most).
  int plants_checked = 0, plants_in_range = 0;
  for (const Plant& plant : world_.plants()) {
    const PlantState state = world_.StateAt(plant, Session(60.0).date);
    const double z0 = world_.TerrainHeight(plant.xy.x(), plant.xy.y());
    const Eigen::Vector3d top =
        camera_from_world * Eigen::Vector3d(plant.xy.x(), plant.xy.y(), z0 + state.height_m);
    Eigen::Vector2d pixel;
    if (!camera.Project(top, &pixel) || !camera.IsInImage(pixel, 2.0) || top.z() > 6.0) continue;
    // Near the projected canopy top some pixel shows the plant: nearer than the ground
    // behind it, not nearer than the canopy can reach.
    const Eigen::Vector3d base =
        camera_from_world * Eigen::Vector3d(plant.xy.x(), plant.xy.y(), z0);
    float nearest = 1e9f;
    for (int dv = -4; dv <= 4; ++dv) {
      for (int du = -4; du <= 4; ++du) {
        const int v = std::clamp(static_cast<int>(std::lround(pixel.y())) + dv, 0, depth1.rows - 1);
        const int u = std::clamp(static_cast<int>(std::lround(pixel.x())) + du, 0, depth1.cols - 1);
        nearest = std::min(nearest, depth1.at<float>(v, u));
      }
    }
    EXPECT_LT(nearest, base.z() + 0.05);
    plants_in_range += nearest > top.z() - 0.6;
    ++plants_checked;
  }
  EXPECT_GT(plants_checked, 5);
  EXPECT_GE(plants_in_range, 0.9 * plants_checked);
  // Sky has depth 0 and nothing is beyond the far plane.
  double max_depth = 0.0;
  cv::minMaxLoc(depth1, nullptr, &max_depth);
  EXPECT_LT(max_depth, options.max_depth_m + 1e3);
}

TEST_F(RendererTest, PlantsAreGreenAndSkyHasNoDepth) {
  const RenderOptions options = SmallOptions();
  MAKE_RENDERER(renderer, world_, options);
  renderer->SetSession(Session(65.0));
  cv::Mat bgr, depth;
  // Level camera: sky and tree line in the upper half.
  const double x = 1.5 * world_.options().row_spacing_m;
  renderer->Render(LookingNorth(Eigen::Vector3d(x, 2.0, 1.5), 0.0), &bgr, &depth);
  int green = 0, sky = 0, total = bgr.rows * bgr.cols;
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const cv::Vec3b c = bgr.at<cv::Vec3b>(v, u);
      // Excess green 2G − R − B (Woebbecke et al., Trans. ASAE 38(1), 1995).
      if (2 * c[1] - c[2] - c[0] > 25) ++green;
      if (depth.at<float>(v, u) == 0.0f) {
        ++sky;
        EXPECT_LT(v, bgr.rows / 2);  // the sky is above the horizon
        EXPECT_GT(c[0], c[2]);       // and bluish
      }
    }
  }
  EXPECT_GT(green, total / 10);
  EXPECT_GT(sky, total / 50);

  // Before emergence there is no green at all.
  renderer->SetSession(Session(2.0));
  renderer->Render(Pose(), &bgr, &depth);
  int bare_green = 0;
  for (int v = 0; v < bgr.rows; ++v) {
    for (int u = 0; u < bgr.cols; ++u) {
      const cv::Vec3b c = bgr.at<cv::Vec3b>(v, u);
      if (2 * c[1] - c[2] - c[0] > 25) ++bare_green;
    }
  }
  EXPECT_LT(bare_green, total / 200);
}

TEST_F(RendererTest, WeedsStandOnTheSoilWhereTheWorldPutsThem) {
  WorldOptions weedy_options = SmallField();
  weedy_options.weeds.density_per_m2 = 4.0;
  const World weedy(weedy_options);
  const RenderOptions options = SmallOptions();
  MAKE_RENDERER(clean_renderer, world_, options);
  MAKE_RENDERER(weedy_renderer, weedy, options);
  const SessionConditions session = Session(40.0);
  clean_renderer->SetSession(session);
  weedy_renderer->SetSession(session);
  cv::Mat clean_bgr, clean_depth, weedy_bgr, weedy_depth;
  clean_renderer->Render(Pose(), &clean_bgr, &clean_depth);
  weedy_renderer->Render(Pose(), &weedy_bgr, &weedy_depth);

  // The pixels whose depth came nearer show a weed that has emerged: they lie in the image box
  // of one (its circle of leaves on the ground and its top, projected; 2 px wider for the
  // depth map's interpolation). Across a depth edge the depth map takes the nearest pixel of
  // its remap, so a few pixels beside a weed may move slightly farther.
  const geometry::Rigid3 camera_from_world = Pose().Inverse();
  const geometry::PinholeRadTan& camera = options.camera;
  std::vector<cv::Rect2d> boxes;
  for (const Weed& weed : weedy.weeds()) {
    const PlantState state = weedy.WeedStateAt(weed, session.date);
    if (!state.emerged) continue;
    double u0 = 1e9, v0 = 1e9, u1 = -1e9, v1 = -1e9;
    for (int k = 0; k <= 16; ++k) {
      const double a = 2.0 * M_PI * k / 16;
      Eigen::Vector2d xy =
          weed.xy + state.canopy_radius_m * Eigen::Vector2d(std::cos(a), std::sin(a));
      double z = weedy.TerrainHeight(xy.x(), xy.y());
      if (k == 16) {
        xy = weed.xy;
        z += state.height_m;
      }
      Eigen::Vector2d pixel;
      if (!camera.Project(camera_from_world * Eigen::Vector3d(xy.x(), xy.y(), z), &pixel)) continue;
      u0 = std::min(u0, pixel.x());
      v0 = std::min(v0, pixel.y());
      u1 = std::max(u1, pixel.x());
      v1 = std::max(v1, pixel.y());
    }
    if (u1 >= u0) boxes.emplace_back(u0 - 2.0, v0 - 2.0, u1 - u0 + 4.0, v1 - v0 + 4.0);
  }
  int changed = 0, nearer = 0, on_weed = 0;
  for (int v = 0; v < clean_depth.rows; ++v) {
    for (int u = 0; u < clean_depth.cols; ++u) {
      const float dc = clean_depth.at<float>(v, u), dw = weedy_depth.at<float>(v, u);
      if (std::abs(dc - dw) < 0.005f) continue;
      ++changed;
      if (dw > dc) continue;
      ++nearer;
      for (const cv::Rect2d& box : boxes) {
        if (box.contains(cv::Point2d(u, v))) {
          ++on_weed;
          break;
        }
      }
    }
  }
  EXPECT_GT(nearer, 100);
  EXPECT_GE(nearer, 0.85 * changed);
  EXPECT_GE(on_weed, 0.98 * nearer);
}

TEST_F(RendererTest, PlantsCastShadowsOnTheSoil) {
  RenderOptions options = SmallOptions();
  MAKE_RENDERER(with_shadows, world_, options);
  options.shadows = false;
  MAKE_RENDERER(without_shadows, world_, options);
  SessionConditions session = Session(70.0);
  session.sun_elevation_rad = 0.6;
  session.sun_azimuth_rad = 1.6;  // from the east: shadows fall west of the rows
  with_shadows->SetSession(session);
  without_shadows->SetSession(session);
  cv::Mat lit, unlit, depth;
  with_shadows->Render(Pose(), &lit, &depth);
  without_shadows->Render(Pose(), &unlit);
  cv::Mat gray_lit, gray_unlit;
  cv::cvtColor(lit, gray_lit, cv::COLOR_BGR2GRAY);
  cv::cvtColor(unlit, gray_unlit, cv::COLOR_BGR2GRAY);
  int darker = 0, brighter = 0;
  for (int v = 0; v < lit.rows; ++v) {
    for (int u = 0; u < lit.cols; ++u) {
      const int a = gray_lit.at<uchar>(v, u), b = gray_unlit.at<uchar>(v, u);
      if (a < 0.75 * b) ++darker;
      if (a > b + 2) ++brighter;
    }
  }
  // Shadows only darken, and they cover a good part of the view.
  EXPECT_GT(darker, lit.rows * lit.cols / 20);
  EXPECT_EQ(brighter, 0);
}

TEST_F(RendererTest, RainChangesTheSoilButNotTheGeometry) {
  const RenderOptions options = SmallOptions();
  MAKE_RENDERER(renderer, world_, options);
  SessionConditions before = Session(1.0);  // both before the first plant emerges
  SessionConditions after = Session(2.0);
  after.rain_before = true;
  after.soil_epoch = 1;
  cv::Mat bgr_before, bgr_after, depth_before, depth_after;
  renderer->SetSession(before);
  renderer->Render(Pose(), &bgr_before, &depth_before);
  renderer->SetSession(after);
  renderer->Render(Pose(), &bgr_after, &depth_after);
  EXPECT_EQ(cv::norm(depth_before, depth_after, cv::NORM_INF), 0.0);
  cv::Mat gray_before, gray_after;
  cv::cvtColor(bgr_before, gray_before, cv::COLOR_BGR2GRAY);
  cv::cvtColor(bgr_after, gray_after, cv::COLOR_BGR2GRAY);
  // Different texture, not only darker: compare after removing the mean brightness.
  const double mean_before = cv::mean(gray_before)[0], mean_after = cv::mean(gray_after)[0];
  EXPECT_LT(mean_after, mean_before);  // wet soil is darker
  cv::Mat a, b;
  gray_before.convertTo(a, CV_32F, 1.0 / mean_before);
  gray_after.convertTo(b, CV_32F, 1.0 / mean_after);
  cv::Mat diff = cv::abs(a - b);
  EXPECT_GT(cv::mean(diff)[0], 0.1);
  // The fine texture is decorrelated.
  cv::Mat corr;
  cv::matchTemplate(a, b, corr, cv::TM_CCOEFF_NORMED);
  EXPECT_LT(corr.at<float>(0, 0), 0.5);
}

TEST_F(RendererTest, LeavesSwayInTheWindAndNothingElseMoves) {
  const RenderOptions options = SmallOptions();
  MAKE_RENDERER(renderer, world_, options);
  const geometry::Rigid3 pose = Pose();
  // A pixel sees a plant when its surface point lies clearly above the terrain.
  auto plant = [&](const cv::Mat& depth, int r, int c) {
    Eigen::Vector3d ray;
    const float z = depth.at<float>(r, c);
    if (z <= 0.0f || !options.camera.Unproject(Eigen::Vector2d(c, r), &ray)) return false;
    const Eigen::Vector3d p = pose * Eigen::Vector3d(ray * (z / ray.z()));
    return p.z() - world_.TerrainHeight(p.x(), p.y()) > 0.01;
  };
  auto render = [&](double sway_m, double t, cv::Mat* bgr, cv::Mat* depth) {
    SessionConditions session = Session(60.0);
    session.wind_sway_m = sway_m;
    renderer->SetSession(session);
    renderer->SetTime(t);
    renderer->Render(pose, bgr, depth);
  };
  // Still air: time changes nothing.
  cv::Mat a, b, da, db;
  render(0.0, 0.0, &a, &da);
  render(0.0, 0.7, &b, &db);
  EXPECT_EQ(cv::norm(a, b, cv::NORM_INF), 0.0);
  // A breeze moves the leaves between two frames, and only them: every pixel whose depth
  // changes sees a plant in one of the frames; the change grows with the amplitude.
  double previous_change = 0.0;
  for (const double sway : {0.005, 0.02}) {
    render(sway, 0.0, &a, &da);
    render(sway, 0.7, &b, &db);
    // Plant pixels in either frame, grown by 2 px (the depth at a leaf's edge is resolved
    // from the multisampled image and mixes leaf and soil).
    cv::Mat plant_mask(da.size(), CV_8U, cv::Scalar(0));
    for (int r = 0; r < da.rows; ++r) {
      for (int c = 0; c < da.cols; ++c) {
        plant_mask.at<std::uint8_t>(r, c) = plant(da, r, c) || plant(db, r, c) ? 255 : 0;
      }
    }
    const int plant_pixels = cv::countNonZero(plant_mask);
    cv::dilate(plant_mask, plant_mask, cv::Mat::ones(5, 5, CV_8U));
    int changed = 0, changed_soil = 0;
    for (int r = 0; r < da.rows; ++r) {
      for (int c = 0; c < da.cols; ++c) {
        if (da.at<float>(r, c) != db.at<float>(r, c)) {
          ++changed;
          changed_soil += plant_mask.at<std::uint8_t>(r, c) == 0;
        }
      }
    }
    ASSERT_GT(plant_pixels, 1000);
    EXPECT_GT(changed, 0) << sway;
    // (Allowing for the few leaf tips that hang within 1 cm of the soil.)
    EXPECT_LE(changed_soil, changed / 200) << sway << ": " << changed;
    const double change = cv::norm(a, b, cv::NORM_L1) / (a.total() * 3);
    EXPECT_GT(change, previous_change) << sway;
    previous_change = change;
  }
}

TEST(RenderOptionsTest, Check) {
  RenderOptions options;
  EXPECT_NE(options.Check(), "");  // no camera
  options.camera = Camera(64, 48);
  EXPECT_EQ(options.Check(), "");
  options.soil_texture_size = 1000;  // not a power of two
  EXPECT_NE(options.Check(), "");
}

}  // namespace
}  // namespace crop4d::sim
