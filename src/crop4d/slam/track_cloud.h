#pragma once

// A coloured sparse cloud from feature tracks: every track (its images, keypoints and mean
// colour: a LandmarkTrack) triangulated from given camera poses (TriangulatePoint, in
// parallel), keeping the points that pass the triangulation checks with their colour, track
// length and reprojection error. Row SLAM writes each pass's cloud this way from its final
// poses; 4D fusion re-triangulates the same tracks from the fused poses.

#include <array>
#include <cstdint>
#include <vector>

#include "crop4d/geometry/camera.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::slam {

struct TrackCloud {
  // One entry per triangulated track, in the order of the tracks.
  std::vector<Eigen::Vector3d> points_world;
  // The colour of the point's track (LandmarkTrack::color).
  std::vector<std::array<std::uint8_t, 3>> colors;
  // The track's number of images and its mean reprojection error, px.
  std::vector<int> track_lengths;
  std::vector<double> reprojection_errors_px;
  // The index of each point's track.
  std::vector<int> track_indices;

  std::size_t size() const { return points_world.size(); }
};

// Every track triangulated from `world_from_camera` (one per image: the tracks' `state` is the
// image index). Threads: TBB (the caller's arena); the result does not depend on them.
std::vector<TriangulationResult> TriangulateTracks(
    const geometry::PinholeRadTan& camera, const std::vector<geometry::Rigid3>& world_from_camera,
    const std::vector<LandmarkTrack>& tracks, const TriangulationOptions& options);

// The tracks that triangulate (TriangulateTracks), with their colours.
TrackCloud TriangulateTrackCloud(const geometry::PinholeRadTan& camera,
                                 const std::vector<geometry::Rigid3>& world_from_camera,
                                 const std::vector<LandmarkTrack>& tracks,
                                 const TriangulationOptions& options);

}  // namespace crop4d::slam
