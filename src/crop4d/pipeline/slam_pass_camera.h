#pragma once

// The camera's part of a slam pass (slam_pass.h): the front end on the pass's images (features,
// matches, tracks; features.bin caches them), its tracks as the back end takes them, and the
// pass's sparse cloud with the observations behind it (landmarks.ply, tracks.bin).

#include <nlohmann/json.hpp>
#include <vector>

#include "crop4d/features/front_end.h"
#include "crop4d/geometry/rigid.h"
#include "crop4d/pipeline/slam_pass.h"
#include "crop4d/slam/row_optimiser.h"
#include "crop4d/slam/triangulation.h"

namespace crop4d::pipeline {

// The pass's images through the front end and the tracks it kept, as the back end takes them.
struct PassFrontEnd {
  features::FrontEnd::Result front;
  std::vector<slam::LandmarkTrack> tracks;
  double seconds = 0;
};

// Runs the front end on the images at the pass's state times (job.streams.camera must be set);
// its counts go to summary.json's "front_end".
PassFrontEnd RunFrontEnd(const PassJob& job, nlohmann::json* summary);

// Every track of two or more images of the front end's pairs (the output cloud, the visual
// initial guess and the soil's depth use them).
std::vector<features::Track> AllTracks(const features::FrontEnd::Result& front);

// Front-end tracks as the back end takes them: the keypoints that observe each and their mean
// colour.
std::vector<slam::LandmarkTrack> ToLandmarkTracks(
    const std::vector<features::Track>& tracks, const std::vector<features::FeatureSet>& features);

// Writes the pass's cloud (landmarks.ply: the `all_tracks` triangulated from the final `cameras`)
// and the observations behind its landmarks and cloud points (tracks.bin, pass_files.h); the
// counts go to summary.json's "cloud". Returns the number of cloud points.
int WritePassCloud(const PassJob& job, const PassFrontEnd& front_end,
                   const std::vector<features::Track>& all_tracks,
                   const std::vector<geometry::Rigid3>& cameras,
                   const slam::RowOptimiser::Result& result, nlohmann::json* summary);

}  // namespace crop4d::pipeline
