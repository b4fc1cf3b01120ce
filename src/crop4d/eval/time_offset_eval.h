#pragma once

// The true camera–IMU time offset of a pass, from a simulated field's capture instants, to judge
// row SLAM's estimate (slam.estimate_time_offset, docs/slam.md). The offset follows SLAM's
// convention: capture instant − image stamp, seconds.

#include <map>
#include <optional>
#include <string>
#include <vector>

#include "crop4d/core/timestamp.h"

namespace crop4d::eval {

// The capture instant of every image stamp of ground_truth/<session>/cam0_exposure.csv
// ("#timestamp [ns],capture [ns],gain,exposure [s]"). Throws InputError naming the file and
// line for a malformed line, a missing file or a repeated stamp.
std::map<Timestamp, Timestamp> ReadCaptureInstants(const std::string& path);

// Mean of capture − stamp over the `stamps` found in `captures`, seconds; nullopt when none is.
std::optional<double> TrueTimeOffset(const std::vector<Timestamp>& stamps,
                                     const std::map<Timestamp, Timestamp>& captures);

}  // namespace crop4d::eval
