// Contact sheets of the simulated field for docs/simulator.md: the same spot of the demo field
// seen from the same camera pose in four sessions over the season (growth), and one session
// after rain next to the dry session of the same date (soil).
//
//   build/release/bench/sim_contact_sheet docs/images
//
// writes OUT/sim_growth.png and OUT/sim_rain.png (tiles of 360x270, colours quantised, PNG < 500 KB
// each).

#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "crop4d/core/error.h"
#include "crop4d/core/progress.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace {

using namespace crop4d;

constexpr int kTileWidth = 360, kTileHeight = 270;
constexpr int kColorStep = 8;  // colours quantised to 32 levels per channel: smaller PNGs

cv::Mat Tile(const cv::Mat& image, const std::string& label) {
  cv::Mat tile;
  cv::resize(image, tile, cv::Size(kTileWidth, kTileHeight), 0, 0, cv::INTER_AREA);
  tile.forEach<cv::Vec3b>([](cv::Vec3b& p, const int*) {
    for (int c = 0; c < 3; ++c)
      p[c] = static_cast<uchar>(p[c] / kColorStep * kColorStep + kColorStep / 2);
  });
  cv::rectangle(tile, cv::Rect(0, 0, kTileWidth, 26), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(tile, label, cv::Point(8, 19), cv::FONT_HERSHEY_SIMPLEX, 0.55,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return tile;
}

void Write(const std::string& path, const cv::Mat& image) {
  if (!cv::imwrite(path, image, {cv::IMWRITE_PNG_COMPRESSION, 9})) {
    throw std::runtime_error("cannot write " + path);
  }
  std::printf("wrote %s\n", path.c_str());
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
    return 2;
  }
  const std::string out = argv[1];
  Progress::SetGloballySilent(true);
  try {
    sim::SimConfig config = sim::PresetConfig("demo");
    // Four dates over the season (0, 1, 3, 4) and, the day after the second, a session after
    // rain (2).
    config.sessions = {{"2016-05-25", false},
                       {"2016-06-15", false},
                       {"2016-06-16", true},
                       {"2016-07-06", false},
                       {"2016-07-27", false}};
    config.recording.start_jitter_h = 0.0;
    config.recording.brightness_jitter = 0.0;
    const sim::Simulator simulator(config);

    // The camera pose: a third of the way along the first row pass.
    const sim::SessionRecord first = simulator.SimulateSession(0);
    const sim::Pass& pass = first.trajectory->passes().front();
    const double t = pass.t_begin + 0.35 * (pass.t_end - pass.t_begin);
    const geometry::Rigid3 world_from_camera =
        first.trajectory->WorldFromBody(t) * simulator.BodyFromCamera();

    sim::RenderOptions options;
    options.camera = config.camera.Intrinsics();
    sim::Renderer renderer(simulator.world(), options);
    std::vector<cv::Mat> tiles;
    for (int i = 0; i < static_cast<int>(config.sessions.size()); ++i) {
      const sim::SessionConditions conditions = simulator.ConditionsOf(i);
      renderer.SetSession(conditions);
      cv::Mat bgr;
      renderer.Render(world_from_camera, &bgr);
      const double days = simulator.world().DaysAfterSowing(conditions.date);
      tiles.push_back(Tile(bgr, config.sessions[i].date + "  (day " +
                                    std::to_string(static_cast<int>(days)) + ")" +
                                    (conditions.rain_before ? "  after rain" : "")));
    }
    cv::Mat top, bottom, growth, rain;
    cv::hconcat(tiles[0], tiles[1], top);
    cv::hconcat(tiles[3], tiles[4], bottom);
    cv::vconcat(top, bottom, growth);
    Write(out + "/sim_growth.png", growth);

    // The dry session of 2016-06-15 next to the rainy one a day later (same plants, new soil).
    cv::hconcat(tiles[1], tiles[2], rain);
    Write(out + "/sim_rain.png", rain);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
