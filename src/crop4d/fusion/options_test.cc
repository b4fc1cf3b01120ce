// Each option struct of fusion/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/fusion/ground_ties.h"
#include "crop4d/fusion/joint_optimiser.h"
#include "crop4d/fusion/pass_alignment.h"

namespace crop4d::fusion {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(FusionOptions, CheckNamesTheWrongOption) {
  using G = GroundTieOptions;
  ExpectCheckNamesOption<G>(
      G(), {
               {"max_excess_green", [](G& o) { o.max_excess_green = -1; }},
               {"band_half_width_m", [](G& o) { o.band_half_width_m = 0; }},
               {"min_depth_below_camera_m", [](G& o) { o.min_depth_below_camera_m = -0.1; }},
               {"segment_m", [](G& o) { o.segment_m = 0; }},
               {"cell_along_m", [](G& o) { o.cell_along_m = 0; }},
               {"cell_across_m", [](G& o) { o.cell_across_m = 0; }},
               {"min_points", [](G& o) { o.min_points = 0; }},
               {"max_heading_difference_deg", [](G& o) { o.max_heading_difference_deg = 90; }},
           });
  using A = PassAlignmentOptions;
  ExpectCheckNamesOption<A>(
      A(), {
               {"inlier_threshold_m", [](A& o) { o.inlier_threshold_m = 0; }},
               {"ransac_iterations", [](A& o) { o.ransac_iterations = 0; }},
               {"min_inliers", [](A& o) { o.min_inliers = 1; }},
               {"min_sample_distance_m", [](A& o) { o.min_sample_distance_m = -1; }},
           });
  using J = JointOptimiser::Options;
  ExpectCheckNamesOption<J>(
      J(), {
               {"alignment.min_inliers", [](J& o) { o.alignment.min_inliers = 1; }},
           });
}

}  // namespace
}  // namespace crop4d::fusion
