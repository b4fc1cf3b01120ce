#include "crop4d/dense/cell_window.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <vector>

namespace crop4d::dense {
namespace {

// A value in [0, 1) from a cell and a salt: the synthetic sweeps below are a function of the
// cell alone, whatever order the cells are matched in.
double Hash(int i, int j, int salt) {
  std::uint64_t h = (static_cast<std::uint64_t>(i) * 0x9E3779B97F4A7C15ULL) ^
                    (static_cast<std::uint64_t>(j) * 0xC2B2AE3D27D4EB4FULL) ^
                    (static_cast<std::uint64_t>(salt) * 0x165667B19E3779F9ULL);
  h ^= h >> 31;
  h *= 0xD6E8FEB86659FD93ULL;
  h ^= h >> 32;
  return static_cast<double>(h >> 11) / 9007199254740992.0;
}

// A strip of field 12 m long and 1 m wide (along y, or along x when `along_x`), seen by cameras
// 1 m above a line along it every 10 cm; each cell's reference is the camera about 60 cm behind
// it.
struct Strip {
  bool along_x = false;
  DenseRegion region;
  std::vector<Eigen::Vector3d> cameras;

  explicit Strip(bool x) : along_x(x) {
    const Eigen::Vector2d size = x ? Eigen::Vector2d(12.0, 1.0) : Eigen::Vector2d(1.0, 12.0);
    region.bounds = Eigen::AlignedBox2d(Eigen::Vector2d(0.003, -0.002), size);
    for (int k = 0; k <= 120; ++k) {
      cameras.push_back(x ? Eigen::Vector3d(0.1 * k, 0.5, 1.0)
                          : Eigen::Vector3d(0.5, 0.1 * k, 1.0));
    }
  }

  int Reference(const Eigen::Vector2d& xy) const {
    const double along = (along_x ? xy.x() : xy.y()) - 0.6;
    return std::clamp(static_cast<int>(std::lround(along / 0.1)), 0, 120);
  }

  // The farthest a cell lies from its reference, horizontally.
  double Reach(const CellWindow& w) const {
    double reach = 0;
    for (int j = 0; j < w.gy; ++j) {
      for (int i = 0; i < w.gx; ++i) {
        const Eigen::Vector2d xy = w.Centre(i, j);
        reach = std::max(reach, (cameras[Reference(xy)].head<2>() - xy).norm() + w.s);
      }
    }
    return reach;
  }

  // What the sweeps would find at the window's cells with along-coordinate in [a0, a1): soil,
  // plants 15 cm high, false matches floating 30 cm above the soil in small patches (they block
  // the rays of the soil behind them), lone spikes, and cells the sweeps reject.
  void Match(int a0, int a1, CellWindow* w) const {
    for (int a = a0; a < a1; ++a) {
      for (int c = 0; c < w->cross_size(); ++c) {
        const int i = w->I(a, c), j = w->J(a, c);
        const std::size_t g = w->At(i, j);
        if (w->state[g] == kOutside) continue;
        const Eigen::Vector2d xy = w->Centre(i, j);
        if (Hash(i, j, 1) < 0.1) {
          w->state[g] = Hash(i, j, 2) < 0.5 ? kLowScore : kLowTexture;
          continue;
        }
        const double along = along_x ? xy.x() : xy.y();
        const double across = along_x ? xy.y() : xy.x();
        double z = 0.01 * std::sin(along) + 0.002 * Hash(i, j, 3);
        if (std::hypot(std::fmod(along, 0.5) - 0.25, across - 0.5) < 0.08) z += 0.15;  // a plant
        // Patches of 4 × 4 cm (16 cells) at random places: false matches or top leaves.
        const int pi = static_cast<int>(std::floor(xy.x() / 0.04));
        const int pj = static_cast<int>(std::floor(xy.y() / 0.04));
        if (Hash(pi, pj, 4) < 0.03) z += 0.3;
        if (Hash(i, j, 5) < 0.01) z += 0.05;  // a spike
        w->state[g] = kKept;
        w->height[g] = static_cast<float>(z);
        w->score[g] = static_cast<float>(0.5 + 0.5 * Hash(i, j, 6));
        w->unique[g] = static_cast<float>(Hash(i, j, 7));
        w->disagreement[g] = static_cast<float>(Hash(pi, pj, 8) < 0.3 ? 0.2 : 0.01);
        w->num_views[g] = static_cast<std::uint8_t>(3 + 5 * Hash(i, j, 9));
        w->rgb[g] = {static_cast<std::uint8_t>(255 * Hash(i, j, 10)), 100, 50};
        w->reference_of[g] = Reference(xy);
        w->on_top_surface[g] = Hash(i, j, 11) < 0.1 ? 1 : 0;
      }
    }
  }
};

struct Filtered {
  io::PlyPointCloud cloud;
  HeightFieldStereo::Summary summary;
};

// The filters over the strip, its cells matched `step` cells at a time along it (0: all at once).
Filtered FilterStrip(const Strip& strip, int step) {
  HeightFieldStereo::Options o;
  o.cell_m = 0.01;
  Filtered out;
  CellWindow w = CellWindow::ForRegion(o.cell_m, strip.region);
  CellFilters filters(o, strip.region, &w, strip.cameras, strip.Reach(w), nullptr, &out.cloud,
                      &out.summary);
  const int n = w.along_size();
  for (int a0 = 0; a0 < n;) {
    const int a1 = step > 0 ? std::min(n, a0 + step) : n;
    filters.Hold(a1);
    strip.Match(a0, a1, &w);
    filters.Matched(a1);
    a0 = a1;
  }
  filters.Finish();
  return out;
}

// The region matched and filtered a band at a time gives the points of the whole region held at
// once, to the bit and in the same order, with a fraction of its cells in memory.
TEST(CellFiltersTest, BandByBandGivesTheCloudOfTheWholeRegionWithAFractionOfItsCells) {
  for (const bool along_x : {false, true}) {
    SCOPED_TRACE(along_x ? "along x" : "along y");
    const Strip strip(along_x);
    const Filtered whole = FilterStrip(strip, 0);
    const Filtered bands = FilterStrip(strip, 37);
    // The filters had work to do: every kind of rejection is there.
    EXPECT_GT(whole.summary.num_occluding, 100);
    EXPECT_GT(whole.summary.num_isolated, 1000);
    EXPECT_GT(whole.summary.num_low_score, 1000);
    ASSERT_GT(whole.cloud.size(), 50000u);
    const CellWindow grid = CellWindow::ForRegion(0.01, strip.region);
    EXPECT_EQ(grid.along_y, !along_x);
    EXPECT_EQ(whole.summary.max_cells_held, static_cast<std::int64_t>(grid.gx) * grid.gy);
    EXPECT_LT(bands.summary.max_cells_held, 0.45 * whole.summary.max_cells_held);
    std::printf("%s: %zu points, %lld occluding, %lld isolated; cells held %lld of %lld\n",
                along_x ? "along x" : "along y", whole.cloud.size(),
                static_cast<long long>(whole.summary.num_occluding),
                static_cast<long long>(whole.summary.num_isolated),
                static_cast<long long>(bands.summary.max_cells_held),
                static_cast<long long>(whole.summary.max_cells_held));

    EXPECT_TRUE(bands.cloud.points == whole.cloud.points);
    EXPECT_TRUE(bands.cloud.colors == whole.cloud.colors);
    ASSERT_EQ(bands.cloud.scalars.size(), 3u);
    for (std::size_t k = 0; k < 3; ++k) {
      EXPECT_TRUE(bands.cloud.scalars[k].values == whole.cloud.scalars[k].values);
    }
    EXPECT_EQ(bands.summary.num_points, whole.summary.num_points);
    EXPECT_EQ(bands.summary.num_isolated, whole.summary.num_isolated);
    EXPECT_EQ(bands.summary.num_occluding, whole.summary.num_occluding);
    EXPECT_EQ(bands.summary.num_top_surface, whole.summary.num_top_surface);
    EXPECT_EQ(bands.summary.num_cells_with_views, whole.summary.num_cells_with_views);
  }
}

// The points come out in along-major order: rows of the grid, one after the other, along y.
TEST(CellFiltersTest, PointsComeOutAlongTheLongerSide) {
  for (const bool along_x : {false, true}) {
    const Strip strip(along_x);
    const Filtered f = FilterStrip(strip, 50);
    ASSERT_GT(f.cloud.size(), 1000u);
    for (std::size_t k = 1; k < f.cloud.size(); ++k) {
      const Eigen::Vector3d& p = f.cloud.points[k - 1];
      const Eigen::Vector3d& q = f.cloud.points[k];
      const double dp = along_x ? p.x() : p.y(), dq = along_x ? q.x() : q.y();
      ASSERT_LE(dp, dq + 1e-12) << k;
    }
  }
}

}  // namespace
}  // namespace crop4d::dense
