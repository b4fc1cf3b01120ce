#pragma once

// Test scenes with known correspondences, without the simulator: a textured plane (noise at
// several scales plus random blobs) seen by a camera that moves along it, each view rendered
// with cv::warpPerspective through the plane-induced homography, so that the true pixel
// correspondence between any two views is H_j H_i⁻¹.

#include <Eigen/Core>
#include <opencv2/core/mat.hpp>
#include <vector>

namespace crop4d::features::testing {

struct PlaneScene {
  cv::Mat texture;                                 // BGR texture of the plane
  std::vector<cv::Mat> views;                      // BGR views
  std::vector<Eigen::Matrix3d> view_from_texture;  // H_i: texture pixel → view i pixel

  // Where pixel x of view i appears in view j.
  Eigen::Vector2d Transfer(int i, int j, const Eigen::Vector2d& x) const;
  // Where pixel x of view i lies on the texture.
  Eigen::Vector2d ToTexture(int i, const Eigen::Vector2d& x) const;
};

struct PlaneSceneOptions {
  int num_views = 10;
  int width = 640;
  int height = 480;
  double focal_px = 500;
  double height_m = 1.2;      // camera height above the plane
  double step_m = 0.08;       // camera travel between views, along the texture's x
  double tilt_deg = 15;       // camera pitch away from nadir
  double yaw_wobble_deg = 2;  // alternating yaw, so that views are not pure translations
  unsigned seed = 7;
};

// Builds the scene; every view lies entirely inside the texture (checked).
PlaneScene MakePlaneScene(const PlaneSceneOptions& options = PlaneSceneOptions());

}  // namespace crop4d::features::testing
