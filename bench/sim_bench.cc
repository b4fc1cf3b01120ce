// Throughput of the simulator's image pipeline: frames rendered (EGL/OpenGL, Mesa llvmpipe on
// the CPU), PNG-encoded and written per second, at 640x480 and 1280x960, in the demo field's
// last session (the largest plants). One session of `kSeconds` of driving per run; the renderer's
// start-up and Renderer::SetSession are reported apart ("setup_s"). Results: bench/RESULTS.md.
//
//   taskset -c 0,1 build/release/bench/sim_bench

#include <benchmark/benchmark.h>

#include <filesystem>

#include "crop4d/core/progress.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace {

namespace fs = std::filesystem;
using crop4d::sim::SimConfig;
using crop4d::sim::Simulator;

constexpr double kSeconds = 8.0;  // 60 images at 7.5 Hz

void BM_SimulateImages(benchmark::State& state) {
  crop4d::Progress::SetGloballySilent(true);
  SimConfig config = crop4d::sim::PresetConfig("demo");
  config.sessions = {config.sessions.back()};
  const int width = static_cast<int>(state.range(0));
  const double scale = width / static_cast<double>(config.camera.width);
  config.camera.width = width;
  config.camera.height = static_cast<int>(state.range(1));
  config.camera.fx *= scale;
  config.camera.fy *= scale;
  config.camera.cx *= scale;
  config.camera.cy *= scale;
  config.drive.max_duration_s = kSeconds;
  config.ground_truth.depth = state.range(2) != 0;
  const fs::path dir = fs::temp_directory_path() / "crop4d_sim_bench";
  Simulator::Summary summary;
  for (auto _ : state) {
    state.PauseTiming();
    fs::remove_all(dir);
    state.ResumeTiming();
    Simulator simulator(config);
    summary = simulator.Write(dir.string());
    state.SetIterationTime(summary.images_seconds);
  }
  fs::remove_all(dir);
  state.counters["images"] = static_cast<double>(summary.images);
  state.counters["fps"] = summary.FramesPerSecond();
  state.counters["render_fps"] =
      summary.render_seconds > 0 ? summary.images / summary.render_seconds : 0.0;
  state.counters["setup_s"] = summary.setup_seconds;
  state.SetLabel(std::to_string(config.camera.width) + "x" + std::to_string(config.camera.height) +
                 (config.ground_truth.depth ? " +depth" : ""));
}

BENCHMARK(BM_SimulateImages)
    ->ArgNames({"width", "height", "depth"})
    ->Args({640, 480, 0})
    ->Args({1280, 960, 0})
    ->Args({640, 480, 1})
    ->UseManualTime()
    ->Iterations(1)
    ->Unit(benchmark::kSecond);

}  // namespace

BENCHMARK_MAIN();
