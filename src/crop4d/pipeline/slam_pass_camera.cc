// The camera's part of a slam pass (slam_pass_camera.h): the front end on the pass's images and
// the sparse cloud triangulated from the final poses.

#include "crop4d/pipeline/slam_pass_camera.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "crop4d/core/stopwatch.h"
#include "crop4d/io/ply.h"
#include "crop4d/slam/track_cloud.h"
#include "crop4d/workspace/pass_files.h"

namespace crop4d::pipeline {
namespace {

using Clock = std::chrono::steady_clock;
using nlohmann::json;

// The shortest track of the output cloud: two images triangulate a point.
constexpr int kMinCloudTrackLength = 2;

// A front-end track as the back end takes it: the keypoints that observe it and their mean
// colour.
slam::LandmarkTrack ToLandmarkTrack(const features::Track& track,
                                    const std::vector<features::FeatureSet>& features) {
  slam::LandmarkTrack t;
  Eigen::Vector3i color_sum = Eigen::Vector3i::Zero();
  for (const features::Observation& obs : track.observations) {
    const features::FeatureSet& f = features[obs.image];
    const features::Keypoint& kp = f.keypoints[obs.feature];
    t.observations.push_back({obs.image, Eigen::Vector2d(kp.x, kp.y)});
    if (!f.colors.empty()) {
      for (int c = 0; c < 3; ++c) color_sum(c) += f.colors[obs.feature][c];
    }
  }
  for (int c = 0; c < 3; ++c) {
    t.color[c] = static_cast<std::uint8_t>(color_sum(c) / static_cast<int>(track.size()));
  }
  return t;
}

// A track cloud as a PLY cloud with the track length and reprojection error of each point.
io::PlyPointCloud ToPly(const slam::TrackCloud& track_cloud) {
  io::PlyPointCloud cloud;
  cloud.points = track_cloud.points_world;
  cloud.colors = track_cloud.colors;
  io::PlyScalarField length{"track_length", io::PlyType::kInt32, {}};
  io::PlyScalarField error{"reprojection_error", io::PlyType::kFloat32, {}};
  length.values.assign(track_cloud.track_lengths.begin(), track_cloud.track_lengths.end());
  error.values = track_cloud.reprojection_errors_px;
  cloud.scalars = {length, error};
  return cloud;
}

// The observations behind the optimised landmarks (those the final solve kept) and behind every
// cloud point, for association and the joint 4D problem (pass_files.h).
workspace::PassTracks PassTracksOf(const PassFrontEnd& front_end,
                                   const std::vector<features::Track>& all_tracks,
                                   const slam::TrackCloud& track_cloud,
                                   const slam::RowOptimiser::Result& result) {
  workspace::PassTracks pass_tracks;
  for (std::size_t l = 0; l < result.landmarks_world.size(); ++l) {
    const features::Track& track = front_end.front.tracks[result.landmark_tracks[l]];
    workspace::PassTrack t;
    t.position_world = result.landmarks_world[l];
    t.color = front_end.tracks[result.landmark_tracks[l]].color;
    for (std::size_t o = 0; o < track.observations.size(); ++o) {
      if (result.landmark_observations_kept[l][o]) t.observations.push_back(track.observations[o]);
    }
    pass_tracks.landmarks.push_back(std::move(t));
  }
  for (std::size_t k = 0; k < track_cloud.size(); ++k) {
    pass_tracks.cloud.push_back({track_cloud.points_world[k], track_cloud.colors[k],
                                 all_tracks[track_cloud.track_indices[k]].observations});
  }
  return pass_tracks;
}

}  // namespace

PassFrontEnd RunFrontEnd(const PassJob& job, json* summary) {
  const SessionContext& ctx = job.ctx;
  const slam::RowPass& pass = job.pass;
  const std::vector<Timestamp>& times = job.times;
  const slam::CameraStream* camera = job.streams.camera;
  PassFrontEnd out;
  auto start = Clock::now();
  features::FrontEnd::Options fe = job.options.front_end;
  fe.cache_path = job.layout.PassFeatures(ctx.session->id(), pass.id).string();
  fe.show_progress = job.options.show_progress;
  const features::FrontEnd front_end(fe, &camera->sensor.camera);
  std::vector<std::string> keys;
  std::vector<std::string> paths;
  for (const io::ImageEntry& e : camera->images) {
    if (e.t < times.front() || e.t > times.back()) continue;
    keys.push_back(std::to_string(e.t));
    paths.push_back(ctx.session->ImagePath(camera->sensor.name, e.filename));
  }
  out.front =
      front_end.Run(keys, [&](std::size_t i) { return cv::imread(paths[i], cv::IMREAD_COLOR); });
  if (out.front.summary.num_images_unreadable > 0) {
    spdlog::warn(
        "{}/{}: {} images could not be read (no features; the IMU and GPS carry the "
        "states there)",
        ctx.session->id(), pass.id, out.front.summary.num_images_unreadable);
  }
  for (const features::Track& track : out.front.tracks) {
    out.tracks.push_back(ToLandmarkTrack(track, out.front.features));
  }
  out.seconds = SecondsSince(start);
  (*summary)["front_end"] = {{"images", out.front.summary.num_images},
                             {"images_from_cache", out.front.summary.num_images_from_cache},
                             {"images_unreadable", out.front.summary.num_images_unreadable},
                             {"features", out.front.summary.num_features},
                             {"pairs", out.front.summary.num_pairs},
                             {"verified_pairs", out.front.summary.num_verified_pairs},
                             {"inlier_matches", out.front.summary.num_inlier_matches},
                             {"tracks", out.front.summary.tracks.num_tracks},
                             {"landmarks", out.front.summary.num_landmarks},
                             {"seconds", out.seconds}};
  return out;
}

std::vector<features::Track> AllTracks(const features::FrontEnd::Result& front) {
  features::TrackBuilder::Options tb;
  tb.min_track_length = kMinCloudTrackLength;
  std::vector<int> num_features;
  for (const features::FeatureSet& f : front.features) {
    num_features.push_back(static_cast<int>(f.size()));
  }
  return features::TrackBuilder(tb).Build(num_features, front.pairs);
}

std::vector<slam::LandmarkTrack> ToLandmarkTracks(
    const std::vector<features::Track>& tracks, const std::vector<features::FeatureSet>& features) {
  std::vector<slam::LandmarkTrack> out;
  out.reserve(tracks.size());
  for (const features::Track& track : tracks) out.push_back(ToLandmarkTrack(track, features));
  return out;
}

int WritePassCloud(const PassJob& job, const PassFrontEnd& front_end,
                   const std::vector<features::Track>& all_tracks,
                   const std::vector<geometry::Rigid3>& cameras,
                   const slam::RowOptimiser::Result& result, json* summary) {
  const std::string& session = job.session();
  const std::string& pass = job.pass.id;
  // Every track of two or more images, triangulated from the final poses.
  const std::vector<slam::LandmarkTrack> cloud_tracks =
      ToLandmarkTracks(all_tracks, front_end.front.features);
  const slam::TrackCloud track_cloud = slam::TriangulateTrackCloud(
      job.streams.camera->sensor.camera, cameras, cloud_tracks, job.options.cloud);
  const io::PlyPointCloud cloud = ToPly(track_cloud);
  workspace::WritePassTracks(job.layout.PassTracks(session, pass).string(),
                             PassTracksOf(front_end, all_tracks, track_cloud, result));
  io::PlyWriteOptions ply_options;
  ply_options.comment =
      "crop4d sparse cloud of " + session + "/" + pass + ", field ENU frame (metres)";
  io::WritePly(job.layout.PassLandmarks(session, pass).string(), cloud, ply_options);
  (*summary)["cloud"] = {{"tracks", all_tracks.size()}, {"points", cloud.size()}};
  return static_cast<int>(cloud.size());
}

}  // namespace crop4d::pipeline
