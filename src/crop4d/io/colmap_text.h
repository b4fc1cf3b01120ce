#pragma once

// COLMAP text models (DESIGN.md §5): the fused 4D reconstruction is written as
// WS/fused/colmap/{cameras,images,points3D}.txt, one image per session/row/frame, so that COLMAP,
// its GUI and the tools built on its format (OpenMVS, nerfstudio, gsplat, ...) read it. The
// format is COLMAP's documented text model ("Output Format" in the COLMAP documentation):
//
//   cameras.txt   CAMERA_ID MODEL WIDTH HEIGHT PARAMS[]
//   images.txt    IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME      (first line of an image)
//                 X Y POINT3D_ID X Y POINT3D_ID ...                  (second line, may be empty)
//   points3D.txt  POINT3D_ID X Y Z R G B ERROR IMAGE_ID POINT2D_IDX IMAGE_ID POINT2D_IDX ...
//
// Lines starting with '#' are comments; the writer puts COLMAP's own header comments first (with
// the counts and the mean observations / track length).
//
// Conventions, converted on writing and reading so that the in-memory model uses crop4d's:
//  - Pose. COLMAP stores camera_from_world (QW QX QY QZ is the Hamilton quaternion of its
//    rotation, TX TY TZ its translation): x_in_camera = R x_in_world + t. The model holds
//    world_from_camera, like the rest of crop4d, and the writer inverts it.
//  - Pixels. COLMAP puts the centre of the top-left pixel at (0.5, 0.5) (the image spans
//    [0, width] × [0, height]); crop4d, like OpenCV, at (0, 0). The model holds OpenCV pixel
//    coordinates; the writer adds 0.5 to the principal point cx, cy and to every 2D point, the
//    reader subtracts it. A point projected with the written intrinsics and pose by COLMAP's
//    camera model lands on the written 2D point.
//  - Cameras. crop4d's pinhole radial-tangential camera (geometry/camera.h) is written as
//    COLMAP's OPENCV model (fx fy cx cy k1 k2 p1 p2) when k3 = 0, else as FULL_OPENCV
//    (fx fy cx cy k1 k2 p1 p2 k3 k4 k5 k6, with k4 = k5 = k6 = 0: the rational model's
//    denominator is then 1 and it is the same lens). The reader also takes the models that are
//    special cases of it: SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL.
//
// Numbers are written with the shortest decimal representation that reads back to the same
// double, so a round trip is exact up to the pose inversion (~1e-16).

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"

namespace crop4d::io {

struct ColmapCamera {
  std::uint32_t camera_id = 0;
  // Intrinsics in crop4d's (OpenCV) pixel convention; width and height included.
  geometry::PinholeRadTan intrinsics;
};

struct ColmapPoint2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();  // pixel, crop4d's (OpenCV) convention
  std::int64_t point3d_id = -1;                  // -1: no 3D point
};

struct ColmapImage {
  std::uint32_t image_id = 0;
  std::uint32_t camera_id = 0;
  // Path relative to the image folder, without whitespace,
  // e.g. "2016-06-01/row03/1464792748146793805.png".
  std::string name;
  geometry::Rigid3 world_from_camera;
  std::vector<ColmapPoint2D> points2d;
};

struct ColmapTrackElement {
  std::uint32_t image_id = 0;
  std::uint32_t point2d_idx = 0;  // index into that image's points2d

  bool operator==(const ColmapTrackElement&) const = default;
};

struct ColmapPoint3D {
  std::int64_t point3d_id = 0;                    // ≥ 0
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();  // point_world
  std::array<std::uint8_t, 3> rgb = {0, 0, 0};
  double error = 0.0;  // mean reprojection error, pixels
  std::vector<ColmapTrackElement> track;
};

struct ColmapModel {
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::vector<ColmapPoint3D> points;

  // A consistent model: unique ids; every image's camera exists and every camera is valid
  // (PinholeRadTan::Check); names are non-empty without whitespace; every 2D point with a 3D
  // point is in exactly that point's track and every track element refers to an existing image
  // and 2D point that names the point back; finite values. On failure, `why` (if not null) says
  // what is wrong.
  bool Check(std::string* why = nullptr) const;
  // Number of 2D points with a 3D point (= the sum of the track lengths of a consistent model).
  std::size_t NumObservations() const;
};

// The COLMAP camera model crop4d writes for `camera`: "OPENCV" when k3 == 0, else "FULL_OPENCV".
const char* ColmapCameraModelName(const geometry::PinholeRadTan& camera);

// `name` with every whitespace character replaced by '_': COLMAP's images.txt separates its
// fields by spaces, so an image name cannot hold one (a session folder "2016-06-10 early"
// gives images "2016-06-10_early/...").
std::string ColmapImageName(std::string name);

// Writes cameras.txt, images.txt and points3D.txt into `folder` (created when missing), each
// atomically (io/atomic_file.h), in the order of the model's vectors. Throws InputError when an
// image name is empty or holds whitespace (COLMAP's text format cannot hold it) or a file
// cannot be written; any other inconsistency (Check) is a programmer error (CHECK).
void WriteColmapText(const std::string& folder, const ColmapModel& model);

// An observation of a 3D point for ColmapTextWriter: the image (its index in the writer's
// images) and the pixel (crop4d's convention).
struct ColmapObservation {
  std::size_t image = 0;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
};

// Writes a COLMAP text model whose 3D points come one at a time, so that their tracks are never
// all in memory (the fused season's landmarks; pipeline/fuse_outputs.h): the same files as
// WriteColmapText for the model whose images have, in order, the 2D points of the points added
// (each image's numbered in the order its points came). points3D.txt's lines and each image
// group's 2D points wait in temporary files in `folder` (its header counts the points, and an
// image's 2D points come from every point that sees it); Finish writes the files, reading back
// one group at a time: a group (e.g. a session's images) is what is held in memory then.
class ColmapTextWriter {
 public:
  // `images` without 2D points (any are dropped), `image_groups` one per image, nondecreasing.
  // Throws InputError for an image name COLMAP cannot store or a folder that cannot be made;
  // other inconsistencies (missing camera, duplicate ids, invalid camera) are CHECKed.
  ColmapTextWriter(const std::string& folder, std::vector<ColmapCamera> cameras,
                   std::vector<ColmapImage> images, std::vector<std::uint32_t> image_groups);
  // Removes the temporary files; without Finish() the model's files are left as they were.
  ~ColmapTextWriter();
  ColmapTextWriter(const ColmapTextWriter&) = delete;
  ColmapTextWriter& operator=(const ColmapTextWriter&) = delete;

  // The next 3D point (id ≥ 0, finite values; CHECKed) and its observations, its track in their
  // order. Throws InputError when a temporary file cannot be written.
  void AddPoint(std::int64_t point3d_id, const Eigen::Vector3d& xyz,
                const std::array<std::uint8_t, 3>& rgb, double error,
                const std::vector<ColmapObservation>& observations);
  // Writes cameras.txt, images.txt and points3D.txt, each atomically, and removes the temporary
  // files. Once, and no AddPoint after it (CHECK).
  void Finish();

 private:
  struct Spill;
  std::string SpillPath(const std::string& part) const;
  void RemoveSpills();

  std::string folder_;
  std::vector<ColmapCamera> cameras_;
  std::vector<ColmapImage> images_;
  std::vector<std::uint32_t> groups_;
  std::vector<std::uint32_t> points2d_;  // 2D points of each image so far
  std::unique_ptr<Spill> spill_;
  std::size_t num_points_ = 0;
  std::size_t track_sum_ = 0;
  bool finished_ = false;
};

// Reads the three files of `folder`, in file order. Throws InputError naming the file and line
// for anything malformed: a missing file, a line with the wrong number of fields or a field that
// is not a number, an unsupported camera model (or FULL_OPENCV with k4..k6 ≠ 0), duplicate ids,
// an image whose camera or POINTS2D line is missing, a 2D point or track that refers to a
// missing image, 2D point or 3D point, or a 2D point and a track that disagree.
ColmapModel ReadColmapText(const std::string& folder);

}  // namespace crop4d::io
