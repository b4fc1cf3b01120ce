#pragma once

// Test helper: a simulated field written once per build tree, into
// CROP4D_BINARY_DIR/test_data/<name>, and shared by the tests that use it (under ctest each test
// is its own process). It is written to a temporary folder and renamed into place, so that
// concurrent tests never see a half-written field; a process that loses the race keeps the
// winner's field. The folder holds the configuration it was simulated from (sim_config.yaml) and
// the simulator's version (simulator_version.txt: a hash of the sim module's sources made at
// build time, cmake/crop4d_sim_version.cmake): a test asking for another configuration, or built
// with a changed simulator, gets the field simulated again, so no test runs on a stale field.

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/sim_version.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::sim::testing {

inline std::string CachedSimulatedField(const std::string& name, const SimConfig& config) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(CROP4D_BINARY_DIR) / "test_data" / name;
  const std::string yaml = SimConfigToYaml(config);
  const std::string version = CROP4D_SIMULATOR_VERSION;
  const auto holds = [&](const char* file, const std::string& expected) {
    std::ifstream in(folder / file);
    std::ostringstream text;
    text << in.rdbuf();
    return in && text.str() == expected;
  };
  const auto cached = [&] {
    return fs::exists(folder / "field.yaml") && holds("sim_config.yaml", yaml) &&
           holds("simulator_version.txt", version);
  };
  if (cached()) return folder.string();
  const fs::path tmp = folder.string() + ".tmp." + std::to_string(getpid());
  fs::remove_all(tmp);
  Simulator(config).Write(tmp.string());
  std::ofstream(tmp / "sim_config.yaml") << yaml;
  std::ofstream(tmp / "simulator_version.txt") << version;
  fs::create_directories(folder.parent_path());
  std::error_code ec;
  if (!cached()) fs::remove_all(folder, ec);  // a stale field (other configuration or simulator)
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
