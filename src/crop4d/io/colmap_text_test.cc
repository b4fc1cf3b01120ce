#include "crop4d/io/colmap_text.h"

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <random>
#include <sstream>

#include "crop4d/core/error.h"
#include "crop4d/geometry/rotation.h"
#include "crop4d/io/test_helpers.h"

namespace crop4d::io {
namespace {

geometry::PinholeRadTan TestCamera(double k3) {
  geometry::PinholeRadTan c;
  c.width = 1280;
  c.height = 960;
  c.fx = 1105.25;
  c.fy = 1101.5;
  c.cx = 641.3;
  c.cy = 478.9;
  c.k1 = -0.12;
  c.k2 = 0.031;
  c.p1 = 1.5e-4;
  c.p2 = -2e-4;
  c.k3 = k3;
  return c;
}

// Two cameras (OPENCV and FULL_OPENCV), three images, three 3D points: point 7 seen by images
// 1, 2 and 3, point 9 by images 1 and 3, point 12 by image 2; image 3 has an unmatched 2D point.
ColmapModel TestModel() {
  ColmapModel model;
  model.cameras = {{1, TestCamera(0.0)}, {4, TestCamera(0.0021)}};
  auto image = [](std::uint32_t id, std::uint32_t camera, const std::string& name, double angle) {
    ColmapImage im;
    im.image_id = id;
    im.camera_id = camera;
    im.name = name;
    im.world_from_camera =
        geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(3.0 - angle, 0.1 * angle, 0.2)),
                         Eigen::Vector3d(12.5 + angle, -3.25, 1.3));
    return im;
  };
  model.images = {image(1, 1, "2016-06-01/row03/1464792748146793805.png", 0.1),
                  image(2, 1, "2016-06-01/row03/1464792748280127138.png", 0.2),
                  image(3, 4, "2016-06-10/row03/1465570000000000000.png", 0.3)};
  model.images[0].points2d = {{{100.25, 200.125}, 7}, {{333.3, 444.4}, 9}};
  model.images[1].points2d = {{{12.0, 13.0}, 12}, {{101.5, 201.75}, 7}};
  model.images[2].points2d = {{{0.0, 0.0}, -1}, {{-0.4, 959.4}, 9}, {{1e-3, 5.5}, 7}};
  model.points = {
      {7, {12.6, -2.5, 0.05}, {10, 200, 30}, 0.41, {{1, 0}, {2, 1}, {3, 2}}},
      {9, {13.1, -2.75, 0.31}, {255, 0, 128}, 1.25, {{3, 1}, {1, 1}}},
      {12, {1e-7, 1e6, -0.5}, {0, 0, 0}, 0.0, {{2, 0}}},
  };
  return model;
}

TEST(ColmapTextTest, RoundTripIsExact) {
  testing::TempDir dir;
  const ColmapModel model = TestModel();
  std::string why;
  ASSERT_TRUE(model.Check(&why)) << why;
  WriteColmapText(dir / "fused/colmap", model);
  const ColmapModel back = ReadColmapText(dir / "fused/colmap");

  ASSERT_EQ(back.cameras.size(), model.cameras.size());
  for (std::size_t i = 0; i < model.cameras.size(); ++i) {
    const geometry::PinholeRadTan &a = model.cameras[i].intrinsics, &b = back.cameras[i].intrinsics;
    EXPECT_EQ(back.cameras[i].camera_id, model.cameras[i].camera_id);
    EXPECT_EQ(b.width, a.width);
    EXPECT_EQ(b.height, a.height);
    EXPECT_EQ(b.fx, a.fx);
    EXPECT_EQ(b.fy, a.fy);
    EXPECT_NEAR(b.cx, a.cx, 1e-12);
    EXPECT_NEAR(b.cy, a.cy, 1e-12);
    EXPECT_EQ(b.k1, a.k1);
    EXPECT_EQ(b.k2, a.k2);
    EXPECT_EQ(b.p1, a.p1);
    EXPECT_EQ(b.p2, a.p2);
    EXPECT_EQ(b.k3, a.k3);
  }
  ASSERT_EQ(back.images.size(), model.images.size());
  for (std::size_t i = 0; i < model.images.size(); ++i) {
    const ColmapImage &a = model.images[i], &b = back.images[i];
    EXPECT_EQ(b.image_id, a.image_id);
    EXPECT_EQ(b.camera_id, a.camera_id);
    EXPECT_EQ(b.name, a.name);
    EXPECT_LT((b.world_from_camera.translation() - a.world_from_camera.translation()).norm(),
              1e-12);
    EXPECT_LT(
        geometry::AngleBetween(b.world_from_camera.rotation(), a.world_from_camera.rotation()),
        1e-12);
    ASSERT_EQ(b.points2d.size(), a.points2d.size());
    for (std::size_t k = 0; k < a.points2d.size(); ++k) {
      EXPECT_LT((b.points2d[k].xy - a.points2d[k].xy).norm(), 1e-12);
      EXPECT_EQ(b.points2d[k].point3d_id, a.points2d[k].point3d_id);
    }
  }
  ASSERT_EQ(back.points.size(), model.points.size());
  for (std::size_t i = 0; i < model.points.size(); ++i) {
    const ColmapPoint3D &a = model.points[i], &b = back.points[i];
    EXPECT_EQ(b.point3d_id, a.point3d_id);
    EXPECT_EQ(b.xyz, a.xyz);
    EXPECT_EQ(b.rgb, a.rgb);
    EXPECT_EQ(b.error, a.error);
    EXPECT_EQ(b.track, a.track);
  }

  // COLMAP's header comments with the counts, and the camera models.
  const std::string cameras = testing::ReadText(dir / "fused/colmap/cameras.txt");
  EXPECT_NE(cameras.find("# Number of cameras: 2\n"), std::string::npos) << cameras;
  EXPECT_NE(cameras.find("\n1 OPENCV 1280 960 1105.25 1101.5 641.8 479.4 -0.12 0.031 "),
            std::string::npos)
      << cameras;
  EXPECT_NE(cameras.find("\n4 FULL_OPENCV 1280 960 "), std::string::npos) << cameras;
  EXPECT_NE(cameras.find(" 0.0021 0 0 0\n"), std::string::npos) << cameras;
  const std::string images = testing::ReadText(dir / "fused/colmap/images.txt");
  EXPECT_NE(images.find("# Number of images: 3, mean observations per image: 2\n"),
            std::string::npos)
      << images;
  EXPECT_NE(images.find("\n0.5 0.5 -1 0.09999999999999998 959.9 9 0.501 6 7\n"), std::string::npos)
      << images;
  const std::string points = testing::ReadText(dir / "fused/colmap/points3D.txt");
  EXPECT_NE(points.find("# Number of points: 3, mean track length: 2\n"), std::string::npos)
      << points;
  EXPECT_NE(points.find("\n9 13.1 -2.75 0.31 255 0 128 1.25 3 1 1 1\n"), std::string::npos)
      << points;

  // Writing again replaces the files (atomic rename), byte for byte the same.
  WriteColmapText(dir / "fused/colmap", back);
  EXPECT_EQ(testing::ReadText(dir / "fused/colmap/points3D.txt"), points);
}

std::string FileText(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream text;
  text << in.rdbuf();
  return text.str();
}

// Points given one at a time to ColmapTextWriter give the files WriteColmapText writes for the
// whole model, whatever the image groups; the temporary files go; and without Finish nothing is
// written.
TEST(ColmapTextWriterTest, PointByPointGivesTheWholeModelsFiles) {
  std::mt19937_64 rng(3);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  ColmapModel model;
  model.cameras = {{1, TestCamera(0.0)}, {2, TestCamera(0.0021)}};
  for (std::uint32_t i = 0; i < 9; ++i) {
    ColmapImage image;
    image.image_id = 10 + i;
    image.camera_id = i < 5 ? 1 : 2;
    image.name = "s" + std::to_string(i / 3) + "/row/" + std::to_string(i) + ".png";
    image.world_from_camera =
        geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(u(rng), u(rng), u(rng))),
                         Eigen::Vector3d(u(rng), u(rng), u(rng)));
    model.images.push_back(image);
  }
  // 40 points, each seen by 0 to 4 images (image 4 by none); an image's 2D points in the order
  // of the points, as the writer numbers them.
  std::vector<std::vector<ColmapObservation>> seen;
  for (std::int64_t id = 0; id < 40; ++id) {
    ColmapPoint3D point;
    point.point3d_id = 3 * id + 1;
    point.xyz = {u(rng) * 10, u(rng), 1e-3 * id};
    point.rgb = {std::uint8_t(id), 7, std::uint8_t(250 - id)};
    point.error = u(rng);
    std::vector<ColmapObservation> observations;
    const int n = static_cast<int>(id % 5);
    for (int k = 0; k < n; ++k) {
      const std::size_t i = (id * 7 + k * 2) % 9;
      if (i == 4) continue;
      const Eigen::Vector2d pixel(u(rng) * 1280, u(rng) * 960);
      observations.push_back({i, pixel});
      point.track.push_back(
          {model.images[i].image_id, static_cast<std::uint32_t>(model.images[i].points2d.size())});
      model.images[i].points2d.push_back({pixel, point.point3d_id});
    }
    seen.push_back(observations);
    model.points.push_back(point);
  }
  std::string why;
  ASSERT_TRUE(model.Check(&why)) << why;
  testing::TempDir dir;
  const std::filesystem::path root = dir.path();
  WriteColmapText((root / "whole").string(), model);
  for (const std::vector<std::uint32_t>& groups :
       {std::vector<std::uint32_t>(9, 0), std::vector<std::uint32_t>{0, 0, 0, 1, 1, 1, 2, 2, 2},
        std::vector<std::uint32_t>{0, 1, 2, 3, 4, 5, 6, 7, 9}}) {
    const std::filesystem::path out = root / ("parts" + std::to_string(groups.back()));
    {
      ColmapTextWriter writer(out.string(), model.cameras, model.images, groups);
      for (std::size_t p = 0; p < model.points.size(); ++p) {
        const ColmapPoint3D& point = model.points[p];
        writer.AddPoint(point.point3d_id, point.xyz, point.rgb, point.error, seen[p]);
      }
      writer.Finish();
      std::size_t entries = 0;
      for ([[maybe_unused]] const auto& entry : std::filesystem::directory_iterator(out)) ++entries;
      EXPECT_EQ(entries, 3u);  // the temporary files go with Finish
    }
    for (const char* file : {"cameras.txt", "images.txt", "points3D.txt"}) {
      EXPECT_EQ(FileText(out / file), FileText(root / "whole" / file)) << file;
    }
  }
  {
    ColmapTextWriter writer((root / "unfinished").string(), model.cameras, model.images,
                            std::vector<std::uint32_t>(9, 0));
    writer.AddPoint(1, {0, 0, 0}, {1, 2, 3}, 0.5, seen[3]);
  }
  EXPECT_TRUE(std::filesystem::is_empty(root / "unfinished"));
  ColmapImage spaced = model.images[0];
  spaced.name = "a b.png";
  EXPECT_THROW(ColmapTextWriter((root / "bad").string(), model.cameras, {spaced}, {0}), InputError);
}

TEST(ColmapTextTest, ReadsHandWrittenModel) {
  testing::TempDir dir;
  // Camera 2: a SIMPLE_RADIAL camera as COLMAP writes it; principal point at the image centre
  // in COLMAP's convention (width / 2, height / 2) is (width − 1) / 2 in OpenCV's.
  testing::WriteText(dir / "m/cameras.txt",
                     "# Camera list with one line of data per camera:\n"
                     "2 SIMPLE_RADIAL 640 480 500 320 240 -0.05\r\n"
                     "\n"
                     "3 PINHOLE 100 50 80 81 50 25\n");
  // Image 5: camera_from_world is a rotation of 90° about z, then t = (1, 2, 3):
  // world_from_camera = (Rᵀ, −Rᵀ t), its camera centre at −Rᵀ t = (−2, 1, −3).
  const double h = std::sqrt(0.5);
  testing::WriteText(dir / "m/images.txt",
                     "# Image list with two lines of data per image:\n"
                     "5 " +
                         std::to_string(h) + " 0 0 " + std::to_string(h) +
                         " 1 2 3 2 2016-06-01/row03/1464792748146793805.png\n"
                         "320.5 240.5 11 10 20 -1\n"
                         "6 1 0 0 0 0 0 0 3 b.png\n"
                         "\n");
  testing::WriteText(dir / "m/points3D.txt", "11 0.5 -1 2.25 1 2 3 0.75 5 0\n");
  const ColmapModel model = ReadColmapText(dir / "m");

  ASSERT_EQ(model.cameras.size(), 2u);
  const geometry::PinholeRadTan& c = model.cameras[0].intrinsics;
  EXPECT_EQ(model.cameras[0].camera_id, 2u);
  EXPECT_EQ(c.width, 640);
  EXPECT_EQ(c.height, 480);
  EXPECT_EQ(c.fx, 500.0);
  EXPECT_EQ(c.fy, 500.0);
  EXPECT_EQ(c.cx, 319.5);
  EXPECT_EQ(c.cy, 239.5);
  EXPECT_EQ(c.k1, -0.05);
  EXPECT_EQ(c.k2, 0.0);
  EXPECT_EQ(model.cameras[1].intrinsics.fy, 81.0);
  EXPECT_EQ(model.cameras[1].intrinsics.cx, 49.5);

  ASSERT_EQ(model.images.size(), 2u);
  const ColmapImage& image = model.images[0];
  EXPECT_EQ(image.image_id, 5u);
  EXPECT_EQ(image.camera_id, 2u);
  EXPECT_EQ(image.name, "2016-06-01/row03/1464792748146793805.png");
  EXPECT_LT((image.world_from_camera.translation() - Eigen::Vector3d(-2, 1, -3)).norm(), 1e-6);
  // The camera's x axis (column 0 of world_from_camera's rotation) is the world's −y.
  EXPECT_LT((image.world_from_camera.RotationMatrix().col(0) - Eigen::Vector3d(0, -1, 0)).norm(),
            1e-6);
  ASSERT_EQ(image.points2d.size(), 2u);
  EXPECT_EQ(image.points2d[0].xy, Eigen::Vector2d(320, 240));
  EXPECT_EQ(image.points2d[0].point3d_id, 11);
  EXPECT_EQ(image.points2d[1].xy, Eigen::Vector2d(9.5, 19.5));
  EXPECT_EQ(image.points2d[1].point3d_id, -1);
  EXPECT_TRUE(model.images[1].points2d.empty());
  EXPECT_EQ(model.images[1].world_from_camera.translation(), Eigen::Vector3d::Zero());

  ASSERT_EQ(model.points.size(), 1u);
  EXPECT_EQ(model.points[0].point3d_id, 11);
  EXPECT_EQ(model.points[0].xyz, Eigen::Vector3d(0.5, -1, 2.25));
  EXPECT_EQ(model.points[0].rgb, (std::array<std::uint8_t, 3>{1, 2, 3}));
  EXPECT_EQ(model.points[0].error, 0.75);
  ASSERT_EQ(model.points[0].track.size(), 1u);
  EXPECT_EQ(model.points[0].track[0], (ColmapTrackElement{5, 0}));
  std::string why;
  EXPECT_TRUE(model.Check(&why)) << why;
}

TEST(ColmapTextTest, MalformedFilesNameFileLineAndProblem) {
  testing::TempDir dir;
  const std::string good_cameras = "# c\n1 OPENCV 640 480 500 500 320 240 0 0 0 0\n";
  const std::string good_images = "# i\n1 1 0 0 0 0 0 0 1 a.png\n10 20 3 30 40 -1\n";
  const std::string good_points = "# p\n3 0 0 1 10 20 30 0.5 1 0\n";
  auto expect_error = [&](const std::string& cameras, const std::string& images,
                          const std::string& points, const std::string& file, int line,
                          const std::string& what) {
    const std::string folder = dir / "m";
    testing::WriteText(folder + "/cameras.txt", cameras);
    testing::WriteText(folder + "/images.txt", images);
    testing::WriteText(folder + "/points3D.txt", points);
    try {
      ReadColmapText(folder);
      ADD_FAILURE() << "no error; expected " << what;
    } catch (const InputError& e) {
      EXPECT_EQ(e.file(), folder + "/" + file) << e.what();
      EXPECT_EQ(e.line(), line) << e.what();
      EXPECT_NE(e.message().find(what), std::string::npos) << e.what() << "\nexpected: " << what;
    }
  };
  // The good model reads.
  testing::WriteText(dir / "m/cameras.txt", good_cameras);
  testing::WriteText(dir / "m/images.txt", good_images);
  testing::WriteText(dir / "m/points3D.txt", good_points);
  EXPECT_NO_THROW(ReadColmapText(dir / "m"));

  // cameras.txt
  expect_error("# c\n1 OPENCV 640 480 500 500 320 240 0 0 0\n", good_images, good_points,
               "cameras.txt", 2, "camera model OPENCV has 8 parameters, found 7");
  expect_error("1 OPENCV_FISHEYE 640 480 500 500 320 240 0 0 0 0\n", good_images, good_points,
               "cameras.txt", 1, "camera model 'OPENCV_FISHEYE' is not supported");
  expect_error("1 FULL_OPENCV 640 480 500 500 320 240 0 0 0 0 0 0.1 0 0\n", good_images,
               good_points, "cameras.txt", 1, "k4, k5, k6");
  expect_error("1 PINHOLE 640 480 500 x5 320 240\n", good_images, good_points, "cameras.txt", 1,
               "PARAM 'x5' is not a number");
  expect_error("1 PINHOLE 640 -480 500 500 320 240\n", good_images, good_points, "cameras.txt", 1,
               "HEIGHT -480 is out of range");
  expect_error("1 PINHOLE 640 480 0 500 320 240\n", good_images, good_points, "cameras.txt", 1,
               "invalid intrinsics");
  expect_error(good_cameras + "1 PINHOLE 640 480 500 500 320 240\n", good_images, good_points,
               "cameras.txt", 3, "duplicate CAMERA_ID 1");
  expect_error("1 PINHOLE\n", good_images, good_points, "cameras.txt", 1,
               "expected CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]");
  // images.txt
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1\n\n", good_points, "images.txt", 1,
               "10 fields), found 9");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1 a b.png\n\n", good_points, "images.txt", 1,
               "found 11");
  expect_error(good_cameras, "1 0 0 0 0 0 0 0 1 a.png\n\n", good_points, "images.txt", 1,
               "zero quaternion");
  expect_error(good_cameras, "1 nan 0 0 0 0 0 0 1 a.png\n\n", good_points, "images.txt", 1,
               "QW is NaN or infinite");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 2 a.png\n\n", good_points, "images.txt", 1,
               "CAMERA_ID 2 is not in cameras.txt");
  expect_error(good_cameras, "# i\n1 1 0 0 0 0 0 0 1 a.png", good_points, "images.txt", 2,
               "image 1 has no POINTS2D line");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1 a.png\n10 20 3 30\n", good_points, "images.txt", 2,
               "X Y POINT3D_ID triples, found 4 fields");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1 a.png\n10 20 3.5\n", good_points, "images.txt", 2,
               "POINT3D_ID '3.5' is not an integer");
  expect_error(good_cameras, good_images + "1 1 0 0 0 0 0 0 1 b.png\n\n", good_points, "images.txt",
               4, "duplicate IMAGE_ID 1");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1 a.png\n10 20 3 30 40 8\n", good_points,
               "images.txt", 2, "refers to 3D point 8, which is not in points3D.txt");
  expect_error(good_cameras, "1 1 0 0 0 0 0 0 1 a.png\n10 20 3 30 40 3\n", good_points,
               "images.txt", 2, "refers to 3D point 3, whose track does not contain it");
  // points3D.txt
  expect_error(good_cameras, good_images, "# p\n3 0 0 1 10 20 30\n", "points3D.txt", 2,
               "expected POINT3D_ID X Y Z R G B ERROR");
  expect_error(good_cameras, good_images, "3 0 0 1 10 20 30 0.5 1\n", "points3D.txt", 1,
               "expected POINT3D_ID X Y Z R G B ERROR");
  expect_error(good_cameras, good_images, "3 0 0 1 10 256 30 0.5 1 0\n", "points3D.txt", 1,
               "G 256 is out of range [0, 255]");
  expect_error(good_cameras, good_images, "3 0 0 1 10 20 30 0.5 2 0\n", "points3D.txt", 1,
               "IMAGE_ID 2 is not in images.txt");
  expect_error(good_cameras, good_images, "3 0 0 1 10 20 30 0.5 1 2\n", "points3D.txt", 1,
               "image 1 has no 2D point 2 (it has 2)");
  expect_error(good_cameras, good_images, "3 0 0 1 10 20 30 0.5 1 0 1 1\n", "points3D.txt", 1,
               "2D point 1 of image 1 refers to 3D point -1");
  expect_error(good_cameras, good_images, "3 0 0 1 10 20 30 0.5 1 0 1 0\n", "points3D.txt", 1,
               "2D point 0 of image 1 is listed twice");
  expect_error(good_cameras, good_images, good_points + "3 0 0 1 10 20 30 0.5\n", "points3D.txt", 3,
               "duplicate POINT3D_ID 3");
  expect_error(good_cameras, good_images, "-3 0 0 1 10 20 30 0.5\n", "points3D.txt", 1,
               "POINT3D_ID -3 is out of range");

  // A missing file.
  std::filesystem::remove(dir / "m/points3D.txt");
  try {
    ReadColmapText(dir / "m");
    ADD_FAILURE() << "no error for a missing points3D.txt";
  } catch (const InputError& e) {
    EXPECT_EQ(e.file(), dir / "m/points3D.txt");
    EXPECT_NE(e.message().find("cannot open"), std::string::npos) << e.what();
  }
}

TEST(ColmapTextTest, NameWithWhitespaceIsRejectedOnWriting) {
  testing::TempDir dir;
  ColmapModel model = TestModel();
  model.images[1].name = "2016-06-01/row 03/a.png";
  try {
    WriteColmapText(dir.path(), model);
    ADD_FAILURE() << "no error";
  } catch (const InputError& e) {
    EXPECT_NE(e.message().find("whitespace"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "images.txt"));
}

TEST(ColmapTextTest, NamesWithWhitespaceAreMappedToNamesColmapCanHold) {
  EXPECT_EQ(ColmapImageName("2016-06-10 früh/row 03/a\tb.png"), "2016-06-10_früh/row_03/a_b.png");
  EXPECT_EQ(ColmapImageName("2016-06-10/row03/a.png"), "2016-06-10/row03/a.png");
  testing::TempDir dir;
  ColmapModel model = TestModel();
  model.images[1].name = ColmapImageName("2016-06-10 früh/row 03/a.png");
  WriteColmapText(dir.path(), model);
  EXPECT_EQ(ReadColmapText(dir.path()).images[1].name, "2016-06-10_früh/row_03/a.png");
}

TEST(ColmapTextTest, CheckFindsInconsistentTracks) {
  std::string why;
  ColmapModel model = TestModel();
  model.points[0].track.pop_back();  // image 3's 2D point 2 still names point 7
  EXPECT_FALSE(model.Check(&why));
  EXPECT_NE(why.find("2D point 2 of image 3"), std::string::npos) << why;
  model = TestModel();
  model.images[0].camera_id = 2;
  EXPECT_FALSE(model.Check(&why));
  EXPECT_NE(why.find("camera 2"), std::string::npos) << why;
  model = TestModel();
  model.points[1].track.push_back({1, 1});
  EXPECT_FALSE(model.Check(&why));
  EXPECT_NE(why.find("listed twice"), std::string::npos) << why;
}

// COLMAP's projection of its OPENCV / FULL_OPENCV models, written here from its documentation
// and applied to the numbers of the written files: a world point, transformed by the written
// camera_from_world (QW QX QY QZ TX TY TZ), distorted and scaled with the written parameters,
// must land on the written 2D point (COLMAP's pixel convention, no further offset).
Eigen::Vector2d ColmapProject(const std::vector<double>& params, const std::vector<double>& pose,
                              const Eigen::Vector3d& point_world) {
  const Eigen::Quaterniond q(pose[0], pose[1], pose[2], pose[3]);
  const Eigen::Vector3d p =
      q.normalized() * point_world + Eigen::Vector3d(pose[4], pose[5], pose[6]);
  const double x = p.x() / p.z(), y = p.y() / p.z();
  const double fx = params[0], fy = params[1], cx = params[2], cy = params[3];
  const double k1 = params[4], k2 = params[5], p1 = params[6], p2 = params[7];
  const double k3 = params.size() > 8 ? params[8] : 0.0;
  const double r2 = x * x + y * y;
  const double radial = 1 + k1 * r2 + k2 * r2 * r2 + k3 * r2 * r2 * r2;
  const double xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x);
  const double yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y;
  return {fx * xd + cx, fy * yd + cy};
}

std::vector<std::vector<double>> NumericLines(const std::string& path) {
  std::vector<std::vector<double>> lines;
  for (const std::string& line : testing::ReadLines(path)) {
    if (!line.empty() && line[0] == '#') continue;
    std::istringstream in(line);
    std::vector<double> values;
    for (std::string token; in >> token;) {
      values.push_back(token.find_first_not_of("0123456789.-+e") == std::string::npos
                           ? std::stod(token)
                           : std::nan(""));
    }
    lines.push_back(values);
  }
  return lines;
}

TEST(ColmapTextTest, WrittenPoseAndIntrinsicsProjectOntoWrittenPointsByColmapConvention) {
  testing::TempDir dir;
  for (double k3 : {0.0, 0.004}) {
    ColmapModel model;
    model.cameras = {{1, TestCamera(k3)}};
    const geometry::PinholeRadTan& camera = model.cameras[0].intrinsics;
    ColmapImage image;
    image.image_id = 1;
    image.camera_id = 1;
    image.name = "2016-06-01/row03/1464792748146793805.png";
    // A camera 1.2 m above the ground looking down (z forward = world −z), x along east.
    image.world_from_camera =
        geometry::Rigid3(geometry::ExpQuat(Eigen::Vector3d(0.05, -0.03, 0.2)) *
                             Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())),
                         Eigen::Vector3d(10.0, 4.0, 1.2));
    const std::vector<Eigen::Vector3d> points_world = {
        {10.1, 4.2, 0.05}, {9.6, 3.8, 0.0}, {10.4, 4.3, 0.3}};
    for (std::size_t i = 0; i < points_world.size(); ++i) {
      Eigen::Vector2d pixel;
      ASSERT_TRUE(camera.Project(image.world_from_camera.Inverse() * points_world[i], &pixel));
      ASSERT_TRUE(camera.IsInImage(pixel));
      image.points2d.push_back({pixel, static_cast<std::int64_t>(i)});
      model.points.push_back({static_cast<std::int64_t>(i),
                              points_world[i],
                              {0, 0, 0},
                              0.0,
                              {{1, static_cast<std::uint32_t>(i)}}});
    }
    model.images = {image};
    WriteColmapText(dir.path(), model);

    // cameras.txt: CAMERA_ID MODEL WIDTH HEIGHT PARAMS (MODEL parses as NaN here).
    const std::vector<std::vector<double>> cameras = NumericLines(dir / "cameras.txt");
    ASSERT_EQ(cameras.size(), 1u);
    const std::vector<double> params(cameras[0].begin() + 4, cameras[0].end());
    ASSERT_EQ(params.size(), k3 == 0.0 ? 8u : 12u);
    // images.txt: pose line, then X Y POINT3D_ID triples.
    const std::vector<std::vector<double>> images = NumericLines(dir / "images.txt");
    ASSERT_EQ(images.size(), 2u);
    const std::vector<double> pose(images[0].begin() + 1, images[0].begin() + 8);
    const std::vector<std::string> lines = testing::ReadLines(dir / "images.txt");
    EXPECT_EQ(lines[lines.size() - 2].substr(lines[lines.size() - 2].rfind(' ') + 1), image.name);
    ASSERT_EQ(images[1].size(), 3 * points_world.size());
    for (std::size_t i = 0; i < points_world.size(); ++i) {
      const Eigen::Vector2d written(images[1][3 * i], images[1][3 * i + 1]);
      EXPECT_LT((ColmapProject(params, pose, points_world[i]) - written).norm(), 1e-9)
          << "point " << i << " k3 " << k3;
      // And it is crop4d's pixel moved by half a pixel.
      EXPECT_LT((written - image.points2d[i].xy - Eigen::Vector2d(0.5, 0.5)).norm(), 1e-9);
    }
    // The camera centre in the world is −Rᵀ t of the written camera_from_world.
    const Eigen::Quaterniond q(pose[0], pose[1], pose[2], pose[3]);
    const Eigen::Vector3d centre =
        -(q.normalized().conjugate() * Eigen::Vector3d(pose[4], pose[5], pose[6]));
    EXPECT_LT((centre - image.world_from_camera.translation()).norm(), 1e-12);
  }
}

}  // namespace
}  // namespace crop4d::io
