// libFuzzer target: `crop4d import --bag` on arbitrary bytes. The bytes become a .bag file that
// is imported into a scratch field (every topic picked automatically, and a calibration given
// for cam0 so that images are decoded and written). Whatever the input, the import must either
// succeed or throw InputError: any other exception, a crash, a hang or a leak is a finding.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/io/rosbag/bag_import.h"

namespace fs = std::filesystem;
using namespace crop4d;

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  static const fs::path scratch =
      fs::temp_directory_path() / ("crop4d_bag_fuzz_" + std::to_string(::getpid()));
  std::error_code ec;
  fs::remove_all(scratch, ec);
  fs::create_directories(scratch);
  const fs::path bag = scratch / "input.bag";
  {
    std::ofstream out(bag, std::ios::binary);
    out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  }
  io::BagImportOptions options;
  options.bag_path = bag.string();
  options.field_folder = (scratch / "field").string();
  io::CameraSensor camera;
  camera.camera.width = 8;
  camera.camera.height = 6;
  camera.camera.fx = camera.camera.fy = 10;
  camera.camera.cx = 4;
  camera.camera.cy = 3;
  options.cameras["cam0"] = camera;
  try {
    io::ImportBag(options);
  } catch (const InputError&) {
    // Bad input is expected; anything else escapes and libFuzzer reports it.
  }
  fs::remove_all(scratch, ec);
  return 0;
}
