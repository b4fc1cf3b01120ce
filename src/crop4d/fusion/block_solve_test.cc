// Blocks of passes for the joint problem (block_solve.h): which passes go together. The solve
// in blocks against the joint solve is in joint_optimiser_test.cc (its simulated passes).

#include "crop4d/fusion/block_solve.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

namespace crop4d::fusion {
namespace {

// A pass along a row at `x` (east), driven north or south over 20 m.
JointOptimiser::Pass RowPass(double x, bool north) {
  JointOptimiser::Pass pass;
  for (int k = 0; k <= 20; ++k) {
    slam::RowState s;
    s.t = k * 100000000LL;
    const double y = north ? k : 20 - k;
    s.nav.world_from_body = geometry::Rigid3(Eigen::Quaterniond::Identity(), {x, y, 0.0});
    pass.initial_states.push_back(s);
  }
  return pass;
}

// The blocks with their passes sorted, in the order of their first pass: which side of the
// field comes first is the partition's choice.
std::vector<std::vector<int>> Sorted(std::vector<std::vector<int>> blocks) {
  for (auto& b : blocks) std::sort(b.begin(), b.end());
  std::sort(blocks.begin(), blocks.end());
  return blocks;
}

TEST(PartitionPasses, NeighbouringRowsOfEveryDateGoTogether) {
  // Three rows 0.75 m apart, two dates, each date driving its rows in the other order and
  // direction; a little GPS scatter across the row.
  std::vector<JointOptimiser::Pass> passes;
  for (const int date : {0, 1}) {
    for (int r = 0; r < 3; ++r) {
      const int row = date == 0 ? r : 2 - r;
      passes.push_back(RowPass(0.75 * row + 0.02 * date, (row + date) % 2 == 0));
    }
  }
  const std::vector<std::int64_t> observations(6, 100);
  const std::vector<bool> every(6, true);
  // Row 0 is pass 0 (date 0) and pass 5 (date 1), row 1 passes 1 and 4, row 2 passes 2 and 3.
  const std::vector<std::vector<int>> rows = PartitionPasses(passes, observations, every, 250);
  EXPECT_EQ(Sorted(rows), (std::vector<std::vector<int>>{{0, 5}, {1, 4}, {2, 3}}));
  // The blocks go across the field: the middle row between the outer ones.
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(Sorted({rows[1]}), (std::vector<std::vector<int>>{{1, 4}}));
  // Two blocks of at most 400, of equal size: three passes each, the middle row split.
  const std::vector<std::vector<int>> two = PartitionPasses(passes, observations, every, 400);
  ASSERT_EQ(two.size(), 2u);
  EXPECT_EQ(two[0].size(), 3u);
  const auto halves = Sorted(two);
  EXPECT_TRUE(halves == (std::vector<std::vector<int>>{{0, 1, 5}, {2, 3, 4}}) ||
              halves == (std::vector<std::vector<int>>{{0, 4, 5}, {1, 2, 3}}));
  EXPECT_EQ(PartitionPasses(passes, observations, every, 600).size(), 1u);
  // Held passes are in no block; a pass above the bound is a block of its own.
  std::vector<bool> free = every;
  free[4] = false;
  std::vector<std::int64_t> heavy = observations;
  heavy[1] = 1000;
  EXPECT_EQ(Sorted(PartitionPasses(passes, heavy, free, 250)),
            (std::vector<std::vector<int>>{{0, 5}, {1}, {2, 3}}));
}

TEST(PartitionPasses, RowsAlongAnyHeadingAreOrderedAcrossThem) {
  // Rows heading 30° east of north, 1 m apart, listed out of order.
  const double a = 30.0 * M_PI / 180.0;
  const Eigen::Vector3d along(std::sin(a), std::cos(a), 0), across(std::cos(a), -std::sin(a), 0);
  std::vector<JointOptimiser::Pass> passes;
  for (const int row : {2, 0, 3, 1}) {
    JointOptimiser::Pass pass = RowPass(0, row % 2 == 0);
    for (slam::RowState& s : pass.initial_states) {
      const double y = s.nav.world_from_body.translation().y();
      s.nav.world_from_body =
          geometry::Rigid3(Eigen::Quaterniond::Identity(), row * across + y * along);
    }
    passes.push_back(pass);
  }
  const std::vector<std::vector<int>> blocks =
      PartitionPasses(passes, std::vector<std::int64_t>(4, 10), std::vector<bool>(4, true), 20);
  // Rows 0 and 1 (passes 1 and 3), rows 2 and 3 (passes 0 and 2).
  EXPECT_EQ(Sorted(blocks), (std::vector<std::vector<int>>{{0, 2}, {1, 3}}));
}

// Refused up front, by SolveInBlocks itself (its message), before any block reaches the joint
// optimiser, which would refuse some of these inputs too.
void ExpectRefusedUpFront(const std::vector<JointOptimiser::Pass>& passes,
                          const std::vector<JointLandmark>& landmarks,
                          const std::vector<bool>& fixed = {}) {
  try {
    SolveInBlocks(JointOptimiser::Options(), BlockSolveOptions(), passes, landmarks, {}, fixed);
    ADD_FAILURE() << "accepted";
  } catch (const std::invalid_argument& e) {
    EXPECT_EQ(std::string(e.what()).rfind("SolveInBlocks: ", 0), 0u) << e.what();
  }
}

TEST(SolveInBlocks, RejectsInconsistentInput) {
  std::vector<JointOptimiser::Pass> passes = {RowPass(0, true), RowPass(1, false)};
  passes[1].initial_states.resize(1);
  ExpectRefusedUpFront(passes, {});
  passes[1] = RowPass(1, false);
  JointLandmark out_of_range;
  out_of_range.observations.push_back({2, 0, Eigen::Vector2d(1, 1)});
  ExpectRefusedUpFront(passes, {out_of_range});
  // A state out of range, an image of a pass without camera.
  geometry::PinholeRadTan camera;
  passes[0].camera = &camera;
  out_of_range.observations = {{0, 21, Eigen::Vector2d(1, 1)}};
  ExpectRefusedUpFront(passes, {out_of_range});
  out_of_range.observations = {{1, 0, Eigen::Vector2d(1, 1)}};
  ExpectRefusedUpFront(passes, {out_of_range});
  // fixed_passes of another length.
  ExpectRefusedUpFront(passes, {}, {true});
}

TEST(BlockSolveOptions, Check) {
  BlockSolveOptions o;
  EXPECT_TRUE(o.Check().empty());
  o.sweeps = 0;
  EXPECT_EQ(o.Check(), "sweeps: must be >= 1 (got 0)");
  o = BlockSolveOptions();
  o.max_observations = -1;
  EXPECT_EQ(o.Check(), "max_observations: must be >= 0 (got -1)");
}

}  // namespace
}  // namespace crop4d::fusion
