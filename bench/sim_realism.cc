// The imperfect world of the simulator next to the ideal one (issue 26): for every session of
// the demo preset, what `realism: real` changes in the sensor data (standstills, camera clock,
// GPS outliers, RTK float and dropouts), in the images (exposure gain, motion blur, noise,
// wind) and in the soil between sessions; and a contact sheet of the same camera pose in two
// consecutive sessions, ideal and real.
//
//   build/release/bench/sim_realism [OUT_DIR]
//
// prints two tables (bench/RESULTS.md, "Simulator: the imperfect world") and, with OUT_DIR,
// writes OUT_DIR/sim_realism.jpg. Sensor figures come from Simulator::SimulateSession exactly
// as `crop4d simulate` writes them; the image figures apply the simulator's image functions
// (MotionBlur, AutoExposureGain, ExposeAndQuantise) to one rendered frame per session.

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "crop4d/core/progress.h"
#include "crop4d/sim/imperfections.h"
#include "crop4d/sim/random.h"
#include "crop4d/sim/renderer.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"
#include "crop4d/sim/textures.h"

namespace {

using namespace crop4d;

double ShareOf(const std::vector<sim::GpsFault>& faults, bool sim::GpsFault::*flag) {
  if (faults.empty()) return 0.0;
  double n = 0;
  for (const sim::GpsFault& f : faults) n += f.*flag;
  return n / faults.size();
}

// Mean gradient magnitude of the grey image (a sharpness measure).
double Sharpness(const cv::Mat& bgr) {
  cv::Mat grey, gx, gy, magnitude;
  cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
  grey.convertTo(grey, CV_32F);
  cv::Sobel(grey, gx, CV_32F, 1, 0);
  cv::Sobel(grey, gy, CV_32F, 0, 1);
  cv::magnitude(gx, gy, magnitude);
  return cv::mean(magnitude)[0];
}

cv::Mat Tile(const cv::Mat& image, const std::string& label) {
  cv::Mat tile;
  cv::resize(image, tile, cv::Size(480, 360), 0, 0, cv::INTER_AREA);
  cv::rectangle(tile, cv::Rect(0, 0, 480, 26), cv::Scalar(0, 0, 0), cv::FILLED);
  cv::putText(tile, label, cv::Point(8, 19), cv::FONT_HERSHEY_SIMPLEX, 0.55,
              cv::Scalar(255, 255, 255), 1, cv::LINE_AA);
  return tile;
}

}  // namespace

int main(int argc, char** argv) {
  Progress::SetGloballySilent(true);
  try {
    const sim::SimConfig ideal_config = sim::PresetConfig("demo");
    sim::SimConfig real_config = ideal_config;
    sim::ApplyRealism("real", &real_config);
    const sim::Simulator ideal(ideal_config), real(real_config);
    const int sessions = static_cast<int>(ideal_config.sessions.size());

    std::printf("Sensors, demo preset (seed %llu), ideal -> real:\n\n",
                static_cast<unsigned long long>(ideal_config.seed));
    std::printf(
        "| session | duration s | standstill s (stops) | images | stamp - capture ms | "
        "gps0 samples | gps0 RTK float %% | gps0 outliers %% | gps1 samples | gps1 "
        "outliers %% |\n|---|---|---|---|---|---|---|---|---|---|\n");
    std::vector<sim::SessionRecord> ideal_records, real_records;
    for (int i = 0; i < sessions; ++i) {
      ideal_records.push_back(ideal.SimulateSession(i));
      real_records.push_back(real.SimulateSession(i));
      const sim::SessionRecord& a = ideal_records.back();
      const sim::SessionRecord& b = real_records.back();
      double still = 0.0;
      for (const sim::Standstill& s : b.trajectory->standstills()) still += s.t_end - s.t_begin;
      double offset_min = 1e9, offset_max = -1e9;
      for (size_t k = 0; k < b.image_times.size(); ++k) {
        const double d = 1e3 * DurationSeconds(b.image_capture_times[k], b.image_times[k]);
        offset_min = std::min(offset_min, d);
        offset_max = std::max(offset_max, d);
      }
      std::printf(
          "| %s | %.0f -> %.0f | %.1f (%zu) | %zu -> %zu | %.2f .. %.2f | %zu -> %zu | %.1f | "
          "%.1f | %zu -> %zu | %.1f |\n",
          ideal_config.sessions[i].date.c_str(), a.trajectory->Duration(), b.trajectory->Duration(),
          still, b.trajectory->standstills().size(), a.image_times.size(), b.image_times.size(),
          offset_min, offset_max, a.gps[0].size(), b.gps[0].size(),
          100.0 * ShareOf(b.gps_faults[0], &sim::GpsFault::is_float),
          100.0 * ShareOf(b.gps_faults[0], &sim::GpsFault::outlier), a.gps[1].size(),
          b.gps[1].size(), 100.0 * ShareOf(b.gps_faults[1], &sim::GpsFault::outlier));
    }
    const sim::CalibrationErrors& e = real.calibration_errors();
    std::printf(
        "\nCalibration written to the dataset vs truth: fx %+.2f px, fy %+.2f px, principal point "
        "(%+.2f, %+.2f) px, k1 %+.4f, k2 %+.4f, T_BS rotation %.2f deg, camera lever arm %.1f mm, "
        "time offset %+.1f ms, drift %+.0f ppm\n",
        e.dfx, e.dfy, e.dcx, e.dcy, e.dk1, e.dk2, e.camera_rotation.norm() * 180.0 / M_PI,
        1e3 * e.camera_translation.norm(), 1e3 * e.time_offset_s, 1e6 * e.drift);

    // Images: one frame per session at the same pose (a third along the first pass of the
    // first session), ideal and real.
    const sim::SessionRecord& first = ideal_records[0];
    const sim::Pass& pass = first.trajectory->passes().front();
    const double t = pass.t_begin + 0.35 * (pass.t_end - pass.t_begin);
    const geometry::Rigid3 world_from_camera =
        first.trajectory->WorldFromBody(t) * ideal.BodyFromCamera();
    const sim::BodyState state = first.trajectory->StateAt(t);
    // The real frame moves as the vehicle does at that instant during the exposure.
    const double exposure = real_config.image.exposure_s;
    auto camera_at = [&](double dt) {
      return first.trajectory->WorldFromBody(t + dt) * ideal.BodyFromCamera();
    };
    const geometry::Rigid3 begin_from_mid =
        camera_at(-0.5 * exposure).Inverse() * world_from_camera;
    const geometry::Rigid3 end_from_mid = camera_at(0.5 * exposure).Inverse() * world_from_camera;

    sim::RenderOptions options;
    options.camera = ideal_config.camera.Intrinsics();
    sim::Renderer renderer(ideal.world(), options);
    std::printf("\nImages, one frame per session at the same pose (%.2f m/s), ideal -> real:\n\n",
                state.velocity_world.norm());
    std::printf(
        "| session | soil renewed since the previous session %% | soil level | wind sway "
        "mm | exposure gain over the session | gain of this frame | mean abs diff (grey) "
        "| sharpness ideal -> real |\n|---|---|---|---|---|---|---|---|\n");
    std::vector<cv::Mat> tiles;
    cv::Mat previous_soil;
    for (int i = 0; i < sessions; ++i) {
      const sim::SessionConditions ci = ideal.ConditionsOf(i), cr = real.ConditionsOf(i);
      cv::Mat a, b, depth;
      renderer.SetSession(ci);
      renderer.SetTime(t);
      renderer.Render(world_from_camera, &a);
      renderer.SetSession(cr);
      renderer.Render(world_from_camera, &b, &depth);
      const std::uint64_t seed = sim::HashCombine(real_config.seed, 0xbe4c, i);
      double gain_min = 10, gain_max = 0;
      const sim::SessionRecord& rec = real_records[i];
      for (const Timestamp capture : rec.image_capture_times) {
        const double g = sim::AutoExposureGain(real_config.image, seed, rec.Seconds(capture));
        gain_min = std::min(gain_min, g);
        gain_max = std::max(gain_max, g);
      }
      const double gain = sim::AutoExposureGain(real_config.image, seed, t);
      b = sim::ExposeAndQuantise(
          sim::MotionBlur(b, depth, options.camera, begin_from_mid, end_from_mid), gain,
          real_config.image, seed);
      // The soil texture's change since the previous session (a 512² crop of the same texel
      // size as the renderer's).
      sim::SoilTextureOptions soil;
      soil.size_px = 512;
      soil.extent_m = 0.5;
      soil.seed = real.world().options().seed;
      soil.epoch = cr.soil_epoch;
      const cv::Mat soil_now = sim::ApplySoilChange(soil, sim::GenerateSoilTexture(soil),
                                                    cr.soil_change_level, cr.soil_change);
      double renewed = 100.0;
      if (!previous_soil.empty() && !cr.rain_before) {
        cv::Mat diff;
        cv::absdiff(soil_now, previous_soil, diff);
        cv::Mat grey;
        cv::cvtColor(diff, grey, cv::COLOR_BGRA2GRAY);
        // Texels changed beyond the drying tone (a few grey levels).
        renewed = 100.0 * cv::countNonZero(grey > 6) / grey.total();
      }
      previous_soil = soil_now;
      char renewed_text[32];
      std::snprintf(renewed_text, sizeof renewed_text, "%.1f", renewed);
      std::printf("| %s | %s | %d | %.1f | %.2f .. %.2f | %.2f | %.1f | %.1f -> %.1f |\n",
                  ideal_config.sessions[i].date.c_str(),
                  i == 0 ? "-" : (cr.rain_before ? "100 (rain)" : renewed_text),
                  cr.soil_change_level, 1e3 * cr.wind_sway_m, gain_min, gain_max, gain,
                  cv::norm(a, b, cv::NORM_L1) / (a.total() * 3), Sharpness(a), Sharpness(b));
      if (argc > 1 && i < 2) {
        tiles.push_back(Tile(a, ideal_config.sessions[i].date + "  ideal"));
        tiles.push_back(Tile(b, ideal_config.sessions[i].date + "  real"));
      }
    }
    if (argc > 1) {
      cv::Mat top, bottom, sheet;
      cv::hconcat(tiles[0], tiles[1], top);
      cv::hconcat(tiles[2], tiles[3], bottom);
      cv::vconcat(top, bottom, sheet);
      // JPEG: the noise of the real images makes a PNG of them large.
      const std::string path = std::string(argv[1]) + "/sim_realism.jpg";
      if (!cv::imwrite(path, sheet, {cv::IMWRITE_JPEG_QUALITY, 90})) {
        throw std::runtime_error("cannot write " + path);
      }
      std::printf("\nwrote %s\n", path.c_str());
    }
  } catch (const std::exception& e) {
    std::fprintf(stderr, "error: %s\n", e.what());
    return 1;
  }
  return 0;
}
