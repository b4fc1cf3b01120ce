// Each option struct of eval/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include <cmath>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/eval/workspace_eval.h"

namespace crop4d::eval {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(EvalOptions, CheckNamesTheWrongOption) {
  using O = WorkspaceEvalOptions;
  ExpectCheckNamesOption<O>(
      O(),
      {
          {"metrics.rpe_distance_m", [](O& o) { o.metrics.rpe_distance_m = -1; }},
          {"max_dt_s", [](O& o) { o.max_dt_s = -0.1; }},
          {"association.max_distance_m", [](O& o) { o.association.max_distance_m = 0; }},
          {"association.coarse_distance_m", [](O& o) { o.association.coarse_distance_m = NAN; }},
          {"association.near_depth_m", [](O& o) { o.association.near_depth_m = 0; }},
          {"association.true_point.max_edge_m",
           [](O& o) { o.association.true_point.max_edge_m = 0; }},
          {"association.true_point.max_depth_m",
           [](O& o) { o.association.true_point.max_depth_m = -1; }},
          {"clouds.selection.plant_margin_m", [](O& o) { o.clouds.selection.plant_margin_m = -1; }},
          {"clouds.selection.max_terrain_distance_m",
           [](O& o) { o.clouds.selection.max_terrain_distance_m = 0; }},
          {"clouds.misalignment.radius_m", [](O& o) { o.clouds.misalignment.radius_m = 0; }},
          {"clouds.misalignment.min_points", [](O& o) { o.clouds.misalignment.min_points = 2; }},
          {"clouds.misalignment.max_slope_deg",
           [](O& o) { o.clouds.misalignment.max_slope_deg = 91; }},
          {"clouds.misalignment.max_query_points",
           [](O& o) { o.clouds.misalignment.max_query_points = 0; }},
          {"canopy.max_error_m", [](O& o) { o.canopy_options.max_error_m = -1; }},
          {"dense.top_radius_m", [](O& o) { o.dense_options.top_radius_m = 0; }},
          {"dense.tolerance_m", [](O& o) { o.dense_options.tolerance_m = 0; }},
          {"dense.ground.plant_margin_m", [](O& o) { o.dense_options.ground.plant_margin_m = -1; }},
      });
  EXPECT_EQ(PlantEvalOptions{.max_stem_offset_m = 0}.Check(),
            "max_stem_offset_m: must be > 0 (got 0)");
}

}  // namespace
}  // namespace crop4d::eval
