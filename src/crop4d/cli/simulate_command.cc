// crop4d simulate: make a synthetic field (docs/simulator.md).
//
//   crop4d simulate --preset {tiny,demo,paper} [--realism {real,ideal}] [--config FILE.yaml]
//                   [--seed N] [--depth] [--force] --out FIELD
//   crop4d simulate --print-config [--preset P] [--config FILE.yaml]

#include <spdlog/spdlog.h>

#include <cstdint>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>

#include "crop4d/cli/command.h"
#include "crop4d/core/error.h"
#include "crop4d/core/timestamp.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::cli {

RunFunction SetupSimulate(CLI::App& app) {
  struct Args {
    std::string preset = "demo";
    std::string config_file;
    // The field a user simulates has the imperfections of real rigs unless asked for the
    // perfect world; sim::PresetConfig (the tests' presets) stays ideal.
    std::string realism = "real";
    std::optional<std::uint64_t> seed;
    bool depth = false;
    bool print_config = false;
    bool force = false;
    std::string out;
  };
  auto args = std::make_shared<Args>();
  app.add_option("--preset", args->preset,
                 "Starting configuration: tiny (tests, seconds), demo (make demo), paper (the "
                 "scale of Dong et al. 2017: 21 rows x 150 m, 23 sessions)")
      ->check(CLI::IsMember(sim::PresetNames()))
      ->capture_default_str();
  app.add_option("--realism", args->realism,
                 "Set every imperfection of real rigs at once (the `realism` key): real (soil "
                 "change, wind, standstills, calibration and clock errors, image noise and "
                 "blur, IMU and GPS faults) or ideal (none: the perfect world); applied to the "
                 "preset before --config")
      ->check(CLI::IsMember(sim::RealismLevels()))
      ->capture_default_str();
  app.add_option("--config", args->config_file,
                 "YAML file whose keys override the preset's (same keys as --print-config)");
  app.add_option("--seed", args->seed, "Master seed (overrides the configuration's seed)");
  app.add_flag("--depth", args->depth,
               "Also write a depth map per image: ground_truth/<session>/cam0_depth/<ts>.png, "
               "16-bit, millimetres");
  app.add_flag("--print-config", args->print_config,
               "Print the effective configuration as commented YAML and exit");
  app.add_flag("--force", args->force,
               "Replace the field in a non-empty --out folder (deletes its field.yaml, "
               "sessions/ and ground_truth/)");
  app.add_option("--out", args->out, "Field folder to write");

  return [args]() -> int {
    sim::SimConfig config = sim::PresetConfig(args->preset);
    sim::ApplyRealism(args->realism, &config);
    if (!args->config_file.empty()) sim::LoadSimConfigFile(args->config_file, &config);
    if (args->seed) config.seed = *args->seed;
    if (args->depth) config.ground_truth.depth = true;
    config.Check();
    if (args->print_config) {
      const std::string yaml = sim::SimConfigToYaml(config, args->preset);
      std::fwrite(yaml.data(), 1, yaml.size(), stdout);
      return 0;
    }
    if (args->out.empty()) {
      throw InputError("simulate needs --out FIELD (or --print-config to show the configuration)");
    }
    sim::PrepareOutputFolder(args->out, args->force);
    sim::Simulator simulator(config);
    spdlog::info(
        "simulate: field \"{}\", {} rows x {} m, {} sessions, {}x{} images, seed {}, realism {}",
        config.name, config.world.num_rows, config.world.row_length_m, config.sessions.size(),
        config.camera.width, config.camera.height, config.seed, config.realism);
    const sim::Simulator::Summary summary = simulator.Write(args->out);
    spdlog::info(
        "simulate: wrote {} in {}: {} sessions, {} images ({:.1f} img/s, rendering {:.0f}% of "
        "the time), {} IMU, {} magnetometer and {} GPS samples",
        args->out, FormatDuration(summary.total_seconds), summary.sessions, summary.images,
        summary.FramesPerSecond(),
        summary.total_seconds > 0 ? 100.0 * summary.render_seconds / summary.total_seconds : 0.0,
        summary.imu_samples, summary.mag_samples, summary.gps_samples);
    return 0;
  };
}

}  // namespace crop4d::cli
