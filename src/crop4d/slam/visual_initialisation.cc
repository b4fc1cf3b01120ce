#include "crop4d/slam/visual_initialisation.h"

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <stdexcept>

#include "crop4d/geometry/rotation.h"

namespace crop4d::slam {
namespace {

// Normalised image coordinates (x/z, y/z) of every track's observation, per image.
std::vector<std::vector<std::pair<int, cv::Point2d>>> NormalisedObservations(
    const geometry::PinholeRadTan& camera, const std::vector<LandmarkTrack>& tracks,
    int num_images) {
  std::vector<std::vector<std::pair<int, cv::Point2d>>> per_image(num_images);
  for (std::size_t t = 0; t < tracks.size(); ++t) {
    for (const LandmarkObservation& obs : tracks[t].observations) {
      if (obs.state < 0 || obs.state >= num_images) continue;
      Eigen::Vector3d ray;
      if (!camera.Unproject(obs.pixel, &ray) || ray.z() <= 0) continue;
      per_image[obs.state].emplace_back(static_cast<int>(t),
                                        cv::Point2d(ray.x() / ray.z(), ray.y() / ray.z()));
    }
  }
  for (auto& image : per_image) {
    std::sort(image.begin(), image.end(),
              [](const auto& a, const auto& b) { return a.first < b.first; });
  }
  return per_image;
}

// The motion between two images from their shared tracks (sorted by track index).
ImagePairMotion PairMotion(const std::vector<std::pair<int, cv::Point2d>>& a,
                           const std::vector<std::pair<int, cv::Point2d>>& b, double focal_px,
                           const VisualInitialisationOptions& options) {
  std::vector<cv::Point2d> pa, pb;
  for (std::size_t i = 0, j = 0; i < a.size() && j < b.size();) {
    if (a[i].first < b[j].first) {
      ++i;
    } else if (b[j].first < a[i].first) {
      ++j;
    } else {
      pa.push_back(a[i++].second);
      pb.push_back(b[j++].second);
    }
  }
  ImagePairMotion m;
  m.correspondences = static_cast<int>(pa.size());
  if (m.correspondences < options.min_correspondences) return m;
  cv::Mat inliers;
  const cv::Mat E = cv::findEssentialMat(pa, pb, cv::Mat::eye(3, 3, CV_64F), cv::USAC_ACCURATE,
                                         options.ransac_confidence,
                                         options.ransac_threshold_px / focal_px, inliers);
  // Several solutions come stacked (3 × 3 each) when the five-point solver finds more than one;
  // the first is the one with the most inliers.
  if (E.rows < 3 || E.cols != 3) return m;
  cv::Mat R, t;
  m.inliers = cv::recoverPose(E.rowRange(0, 3), pa, pb, cv::Mat::eye(3, 3, CV_64F), R, t, inliers);
  if (m.inliers < options.min_inlier_fraction * m.correspondences) return m;
  // recoverPose: x_b = R x_a + t, so camera b's centre in a's frame is −Rᵀ t.
  Eigen::Matrix3d b_from_a;
  Eigen::Vector3d t_b;
  cv::cv2eigen(R, b_from_a);
  cv::cv2eigen(t, t_b);
  const Eigen::Vector3d centre = -b_from_a.transpose() * t_b;
  if (!centre.allFinite() || centre.norm() < 1e-9) return m;
  m.ok = true;
  m.rotation = Eigen::Quaterniond(b_from_a.transpose()).normalized();
  m.direction = centre.normalized();
  return m;
}

// The rotation about the vertical by `angle` rad.
Eigen::Matrix3d Yaw(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

}  // namespace

OptionCheck VisualInitialisationOptions::Check() const {
  OptionChecker c;
  c.AtLeast("min_correspondences", min_correspondences, 5)
      .Greater("ransac_threshold_px", ransac_threshold_px, 0.0)
      .Between("ransac_confidence", ransac_confidence, 0.0, 1.0)
      .InRange("min_inlier_fraction", min_inlier_fraction, 0.0, 1.0)
      .AtLeast("min_step_m", min_step_m, 0.0)
      .InRange("min_usable_fraction", min_usable_fraction, 0.0, 1.0);
  return c.Result();
}

std::vector<ImagePairMotion> ConsecutiveImageMotions(const geometry::PinholeRadTan& camera,
                                                     const std::vector<LandmarkTrack>& tracks,
                                                     int num_images,
                                                     const VisualInitialisationOptions& options) {
  if (const OptionCheck why = options.Check(); !why.empty()) {
    throw std::invalid_argument("VisualInitialisationOptions: " + why);
  }
  const auto per_image = NormalisedObservations(camera, tracks, num_images);
  const double focal = 0.5 * (camera.fx + camera.fy);
  std::vector<ImagePairMotion> motions(std::max(num_images - 1, 0));
  for (int k = 0; k + 1 < num_images; ++k) {
    motions[k] = PairMotion(per_image[k], per_image[k + 1], focal, options);
  }
  return motions;
}

std::vector<RowState> VisualInitialGuess(const std::vector<RowState>& gps_guess,
                                         const geometry::PinholeRadTan& camera,
                                         const geometry::Rigid3& body_from_camera,
                                         const std::vector<LandmarkTrack>& tracks,
                                         const Eigen::Vector3d& up_body,
                                         const VisualInitialisationOptions& options,
                                         VisualInitialisationSummary* summary) {
  VisualInitialisationSummary local;
  VisualInitialisationSummary& s = summary != nullptr ? *summary : local;
  s = VisualInitialisationSummary();
  const int n = static_cast<int>(gps_guess.size());
  s.steps = std::max(n - 1, 0);
  if (n < 3) return gps_guess;
  const std::vector<ImagePairMotion> motions = ConsecutiveImageMotions(camera, tracks, n, options);

  // The chain, in the frame of camera 0 ("A"): camera rotations and centres.
  std::vector<Eigen::Matrix3d> a_from_camera(n, Eigen::Matrix3d::Identity());
  std::vector<Eigen::Vector3d> centre_a(n, Eigen::Vector3d::Zero());
  Eigen::Vector3d direction_a = Eigen::Vector3d::Zero();  // of the last usable step
  for (int k = 0; k + 1 < n; ++k) {
    const double step = (gps_guess[k + 1].nav.world_from_body.translation() -
                         gps_guess[k].nav.world_from_body.translation())
                            .norm();
    Eigen::Matrix3d rotation = a_from_camera[k];
    if (motions[k].ok && step >= options.min_step_m) {
      rotation = a_from_camera[k] * motions[k].rotation.toRotationMatrix();
      direction_a = a_from_camera[k] * motions[k].direction;
      ++s.visual_steps;
    }
    a_from_camera[k + 1] = rotation;
    centre_a[k + 1] = centre_a[k] + step * direction_a;
  }
  if (s.visual_steps < options.min_usable_fraction * s.steps) return gps_guess;

  // Body poses in A.
  const geometry::Rigid3 camera_from_body = body_from_camera.Inverse();
  std::vector<geometry::Rigid3> a_from_body(n);
  Eigen::Vector3d mean_up_a = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    a_from_body[k] = geometry::Rigid3(a_from_camera[k], centre_a[k]) * camera_from_body;
    mean_up_a += a_from_body[k].RotationMatrix() * up_body.normalized();
  }
  if (mean_up_a.norm() < 1e-6) return gps_guess;

  // Tilt: the mean up axis onto the world's up. Then the yaw that turns the horizontal
  // displacement of the chain onto the GPS guess's.
  const Eigen::Matrix3d level =
      Eigen::Quaterniond::FromTwoVectors(mean_up_a.normalized(), Eigen::Vector3d::UnitZ())
          .toRotationMatrix();
  const Eigen::Vector3d chain_span =
      level * (a_from_body.back().translation() - a_from_body.front().translation());
  const Eigen::Vector3d gps_span = gps_guess.back().nav.world_from_body.translation() -
                                   gps_guess.front().nav.world_from_body.translation();
  if (chain_span.head<2>().norm() < 1e-6 || gps_span.head<2>().norm() < 1e-6) return gps_guess;
  const double yaw =
      std::atan2(gps_span.y(), gps_span.x()) - std::atan2(chain_span.y(), chain_span.x());
  const Eigen::Matrix3d world_from_a = Yaw(yaw) * level;

  // Shift: the mean positions agree.
  Eigen::Vector3d mean_gps = Eigen::Vector3d::Zero(), mean_chain = Eigen::Vector3d::Zero();
  for (int k = 0; k < n; ++k) {
    mean_gps += gps_guess[k].nav.world_from_body.translation();
    mean_chain += world_from_a * a_from_body[k].translation();
  }
  const geometry::Rigid3 world_from_a_pose(world_from_a, (mean_gps - mean_chain) / n);

  std::vector<RowState> states = gps_guess;
  for (int k = 0; k < n; ++k) states[k].nav.world_from_body = world_from_a_pose * a_from_body[k];
  // Velocities and angular rates by differences (central inside, one-sided at the ends).
  for (int k = 0; k < n; ++k) {
    const int a = std::max(k - 1, 0), b = std::min(k + 1, n - 1);
    const double dt = DurationSeconds(states[a].t, states[b].t);
    const geometry::Rigid3& pa = states[a].nav.world_from_body;
    const geometry::Rigid3& pb = states[b].nav.world_from_body;
    states[k].nav.vel_world = (pb.translation() - pa.translation()) / dt;
    states[k].nav.rate_body =
        geometry::LogSO3((pa.rotation().conjugate() * pb.rotation()).toRotationMatrix()) / dt;
  }
  const auto heading = [](const geometry::Rigid3& pose, const Eigen::Vector3d& forward) {
    const Eigen::Vector3d f = pose.rotation() * forward;
    return std::atan2(f.y(), f.x());
  };
  // The body axis most nearly horizontal of x and y, for the heading.
  const Eigen::Vector3d forward = std::abs(up_body.normalized().x()) < 0.7
                                      ? Eigen::Vector3d::UnitX()
                                      : Eigen::Vector3d::UnitY();
  double change = heading(gps_guess.front().nav.world_from_body, forward) -
                  heading(states.front().nav.world_from_body, forward);
  change = std::remainder(change, 2 * M_PI);
  s.heading_change_deg = change * 180.0 / M_PI;
  s.applied = true;
  return states;
}

}  // namespace crop4d::slam
