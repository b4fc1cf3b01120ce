#include "crop4d/sim/plant_mesh.h"

#include <gtest/gtest.h>

#include <cmath>

namespace crop4d::sim {
namespace {

constexpr Timestamp kDay = 86400LL * 1'000'000'000LL;

struct Extent {
  double top = 0.0;    // highest vertex above the stem base
  double reach = 0.0;  // largest horizontal distance from the stem
};

Extent Measure(const World& world, const Plant& plant, const PlantMesh& mesh) {
  Extent e;
  const double z0 = world.TerrainHeight(plant.xy.x(), plant.xy.y());
  for (const PlantVertex& v : mesh.vertices) {
    e.top = std::max(e.top, v.position[2] - z0);
    e.reach =
        std::max(e.reach, std::hypot(v.position[0] - plant.xy.x(), v.position[1] - plant.xy.y()));
  }
  return e;
}

TEST(PlantMeshTest, SizeFollowsTheGrowthModel) {
  const World world(WorldOptions{});
  for (int i = 0; i < 20; ++i) {
    const Plant& plant = world.plants()[i * 7];
    for (double days : {15.0, 40.0, 70.0, 100.0}) {
      const Timestamp date = static_cast<Timestamp>(days * kDay);
      const PlantState state = world.StateAt(plant, date);
      PlantMesh mesh;
      AppendPlantMesh(world, plant, date, 0, PlantLod::kFull, &mesh);
      ASSERT_TRUE(state.emerged);
      ASSERT_GT(mesh.num_triangles(), 10);
      const Extent e = Measure(world, plant, mesh);
      // The rendered top is the plant's height (the ground truth of site heights).
      EXPECT_NEAR(e.top, state.height_m, 0.001) << days;
      EXPECT_LT(e.reach, 1.15 * state.canopy_radius_m + 0.02) << days;
      if (days >= 70.0) {
        EXPECT_GT(e.reach, 0.6 * state.canopy_radius_m) << days;
      }
    }
  }
}

TEST(PlantMeshTest, LevelsOfDetailAndSessions) {
  const World world(WorldOptions{});
  const Plant& plant = world.plants()[3];
  const Timestamp date = 80 * kDay;
  int previous = 1 << 30;
  for (int lod = 0; lod < kNumPlantLods; ++lod) {
    PlantMesh mesh;
    AppendPlantMesh(world, plant, date, 1, static_cast<PlantLod>(lod), &mesh);
    EXPECT_LT(mesh.num_triangles(), previous);
    EXPECT_GT(mesh.num_triangles(), 0);
    previous = mesh.num_triangles();
    for (std::uint32_t index : mesh.indices) ASSERT_LT(index, mesh.vertices.size());
    for (const PlantVertex& v : mesh.vertices) {
      const double n = std::sqrt(v.normal[0] * v.normal[0] + v.normal[1] * v.normal[1] +
                                 v.normal[2] * v.normal[2]) /
                       127.0;
      EXPECT_NEAR(n, 1.0, 0.03);
    }
  }
  // Leaves are green; the plant grows more leaves over the season.
  PlantMesh young, old;
  AppendPlantMesh(world, plant, 30 * kDay, 1, PlantLod::kFull, &young);
  AppendPlantMesh(world, plant, 90 * kDay, 1, PlantLod::kFull, &old);
  EXPECT_GT(old.num_triangles(), 3 * young.num_triangles());
  int blades = 0, green = 0;
  for (const PlantVertex& v : old.vertices) {
    if (v.color[3] != 255) continue;
    ++blades;
    if (v.color[1] > v.color[0] && v.color[1] > v.color[2]) ++green;
  }
  EXPECT_GT(green, 0.9 * blades);

  // Same session, same mesh; another wind seed moves the leaves a little, not the plant.
  PlantMesh a, b, c;
  AppendPlantMesh(world, plant, date, 1, PlantLod::kFull, &a);
  AppendPlantMesh(world, plant, date, 1, PlantLod::kFull, &b);
  AppendPlantMesh(world, plant, date, 2, PlantLod::kFull, &c);
  ASSERT_EQ(a.vertices.size(), b.vertices.size());
  ASSERT_EQ(a.vertices.size(), c.vertices.size());
  double max_move = 0.0, moved = 0.0;
  for (size_t i = 0; i < a.vertices.size(); ++i) {
    double d2 = 0.0;
    for (int k = 0; k < 3; ++k) {
      EXPECT_EQ(a.vertices[i].position[k], b.vertices[i].position[k]);
      const double d = a.vertices[i].position[k] - c.vertices[i].position[k];
      d2 += d * d;
    }
    max_move = std::max(max_move, std::sqrt(d2));
    moved += std::sqrt(d2);
  }
  EXPECT_GT(moved / a.vertices.size(), 0.001);
  EXPECT_LT(max_move, 0.05);

  // Not emerged: nothing.
  PlantMesh none;
  AppendPlantMesh(world, plant, 2 * kDay, 1, PlantLod::kFull, &none);
  EXPECT_EQ(none.num_triangles(), 0);
}

TEST(PlantMeshTest, WeedsAreLowRosettesOnTheGround) {
  WorldOptions options;
  options.weeds.density_per_m2 = 2.0;
  const World world(options);
  ASSERT_GT(world.weeds().size(), 20u);
  for (std::size_t i = 0; i < world.weeds().size(); i += 7) {
    const Weed& weed = world.weeds()[i];
    for (double days : {weed.emergence_days + 1.0, weed.emergence_days + 10.0, 120.0}) {
      const Timestamp date = static_cast<Timestamp>(days * kDay);
      const PlantState state = world.WeedStateAt(weed, date);
      ASSERT_TRUE(state.emerged);
      PlantMesh mesh;
      AppendWeedMesh(world, weed, date, PlantLod::kFull, &mesh);
      ASSERT_GT(mesh.num_triangles(), 20);
      double top = 0.0, reach = 0.0;
      for (const PlantVertex& v : mesh.vertices) {
        const double ground = world.TerrainHeight(v.position[0], v.position[1]);
        // Draped over the terrain: never below it; the top is the weed's height above the
        // ground under it, the outer leaf reaches its radius.
        EXPECT_GE(v.position[2], ground + 0.001);
        top = std::max(top, v.position[2] - ground);
        reach =
            std::max(reach, std::hypot(v.position[0] - weed.xy.x(), v.position[1] - weed.xy.y()));
        EXPECT_EQ(v.color[3], 255);  // leaf blades: they sway
      }
      EXPECT_NEAR(top, state.height_m + 0.002, 0.001) << days;
      EXPECT_LE(reach, state.canopy_radius_m + 1e-4) << days;
      EXPECT_GE(reach, 0.95 * state.canopy_radius_m) << days;
    }
  }
  // Fewer triangles at every coarser level; nothing before emergence.
  const Weed& weed = world.weeds()[0];
  const Timestamp date = static_cast<Timestamp>((weed.emergence_days + 30.0) * kDay);
  int previous = 1 << 30;
  for (int lod = 0; lod < kNumPlantLods; ++lod) {
    PlantMesh mesh;
    AppendWeedMesh(world, weed, date, static_cast<PlantLod>(lod), &mesh);
    EXPECT_GT(mesh.num_triangles(), 0);
    EXPECT_LE(mesh.num_triangles(), previous);
    if (lod <= static_cast<int>(PlantLod::kCoarse)) {
      EXPECT_LT(mesh.num_triangles(), previous);
    }
    previous = mesh.num_triangles();
    for (std::uint32_t index : mesh.indices) ASSERT_LT(index, mesh.vertices.size());
  }
  PlantMesh none;
  AppendWeedMesh(world, weed, static_cast<Timestamp>((weed.emergence_days - 1.0) * kDay),
                 PlantLod::kFull, &none);
  EXPECT_EQ(none.num_triangles(), 0);
}

}  // namespace
}  // namespace crop4d::sim
