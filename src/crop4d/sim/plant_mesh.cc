#include "crop4d/sim/plant_mesh.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>

#include "crop4d/sim/random.h"

namespace crop4d::sim {
namespace {

using Eigen::Vector3d;
using Eigen::Vector3f;

constexpr double kDeg = M_PI / 180.0;

double Clamp01(double v) { return std::min(1.0, std::max(0.0, v)); }

// Writes geometry into a PlantMesh, mapping plant-local coordinates (origin at the stem base,
// z up, x along the plant's yaw) to the world.
class MeshWriter {
 public:
  MeshWriter(PlantMesh* mesh, const Vector3d& base, double yaw)
      : mesh_(mesh), base_(base), rotation_(Eigen::AngleAxisd(yaw, Vector3d::UnitZ())) {}

  std::uint32_t AddVertex(const Vector3d& local, const Vector3d& normal_local, const Vector3f& rgb,
                          bool blade) {
    PlantVertex v;
    const Vector3d p = base_ + rotation_ * local;
    const Vector3d n = (rotation_ * normal_local).normalized();
    for (int i = 0; i < 3; ++i) {
      v.position[i] = static_cast<float>(p[i]);
      v.normal[i] = static_cast<std::int8_t>(std::lround(std::clamp(n[i], -1.0, 1.0) * 127.0));
      v.color[i] = static_cast<std::uint8_t>(std::lround(std::clamp(rgb[i], 0.0f, 1.0f) * 255.0f));
    }
    v.normal[3] = 0;
    v.color[3] = blade ? 255 : 0;
    mesh_->vertices.push_back(v);
    return static_cast<std::uint32_t>(mesh_->vertices.size() - 1);
  }
  void AddTriangle(std::uint32_t a, std::uint32_t b, std::uint32_t c) {
    mesh_->indices.insert(mesh_->indices.end(), {a, b, c});
  }

  // A tube along a polyline with `sides` faces and per-point radius.
  void Tube(const std::vector<Vector3d>& points, double radius_start, double radius_end,
            const Vector3f& rgb, int sides) {
    if (points.size() < 2) return;
    const std::uint32_t first = static_cast<std::uint32_t>(mesh_->vertices.size());
    const int n = static_cast<int>(points.size());
    for (int k = 0; k < n; ++k) {
      const Vector3d tangent =
          (points[std::min(k + 1, n - 1)] - points[std::max(k - 1, 0)]).normalized();
      const Vector3d helper = std::abs(tangent.z()) < 0.9 ? Vector3d::UnitZ() : Vector3d::UnitX();
      const Vector3d u = tangent.cross(helper).normalized();
      const Vector3d w = tangent.cross(u);
      const double r = radius_start + (radius_end - radius_start) * k / (n - 1);
      for (int j = 0; j < sides; ++j) {
        const double a = 2.0 * M_PI * j / sides;
        const Vector3d radial = std::cos(a) * u + std::sin(a) * w;
        AddVertex(points[k] + r * radial, radial, rgb, false);
      }
    }
    for (int k = 0; k + 1 < n; ++k) {
      for (int j = 0; j < sides; ++j) {
        const std::uint32_t a = first + k * sides + j;
        const std::uint32_t b = first + k * sides + (j + 1) % sides;
        const std::uint32_t c = a + sides, d = b + sides;
        AddTriangle(a, b, d);
        AddTriangle(a, d, c);
      }
    }
  }

 private:
  PlantMesh* mesh_;
  Vector3d base_;
  Eigen::Matrix3d rotation_;
};

// A quadratic Bézier curve sampled at `n` + 1 points.
std::vector<Vector3d> Bezier(const Vector3d& p0, const Vector3d& p1, const Vector3d& p2, int n) {
  std::vector<Vector3d> points;
  for (int i = 0; i <= n; ++i) {
    const double t = static_cast<double>(i) / n;
    points.push_back((1 - t) * (1 - t) * p0 + 2 * (1 - t) * t * p1 + t * t * p2);
  }
  return points;
}

// Leaf colours over the season: young bright yellow-green, dark green at full canopy,
// yellowing late (peanut leaf senescence starts ~100 days after sowing).
Vector3f SeasonColor(double days) {
  const Vector3f young(0.34f, 0.56f, 0.15f);
  const Vector3f mature(0.19f, 0.42f, 0.12f);
  const Vector3f late(0.40f, 0.48f, 0.17f);
  if (days < 50.0) return young + (mature - young) * static_cast<float>(Clamp01((days - 15) / 35));
  return mature + (late - mature) * static_cast<float>(Clamp01((days - 95.0) / 40.0));
}

struct LeafSpec {
  Vector3d node;         // attachment point on the stem
  double azimuth = 0.0;  // horizontal direction of the petiole
  double rise = 0.0;     // elevation angle of the petiole
  double petiole = 0.0;  // petiole length
  double leaflet = 0.0;  // leaflet length
  Vector3f color = Vector3f::Zero();
};

// Emits one tetrafoliate leaf.
void EmitLeaf(const LeafSpec& leaf, std::uint64_t leaf_seed, std::uint64_t wind_seed, PlantLod lod,
              bool essential, MeshWriter* out) {
  // The far levels keep a pseudo-random subset of the leaves (always the essential one).
  if (!essential && ((lod == PlantLod::kFar && leaf_seed % 3 != 0) ||
                     (lod == PlantLod::kDistant && leaf_seed % 8 != 0))) {
    return;
  }
  Random shape(leaf_seed);
  Random wind(HashCombine(leaf_seed, wind_seed, 0x3157u));
  const double azimuth = leaf.azimuth + wind.Normal(0.0, 4.0 * kDeg);
  const double rise = leaf.rise + wind.Normal(0.0, 3.0 * kDeg);
  const Vector3d dir(std::cos(rise) * std::cos(azimuth), std::cos(rise) * std::sin(azimuth),
                     std::sin(rise));
  const Vector3d flat_dir(std::cos(azimuth), std::sin(azimuth), 0.0);
  const Vector3d side = Vector3d::UnitZ().cross(flat_dir).normalized();
  const Vector3d petiole_end = leaf.node + leaf.petiole * dir;
  // Rachis: continues nearly horizontally a little past the petiole.
  const double rachis_length = 0.22 * leaf.leaflet;
  const Vector3d rachis_end = petiole_end + rachis_length * flat_dir;
  const Vector3f stem_rgb(leaf.color.x() * 1.1f, leaf.color.y() * 1.05f, leaf.color.z() * 0.9f);

  if (lod == PlantLod::kFull) {
    // Petiole and rachis: a narrow ribbon facing up.
    const double half_width = 0.0009;
    const std::uint32_t a =
        out->AddVertex(leaf.node - half_width * side, Vector3d::UnitZ(), stem_rgb, false);
    const std::uint32_t b =
        out->AddVertex(leaf.node + half_width * side, Vector3d::UnitZ(), stem_rgb, false);
    const std::uint32_t c =
        out->AddVertex(rachis_end + half_width * side, Vector3d::UnitZ(), stem_rgb, false);
    const std::uint32_t d =
        out->AddVertex(rachis_end - half_width * side, Vector3d::UnitZ(), stem_rgb, false);
    out->AddTriangle(a, d, c);
    out->AddTriangle(a, c, b);
  }

  // The four leaflets: the proximal pair at the petiole end, the distal pair at the rachis
  // end, spread sideways; blades nearly horizontal (peanut leaflets open flat by day).
  struct Blade {
    Vector3d base, axis, normal;
    double length, width;
    Vector3f rgb;
  };
  Blade blades[4];
  for (int i = 0; i < 4; ++i) {
    const bool distal = i >= 2;
    const double sign = (i % 2 == 0) ? 1.0 : -1.0;
    const double spread = (distal ? shape.Uniform(18, 32) : shape.Uniform(55, 75)) * kDeg;
    const double length =
        leaf.leaflet * (distal ? shape.Uniform(1.0, 1.12) : shape.Uniform(0.85, 1.0));
    const double tilt = shape.Uniform(-15, 15) * kDeg + wind.Normal(0.0, 6.0 * kDeg);
    const double droop = shape.Uniform(-5, 20) * kDeg + wind.Normal(0.0, 4.0 * kDeg);
    // Axis in the horizontal plane, then drooping down by `droop`.
    const Vector3d h_axis = std::cos(spread) * flat_dir + sign * std::sin(spread) * side;
    Vector3d axis = std::cos(droop) * h_axis - std::sin(droop) * Vector3d::UnitZ();
    // Roll about the axis by `tilt`.
    const Vector3d across0 = Vector3d::UnitZ().cross(h_axis).normalized();
    const Vector3d across = Eigen::AngleAxisd(tilt, axis) * across0;
    Vector3d normal = axis.cross(across).normalized();
    if (normal.z() < 0) normal = -normal;
    Blade& b = blades[i];
    b.base = distal ? rachis_end : petiole_end;
    b.axis = axis.normalized();
    b.normal = normal;
    b.length = length;
    b.width = length * shape.Uniform(0.45, 0.58);
    const float tone = static_cast<float>(shape.Uniform(0.9, 1.1));
    b.rgb = leaf.color * tone;
  }

  if (lod == PlantLod::kCoarse || lod == PlantLod::kFar || lod == PlantLod::kDistant) {
    // One quad spanning the leaf, at the mean blade orientation (larger for kFar, which
    // keeps a third of the leaves).
    Vector3d normal = Vector3d::Zero();
    Vector3f rgb = Vector3f::Zero();
    for (const Blade& b : blades) {
      normal += b.normal;
      rgb += 0.25f * b.rgb;
    }
    normal.normalize();
    const Vector3d along = (flat_dir - flat_dir.dot(normal) * normal).normalized();
    const Vector3d across = normal.cross(along);
    const double grow = lod == PlantLod::kFar ? 1.6 : lod == PlantLod::kDistant ? 2.4 : 1.0;
    const double half_w = 0.85 * grow * leaf.leaflet;
    const Vector3d p0 = petiole_end - 0.1 * leaf.leaflet * along;
    const Vector3d p1 = rachis_end + 0.95 * grow * leaf.leaflet * along;
    const std::uint32_t a = out->AddVertex(p0 - half_w * across, normal, rgb, true);
    const std::uint32_t b = out->AddVertex(p0 + half_w * across, normal, rgb, true);
    const std::uint32_t c = out->AddVertex(p1 + 0.6 * half_w * across, normal, rgb, true);
    const std::uint32_t d = out->AddVertex(p1 - 0.6 * half_w * across, normal, rgb, true);
    // Order so that the triangles face along `normal`.
    out->AddTriangle(a, d, c);
    out->AddTriangle(a, c, b);
    return;
  }

  for (const Blade& b : blades) {
    const Vector3d across = b.normal.cross(b.axis);  // axis × across = normal
    // Obovate blade: widest at ~60 % of its length.
    const Vector3d left = b.base + 0.6 * b.length * b.axis + 0.5 * b.width * across;
    const Vector3d right = b.base + 0.6 * b.length * b.axis - 0.5 * b.width * across;
    const Vector3d tip = b.base + b.length * b.axis - 0.05 * b.length * b.normal;
    const Vector3f tip_rgb = b.rgb * 1.06f;
    if (lod == PlantLod::kMedium) {
      // One triangle: the base and the blade's outer corners (an obovate outline).
      const Vector3d outer_left = b.base + 0.85 * b.length * b.axis + 0.55 * b.width * across;
      const Vector3d outer_right = b.base + 0.85 * b.length * b.axis - 0.55 * b.width * across;
      const std::uint32_t ib = out->AddVertex(b.base, b.normal, b.rgb * 0.95f, true);
      const std::uint32_t il = out->AddVertex(outer_left, b.normal, b.rgb, true);
      const std::uint32_t ir = out->AddVertex(outer_right, b.normal, tip_rgb, true);
      out->AddTriangle(ib, ir, il);
      continue;
    }
    // Full detail: a diamond whose halves fold up along the midrib (a V).
    const double fold = 0.12 * b.width;
    const Vector3d left_f = left + fold * b.normal;
    const Vector3d right_f = right + fold * b.normal;
    const Vector3d n_left = (b.normal - 0.25 * across).normalized();
    const Vector3d n_right = (b.normal + 0.25 * across).normalized();
    const std::uint32_t ib = out->AddVertex(b.base, b.normal, b.rgb * 0.92f, true);
    const std::uint32_t il = out->AddVertex(left_f, n_left, b.rgb, true);
    const std::uint32_t ir = out->AddVertex(right_f, n_right, b.rgb, true);
    const std::uint32_t it = out->AddVertex(tip, b.normal, tip_rgb, true);
    out->AddTriangle(ib, it, il);
    out->AddTriangle(ib, ir, it);
  }
}

}  // namespace

void AppendPlantMesh(const World& world, const Plant& plant, Timestamp date,
                     std::uint64_t wind_seed, PlantLod lod, PlantMesh* mesh) {
  const PlantState state = world.StateAt(plant, date);
  if (!state.emerged) return;
  const WorldOptions& o = world.options();
  const double days = world.DaysAfterSowing(date) - plant.delay_days;
  const double H = state.height_m;
  const double R = state.canopy_radius_m;
  // Development stage g ∈ [0, 1] from the nominal height curve.
  const double g = Clamp01((H / plant.height_scale - o.emergence_height_m) /
                           (o.final_height_m - o.emergence_height_m));
  const Vector3d base(plant.xy.x(), plant.xy.y(),
                      world.TerrainHeight(plant.xy.x(), plant.xy.y()) - 0.01);
  MeshWriter out(mesh, base, plant.yaw_rad);
  const std::size_t first_vertex = mesh->vertices.size();

  Random plant_random(HashCombine(plant.seed, 0x9a17u));
  const float plant_tone = static_cast<float>(plant_random.Uniform(0.92, 1.08));
  const float plant_hue = static_cast<float>(plant_random.Uniform(-0.04, 0.04));
  Vector3f plant_rgb = SeasonColor(days) * plant_tone;
  plant_rgb.x() += plant_hue;
  const Vector3f stem_rgb(0.42f, 0.40f, 0.20f);
  const double senescence = Clamp01((days - 100.0) / 40.0);

  // Leaf size grows with the stage; petioles are about 1.3 leaflets long.
  const double leaflet = 0.012 + 0.036 * g;
  const double petiole = 0.015 + 0.045 * g;
  auto leaf_color = [&](Random& r, double age) {
    Vector3f rgb = plant_rgb * static_cast<float>(r.Uniform(0.9, 1.1));
    // Young leaves (age ≈ 0) are lighter; old ones darker, and yellow late in the season.
    rgb *= static_cast<float>(1.12 - 0.2 * age);
    if (r.Bernoulli(0.6 * senescence * age)) {
      rgb = Vector3f(0.52f, 0.48f, 0.20f) * static_cast<float>(r.Uniform(0.85, 1.1));
    }
    return rgb;
  };

  // Main stem: upright with a slight lean; its top leaves define the canopy height.
  Random main_random(HashCombine(plant.seed, 0x3a17u));
  const double top_rise = 50.0 * kDeg;
  const double stem_height = std::max(0.5 * H, H - petiole * std::sin(top_rise) - 0.25 * leaflet);
  // Draws are separate statements wherever one expression would hold two: C++ leaves the order
  // of function arguments unspecified (gcc and clang differ), and a seed must give the same field
  // whatever the compiler. The order is the one gcc used, so fields stay as they were.
  const double lean_y = main_random.Normal(0.0, 0.05);
  const double lean_x = main_random.Normal(0.0, 0.05);
  const Vector3d lean(lean_x, lean_y, 1.0);
  const Vector3d stem_top = stem_height * lean.normalized();
  if (lod == PlantLod::kFull) {
    out.Tube({Vector3d::Zero(), 0.5 * stem_top, stem_top}, 0.0015 + 0.002 * g, 0.001, stem_rgb, 4);
  } else if (lod == PlantLod::kMedium) {
    out.Tube({Vector3d::Zero(), stem_top}, 0.0015 + 0.002 * g, 0.001, stem_rgb, 3);
  }
  const int main_leaves = 2 + static_cast<int>(std::lround(10 * g));
  for (int k = 0; k < main_leaves; ++k) {
    Random leaf_random(HashCombine(plant.seed, 0u, static_cast<std::uint64_t>(k)));
    const double along = 1.0 - 0.6 * k / (main_leaves - 1.0);
    LeafSpec leaf;
    leaf.node = along * stem_top;
    leaf.azimuth = k * 137.5 * kDeg + leaf_random.Normal(0.0, 15 * kDeg);  // phyllotaxis
    leaf.rise = (k < 2 ? top_rise : 30.0 * kDeg) + leaf_random.Normal(0.0, 8 * kDeg);
    leaf.petiole = petiole * (k == 0 ? 0.8 : 1.0) * leaf_random.Uniform(0.85, 1.15);
    leaf.leaflet = leaflet * (k == 0 ? 0.8 : 1.0) * leaf_random.Uniform(0.85, 1.15);
    leaf.color = leaf_color(leaf_random, Clamp01(k / 6.0));
    EmitLeaf(leaf, HashCombine(plant.seed, 0u, static_cast<std::uint64_t>(k), 1u), wind_seed, lod,
             k == 0, &out);
  }

  // Lateral branches appear one after another and arch outwards; their outer leaves reach
  // the canopy radius.
  constexpr int kMaxBranches = 8;
  const double reach = std::max(0.0, R - 0.8 * petiole - leaflet);
  for (int i = 0; i < kMaxBranches; ++i) {
    const double start = 0.05 + 0.07 * i;
    if (g <= start) break;
    Random branch_random(HashCombine(plant.seed, 1u + i));
    const double f = Clamp01((g - start) / 0.35);  // branch length fraction
    const double azimuth =
        (i % 2 == 0 ? 0.0 : M_PI) + (i / 2) * 0.9 + branch_random.Normal(0.0, 0.25);
    const double length = reach * f * branch_random.Uniform(0.85, 1.0);
    if (length < 0.01) continue;
    const Vector3d dir(std::cos(azimuth), std::sin(azimuth), 0.0);
    const Vector3d b0 =
        stem_top * std::min(1.0, (0.02 + 0.06 * i / kMaxBranches) / std::max(1e-3, stem_top.z()));
    // Prostrate early (cotyledonary laterals), a dome later: the canopy top stays near H.
    const double lift = 0.55 + 0.35 * g;
    const double tip_z = H * lift * branch_random.Uniform(0.55, 0.8);
    const double arch_z = H * lift * branch_random.Uniform(0.85, 1.0);
    const Vector3d b2 = Vector3d(0, 0, 0) + length * dir + Vector3d(0, 0, tip_z);
    const Vector3d b1 = 0.35 * length * dir + Vector3d(0, 0, arch_z);
    if (lod == PlantLod::kFull) {
      out.Tube(Bezier(b0, b1, b2, 4), 0.0012 + 0.0012 * g, 0.0007, stem_rgb, 3);
    }
    // Nodes every ~4.5 cm along the outer three quarters of the branch; alternate leaves.
    const double internode = 0.045 * branch_random.Uniform(0.9, 1.1);
    const int nodes = std::max(1, static_cast<int>(0.8 * length / internode));
    for (int k = 0; k < nodes; ++k) {
      Random leaf_random(HashCombine(plant.seed, 2u + i, static_cast<std::uint64_t>(k)));
      const double t = 1.0 - 0.75 * k / std::max(1, nodes);  // from the tip inwards
      const Vector3d node = (1 - t) * (1 - t) * b0 + 2 * (1 - t) * t * b1 + t * t * b2;
      const double side = (k % 2 == 0) ? 1.0 : -1.0;
      const double age = Clamp01(static_cast<double>(k) / nodes);
      LeafSpec leaf;
      leaf.node = node;
      leaf.azimuth = azimuth + side * leaf_random.Uniform(40, 80) * kDeg;
      leaf.rise = leaf_random.Uniform(25, 50) * kDeg;
      const double young = k == 0 ? 0.7 : 1.0;
      leaf.petiole = petiole * young * leaf_random.Uniform(0.85, 1.15);
      leaf.leaflet = leaflet * young * leaf_random.Uniform(0.85, 1.15);
      leaf.color = leaf_color(leaf_random, age);
      EmitLeaf(leaf, HashCombine(plant.seed, 2u + i, static_cast<std::uint64_t>(k), 1u), wind_seed,
               lod, false, &out);
      // Secondary branches late in the season fill the canopy.
      if (g > 0.45 && k > 0 && leaf_random.Bernoulli(0.55)) {
        const double sec_length = (0.05 + 0.1 * leaf_random.Uniform()) * Clamp01((g - 0.45) / 0.3);
        const double sec_azimuth = azimuth - side * leaf_random.Uniform(30, 60) * kDeg;
        const Vector3d sec_dir(std::cos(sec_azimuth), std::sin(sec_azimuth), 0.0);
        const Vector3d s0 = node;
        const Vector3d s1 = node + sec_length * sec_dir + Vector3d(0, 0, 0.3 * sec_length);
        if (lod == PlantLod::kFull) out.Tube({s0, s1}, 0.0009, 0.0006, stem_rgb, 3);
        const int sec_leaves = 2 + static_cast<int>(leaf_random.Uniform() * 2.0);
        for (int j = 0; j < sec_leaves; ++j) {
          Random sec_random(
              HashCombine(plant.seed, 100u + i, static_cast<std::uint64_t>(k), 1u + j));
          LeafSpec sec;
          const double u = 1.0 - 0.4 * j / sec_leaves;
          sec.node = s0 + u * (s1 - s0);
          sec.azimuth = sec_azimuth + (j % 2 == 0 ? 1.0 : -1.0) * sec_random.Uniform(30, 70) * kDeg;
          sec.rise = sec_random.Uniform(30, 55) * kDeg;
          sec.petiole = 0.8 * petiole * sec_random.Uniform(0.85, 1.15);
          sec.leaflet = 0.9 * leaflet * sec_random.Uniform(0.85, 1.15);
          sec.color = leaf_color(sec_random, 0.5 * age);
          EmitLeaf(sec,
                   HashCombine(plant.seed, 100u + i, static_cast<std::uint64_t>(k), 1u + j, 1u),
                   wind_seed, lod, false, &out);
        }
      }
    }
  }

  // The parts above fall a little short of H (the stem is sunk 1 cm into the soil, and the top
  // leaf rises less than its petiole's length): stretch the plant vertically about its base so
  // that its highest point is exactly H above the ground at the stem, and tilt the normals
  // accordingly (a vertical stretch by s maps a normal (nx, ny, nz) to (nx, ny, nz / s)).
  float top = -std::numeric_limits<float>::infinity();
  for (std::size_t v = first_vertex; v < mesh->vertices.size(); ++v) {
    top = std::max(top, mesh->vertices[v].position[2]);
  }
  const double target = base.z() + 0.01 + H;
  if (mesh->vertices.size() > first_vertex && top > base.z() + 1e-4) {
    const double stretch = (target - base.z()) / (top - base.z());
    for (std::size_t v = first_vertex; v < mesh->vertices.size(); ++v) {
      PlantVertex& vertex = mesh->vertices[v];
      vertex.position[2] = static_cast<float>(base.z() + stretch * (vertex.position[2] - base.z()));
      Vector3d n(vertex.normal[0], vertex.normal[1], vertex.normal[2] / stretch);
      n.normalize();
      for (int i = 0; i < 3; ++i) {
        vertex.normal[i] =
            static_cast<std::int8_t>(std::lround(std::clamp(n[i], -1.0, 1.0) * 127.0));
      }
    }
  }
}

void AppendWeedMesh(const World& world, const Weed& weed, Timestamp date, PlantLod lod,
                    PlantMesh* mesh) {
  const PlantState state = world.WeedStateAt(weed, date);
  if (!state.emerged) return;
  const double R = state.canopy_radius_m, H = state.height_m;
  const double growth =
      state.canopy_radius_m / (weed.size_scale * world.options().weeds.final_radius_m);
  Random random(weed.seed);
  // Broadleaf weeds (pigweed, morning glory, sicklepod seedlings) are a lighter or bluer green
  // than the crop, each a little different.
  const Vector3f base_rgb(static_cast<float>(random.Uniform(0.24, 0.36)),
                          static_cast<float>(random.Uniform(0.46, 0.58)),
                          static_cast<float>(random.Uniform(0.10, 0.22)));
  // Points are written in world coordinates relative to the rosette's centre on z = 0.
  MeshWriter out(mesh, Vector3d(weed.xy.x(), weed.xy.y(), 0.0), 0.0);
  // Stations along each leaf and the share of the leaves each level of detail keeps.
  const int stations = lod == PlantLod::kFull ? 6 : lod == PlantLod::kMedium ? 4 : 3;
  const int keep_every = lod == PlantLod::kFar ? 2 : lod == PlantLod::kDistant ? 4 : 1;

  // Leaves from the oldest (outermost, flattest) to the youngest (innermost, upright); the
  // youngest one reaches the height H, the oldest one the radius R.
  const int leaves = 4 + static_cast<int>(std::lround(4.0 * growth));
  for (int k = 0; k < leaves; ++k) {
    Random leaf_random(HashCombine(weed.seed, static_cast<std::uint64_t>(k)));
    const double age = 1.0 - static_cast<double>(k) / (leaves - 1);  // 1 oldest … 0 youngest
    const double azimuth = weed.yaw_rad + k * 137.5 * kDeg + leaf_random.Normal(0.0, 12 * kDeg);
    const double length = k == 0 ? R : R * (0.55 + 0.4 * age) * leaf_random.Uniform(0.85, 1.0);
    const double rise =
        k == leaves - 1 ? H : H * (0.35 + 0.5 * (1.0 - age)) * leaf_random.Uniform(0.85, 1.0);
    const double width = 0.4 * length * leaf_random.Uniform(0.85, 1.15);
    if (k != leaves - 1 && k != 0 && k % keep_every != 0) continue;
    const Vector3d along(std::cos(azimuth), std::sin(azimuth), 0.0);
    const Vector3d side(-along.y(), along.x(), 0.0);
    const Vector3f rgb = base_rgb * static_cast<float>(leaf_random.Uniform(0.9, 1.1));
    // Midrib: horizontal distance length·u, height rise·(2u − u²) above the local ground (rising,
    // flattening at the tip); half width ∝ sin(πu)^0.7, so the leaf is pointed at both ends.
    auto point = [&](double u, double across) {
      const Vector3d p = length * u * along + across * side;
      const double z = world.TerrainHeight(weed.xy.x() + p.x(), weed.xy.y() + p.y());
      return Vector3d(p.x(), p.y(), z + 0.002 + rise * (2.0 * u - u * u));
    };
    std::uint32_t previous[3] = {0, 0, 0};
    for (int i = 0; i < stations; ++i) {
      const double u = static_cast<double>(i) / (stations - 1);
      const double half_width = 0.5 * width * std::pow(std::sin(M_PI * u), 0.7);
      const Vector3d mid = point(u, 0.0);
      const Vector3d left = point(u, half_width), right = point(u, -half_width);
      const Vector3d tangent =
          point(std::min(1.0, u + 0.05), 0.0) - point(std::max(0.0, u - 0.05), 0.0);
      Vector3d normal = tangent.cross(side);
      if (normal.z() < 0.0) normal = -normal;
      const std::uint32_t current[3] = {out.AddVertex(left, normal, rgb, true),
                                        out.AddVertex(mid, normal, rgb, true),
                                        out.AddVertex(right, normal, rgb, true)};
      if (i > 0) {
        for (int j = 0; j < 2; ++j) {
          out.AddTriangle(previous[j], previous[j + 1], current[j + 1]);
          out.AddTriangle(previous[j], current[j + 1], current[j]);
        }
      }
      std::copy(current, current + 3, previous);
    }
  }
}

}  // namespace crop4d::sim
