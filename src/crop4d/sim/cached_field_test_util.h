#pragma once

// Test helpers: test data (a simulated field, a workspace) made once per build tree and shared by
// the tests that use it (under ctest each test is its own process, and making it again in each
// would be most of their time). It is written to a temporary folder and renamed into place, so
// that concurrent tests never see a half-written folder.

#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <sstream>
#include <string>

#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/sim_version.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::sim::testing {

// A folder of test data made once per build tree, in CROP4D_BINARY_DIR/test_data/<name>, and
// shared by the tests that use it: `make` fills the folder it is given (returns false when it
// failed), which is then renamed into place with `key` (what it was made from) in
// cache_key.txt. A test asking with another key gets it made again. A lock on the folder makes
// concurrent tests wait for the one that makes it rather than make it twice.
inline std::string CachedTestFolder(const std::string& name, const std::string& key,
                                    const std::function<bool(const std::string&)>& make) {
  namespace fs = std::filesystem;
  const fs::path folder = fs::path(CROP4D_BINARY_DIR) / "test_data" / name;
  fs::create_directories(folder.parent_path());
  const int lock = ::open((folder.string() + ".lock").c_str(), O_CREAT | O_RDWR, 0644);
  if (lock >= 0) ::flock(lock, LOCK_EX);
  const auto cached = [&] {
    std::ifstream in(folder / "cache_key.txt");
    std::ostringstream text;
    text << in.rdbuf();
    return in && text.str() == key;
  };
  if (!cached()) {
    const fs::path tmp = folder.string() + ".tmp." + std::to_string(getpid());
    fs::remove_all(tmp);
    fs::create_directories(tmp);
    if (make(tmp.string())) {
      std::ofstream(tmp / "cache_key.txt") << key;
      std::error_code ec;
      fs::remove_all(folder, ec);  // a stale folder (another key)
      fs::rename(tmp, folder, ec);
    }
    fs::remove_all(tmp);
  }
  if (lock >= 0) ::close(lock);  // (releases the lock)
  return folder.string();
}

// What identifies a built file (a program whose outputs a cached folder holds): its size and
// modification time.
inline std::string BuiltFileStamp(const std::string& path) {
  namespace fs = std::filesystem;
  return std::to_string(fs::file_size(path)) + " " +
         std::to_string(fs::last_write_time(path).time_since_epoch().count());
}

// A simulated field (CachedTestFolder) of `config`; made again when the configuration or the
// simulator's version (a hash of the sim module's sources made at build time,
// cmake/crop4d_sim_version.cmake) changes, so no test runs on a stale field.
inline std::string CachedSimulatedField(const std::string& name, const SimConfig& config) {
  const std::string key =
      SimConfigToYaml(config) + "\nsimulator " + std::string(CROP4D_SIMULATOR_VERSION) + "\n";
  return CachedTestFolder(name, key, [&](const std::string& folder) {
    Simulator(config).Write(folder);
    return true;
  });
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
