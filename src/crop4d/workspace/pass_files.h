#pragma once

// Files of a row pass that the later stages read (DESIGN.md §5, WS/sessions/<s>/rows/<pass>/):
//   tracks.bin   the pass's landmarks with the features that observe them, in two parts:
//                - `landmarks`: the landmarks of row SLAM's final solve, with the observations
//                  it kept (what the joint 4D problem re-uses per pass);
//                - `cloud`: every triangulated track of landmarks.ply, in the same order (what
//                  association projects into the other passes).
//                Observations are (image index in the pass, feature index in the feature
//                cache), so a reader finds descriptors and pixels in features.bin.
//   states.csv   the full state at every state time: world_from_body, velocity, angular rate
//                and IMU biases (the joint problem starts from them).
//
// tracks.bin layout (little-endian):
//   char[8] magic "C4DTRAK\0", u32 version (kPassTracksVersion)
//   2 × { u64 count; count × { f64 x, y, z; u8 r, g, b; u32 n; n × { i32 image, i32 feature } } }
//   u64 FNV-1a 64 checksum of every byte above
// Reading detects a missing, foreign, old, truncated or corrupt file and throws InputError
// saying which.

#include <array>
#include <cstdint>
#include <string>
#include <vector>

#include "crop4d/features/tracks.h"
#include "crop4d/slam/initialisation.h"

namespace crop4d::workspace {

inline constexpr std::uint32_t kPassTracksVersion = 1;

struct PassTrack {
  Eigen::Vector3d position_world = Eigen::Vector3d::Zero();
  std::array<std::uint8_t, 3> color{128, 128, 128};
  std::vector<features::Observation> observations;  // sorted by image

  bool operator==(const PassTrack&) const = default;
};

struct PassTracks {
  std::vector<PassTrack> landmarks;
  std::vector<PassTrack> cloud;

  bool operator==(const PassTracks&) const = default;
};

void WritePassTracks(const std::string& path, const PassTracks& tracks);
PassTracks ReadPassTracks(const std::string& path);

// states.csv: one row per state, `t [ns]` then the 22 values of slam::RowState.
void WritePassStates(const std::string& path, const std::vector<slam::RowState>& states);
std::vector<slam::RowState> ReadPassStates(const std::string& path);

}  // namespace crop4d::workspace
