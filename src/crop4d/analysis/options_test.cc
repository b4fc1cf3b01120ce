// Each option struct of analysis/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/analysis/canopy.h"
#include "crop4d/analysis/ground_filter.h"
#include "crop4d/analysis/growth.h"
#include "crop4d/analysis/plants.h"
#include "crop4d/analysis/terrain.h"
#include "crop4d/analysis/vegetation.h"
#include "crop4d/core/option_check_test_util.h"

namespace crop4d::analysis {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(AnalysisOptions, CheckNamesTheWrongOption) {
  using C = CanopyOptions;
  ExpectCheckNamesOption<C>(C(), {{"min_height_any_colour_m",
                                   [](C& o) { o.min_height_any_colour_m = o.min_height_m - 0.01; }},
                                  {"top_quantile", [](C& o) { o.top_quantile = 0; }},
                                  {"min_canopy_cells", [](C& o) { o.min_canopy_cells = 0; }}});
  using G = GroundFilterOptions;
  ExpectCheckNamesOption<G>(G(), {{"cell_m", [](G& o) { o.cell_m = 0; }},
                                  {"window_m", [](G& o) { o.window_m = 1.0 / 0.0; }}});
  using R = GrowthOptions;
  ExpectCheckNamesOption<R>(R(),
                            {{"max_asymptote_factor", [](R& o) { o.max_asymptote_factor = 0.5; }},
                             {"max_rate_per_day", [](R& o) { o.max_rate_per_day = 0; }}});
  using P = PlantDetectionOptions;
  ExpectCheckNamesOption<P>(P(), {{"top_fraction", [](P& o) { o.top_fraction = 1.5; }},
                                  {"min_cells", [](P& o) { o.min_cells = 0; }},
                                  {"max_row_offset_m", [](P& o) { o.max_row_offset_m = -1; }}});
  GridSpec grid;
  grid.width = grid.height = 10;
  ExpectCheckNamesOption<GridSpec>(grid, {{"width", [](GridSpec& o) { o.width = 0; }},
                                          {"cell_m", [](GridSpec& o) { o.cell_m = -1; }}});
  using T = TerrainOptions;
  ExpectCheckNamesOption<T>(
      T(), {{"fit_radius_m", [](T& o) { o.fit_radius_m = o.cell_m; }},
            {"min_points", [](T& o) { o.min_points = 5; }},
            {"ground_filter.max_height_m", [](T& o) { o.ground_filter.max_height_m = 0; }}});
  using L = PlaneOptions;
  ExpectCheckNamesOption<L>(L(), {{"min_points", [](L& o) { o.min_points = 2; }}});
  using V = VegetationOptions;
  ExpectCheckNamesOption<V>(V(), {{"threshold", [](V& o) { o.threshold = 1.0 / 0.0; }},
                                  {"histogram_bins", [](V& o) { o.histogram_bins = 1; }}});
}

}  // namespace
}  // namespace crop4d::analysis
