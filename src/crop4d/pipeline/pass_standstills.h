#pragma once

// Where a row pass stands still (slam/standstill.h), from every sensor the pass has: the IMU's
// quiet intervals, the image motion between consecutive images (the front end's matches), and
// the speed of the GPS track.

#include <optional>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/features/front_end.h"
#include "crop4d/slam/session_streams.h"
#include "crop4d/slam/standstill.h"

namespace crop4d::pipeline {

// The median displacement of the putative matches between images k and k + 1 of the front end's
// result, px, per consecutive pair (size num_images − 1; unset where the pair was not matched or
// has fewer than 8 matches).
std::vector<std::optional<double>> ConsecutiveImageMotion(const features::FrontEnd::Result& front,
                                                          std::size_t num_images);

// Per interval between consecutive states (times): whether the rig stands still over it.
// `front` (null: no camera) holds one image per state; `gps` (null or empty: none) gives the
// track's speed and should be a precise receiver's (a metre-level track's speed is too noisy to
// tell a standstill).
std::vector<bool> DetectPassStandstills(const std::vector<Timestamp>& times,
                                        const slam::ImuStream& imu,
                                        const features::FrontEnd::Result* front,
                                        const std::vector<slam::GpsFixWorld>* gps,
                                        const slam::StandstillOptions& options);

}  // namespace crop4d::pipeline
