#pragma once

// Test helper: a simulated field written once per build tree, into
// CROP4D_BINARY_DIR/test_data/<name>, and shared by the tests that use it (under ctest each test
// is its own process). It is written to a temporary folder and renamed into place, so that
// concurrent tests never see a half-written field; a process that loses the race keeps the
// winner's field. The folder holds the configuration it was simulated from (sim_config.yaml):
// a test asking for another configuration under the same name gets it simulated again. A change
// of the simulator's code is not detected: delete build/*/test_data after one.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::sim::testing {

inline std::string CachedSimulatedField(const std::string& name, const SimConfig& config) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(CROP4D_BINARY_DIR) / "test_data" / name;
  const std::string yaml = SimConfigToYaml(config);
  const auto cached = [&] {
    std::ifstream in(folder / "sim_config.yaml");
    std::ostringstream text;
    text << in.rdbuf();
    return fs::exists(folder / "field.yaml") && in && text.str() == yaml;
  };
  if (cached()) return folder.string();
  const fs::path tmp = folder.string() + ".tmp." + std::to_string(getpid());
  fs::remove_all(tmp);
  Simulator(config).Write(tmp.string());
  std::ofstream(tmp / "sim_config.yaml") << yaml;
  fs::create_directories(folder.parent_path());
  std::error_code ec;
  if (!cached()) fs::remove_all(folder, ec);  // a stale field of another configuration
  fs::rename(tmp, folder, ec);
  fs::remove_all(tmp);
  return folder.string();
}

// The tiny preset's first session (two row passes of ~50 images at 320×240), simulated once per
// build tree: the field of the row-SLAM stage tests.
inline const std::string& TinyOneSessionField() {
  static const std::string path = [] {
    SimConfig config = PresetConfig("tiny");
    config.sessions.resize(1);
    return CachedSimulatedField("tiny_one_session", config);
  }();
  return path;
}

}  // namespace crop4d::sim::testing
