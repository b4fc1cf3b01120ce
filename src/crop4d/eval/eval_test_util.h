#pragma once

// Tests only (header-only; used by the eval tests and the `crop4d eval` CLI tests): synthetic
// trajectories, and a workspace + field ground truth written into a temporary folder.

#include <unistd.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/io/tum.h"

namespace crop4d::eval::testing {

// A fresh folder "crop4d_eval_<pid>_<n>" under the system temp folder, removed on destruction.
class PidTempDir {
 public:
  PidTempDir() {
    static std::atomic<int> counter{0};
    path_ = (std::filesystem::temp_directory_path() /
             ("crop4d_eval_" + std::to_string(::getpid()) + "_" + std::to_string(counter++)))
                .string();
    std::filesystem::remove_all(path_);
    std::filesystem::create_directories(path_);
  }
  ~PidTempDir() {
    std::error_code ec;
    std::filesystem::remove_all(path_, ec);
  }
  PidTempDir(const PidTempDir&) = delete;
  PidTempDir& operator=(const PidTempDir&) = delete;

  const std::string& path() const { return path_; }
  std::string operator/(const std::string& relative) const {
    return (std::filesystem::path(path_) / relative).string();
  }

 private:
  std::string path_;
};

inline void WriteFile(const std::string& path, const std::string& text) {
  std::filesystem::create_directories(std::filesystem::path(path).parent_path());
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << text;
}

inline constexpr Timestamp kStart = 1464184800 * kNanosPerSecond;  // 2016-05-25 14:00 UTC

// A vehicle driving a gently curving row at 1 m/s, heading along the path, with a small roll
// and pitch: world_from_body at time s (seconds from kStart). Not collinear, so an SE(3)
// alignment is well determined.
inline geometry::Rigid3 CurvedRowPose(double s) {
  const Eigen::Vector3d p(s, 0.5 * std::sin(0.2 * s), 0.05 * std::sin(0.5 * s));
  const double yaw = std::atan2(0.1 * std::cos(0.2 * s), 1.0);
  const Eigen::Quaterniond q =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
      Eigen::AngleAxisd(0.02 * std::sin(s), Eigen::Vector3d::UnitY()) *
      Eigen::AngleAxisd(0.03 * std::cos(0.7 * s), Eigen::Vector3d::UnitX());
  return geometry::Rigid3(q, p);
}

// The camera on the body: 0.5 m ahead, 1 m up, looking down.
inline geometry::Rigid3 BodyFromCamera() {
  return geometry::Rigid3(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX())),
                          Eigen::Vector3d(0.5, 0.0, 1.0));
}

// Poses at `rate_hz` for `duration_s` seconds from kStart + offset_s.
inline std::vector<io::StampedPose> SampleTrajectory(double rate_hz, double duration_s, bool camera,
                                                     double offset_s = 0.0) {
  std::vector<io::StampedPose> poses;
  const int n = static_cast<int>(std::lround(duration_s * rate_hz)) + 1;
  for (int k = 0; k < n; ++k) {
    const double s = offset_s + k / rate_hz;
    io::StampedPose p;
    p.t = kStart + SecondsToTimestamp(s);
    p.pose = camera ? CurvedRowPose(s) * BodyFromCamera() : CurvedRowPose(s);
    poses.push_back(p);
  }
  return poses;
}

// Writes FIELD/ground_truth/<session>/cam0_poses.tum (10 Hz) and body_poses.tum (100 Hz) for
// a 20 s pass.
inline void WriteTruth(const std::string& field, const std::string& session) {
  const std::string dir = field + "/ground_truth/" + session + "/";
  io::WriteTum(dir + "cam0_poses.tum", SampleTrajectory(10.0, 20.0, true),
               "world_from_camera (cam0)");
  io::WriteTum(dir + "body_poses.tum", SampleTrajectory(100.0, 20.0, false),
               "world_from_body (imu0)");
}

// The "problem" of a pass without priors (workspace/pass_priors.h).
inline constexpr const char* kSummaryProblem =
    "{\"camera\": \"cam0\", \"gps_outages\": [], \"forward_axis_body\": null, "
    "\"bias_prior_mean\": [0, 0, 0, 0, 0, 0], \"bias_prior_sigma\": null}";

// A row pass's summary.json (schema 1) with the fields eval reads.
inline std::string SummaryJson(const std::string& session, const std::string& pass, int row,
                               int direction, const std::string& sensors,
                               const std::string& pose_frame) {
  // What workspace::ReadPassSummary needs besides: the schema, a fingerprint and the problem.
  return "{\"schema\": 1, \"fingerprint\": \"0\", \"problem\": " + std::string(kSummaryProblem) +
         ", \"session\": \"" + session + "\", \"pass\": \"" + pass +
         "\", \"row\": " + std::to_string(row) + ", \"direction\": " + std::to_string(direction) +
         ", \"sensors\": \"" + sensors + "\", \"pose_frame\": \"" + pose_frame + "\"}\n";
}

// Writes WS/sessions/<session>/rows/<pass>/{poses.tum,summary.json}.
inline void WritePass(const std::string& workspace, const std::string& session,
                      const std::string& pass, int row, const std::string& sensors,
                      const std::string& pose_frame, const std::vector<io::StampedPose>& poses) {
  const std::string dir = workspace + "/sessions/" + session + "/rows/" + pass + "/";
  io::WriteTum(dir + "poses.tum", poses);
  WriteFile(dir + "summary.json", SummaryJson(session, pass, row, 1, sensors, pose_frame));
}

// Moves every pose by `offset` in the world frame.
inline std::vector<io::StampedPose> Offset(std::vector<io::StampedPose> poses,
                                           const Eigen::Vector3d& offset) {
  for (io::StampedPose& p : poses)
    p.pose = geometry::Rigid3(p.pose.rotation(), p.pose.translation() + offset);
  return poses;
}

// A field with truth for session "2016-05-25" and a workspace with three passes:
//   2016-05-25/0: camera poses at every image, 3 cm east of the truth (cam+imu+rtk);
//   2016-05-25/1: body poses at 5 Hz between the IMU samples (offset 2.5 ms), 1 cm north
//                 (imu+rtk);
//   2016-05-26/0: a session without ground truth.
inline void WriteWorkspaceAndTruth(const std::string& workspace, const std::string& field) {
  WriteTruth(field, "2016-05-25");
  WritePass(workspace, "2016-05-25", "0", 0, "cam+imu+rtk", "camera",
            Offset(SampleTrajectory(10.0, 20.0, true), Eigen::Vector3d(0.03, 0.0, 0.0)));
  WritePass(workspace, "2016-05-25", "1", 1, "imu+rtk", "body",
            Offset(SampleTrajectory(5.0, 19.0, false, 0.0025), Eigen::Vector3d(0.0, 0.01, 0.0)));
  WritePass(workspace, "2016-05-26", "0", 0, "cam+imu+rtk", "camera",
            SampleTrajectory(10.0, 20.0, true));
}

}  // namespace crop4d::eval::testing
