#include "crop4d/sim/world.h"

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/core/error.h"

namespace crop4d::sim {
namespace {

constexpr Timestamp kDay = 86400LL * 1'000'000'000LL;

WorldOptions LongRows() {
  WorldOptions options;
  options.num_rows = 6;
  options.row_length_m = 60.0;
  options.seed = 7;
  return options;
}

TEST(WorldTest, PlantPlacementStatistics) {
  const WorldOptions options = LongRows();
  const World world(options);
  const auto& plants = world.plants();
  ASSERT_FALSE(plants.empty());

  int gaps = 0, doubles = 0;
  for (int row = 0; row < options.num_rows; ++row) {
    const auto [begin, end] = world.RowPlantRange(row);
    ASSERT_LT(begin, end);
    // Mean spacing: row length over the number of plants, within 10 % of the option.
    const double mean_spacing = options.row_length_m / (end - begin);
    EXPECT_NEAR(mean_spacing, options.plant_spacing_m, 0.1 * options.plant_spacing_m)
        << "row " << row;
    for (int i = begin; i < end; ++i) {
      const Plant& p = plants[i];
      EXPECT_EQ(p.row, row);
      EXPECT_EQ(p.id, i);
      // Within the row: near the centre line and between the row ends.
      EXPECT_LT(std::abs(p.xy.x() - world.RowX(row)), 0.06);
      EXPECT_GE(p.xy.y(), 0.0);
      EXPECT_LE(p.xy.y(), options.row_length_m);
      EXPECT_TRUE(world.Bounds().contains(p.xy));
      if (i + 1 < end) {
        const double dy = plants[i + 1].xy.y() - p.xy.y();
        EXPECT_GE(dy, 0.0);  // sorted along the row
        if (dy < 0.07) ++doubles;
        if (dy > 1.7 * options.plant_spacing_m) ++gaps;
      }
    }
  }
  EXPECT_GT(gaps, 5);
  EXPECT_GT(doubles, 5);

  // Per-plant variation: scales spread around 1.
  double sum = 0.0, sum2 = 0.0;
  for (const Plant& p : plants) {
    sum += p.height_scale;
    sum2 += p.height_scale * p.height_scale;
  }
  const double mean = sum / plants.size();
  const double sigma = std::sqrt(sum2 / plants.size() - mean * mean);
  EXPECT_NEAR(mean, 1.0, 0.02);
  EXPECT_NEAR(sigma, options.plant_variation, 0.03);
}

TEST(WorldTest, SameSeedSameField) {
  const World a(LongRows()), b(LongRows());
  ASSERT_EQ(a.plants().size(), b.plants().size());
  for (size_t i = 0; i < a.plants().size(); ++i) {
    EXPECT_EQ(a.plants()[i].xy, b.plants()[i].xy);
    EXPECT_EQ(a.plants()[i].seed, b.plants()[i].seed);
  }
  WorldOptions other = LongRows();
  other.seed = 8;
  const World c(other);
  EXPECT_NE(a.plants()[3].xy, c.plants()[3].xy);
  EXPECT_NE(a.TerrainHeight(3.0, 4.0), c.TerrainHeight(3.0, 4.0));
}

TEST(WorldTest, TerrainSmoothWithConsistentNormal) {
  const World world(LongRows());
  const WorldOptions& o = world.options();
  const Eigen::AlignedBox2d bounds = world.Bounds();
  const double h = 1e-5;
  double max_abs_height = 0.0;
  for (double x = bounds.min().x() - 3.0; x <= bounds.max().x() + 3.0; x += 0.0371) {
    for (double y = bounds.min().y() - 3.0; y <= bounds.max().y() + 3.0; y += 1.13) {
      const double z = world.TerrainHeight(x, y);
      max_abs_height = std::max(max_abs_height, std::abs(z));
      const double gx = (world.TerrainHeight(x + h, y) - world.TerrainHeight(x - h, y)) / (2 * h);
      const double gy = (world.TerrainHeight(x, y + h) - world.TerrainHeight(x, y - h)) / (2 * h);
      const Eigen::Vector3d numeric = Eigen::Vector3d(-gx, -gy, 1.0).normalized();
      const Eigen::Vector3d normal = world.TerrainNormal(x, y);
      EXPECT_NEAR(normal.norm(), 1.0, 1e-12);
      ASSERT_LT((normal - numeric).norm(), 1e-6) << x << " " << y;
      // Gentle: slopes below ~30° everywhere (furrow walls are the steepest part).
      EXPECT_GT(normal.z(), std::cos(30.0 * M_PI / 180.0));
      // C¹: the gradient changes little over 1 mm.
      const Eigen::Vector3d near = world.TerrainNormal(x + 1e-3, y + 1e-3);
      EXPECT_LT((near - normal).norm(), 0.01);
    }
  }
  EXPECT_LT(max_abs_height, o.undulation_amplitude_m + o.bed_height_m + 0.01);

  // Raised beds: the row centre lies higher than the furrow midway, with the tyre track.
  for (int row = 0; row + 1 < o.num_rows; ++row) {
    const double x = world.RowX(row);
    const double y = 10.0;
    const double bed = world.TerrainHeight(x, y);
    const double furrow = world.TerrainHeight(x + 0.5 * o.row_spacing_m, y);
    EXPECT_NEAR(bed - furrow, o.bed_height_m + o.tyre_track_depth_m, 0.01);
  }
  // Row end points lie on the terrain.
  EXPECT_DOUBLE_EQ(world.RowStart(2).z(), world.TerrainHeight(world.RowX(2), 0.0));
  EXPECT_DOUBLE_EQ(world.RowEnd(2).y(), o.row_length_m);
}

TEST(WorldTest, GrowthFollowsPeanutLikeLogistic) {
  const World world(WorldOptions{});
  EXPECT_FALSE(world.NominalStateAt(3.0).emerged);
  const PlantState at_emergence = world.NominalStateAt(7.0);
  EXPECT_TRUE(at_emergence.emerged);
  EXPECT_NEAR(at_emergence.height_m, 0.05, 0.01);
  const PlantState at_90 = world.NominalStateAt(90.0);
  EXPECT_NEAR(at_90.height_m, 0.45, 0.03);
  // Monotone in time.
  PlantState previous = at_emergence;
  for (double d = 7.5; d <= 130.0; d += 0.5) {
    const PlantState s = world.NominalStateAt(d);
    EXPECT_GE(s.height_m, previous.height_m);
    EXPECT_GE(s.canopy_radius_m, previous.canopy_radius_m);
    EXPECT_LE(s.height_m, 0.45 + 1e-9);
    previous = s;
  }
  // The canopy closes late: the rows (0.91 m apart) touch only after ~2 months.
  const double half_spacing = 0.5 * world.options().row_spacing_m;
  EXPECT_LT(world.NominalStateAt(50.0).canopy_radius_m, half_spacing);
  EXPECT_GT(world.NominalStateAt(100.0).canopy_radius_m, half_spacing);

  // A real plant: scaled and delayed.
  Plant p;
  p.height_scale = 1.2;
  p.delay_days = 2.0;
  const Timestamp day_40 = world.options().sowing_date + 40 * kDay;
  EXPECT_NEAR(world.StateAt(p, day_40).height_m, 1.2 * world.NominalStateAt(38.0).height_m, 1e-9);
}

TEST(WorldTest, TrueCanopyHeightIsMeanOfNearbyPlants) {
  const World world(LongRows());
  const Timestamp date = world.options().sowing_date + 60 * kDay;
  const Eigen::Vector2d center(world.RowX(2), 20.0);
  const double radius = 0.8;
  double sum = 0.0;
  int count = 0;
  for (const Plant& p : world.plants()) {
    if ((p.xy - center).norm() <= radius) {
      sum += world.StateAt(p, date).height_m;
      ++count;
    }
  }
  ASSERT_GT(count, 5);
  EXPECT_NEAR(world.TrueCanopyHeight(center, radius, date), sum / count, 1e-12);
  EXPECT_EQ(world.TrueCanopyHeight(center, radius, world.options().sowing_date), 0.0);
  EXPECT_EQ(world.TrueCanopyHeight(Eigen::Vector2d(-50, -50), 1.0, date), 0.0);
}

TEST(WorldTest, WeedsGrowOnTheSoilBetweenTheRowsOnly) {
  WorldOptions options = LongRows();
  options.weeds.density_per_m2 = 3.0;
  const World world(options);
  const WeedOptions& w = options.weeds;
  const double s = options.row_spacing_m;
  const auto& weeds = world.weeds();
  // density × area, each strip's count rounded up or down.
  const double area =
      options.row_length_m * (options.num_rows * s - 2 * options.num_rows * w.row_clearance_m);
  EXPECT_NEAR(static_cast<double>(weeds.size()), w.density_per_m2 * area, options.num_rows + 1.0);
  int seen = 0;
  for (int strip = 0; strip <= options.num_rows; ++strip) {
    const auto [begin, end] = world.WeedStripRange(strip);
    EXPECT_EQ(begin, seen);
    seen = end;
    for (int i = begin; i < end; ++i) {
      const Weed& weed = weeds[i];
      EXPECT_EQ(weed.id, i);
      EXPECT_EQ(weed.strip, strip);
      if (i > begin) {
        EXPECT_LE(weeds[i - 1].xy.y(), weed.xy.y());
      }
      // Clear of every row's band, within the cultivated area and along the rows.
      for (int row = 0; row < options.num_rows; ++row) {
        EXPECT_GE(std::abs(weed.xy.x() - world.RowX(row)), w.row_clearance_m);
      }
      EXPECT_GE(weed.xy.x(), -0.5 * s);
      EXPECT_LE(weed.xy.x(), world.RowX(options.num_rows - 1) + 0.5 * s);
      EXPECT_GE(weed.xy.y(), 0.0);
      EXPECT_LE(weed.xy.y(), options.row_length_m);
      EXPECT_GE(weed.emergence_days, w.first_emergence_days);
      EXPECT_LE(weed.emergence_days, w.first_emergence_days + w.emergence_span_days);
    }
  }
  EXPECT_EQ(seen, static_cast<int>(weeds.size()));

  // Growth: nothing before emergence, a fifth of the final size at it, half after
  // half_size_days, then towards the final size; never shrinking.
  const Weed& weed = weeds[weeds.size() / 2];
  const auto at = [&](double days) {
    return world.WeedStateAt(weed, options.sowing_date + static_cast<Timestamp>(days * kDay));
  };
  const double final_height = weed.size_scale * w.final_height_m;
  EXPECT_FALSE(at(weed.emergence_days - 0.01).emerged);
  EXPECT_NEAR(at(weed.emergence_days + 1e-6).height_m, 0.2 * final_height, 1e-6);
  EXPECT_NEAR(at(weed.emergence_days + w.half_size_days).height_m, 0.5 * final_height, 1e-6);
  EXPECT_NEAR(at(weed.emergence_days + 80.0).canopy_radius_m, weed.size_scale * w.final_radius_m,
              1e-3);
  for (double d = 0.0; d < 60.0; d += 1.0) {
    EXPECT_LE(at(weed.emergence_days + d).height_m, at(weed.emergence_days + d + 1.0).height_m);
  }

  // Weeds draw from their own stream: the crop is the same as in a field without them, and
  // the truth of the sites leaves them out.
  const World clean(LongRows());
  ASSERT_TRUE(clean.weeds().empty());
  ASSERT_EQ(clean.plants().size(), world.plants().size());
  for (std::size_t i = 0; i < clean.plants().size(); ++i) {
    EXPECT_EQ(clean.plants()[i].xy, world.plants()[i].xy);
    EXPECT_EQ(clean.plants()[i].seed, world.plants()[i].seed);
  }
  const Timestamp late = options.sowing_date + 90 * kDay;
  const Eigen::Vector2d between(0.5 * s, 30.0);
  EXPECT_EQ(world.TrueCanopyHeight(between, 0.4, late), clean.TrueCanopyHeight(between, 0.4, late));
}

TEST(WorldTest, BadOptionsThrow) {
  WorldOptions options;
  options.num_rows = 0;
  EXPECT_THROW(World{options}, InputError);
  options = WorldOptions{};
  options.final_height_m = 0.01;
  EXPECT_THROW(options.Check(), InputError);
  options = WorldOptions{};
  options.weeds.density_per_m2 = -1.0;
  EXPECT_THROW(options.Check(), InputError);
  options = WorldOptions{};
  options.weeds.density_per_m2 = 1.0;
  options.weeds.row_clearance_m = 0.5;  // the rows' bands would cover the soil between them
  EXPECT_THROW(options.Check(), InputError);
}

}  // namespace
}  // namespace crop4d::sim
