// libFuzzer target: the YAML helper layer and every metadata reader (field.yaml, session.yaml,
// the four sensor.yaml kinds) on arbitrary bytes. Bad input must end as an InputError or a
// diagnostic, never as a crash, a hang or another exception.

#include <unistd.h>

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <string>

#include "crop4d/core/error.h"
#include "crop4d/io/dataset_reader.h"
#include "crop4d/io/yaml_util.h"

using namespace crop4d::io;

namespace {

// One scratch folder per fuzzing process: <tmp>/crop4d_yaml_fuzz_<pid>/cam0/sensor.yaml etc.
std::string ScratchFile(const std::string& sensor) {
  static const std::filesystem::path root =
      std::filesystem::temp_directory_path() / ("crop4d_yaml_fuzz_" + std::to_string(::getpid()));
  const std::filesystem::path folder = root / sensor;
  std::filesystem::create_directories(folder);
  return (folder / "sensor.yaml").string();
}

template <typename Read>
void Try(Read read) {
  Diagnostics diag;
  try {
    read(&diag);
  } catch (const crop4d::InputError&) {
    // Expected for bad input; the message names the file.
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  // The helper layer straight from memory: read a few keys of every type.
  Try([&](Diagnostics* diag) {
    YamlFile file("mem.yaml", text, diag);
    YamlMap root = file.Root();
    double d = 0;
    int i = 0;
    std::string s;
    bool b = false;
    std::vector<double> v;
    root.Get("rate_hz", &d, YamlMap::kRequired);
    root.Get("index", &i, YamlMap::kOptional);
    root.Get("name", &s, YamlMap::kOptional);
    root.Get("rain_before", &b, YamlMap::kOptional);
    root.Get("intrinsics", &v, 4, 4, YamlMap::kOptional);
    if (std::optional<YamlMap> origin = root.GetMap("origin", YamlMap::kOptional)) {
      origin->Get("lat", &d, YamlMap::kRequired);
      origin->WarnUnknownKeys();
    }
    root.GetSequence("sites", YamlMap::kOptional);
    root.WarnUnknownKeys();
    file.Finish();
  });
  // Every metadata reader, from a file.
  const std::string path = ScratchFile("cam0");
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out.write(text.data(), static_cast<std::streamsize>(text.size()));
  }
  Try([&](Diagnostics* diag) { ReadFieldYaml(path, diag); });
  Try([&](Diagnostics* diag) { ReadSessionYaml(path, "2016-05-25", diag); });
  Try([&](Diagnostics* diag) { ReadCameraSensorYaml(path, diag); });
  Try([&](Diagnostics* diag) { ReadImuSensorYaml(path, diag); });
  Try([&](Diagnostics* diag) { ReadMagSensorYaml(path, diag); });
  Try([&](Diagnostics* diag) { ReadGpsSensorYaml(path, diag); });
  return 0;
}
