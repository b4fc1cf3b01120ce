// Each option struct of dense/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/dense/ground_levels.h"
#include "crop4d/dense/height_field_stereo.h"

namespace crop4d::dense {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(DenseOptions, CheckNamesTheWrongOption) {
  using O = HeightFieldStereo::Options;
  ExpectCheckNamesOption<O>(
      O(), {
               {"cell_m", [](O& o) { o.cell_m = 0; }},
               {"tile_cells", [](O& o) { o.tile_cells = 3; }},
               {"patch_radius", [](O& o) { o.patch_radius = 6; }},
               {"fine_step_m", [](O& o) { o.fine_step_m = o.fine_half_range_m; }},
               {"max_views", [](O& o) { o.max_views = 33; }},
               {"near_time_s", [](O& o) { o.near_time_s = -0.5; }},
               {"near_time_min_green", [](O& o) { o.near_time_min_green = 1.5; }},
               {"min_views", [](O& o) { o.min_views = o.max_views; }},
               {"min_score", [](O& o) { o.min_score = 1; }},
               {"min_neighbours", [](O& o) { o.min_neighbours = 9; }},
               {"neighbour_tolerance_m", [](O& o) { o.neighbour_tolerance_m = -1; }},
               {"coarse_step_m", [](O& o) { o.coarse_step_m = 1e-5; }},
           });
  using G = GroundLevels::Options;
  ExpectCheckNamesOption<G>(G(), {
                                     {"tile_m", [](G& o) { o.tile_m = 0; }},
                                     {"quantile", [](G& o) { o.quantile = 1.5; }},
                                     {"min_points", [](G& o) { o.min_points = 0; }},
                                 });
  using C = CanopyCeilingOptions;
  ExpectCheckNamesOption<C>(C(), {
                                     {"quantile", [](C& o) { o.quantile = 1.5; }},
                                     {"scale", [](C& o) { o.scale = 0.5; }},
                                     {"margin_m", [](C& o) { o.margin_m = -0.1; }},
                                     {"min_m", [](C& o) { o.min_m = 0; }},
                                 });
}

}  // namespace
}  // namespace crop4d::dense
