#include "crop4d/slam/track_cloud.h"

#include <tbb/parallel_for.h>

#include "crop4d/core/error.h"

namespace crop4d::slam {

std::vector<TriangulationResult> TriangulateTracks(
    const geometry::PinholeRadTan& camera, const std::vector<geometry::Rigid3>& world_from_camera,
    const std::vector<LandmarkTrack>& tracks, const TriangulationOptions& options) {
  std::vector<TriangulationResult> tri(tracks.size());
  tbb::parallel_for(std::size_t{0}, tracks.size(), [&](std::size_t i) {
    std::vector<geometry::Rigid3> views;
    std::vector<Eigen::Vector2d> pixels;
    for (const LandmarkObservation& o : tracks[i].observations) {
      CROP4D_CHECK_MSG(o.state >= 0 && o.state < static_cast<int>(world_from_camera.size()),
                       "TriangulateTracks: an observation of an image without a pose");
      views.push_back(world_from_camera[o.state]);
      pixels.push_back(o.pixel);
    }
    tri[i] = TriangulatePoint(camera, views, pixels, options);
  });
  return tri;
}

TrackCloud TriangulateTrackCloud(const geometry::PinholeRadTan& camera,
                                 const std::vector<geometry::Rigid3>& world_from_camera,
                                 const std::vector<LandmarkTrack>& tracks,
                                 const TriangulationOptions& options) {
  const std::vector<TriangulationResult> tri =
      TriangulateTracks(camera, world_from_camera, tracks, options);
  TrackCloud cloud;
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    if (!tri[i].ok()) continue;
    cloud.points_world.push_back(tri[i].point_world);
    cloud.colors.push_back(tracks[i].color);
    cloud.track_lengths.push_back(static_cast<int>(tracks[i].observations.size()));
    cloud.reprojection_errors_px.push_back(tri[i].mean_reprojection_error_px);
    cloud.track_indices.push_back(static_cast<int>(i));
  }
  return cloud;
}

}  // namespace crop4d::slam
