// Each option struct of association/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/association/footprint.h"
#include "crop4d/association/local_planes.h"
#include "crop4d/association/plane_warp.h"
#include "crop4d/association/prealignment.h"
#include "crop4d/association/robust_matcher.h"
#include "crop4d/association/surface_points.h"
#include "crop4d/core/option_check_test_util.h"

namespace crop4d::association {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(AssociationOptions, CheckNamesTheWrongOption) {
  using F = FootprintOptions;
  ExpectCheckNamesOption<F>(F(), {{"max_range_m", [](F& o) { o.max_range_m = 1.0 / 0.0; }},
                                  {"samples_per_side", [](F& o) { o.samples_per_side = 0; }}});
  using P = PairSelectionOptions;
  ExpectCheckNamesOption<P>(P(),
                            {{"footprint.max_range_m", [](P& o) { o.footprint.max_range_m = 0; }},
                             {"min_overlap", [](P& o) { o.min_overlap = 1.5; }},
                             {"max_scale_change", [](P& o) { o.max_scale_change = 0.5; }},
                             {"view_samples", [](P& o) { o.view_samples = 0; }}});
  using L = LocalPlanes::Options;
  ExpectCheckNamesOption<L>(
      L(), {{"min_neighbors", [](L& o) { o.min_neighbors = o.num_neighbors + 1; }},
            {"max_neighbor_distance_m", [](L& o) { o.max_neighbor_distance_m = 0; }}});
  using W = PlaneWarpOptions;
  ExpectCheckNamesOption<W>(W(), {{"descriptor_sigma", [](W& o) { o.descriptor_sigma = 0.5; }},
                                  {"min_view_cosine", [](W& o) { o.min_view_cosine = 1; }},
                                  {"max_pyramid_level", [](W& o) { o.max_pyramid_level = -1; }}});
  using R = RobustMatcher::Options;
  ExpectCheckNamesOption<R>(
      R(),
      {{"max_search_radius_px", [](R& o) { o.max_search_radius_px = o.min_search_radius_px - 1; }},
       {"max_ratio", [](R& o) { o.max_ratio = 1.5; }},
       {"warp.descriptor_sigma", [](R& o) { o.warp.descriptor_sigma = 9; }},
       {"verification.min_num_inliers", [](R& o) { o.verification.min_num_inliers = 7; }}});
  using S = SurfacePointOptions;
  ExpectCheckNamesOption<S>(S(),
                            {{"num_neighbors", [](S& o) { o.num_neighbors = 17; }},
                             {"max_sigma_m", [](S& o) { o.max_sigma_m = 0.5 * o.min_sigma_m; }}});
  using A = PreAlignmentOptions;
  ExpectCheckNamesOption<A>(
      A(), {{"stride", [](A& o) { o.stride = 0; }},
            {"naive.descriptors.max_ratio", [](A& o) { o.naive.descriptors.max_ratio = 0; }}});
}

}  // namespace
}  // namespace crop4d::association
