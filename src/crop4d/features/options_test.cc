// Each option struct of features/ names the option that is wrong (core/option_check.h).

#include <gtest/gtest.h>

#include "crop4d/core/option_check_test_util.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/features/front_end.h"
#include "crop4d/features/matcher.h"
#include "crop4d/features/tracks.h"

namespace crop4d::features {
namespace {

using crop4d::testing::ExpectCheckNamesOption;

TEST(FeaturesOptions, CheckNamesTheWrongOption) {
  using E = FeatureExtractor::Options;
  ExpectCheckNamesOption<E>(E(), {{"num_octave_layers", [](E& o) { o.num_octave_layers = 0; }},
                                  {"sigma", [](E& o) { o.sigma = 1.0 / 0.0; }}});
  using D = DescriptorMatchOptions;
  ExpectCheckNamesOption<D>(D(), {{"max_ratio", [](D& o) { o.max_ratio = 0; }},
                                  {"num_checks", [](D& o) { o.num_checks = 0; }}});
  using V = EpipolarVerificationOptions;
  ExpectCheckNamesOption<V>(V(), {{"confidence", [](V& o) { o.confidence = 1; }},
                                  {"min_num_inliers", [](V& o) { o.min_num_inliers = 7; }}});
  using P = PairMatcher::Options;
  ExpectCheckNamesOption<P>(
      P(), {{"descriptors.num_trees", [](P& o) { o.descriptors.num_trees = 0; }},
            {"verification.max_error_px", [](P& o) { o.verification.max_error_px = 0; }}});
  using T = TrackBuilder::Options;
  ExpectCheckNamesOption<T>(T(), {{"min_track_length", [](T& o) { o.min_track_length = 1; }}});
  using F = FrontEnd::Options;
  ExpectCheckNamesOption<F>(
      F(), {{"extraction.sigma", [](F& o) { o.extraction.sigma = 0; }},
            {"tracks.min_track_length", [](F& o) { o.tracks.min_track_length = 0; }},
            {"num_neighbors", [](F& o) { o.num_neighbors = 0; }}});
}

}  // namespace
}  // namespace crop4d::features
