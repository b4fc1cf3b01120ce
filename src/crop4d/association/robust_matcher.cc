#include "crop4d/association/robust_matcher.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <map>
#include <opencv2/core/mat.hpp>
#include <optional>
#include <tuple>

#include "crop4d/core/error.h"
#include "crop4d/core/stopwatch.h"

namespace crop4d::association {
namespace {

using Clock = std::chrono::steady_clock;

// L2 distance of two 8-bit descriptors (exact, in integers).
float DescriptorDistance(const std::uint8_t* a, const std::uint8_t* b) {
  std::int32_t sum = 0;
  for (int k = 0; k < features::kDescriptorSize; ++k) {
    const std::int32_t d = static_cast<std::int32_t>(a[k]) - static_cast<std::int32_t>(b[k]);
    sum += d * d;
  }
  return std::sqrt(static_cast<float>(sum));
}

// The pinhole pixel of a keypoint with the distortion removed (what the epipolar geometry of
// features::PairMatcher is estimated on); the distorted pixel if undistortion fails.
Eigen::Vector2d UndistortedPixel(const geometry::PinholeRadTan& camera,
                                 const features::FeatureSet& features, int i) {
  const Eigen::Vector2d pixel = features.Point(i);
  Eigen::Vector3d ray;
  if (!camera.Unproject(pixel, &ray)) return pixel;
  return Eigen::Vector2d(camera.fx * ray.x() + camera.cx, camera.fy * ray.y() + camera.cy);
}

// The features of I2 in square buckets, for box queries.
class FeatureGrid {
 public:
  FeatureGrid(const features::FeatureSet& features, int width, int height, double cell)
      : features_(features), cell_(cell) {
    columns_ = std::max(1, static_cast<int>(std::ceil((width + 1) / cell_)));
    rows_ = std::max(1, static_cast<int>(std::ceil((height + 1) / cell_)));
    std::vector<int> count(static_cast<std::size_t>(columns_) * rows_ + 1, 0);
    bucket_of_.resize(features.size());
    for (std::size_t i = 0; i < features.size(); ++i) {
      bucket_of_[i] = Bucket(features.keypoints[i].x, features.keypoints[i].y);
      ++count[bucket_of_[i] + 1];
    }
    for (std::size_t b = 1; b < count.size(); ++b) count[b] += count[b - 1];
    start_ = count;
    order_.resize(features.size());
    for (std::size_t i = 0; i < features.size(); ++i) {
      order_[count[bucket_of_[i]]++] = static_cast<std::int32_t>(i);
    }
  }

  // Appends the features inside [x − r, x + r] × [y − r, y + r].
  void Query(const Eigen::Vector2d& center, double radius, std::vector<std::int32_t>* out) const {
    const int c0 = ColumnOf(center.x() - radius), c1 = ColumnOf(center.x() + radius);
    const int r0 = RowOf(center.y() - radius), r1 = RowOf(center.y() + radius);
    for (int r = r0; r <= r1; ++r) {
      for (int c = c0; c <= c1; ++c) {
        const int b = r * columns_ + c;
        for (int k = start_[b]; k < start_[b + 1]; ++k) {
          const std::int32_t i = order_[k];
          const features::Keypoint& kp = features_.keypoints[i];
          if (std::abs(kp.x - center.x()) <= radius && std::abs(kp.y - center.y()) <= radius) {
            out->push_back(i);
          }
        }
      }
    }
  }

 private:
  int ColumnOf(double x) const {
    return std::clamp(static_cast<int>(std::floor((x + 0.5) / cell_)), 0, columns_ - 1);
  }
  int RowOf(double y) const {
    return std::clamp(static_cast<int>(std::floor((y + 0.5) / cell_)), 0, rows_ - 1);
  }
  int Bucket(double x, double y) const { return RowOf(y) * columns_ + ColumnOf(x); }

  const features::FeatureSet& features_;
  double cell_;
  int columns_ = 1, rows_ = 1;
  std::vector<int> bucket_of_;
  std::vector<int> start_;
  std::vector<std::int32_t> order_;
};

// A projected landmark and what the search needs to know about it.
struct Query {
  int observation = -1;
  Eigen::Vector2d projection;  // in I2
  double radius = 0;
  double predicted_size = 0;  // SIFT size expected in I2
  std::vector<std::int32_t> candidates;
  int warp = -1;  // index into the warp requests, −1: unwarped descriptor
};

}  // namespace

OptionCheck RobustMatcher::Options::Check() const {
  OptionChecker c;
  c.AtLeast("min_search_radius_px", min_search_radius_px, 0.0)
      .AtLeast("search_sigmas", search_sigmas, 0.0)
      .AtLeast("sigma_position_m", sigma_position_m, 0.0)
      .AtLeast("sigma_rotation_rad", sigma_rotation_rad, 0.0)
      .Require(max_search_radius_px >= min_search_radius_px, "max_search_radius_px",
               "must be >= min_search_radius_px", max_search_radius_px)
      .Greater("min_depth_m", min_depth_m, 0.0)
      .Require(max_scale_ratio == 0 || max_scale_ratio >= 1, "max_scale_ratio",
               "must be 0 (off) or >= 1", max_scale_ratio)
      .AtLeast("warp_min_baseline_m", warp_min_baseline_m, 0.0)
      .Nested("warp", warp.Check())
      .Greater("max_ratio", max_ratio, 0.0)
      .AtMost("max_ratio", max_ratio, 1.0)
      .Greater("max_descriptor_distance", max_descriptor_distance, 0.0)
      .AtLeast("same_point_radius_px", same_point_radius_px, 0.0)
      .Nested("verification", verification.Check());
  return c.Result();
}

RobustMatcher::RobustMatcher(Options options) : options_(std::move(options)) {
  CROP4D_CHECK_OPTIONS(options_, "RobustMatcher::Options");
}

namespace {

using MatcherOptions = RobustMatcher::Options;

// Whether a candidate's SIFT size is within max_scale_ratio of the predicted one.
bool ScaleAgrees(const MatcherOptions& options, double size, double predicted_size) {
  if (options.max_scale_ratio <= 0 || predicted_size <= 0) return true;
  const double ratio = size / predicted_size;
  return ratio <= options.max_scale_ratio && ratio * options.max_scale_ratio >= 1;
}

// Step 1, bounded search: each landmark of a that projects into I2 becomes a query with the
// features of I2 in a box sized by the pose uncertainty (and the landmark's own along its
// ray); with `warp`, a landmark with a local plane (or the ground normal, see plane_fallback)
// asks for a warped descriptor.
void BuildQueries(const MatcherOptions& options, const RobustPairInput& input, bool warp,
                  std::vector<Query>* queries, std::vector<WarpRequest>* warp_requests,
                  AssociationStats* stats) {
  const geometry::PinholeRadTan& camera_b = *input.camera_b;
  const features::FeatureSet& features_a = *input.features_a;
  const features::FeatureSet& features_b = *input.features_b;
  const std::vector<LandmarkObservation>& landmarks = *input.landmarks_a;
  const geometry::Rigid3 camera_b_from_world = input.world_from_camera_b.Inverse();
  const geometry::Rigid3 camera_a_from_world = input.world_from_camera_a.Inverse();
  const FeatureGrid grid(features_b, camera_b.width, camera_b.height, 16.0);
  const double focal_b = std::max(camera_b.fx, camera_b.fy);
  const Eigen::Matrix3d camera_a_from_world_rotation = camera_a_from_world.RotationMatrix();
  for (std::size_t o = 0; o < landmarks.size(); ++o) {
    const LandmarkObservation& observation = landmarks[o];
    CROP4D_CHECK(observation.feature >= 0 &&
                 static_cast<std::size_t>(observation.feature) < features_a.size());
    if (!observation.position_world.allFinite()) continue;
    const Eigen::Vector3d point_b = camera_b_from_world * observation.position_world;
    if (!(point_b.z() > options.min_depth_m)) continue;
    Query query;
    if (!camera_b.Project(point_b, &query.projection) || !camera_b.IsInImage(query.projection)) {
      continue;
    }
    ++stats->num_projected;
    // A point known only to σd along ray a moves in I2 by fx·σd·sin θ / z (θ between the rays).
    double along_ray_px = 0;
    if (observation.sigma_along_ray_m > 0) {
      const Eigen::Vector3d ray_a =
          (observation.position_world - input.world_from_camera_a.translation()).normalized();
      const Eigen::Vector3d ray_b =
          (observation.position_world - input.world_from_camera_b.translation()).normalized();
      along_ray_px =
          focal_b * observation.sigma_along_ray_m * ray_a.cross(ray_b).norm() / point_b.z();
    }
    query.radius =
        std::min(options.max_search_radius_px,
                 options.min_search_radius_px +
                     options.search_sigmas * (focal_b * options.sigma_position_m / point_b.z() +
                                              focal_b * options.sigma_rotation_rad + along_ray_px));
    grid.Query(query.projection, query.radius, &query.candidates);
    if (query.candidates.empty()) continue;
    ++stats->num_with_candidates;
    query.observation = static_cast<int>(o);
    const features::Keypoint& keypoint = features_a.keypoints[observation.feature];
    const Eigen::Vector3d point_a = camera_a_from_world * observation.position_world;
    query.predicted_size = keypoint.size * std::max(point_a.z(), 1e-6) / point_b.z();

    if (warp) {
      // The local plane through the landmark, in camera a's frame: nᵀY = nᵀX.
      Eigen::Vector3d normal_world = Eigen::Vector3d::UnitZ();
      bool use_warp = true;
      const LocalPlane plane =
          input.planes != nullptr
              ? input.planes->PlaneFor(observation.landmark, observation.position_world)
              : LocalPlane();
      if (plane.valid) {
        normal_world = plane.normal;
      } else {
        ++stats->num_plane_fallbacks;
        use_warp = options.plane_fallback == RobustMatcher::PlaneFallback::kGroundNormal;
      }
      if (use_warp) {
        WarpRequest request;
        request.feature = observation.feature;
        request.normal_in_a = camera_a_from_world_rotation * normal_world;
        request.offset = request.normal_in_a.dot(point_a);
        if (std::abs(request.offset) > 1e-9) {
          query.warp = static_cast<int>(warp_requests->size());
          warp_requests->push_back(request);
        }
      }
    }
    queries->push_back(std::move(query));
  }
}

// Upright descriptors of I2's candidates of the validly warped landmarks (those whose size
// agrees), each place once: SIFT gives a keypoint with two orientation peaks twice, at one
// position and size, and upright both copies have the same descriptor. `upright_row[c]` is the
// row of feature c in `descriptors`, −1 where it was not described (or its patch refused).
void DescribeUprightCandidates(const MatcherOptions& options, const RobustPairInput& input,
                               const std::vector<Query>& queries,
                               const std::vector<WarpedKeypoint>& warped,
                               std::vector<int>* upright_row,
                               std::vector<std::uint8_t>* descriptors, AssociationStats* stats) {
  const features::FeatureSet& features_b = *input.features_b;
  upright_row->assign(features_b.size(), -1);
  std::map<std::tuple<float, float, float>, int> row_of_place;
  std::vector<std::int32_t> wanted;
  for (const Query& query : queries) {
    if (query.warp < 0 || !warped[query.warp].valid) continue;
    for (const std::int32_t c : query.candidates) {
      if ((*upright_row)[c] != -1 ||
          !ScaleAgrees(options, features_b.keypoints[c].size, warped[query.warp].size_b)) {
        continue;
      }
      const features::Keypoint& k = features_b.keypoints[c];
      const auto [it, added] =
          row_of_place.try_emplace({k.x, k.y, k.size}, static_cast<int>(wanted.size()));
      if (added) wanted.push_back(c);
      (*upright_row)[c] = it->second;
    }
  }
  const std::vector<bool> described = ComputeUprightDescriptors(
      *input.camera_b, features_b, *input.image_b, wanted, options.warp, descriptors);
  for (int& row : *upright_row) {
    if (row >= 0 && !described[row]) row = -1;
  }
  stats->num_upright_b = static_cast<int>(wanted.size());
}

// The descriptors that step 3 compares: the warped ones (and, upright, the upright ones of
// I2's candidates).
struct PairDescriptors {
  std::vector<std::uint8_t> warped_descriptors;
  std::vector<WarpedKeypoint> warped;
  bool upright = false;
  std::vector<int> upright_row;  // see DescribeUprightCandidates
  std::vector<std::uint8_t> upright_descriptors;
};

// Step 3 for one query: its best candidate by descriptor distance among those whose size
// agrees, kept when close enough and distinctive (ratio test against the best candidate at
// another place).
std::optional<LandmarkMatch> BestCandidate(const MatcherOptions& options,
                                           const RobustPairInput& input, const Query& query,
                                           const PairDescriptors& d, AssociationStats* stats) {
  const features::FeatureSet& features_a = *input.features_a;
  const features::FeatureSet& features_b = *input.features_b;
  const LandmarkObservation& observation = (*input.landmarks_a)[query.observation];
  const std::uint8_t* descriptor = features_a.Descriptor(observation.feature);
  double predicted_size = query.predicted_size;
  // Whether the descriptor is an upright warped one, to be compared with upright ones of I2.
  bool compare_upright = false;
  if (query.warp >= 0) {
    const WarpedKeypoint& w = d.warped[query.warp];
    if (w.valid) {
      ++stats->num_warped;
      compare_upright = d.upright;
      descriptor = d.warped_descriptors.data() +
                   static_cast<std::size_t>(query.warp) * features::kDescriptorSize;
      predicted_size = w.size_b;
    } else {
      ++stats->num_warps_refused;
    }
  }
  int best = -1;
  float best_distance = std::numeric_limits<float>::infinity();
  // Distances of the candidates that pass the scale check, for the rival search.
  std::vector<std::pair<std::int32_t, float>> scored;
  scored.reserve(query.candidates.size());
  for (const std::int32_t c : query.candidates) {
    if (!ScaleAgrees(options, features_b.keypoints[c].size, predicted_size)) continue;
    const std::uint8_t* descriptor_b = features_b.Descriptor(c);
    if (compare_upright) {
      if (d.upright_row[c] < 0) continue;  // its patch could not be built
      descriptor_b = d.upright_descriptors.data() +
                     static_cast<std::size_t>(d.upright_row[c]) * features::kDescriptorSize;
    }
    ++stats->num_candidates;
    const float distance = DescriptorDistance(descriptor, descriptor_b);
    scored.emplace_back(c, distance);
    if (distance < best_distance) {
      best_distance = distance;
      best = c;
    }
  }
  if (best < 0 || best_distance > options.max_descriptor_distance) return std::nullopt;
  const Eigen::Vector2d best_point = features_b.Point(best);
  float rival = std::numeric_limits<float>::infinity();
  for (const auto& [c, distance] : scored) {
    if ((features_b.Point(c) - best_point).norm() > options.same_point_radius_px) {
      rival = std::min(rival, distance);
    }
  }
  if (std::isfinite(rival) && !(best_distance < options.max_ratio * rival)) return std::nullopt;
  return LandmarkMatch{observation.feature, best, best_distance, observation.landmark};
}

// One landmark per feature of I2, the closest in descriptor space.
void KeepOnePerFeatureB(std::vector<LandmarkMatch>* putative) {
  std::sort(putative->begin(), putative->end(), [](const LandmarkMatch& p, const LandmarkMatch& q) {
    if (p.feature_b != q.feature_b) return p.feature_b < q.feature_b;
    if (p.distance != q.distance) return p.distance < q.distance;
    return p.feature_a < q.feature_a;
  });
  std::size_t kept = 0;
  for (std::size_t k = 0; k < putative->size(); ++k) {
    if (k > 0 && (*putative)[k].feature_b == (*putative)[k - 1].feature_b) continue;
    (*putative)[kept++] = (*putative)[k];
  }
  putative->resize(kept);
}

// Step 4: the putative matches consistent with one epipolar geometry (RANSAC on F over the
// undistorted pixels); none when it cannot be verified.
std::vector<LandmarkMatch> VerifyMatches(const MatcherOptions& options,
                                         const RobustPairInput& input,
                                         const std::vector<LandmarkMatch>& putative,
                                         AssociationStats* stats) {
  std::vector<Eigen::Vector2d> points_a, points_b;
  points_a.reserve(putative.size());
  points_b.reserve(putative.size());
  for (const LandmarkMatch& m : putative) {
    points_a.push_back(UndistortedPixel(*input.camera_a, *input.features_a, m.feature_a));
    points_b.push_back(UndistortedPixel(*input.camera_b, *input.features_b, m.feature_b));
  }
  const features::EpipolarGeometry geometry =
      features::EstimateEpipolarGeometry(points_a, points_b, options.verification);
  stats->verified = geometry.verified;
  std::vector<LandmarkMatch> matches;
  if (geometry.verified) {
    matches.reserve(geometry.inliers.size());
    for (const int k : geometry.inliers) matches.push_back(putative[k]);
  }
  return matches;
}

}  // namespace

AssociationResult RobustMatcher::Match(const RobustPairInput& input) const {
  const Clock::time_point start = Clock::now();
  CROP4D_CHECK(input.camera_a != nullptr && input.camera_b != nullptr &&
               input.features_a != nullptr && input.features_b != nullptr &&
               input.landmarks_a != nullptr);
  AssociationResult result;
  AssociationStats& stats = result.stats;
  stats.num_landmarks = static_cast<int>(input.landmarks_a->size());
  stats.baseline_m =
      (input.world_from_camera_a.translation() - input.world_from_camera_b.translation()).norm();
  // Without I1 there is nothing to warp: the cached descriptors are compared as for a short
  // baseline.
  const bool warp = stats.baseline_m > options_.warp_min_baseline_m && input.image_a != nullptr &&
                    !input.image_a->empty();

  // 1. Bounded search: project, size the box, collect the candidates.
  std::vector<Query> queries;
  std::vector<WarpRequest> warp_requests;
  BuildQueries(options_, input, warp, &queries, &warp_requests, &stats);

  // 2. Warped descriptors, all patches of the pair described in batches; upright, I2's
  //    candidates of the warped landmarks described upright too (each once).
  PairDescriptors d;
  d.upright = options_.upright_after_warp && input.image_b != nullptr && !input.image_b->empty() &&
              !warp_requests.empty();
  if (!warp_requests.empty()) {
    PlaneWarpInput warp_input;
    warp_input.camera_a = input.camera_a;
    warp_input.camera_b = input.camera_b;
    warp_input.camera_b_from_camera_a =
        input.world_from_camera_b.Inverse() * input.world_from_camera_a;
    warp_input.features_a = input.features_a;
    warp_input.image_a = input.image_a;
    PlaneWarpOptions warp_options = options_.warp;
    warp_options.upright = d.upright;
    d.warped =
        ComputeWarpedDescriptors(warp_input, warp_requests, warp_options, &d.warped_descriptors);
  }
  if (d.upright) {
    DescribeUprightCandidates(options_, input, queries, d.warped, &d.upright_row,
                              &d.upright_descriptors, &stats);
  }

  // 3. The best distinctive candidate of each landmark.
  std::vector<LandmarkMatch> putative;
  for (const Query& query : queries) {
    if (const std::optional<LandmarkMatch> m = BestCandidate(options_, input, query, d, &stats)) {
      putative.push_back(*m);
    }
  }
  if (options_.one_to_one && !putative.empty()) KeepOnePerFeatureB(&putative);
  std::sort(putative.begin(), putative.end(), [](const LandmarkMatch& p, const LandmarkMatch& q) {
    if (p.feature_a != q.feature_a) return p.feature_a < q.feature_a;
    return p.feature_b < q.feature_b;
  });
  stats.num_putative = static_cast<int>(putative.size());

  // 4. Geometric verification.
  if (!options_.verify) {
    result.matches = std::move(putative);
    stats.verified = !result.matches.empty();
  } else {
    result.matches = VerifyMatches(options_, input, putative, &stats);
  }
  stats.num_inliers = static_cast<int>(result.matches.size());
  stats.seconds = SecondsSince(start);
  return result;
}

AssociationResult NaiveMatch(const geometry::PinholeRadTan& camera_a,
                             const features::FeatureSet& features_a,
                             const features::DescriptorIndex& index_a,
                             const geometry::PinholeRadTan& camera_b,
                             const features::FeatureSet& features_b,
                             const features::DescriptorIndex& index_b,
                             const features::PairMatcher::Options& options) {
  const Clock::time_point start = Clock::now();
  CROP4D_CHECK_OPTIONS(options, "PairMatcher::Options");
  AssociationResult result;
  AssociationStats& stats = result.stats;
  stats.num_candidates =
      static_cast<std::int64_t>(features_a.size()) * static_cast<std::int64_t>(features_b.size());
  // PairMatcher::Match's steps; PairMatcher itself undistorts both images with one camera.
  const std::vector<features::FeatureMatch> putative =
      features::MatchDescriptors(features_a, index_a, features_b, index_b, options.descriptors);
  stats.num_putative = static_cast<int>(putative.size());
  std::vector<Eigen::Vector2d> points_a, points_b;
  points_a.reserve(putative.size());
  points_b.reserve(putative.size());
  for (const features::FeatureMatch& m : putative) {
    points_a.push_back(UndistortedPixel(camera_a, features_a, m.feature1));
    points_b.push_back(UndistortedPixel(camera_b, features_b, m.feature2));
  }
  const features::EpipolarGeometry geometry =
      features::EstimateEpipolarGeometry(points_a, points_b, options.verification);
  stats.verified = geometry.verified;
  if (geometry.verified) {
    for (const int k : geometry.inliers) {
      result.matches.push_back(
          {putative[k].feature1, putative[k].feature2, putative[k].distance, -1});
    }
  }
  std::sort(result.matches.begin(), result.matches.end(),
            [](const LandmarkMatch& p, const LandmarkMatch& q) {
              if (p.feature_a != q.feature_a) return p.feature_a < q.feature_a;
              return p.feature_b < q.feature_b;
            });
  stats.num_inliers = static_cast<int>(result.matches.size());
  stats.seconds = SecondsSince(start);
  return result;
}

AssociationResult NaiveMatch(const geometry::PinholeRadTan& camera_a,
                             const features::FeatureSet& features_a,
                             const geometry::PinholeRadTan& camera_b,
                             const features::FeatureSet& features_b,
                             const features::PairMatcher::Options& options) {
  const Clock::time_point start = Clock::now();
  const features::DescriptorIndex index_a(features_a, options.descriptors);
  const features::DescriptorIndex index_b(features_b, options.descriptors);
  AssociationResult result =
      NaiveMatch(camera_a, features_a, index_a, camera_b, features_b, index_b, options);
  result.stats.seconds = SecondsSince(start);  // the indices included
  return result;
}

}  // namespace crop4d::association
