// The true geometry of a simulated field: depth maps rendered from the World that
// simulate.yaml re-creates give true points that lie on the terrain and agree between two
// images; the cache gives the same maps back; the PNG depth format round-trips.

#include "crop4d/eval/truth_geometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "crop4d/core/error.h"
#include "crop4d/eval/eval_test_util.h"
#include "crop4d/eval/quantile.h"
#include "crop4d/io/atomic_file.h"
#include "crop4d/io/tum.h"
#include "crop4d/sim/sim_config.h"
#include "crop4d/sim/simulator.h"

namespace crop4d::eval {
namespace {

TEST(DepthPngTest, RoundTripsToTheMillimetre) {
  testing::PidTempDir dir;
  DepthImage depth;
  depth.width = 3;
  depth.height = 2;
  depth.z = {0.0f, 1.2344f, 2.5f, 70.0f, 0.0004f, 12.3456f};
  WriteDepthPng(dir / "d/1.png", depth);
  DepthImage back;
  ASSERT_TRUE(ReadDepthPng(dir / "d/1.png", &back));
  ASSERT_EQ(back.width, 3);
  ASSERT_EQ(back.height, 2);
  EXPECT_EQ(back.z[0], 0.0f);
  EXPECT_NEAR(back.z[1], 1.234, 1e-6);
  EXPECT_NEAR(back.z[2], 2.5, 1e-6);
  EXPECT_EQ(back.z[3], 0.0f);  // saturated: unknown
  EXPECT_EQ(back.z[4], 0.0f);  // rounds to 0 mm: nothing
  EXPECT_NEAR(back.z[5], 12.346, 1e-5);
  EXPECT_FALSE(ReadDepthPng(dir / "d/missing.png", &back));
  testing::WriteFile(dir / "d/text.png", "not a png");
  EXPECT_FALSE(ReadDepthPng(dir / "d/text.png", &back));
}

TEST(SimulatedFieldTruthTest, NeedsSimulateYaml) {
  testing::PidTempDir dir;
  EXPECT_THROW(SimulatedFieldTruth truth(dir.path(), {}), InputError);
}

class RenderedTruthTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = sim::PresetConfig("tiny");
    simulator_ = std::make_unique<sim::Simulator>(config_);
    io::WriteFileAtomic(field() + "/ground_truth/simulate.yaml", sim::SimConfigToYaml(config_));
    // Session 1 (45 days after sowing: plants), two images 3 frames apart in the middle of
    // the first pass.
    const sim::SessionRecord rec = simulator_->SimulateSession(kSession);
    const sim::Pass& pass = rec.trajectory->passes().front();
    const Timestamp middle = rec.start + SecondsToTimestamp(0.5 * (pass.t_begin + pass.t_end));
    const auto it = std::lower_bound(rec.image_times.begin(), rec.image_times.end(), middle);
    ASSERT_TRUE(it + 3 < rec.image_times.end());
    std::vector<io::StampedPose> poses;
    for (const Timestamp t : {*it, *(it + 3)}) {
      poses.push_back(
          {t, rec.trajectory->WorldFromBody(rec.Seconds(t)) * simulator_->BodyFromCamera()});
    }
    poses_ = poses;
    io::WriteTum(field() + "/ground_truth/" + session() + "/cam0_poses.tum", poses);
  }

  std::string field() const { return dir_ / "field"; }
  std::string session() const { return config_.sessions[kSession].date; }
  SimulatedFieldTruthOptions Options() const {
    SimulatedFieldTruthOptions options;
    options.depth_cache_dir = dir_ / "cache";
    return options;
  }

  static constexpr int kSession = 1;
  testing::PidTempDir dir_;
  sim::SimConfig config_;
  std::unique_ptr<sim::Simulator> simulator_;
  std::vector<io::StampedPose> poses_;
};

TEST_F(RenderedTruthTest, TruePointsLieOnTheTerrainAndAgreeBetweenImages) {
  SimulatedFieldTruth truth(field(), Options());
  EXPECT_EQ(truth.sessions(), (std::vector<std::string>{"2016-06-10", "2016-06-24"}));
  EXPECT_EQ(truth.rain_before(), (std::vector<bool>{false, true}));

  geometry::PinholeRadTan camera;
  geometry::Rigid3 pose1, pose2;
  ASSERT_TRUE(truth.TrueCamera(session(), poses_[0].t, &camera, &pose1));
  ASSERT_TRUE(truth.TrueCamera(session(), poses_[1].t, &camera, &pose2));
  EXPECT_FALSE(truth.TrueCamera(session(), poses_[0].t + 1, &camera, &pose1));
  EXPECT_FALSE(truth.TrueCamera("2016-06-10", poses_[0].t, &camera, &pose1));
  EXPECT_EQ(camera.width, 320);
  DepthImage depth1, depth2;
  try {
    ASSERT_TRUE(truth.Depth(session(), poses_[0].t, &depth1));
  } catch (const std::runtime_error& e) {
    GTEST_SKIP() << "no headless OpenGL: " << e.what();
  }
  ASSERT_TRUE(truth.Depth(session(), poses_[1].t, &depth2));
  DepthImage no_image;
  EXPECT_FALSE(truth.Depth(session(), poses_[0].t + 1, &no_image));  // no true pose
  EXPECT_EQ(truth.stats().rendered, 2);
  EXPECT_EQ(truth.stats().unavailable, 1);
  ASSERT_EQ(depth1.width, 320);
  ASSERT_EQ(depth1.height, 240);

  const sim::World& world = simulator_->world();
  const Timestamp date = config_.SessionDates()[kSession];
  const auto near_plant = [&](const Eigen::Vector3d& p, double margin) {
    for (const sim::Plant& plant : world.plants()) {
      const sim::PlantState state = world.StateAt(plant, date);
      const double radius = state.emerged ? state.canopy_radius_m : 0.0;
      if ((plant.xy - p.head<2>()).norm() < radius + margin) return true;
    }
    return false;
  };
  const TruePointOptions options;
  int soil = 0, known = 0, edges = 0;
  std::vector<double> agreement;  // |P1 − P2| of the same world point seen in both images
  for (int v = 4; v < 236; v += 6) {
    for (int u = 4; u < 316; u += 6) {
      const Eigen::Vector2d pixel(u + 0.3, v - 0.2);
      const TruePointResult r = TruePointInImage(depth1, camera, pose1, pixel, options);
      if (r.status == TruePointStatus::kDepthEdge) ++edges;
      if (!r.ok()) continue;
      ++known;
      // It re-projects onto the pixel.
      Eigen::Vector2d back;
      ASSERT_TRUE(camera.Project(pose1.Inverse() * r.point_world, &back));
      EXPECT_LT((back - pixel).norm(), 1e-3);
      // On bare soil between the rows it lies on the terrain (the renderer meshes the terrain
      // finely there; the coarser mesh of the headlands departs from TerrainHeight by a few
      // centimetres: the rendered surface is the truth the images show).
      const Eigen::Vector3d& p = r.point_world;
      const bool in_rows = p.y() > 0.5 && p.y() < world.options().row_length_m - 0.5 &&
                           p.x() > -0.4 && p.x() < world.RowX(world.options().num_rows - 1) + 0.4;
      if (in_rows && !near_plant(p, 0.05) && r.depth_m < 6.0) {
        ++soil;
        EXPECT_NEAR(r.point_world.z(), world.TerrainHeight(r.point_world.x(), r.point_world.y()),
                    0.01)
            << "pixel " << pixel.transpose() << " point " << r.point_world.transpose() << " depth "
            << r.depth_m;
      }
      // The same point seen from the second image.
      Eigen::Vector2d pixel2;
      if (r.depth_m < 6.0 && camera.Project(pose2.Inverse() * r.point_world, &pixel2) &&
          camera.IsInImage(pixel2, 2.0)) {
        const TruePointResult r2 = TruePointInImage(depth2, camera, pose2, pixel2, options);
        if (r2.ok()) agreement.push_back((r2.point_world - r.point_world).norm());
      }
    }
  }
  EXPECT_GT(known, 1000);
  EXPECT_GT(soil, 100);
  EXPECT_GT(edges, 0);  // plant silhouettes
  ASSERT_GT(agreement.size(), 300u);
  EXPECT_LT(Quantile(&agreement, 0.5), 0.002);
  // Some points are hidden behind a leaf in the second view; most are not.
  EXPECT_LT(Quantile(&agreement, 0.8), 0.005);

  // A second evaluation reads the cache: the same maps, nothing rendered.
  SimulatedFieldTruth again(field(), Options());
  DepthImage cached;
  ASSERT_TRUE(again.Depth(session(), poses_[0].t, &cached));
  EXPECT_EQ(again.stats().from_cache, 1);
  EXPECT_EQ(again.stats().rendered, 0);
  EXPECT_EQ(cached.z, depth1.z);

  // Without rendering and without a cache, a map is unavailable.
  SimulatedFieldTruthOptions none;
  none.render = false;
  SimulatedFieldTruth no_render(field(), none);
  EXPECT_FALSE(no_render.Depth(session(), poses_[0].t, &cached));
  EXPECT_EQ(no_render.stats().unavailable, 1);
}

}  // namespace
}  // namespace crop4d::eval
