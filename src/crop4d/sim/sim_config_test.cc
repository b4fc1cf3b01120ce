#include "crop4d/sim/sim_config.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "crop4d/core/error.h"

namespace crop4d::sim {
namespace {

// The InputError of applying `yaml` over the tiny preset (fails the test if there is none).
InputError ErrorOf(const std::string& yaml) {
  SimConfig config = PresetConfig("tiny");
  try {
    ApplySimConfigYaml("bad.yaml", yaml, &config);
  } catch (const InputError& e) {
    return e;
  }
  ADD_FAILURE() << "no error for:\n" << yaml;
  return InputError("none");
}

TEST(SimConfigTest, PresetsAreValid) {
  for (const std::string& name : PresetNames()) {
    const SimConfig c = PresetConfig(name);
    EXPECT_NO_THROW(c.Check()) << name;
    EXPECT_EQ(c.name, name);
  }
  const SimConfig tiny = PresetConfig("tiny");
  EXPECT_EQ(tiny.world.num_rows, 2);
  EXPECT_EQ(tiny.camera.width, 320);
  EXPECT_EQ(tiny.sessions.size(), 2u);
  const SimConfig demo = PresetConfig("demo");
  EXPECT_EQ(demo.camera.width, 640);
  EXPECT_EQ(demo.sessions.size(), 4u);
  int rainy = 0;
  for (const SessionSpec& s : demo.sessions) rainy += s.rain_before;
  EXPECT_EQ(rainy, 1);
  const SimConfig paper = PresetConfig("paper");
  EXPECT_EQ(paper.world.num_rows, 21);
  EXPECT_EQ(paper.world.row_length_m, 150.0);
  EXPECT_EQ(paper.camera.width, 1280);
  ASSERT_EQ(paper.sessions.size(), 23u);
  const std::vector<Timestamp> dates = paper.SessionDates();
  EXPECT_EQ((dates.back() - dates.front()) / (86400 * kNanosPerSecond), 89);
  EXPECT_THROW(PresetConfig("huge"), InputError);
}

TEST(SimConfigTest, PrintedConfigRoundTripsAndDocumentsEveryKey) {
  for (const std::string& name : PresetNames()) {
    const SimConfig original = PresetConfig(name);
    const std::string yaml = SimConfigToYaml(original, name);
    // Loading the printed file over another preset gives the same configuration back.
    SimConfig loaded = PresetConfig(name == "tiny" ? "paper" : "tiny");
    ApplySimConfigYaml("printed.yaml", yaml, &loaded);
    EXPECT_EQ(SimConfigToYaml(loaded, name), yaml) << name;
    EXPECT_EQ(loaded.seed, original.seed);
    EXPECT_EQ(loaded.camera.fx, original.camera.fx);
    EXPECT_EQ(loaded.gps1.antenna_in_body, original.gps1.antenna_in_body);
    EXPECT_EQ(loaded.sessions.size(), original.sessions.size());
  }
  // Every key line carries a comment.
  const std::string yaml = SimConfigToYaml(PresetConfig("demo"), "demo");
  size_t begin = 0;
  int keys = 0;
  while (begin < yaml.size()) {
    const size_t end = yaml.find('\n', begin);
    const std::string line = yaml.substr(begin, end - begin);
    begin = end + 1;
    if (line.empty() || line[0] == '#' || line.find("- {date") != std::string::npos) continue;
    if (line.back() == ':') continue;  // a section
    ++keys;
    EXPECT_NE(line.find(" # "), std::string::npos) << line;
  }
  EXPECT_GT(keys, 80);
  for (const char* key : {"rows:", "count:", "length_m:", "spacing_m:", "sessions:", "rain_before:",
                          "width:", "height_m:", "pitch_deg:", "fx:", "speed_mps:",
                          "gyroscope_noise_density:", "sigma_h_m:", "seed:"}) {
    EXPECT_NE(yaml.find(key), std::string::npos) << key;
  }
}

TEST(SimConfigTest, FileOverridesOnlyItsKeys) {
  SimConfig config = PresetConfig("demo");
  ApplySimConfigYaml("override.yaml",
                     "seed: 42\n"
                     "rows:\n"
                     "  count: 3\n"
                     "camera:\n"
                     "  pitch_deg: 30\n"
                     "gps1:\n"
                     "  antenna_in_body: [0, 0, 2]\n"
                     "sessions:\n"
                     "  - {date: 2016-06-02}\n"
                     "  - {date: 2016-06-09, rain_before: true}\n",
                     &config);
  EXPECT_EQ(config.seed, 42u);
  EXPECT_EQ(config.world.num_rows, 3);
  EXPECT_EQ(config.world.row_length_m, 20.0);  // kept from the preset
  EXPECT_EQ(config.camera.pitch_deg, 30.0);
  EXPECT_EQ(config.camera.width, 640);
  EXPECT_EQ(config.gps1.antenna_in_body, Eigen::Vector3d(0, 0, 2));
  ASSERT_EQ(config.sessions.size(), 2u);
  EXPECT_FALSE(config.sessions[0].rain_before);
  EXPECT_TRUE(config.sessions[1].rain_before);
  // An empty file changes nothing.
  SimConfig same = PresetConfig("demo");
  ApplySimConfigYaml("empty.yaml", "", &same);
  EXPECT_EQ(SimConfigToYaml(same), SimConfigToYaml(PresetConfig("demo")));
}

TEST(SimConfigTest, BadValuesNameTheKeyAndTheLine) {
  struct Case {
    std::string yaml;
    std::string key;
    int line;
  };
  const Case cases[] = {
      {"rows:\n  length_m: -5\n", "rows.length_m", 2},
      {"rows:\n  count: 0\n", "rows.count", 2},
      {"camera:\n  widht: 640\n", "camera.widht", 2},
      {"cameras:\n  width: 640\n", "cameras", 1},
      {"camera:\n  width: wide\n", "camera.width", 2},
      {"camera:\n  width: 6.5\n", "camera.width", 2},
      {"seed: -3\n", "seed", 1},
      {"drive:\n  lane: middle\n", "drive.lane", 2},
      {"gps0:\n  sigma_h_m: -0.1\n", "gps0.sigma_h_m", 2},
      {"mag:\n  field_enu_ut: [1, 2]\n", "mag.field_enu_ut", 2},
      {"sessions:\n  - {date: 2016-06-10}\n  - {date: 2016-06-03}\n", "sessions[1].date", 3},
      {"sessions:\n  - {date: 2016-13-10}\n", "sessions[0].date", 2},
      {"sessions:\n  - {date: 2016-06-10, rain: true}\n", "sessions[0].rain", 2},
      {"sessions: []\n", "sessions", 1},
      {"growth:\n  sowing_date: yesterday\n", "growth.sowing_date", 2},
      {"drive:\n  turn_radius_m: 5\n", "drive.turn_radius_m", 2},
      {"camera:\n  msaa_samples: 3\n", "camera.msaa_samples", 2},
      {"imu:\n  rate_hz: 0\n", "imu.rate_hz", 2},
      {"rows: [1, 2]\n", "rows", 1},
      {"camera: {width: 640\n", "", 0},  // not YAML
  };
  for (const Case& c : cases) {
    const InputError e = ErrorOf(c.yaml);
    EXPECT_EQ(e.file(), "bad.yaml") << c.yaml;
    if (c.line > 0) {
      EXPECT_EQ(e.line(), c.line) << c.yaml << " -> " << e.what();
    }
    EXPECT_NE(std::string(e.what()).find(c.key), std::string::npos) << c.yaml << " -> " << e.what();
  }
}

TEST(SimConfigTest, CameraLooksForwardAndDown) {
  const CameraRigOptions cam = PresetConfig("demo").camera;
  const geometry::Rigid3 body_from_camera = cam.BodyFromCamera(0.8);
  // Optical axis: forward (body x) and down by the pitch.
  const Eigen::Vector3d axis = body_from_camera.rotation() * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(axis.x(), std::cos(cam.pitch_deg * M_PI / 180), 1e-12);
  EXPECT_NEAR(axis.z(), -std::sin(cam.pitch_deg * M_PI / 180), 1e-12);
  // Image x to the right (−body y), 1.5 m above the ground for a body 0.8 m up.
  EXPECT_NEAR((body_from_camera.rotation() * Eigen::Vector3d::UnitX()).y(), -1.0, 1e-12);
  EXPECT_NEAR(body_from_camera.translation().z(), cam.height_m - 0.8, 1e-12);
  EXPECT_NEAR(body_from_camera.RotationMatrix().determinant(), 1.0, 1e-12);
  // The top of the image sees above the horizon (tree line and sky), the bottom the ground.
  const double half_vfov = std::atan(cam.cy / cam.fy) * 180 / M_PI;
  EXPECT_GT(half_vfov, cam.pitch_deg);
}

}  // namespace
}  // namespace crop4d::sim
