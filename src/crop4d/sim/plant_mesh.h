#pragma once

// Procedural 3D peanut plants (Arachis hypogaea): an upright main stem and cotyledonary and
// later lateral branches that arch outwards, secondary branches late in the season, and
// alternate tetrafoliate leaves (a petiole with two pairs of leaflets). The plant's structure
// comes from its seed, node by node, so a plant keeps its leaves from session to session while
// it grows; its size follows World::StateAt (height = top of the canopy, canopy radius = reach
// of the outermost leaflets). The wind seed of a session perturbs leaf angles slightly.
//
// Four levels of detail share the same structure: kFull (leaflets folded along the midrib,
// tubular stems, petiole ribbons), kMedium (one triangle per leaflet, main stem only), kCoarse
// (one quad per leaf, no stems), kFar (a third of the leaves as larger quads) and kDistant (an
// eighth of the leaves as still larger quads).

#include <cstdint>
#include <vector>

#include "crop4d/core/timestamp.h"
#include "crop4d/sim/world.h"

namespace crop4d::sim {

// Vertex layout the renderer uploads as is (20 bytes).
struct PlantVertex {
  float position[3];      // world frame (ENU), metres
  std::int8_t normal[4];  // unit normal × 127; w unused
  std::uint8_t color[4];  // RGB albedo; A = 255 for leaf blades, 0 for stems and petioles
};
static_assert(sizeof(PlantVertex) == 20);

struct PlantMesh {
  std::vector<PlantVertex> vertices;
  std::vector<std::uint32_t> indices;  // triangles (counter-clockwise seen along the normal)
  int num_triangles() const { return static_cast<int>(indices.size() / 3); }
  void Clear() {
    vertices.clear();
    indices.clear();
  }
};

enum class PlantLod { kFull = 0, kMedium = 1, kCoarse = 2, kFar = 3, kDistant = 4 };
inline constexpr int kNumPlantLods = 5;

// Appends the mesh of `plant` on `date` (nothing when it has not emerged) in world
// coordinates, standing on the terrain of `world`. Its highest point lies exactly
// World::StateAt(plant, date).height_m above the terrain at the stem (the plant is stretched
// vertically by the few per cent its parts miss), so that the heights of the ground truth
// (plants.csv, site_truth.csv) are those of the rendered canopy, at every level of detail.
void AppendPlantMesh(const World& world, const Plant& plant, Timestamp date,
                     std::uint64_t wind_seed, PlantLod lod, PlantMesh* mesh);

// Appends the mesh of `weed` on `date` (nothing before it emerges): a low rosette of simple
// ovate leaves rising from its centre, draped over the terrain, the inner ones steepest; its
// highest point lies World::WeedStateAt(weed, date).height_m above the ground under it and its
// leaves reach canopy_radius_m. Leaf blades sway in the wind like the crop's. The far levels
// of detail keep fewer leaves with fewer facets.
void AppendWeedMesh(const World& world, const Weed& weed, Timestamp date, PlantLod lod,
                    PlantMesh* mesh);

}  // namespace crop4d::sim
