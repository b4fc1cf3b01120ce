#pragma once

// The field lists of the front end's option structs (core/option_fields.h): one VisitFields per
// struct, every data member in declaration order. A member added to a struct must be added here
// (the stage options test counts them).

#include <span>

#include "crop4d/core/option_fields.h"
#include "crop4d/features/feature_extractor.h"
#include "crop4d/features/front_end.h"
#include "crop4d/features/matcher.h"
#include "crop4d/features/tracks.h"

namespace crop4d::features {

inline std::span<const fields::EnumName<DescriptorMatchOptions::Method>> FieldEnumNames(
    DescriptorMatchOptions::Method) {
  using M = DescriptorMatchOptions::Method;
  static constexpr fields::EnumName<M> kNames[] = {{M::kFlann, "flann"},
                                                   {M::kExhaustive, "exhaustive"}};
  return kNames;
}

inline std::span<const fields::EnumName<EpipolarVerificationOptions::Method>> FieldEnumNames(
    EpipolarVerificationOptions::Method) {
  using M = EpipolarVerificationOptions::Method;
  static constexpr fields::EnumName<M> kNames[] = {{M::kRansac8Point, "ransac-8-point"},
                                                   {M::kRansac7Point, "ransac-7-point"}};
  return kNames;
}

inline std::span<const fields::EnumName<TrackBuilder::ConflictPolicy>> FieldEnumNames(
    TrackBuilder::ConflictPolicy) {
  using P = TrackBuilder::ConflictPolicy;
  static constexpr fields::EnumName<P> kNames[] = {{P::kSplit, "split"}, {P::kDrop, "drop"}};
  return kNames;
}

template <class V>
void VisitFields(FeatureExtractor::Options& o, V&& visit) {
  visit("max_num_features", o.max_num_features);
  visit("num_octave_layers", o.num_octave_layers);
  visit("contrast_threshold", o.contrast_threshold);
  visit("edge_threshold", o.edge_threshold);
  visit("sigma", o.sigma);
  visit("max_image_size", o.max_image_size);
  visit("spatial_grid_cells", o.spatial_grid_cells);
}

template <class V>
void VisitFields(DescriptorMatchOptions& o, V&& visit) {
  visit("method", o.method);
  visit("max_ratio", o.max_ratio);
  visit("cross_check", o.cross_check);
  visit("num_trees", o.num_trees);
  visit("num_checks", o.num_checks);
  visit("seed", o.seed);
}

template <class V>
void VisitFields(EpipolarVerificationOptions& o, V&& visit) {
  visit("method", o.method);
  visit("max_error_px", o.max_error_px);
  visit("confidence", o.confidence);
  visit("max_num_iterations", o.max_num_iterations);
  visit("refine", o.refine);
  visit("min_num_inliers", o.min_num_inliers);
}

template <class V>
void VisitFields(PairMatcher::Options& o, V&& visit) {
  visit("descriptors", o.descriptors);
  visit("verification", o.verification);
}

template <class V>
void VisitFields(TrackBuilder::Options& o, V&& visit) {
  visit("min_track_length", o.min_track_length);
  visit("conflict_policy", o.conflict_policy);
}

template <class V>
void VisitFields(FrontEnd::Options& o, V&& visit) {
  visit("extraction", o.extraction);
  visit("matching", o.matching);
  visit("tracks", o.tracks);
  visit("num_neighbors", o.num_neighbors);
  // How the images are blocked in memory while matching: the same matches for any size.
  visit("matching_block_size", o.matching_block_size, fields::Role::kControl);
  visit("cache_path", o.cache_path, fields::Role::kControl);
  visit("num_threads", o.num_threads, fields::Role::kControl);
  visit("show_progress", o.show_progress, fields::Role::kControl);
}

}  // namespace crop4d::features
