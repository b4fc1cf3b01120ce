#include "crop4d/pipeline/fuse_pass.h"

namespace crop4d::pipeline::fuse {

// The image file names of a camera stream by timestamp.
std::map<Timestamp, std::string> ImageNames(const slam::SessionStreams& streams) {
  std::map<Timestamp, std::string> names;
  if (streams.camera) {
    for (const io::ImageEntry& e : streams.camera->images) names[e.t] = e.filename;
  }
  return names;
}

// The cloud tracks of a pass (their keypoints and colours) triangulated from the given cameras
// (one per image).
slam::TrackCloud CloudOfTracks(const LoadedPass& pass, const std::vector<geometry::Rigid3>& cameras,
                               const slam::TriangulationOptions& options) {
  const workspace::PassData& data = pass.data;
  std::vector<slam::LandmarkTrack> tracks(data.tracks.cloud.size());
  for (std::size_t i = 0; i < tracks.size(); ++i) {
    for (const features::Observation& o : data.tracks.cloud[i].observations) {
      tracks[i].observations.push_back({o.image, data.features[o.image].Point(o.feature)});
    }
    tracks[i].color = data.tracks.cloud[i].color;
  }
  return slam::TriangulateTrackCloud(*pass.input.camera, cameras, tracks, options);
}

}  // namespace crop4d::pipeline::fuse
