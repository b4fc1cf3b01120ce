#include "crop4d/fusion/ground_ties.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "crop4d/core/color.h"

namespace crop4d::fusion {
namespace {

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

// Pass a's track frame: s along the track, l across it (both horizontal), z up.
struct TrackFrame {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  Eigen::Vector2d along = Eigen::Vector2d::UnitY();
  Eigen::Vector2d across = -Eigen::Vector2d::UnitX();

  Eigen::Vector2d SL(const Eigen::Vector3d& p) const {
    const Eigen::Vector2d d = p.head<2>() - origin;
    return {d.dot(along), d.dot(across)};
  }
  Eigen::Vector3d Point(double s, double l, double z) const {
    const Eigen::Vector2d xy = origin + s * along + l * across;
    return {xy.x(), xy.y(), z};
  }
};

// The horizontal principal direction of the camera positions (the heading of a straight pass),
// pointing the way the pass was driven.
Eigen::Vector2d Heading(const std::vector<geometry::Rigid3>& cameras, Eigen::Vector2d* mean) {
  Eigen::Vector2d m = Eigen::Vector2d::Zero();
  for (const geometry::Rigid3& c : cameras) m += c.translation().head<2>();
  m /= static_cast<double>(cameras.size());
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  for (const geometry::Rigid3& c : cameras) {
    const Eigen::Vector2d d = c.translation().head<2>() - m;
    scatter += d * d.transpose();
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eig(scatter);
  if (mean != nullptr) *mean = m;
  const Eigen::Vector2d travel =
      cameras.back().translation().head<2>() - cameras.front().translation().head<2>();
  return eig.eigenvectors().col(1).dot(travel) < 0 ? Eigen::Vector2d(-eig.eigenvectors().col(1))
                                                   : Eigen::Vector2d(eig.eigenvectors().col(1));
}

// A pass's track in a's frame: l and the camera height as piecewise-linear functions of s.
class Track {
 public:
  Track(const TrackFrame& frame, const std::vector<geometry::Rigid3>& cameras) {
    for (const geometry::Rigid3& c : cameras) {
      const Eigen::Vector2d sl = frame.SL(c.translation());
      samples_.push_back({sl.x(), sl.y(), c.translation().z()});
    }
    std::sort(samples_.begin(), samples_.end(),
              [](const Sample& x, const Sample& y) { return x.s < y.s; });
  }
  double min_s() const { return samples_.front().s; }
  double max_s() const { return samples_.back().s; }
  // l and camera z at s (clamped to the ends).
  void At(double s, double* l, double* z) const {
    const auto it = std::lower_bound(samples_.begin(), samples_.end(), s,
                                     [](const Sample& x, double v) { return x.s < v; });
    if (it == samples_.begin() || it == samples_.end()) {
      const Sample& e = it == samples_.begin() ? samples_.front() : samples_.back();
      *l = e.l;
      *z = e.z;
      return;
    }
    const Sample& hi = *it;
    const Sample& lo = *(it - 1);
    const double w = hi.s > lo.s ? (s - lo.s) / (hi.s - lo.s) : 0.0;
    *l = lo.l + w * (hi.l - lo.l);
    *z = lo.z + w * (hi.z - lo.z);
  }

 private:
  struct Sample {
    double s, l, z;
  };
  std::vector<Sample> samples_;
};

// A soil point in a's frame, l relative to its own pass's track.
struct Soil {
  double s, l_rel, z;
};

std::vector<Soil> SoilPoints(const GroundTiePass& pass, const TrackFrame& frame, const Track& track,
                             const GroundTieOptions& o) {
  std::vector<Soil> soil;
  for (std::size_t i = 0; i < pass.points.size(); ++i) {
    if (ExcessGreen(pass.colors[i]) > o.max_excess_green) continue;
    const Eigen::Vector2d sl = frame.SL(pass.points[i]);
    if (sl.x() < track.min_s() || sl.x() > track.max_s()) continue;
    double l = 0, z_camera = 0;
    track.At(sl.x(), &l, &z_camera);
    if (std::abs(sl.y() - l) > o.band_half_width_m) continue;
    if (pass.points[i].z() > z_camera - o.min_depth_below_camera_m) continue;
    soil.push_back({sl.x(), sl.y() - l, pass.points[i].z()});
  }
  return soil;
}

int NearestState(const std::vector<geometry::Rigid3>& cameras, const Eigen::Vector3d& p) {
  int best = 0;
  double best_d = std::numeric_limits<double>::infinity();
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    const double d = (cameras[k].translation().head<2>() - p.head<2>()).squaredNorm();
    if (d < best_d) {
      best_d = d;
      best = static_cast<int>(k);
    }
  }
  return best;
}

}  // namespace

bool GroundTieOptions::Check() const {
  return max_excess_green > -1 && band_half_width_m > 0 && min_depth_below_camera_m >= 0 &&
         segment_m > 0 && cell_along_m > 0 && cell_across_m > 0 && min_points > 0 &&
         max_heading_difference_deg > 0 && max_heading_difference_deg < 90;
}

std::vector<GroundTie> ComputeGroundTies(const GroundTiePass& a, const GroundTiePass& b,
                                         const GroundTieOptions& options,
                                         GroundTieSummary* summary) {
  if (!options.Check()) throw std::invalid_argument("ComputeGroundTies: invalid options");
  if (a.colors.size() != a.points.size() || b.colors.size() != b.points.size()) {
    throw std::invalid_argument("ComputeGroundTies: one colour per point needed");
  }
  GroundTieSummary local;
  GroundTieSummary& sum = summary != nullptr ? *summary : local;
  sum = {};
  std::vector<GroundTie> ties;
  if (a.cameras.size() < 2 || b.cameras.size() < 2) return ties;

  TrackFrame frame;
  frame.along = Heading(a.cameras, &frame.origin);
  frame.across = Eigen::Vector2d(-frame.along.y(), frame.along.x());
  const Eigen::Vector2d heading_b = Heading(b.cameras, nullptr);
  if (std::abs(heading_b.dot(frame.along)) <
      std::cos(options.max_heading_difference_deg * M_PI / 180.0)) {
    return ties;
  }
  const Track track_a(frame, a.cameras), track_b(frame, b.cameras);
  const double lo = std::max(track_a.min_s(), track_b.min_s());
  const double hi = std::min(track_a.max_s(), track_b.max_s());
  if (hi - lo < options.segment_m) return ties;

  const std::vector<Soil> soil_a = SoilPoints(a, frame, track_a, options);
  const std::vector<Soil> soil_b = SoilPoints(b, frame, track_b, options);
  sum.soil_points_a = static_cast<int>(soil_a.size());
  sum.soil_points_b = static_cast<int>(soil_b.size());

  // Pass a's soil surface: the median height per cell (cells with two points or more).
  auto key = [&](double s, double l_rel) {
    const auto i = static_cast<std::int64_t>(std::floor(s / options.cell_along_m));
    const auto j = static_cast<std::int64_t>(std::floor(l_rel / options.cell_across_m));
    return (i << 32) ^ (j & 0xffffffff);
  };
  std::unordered_map<std::int64_t, std::vector<double>> cells;
  for (const Soil& p : soil_a) cells[key(p.s, p.l_rel)].push_back(p.z);
  std::unordered_map<std::int64_t, double> surface;
  for (auto& [k, zs] : cells) {
    if (zs.size() >= 2) surface[k] = Median(std::move(zs));
  }

  const int num_segments = static_cast<int>(std::floor((hi - lo) / options.segment_m));
  sum.segments = num_segments;
  std::vector<std::vector<double>> differences(num_segments), heights_a(num_segments);
  auto segment_of = [&](double s) {
    return static_cast<int>(std::floor((s - lo) / options.segment_m));
  };
  for (const Soil& p : soil_b) {
    const int k = segment_of(p.s);
    if (k < 0 || k >= num_segments) continue;
    const auto it = surface.find(key(p.s, p.l_rel));
    if (it != surface.end()) differences[k].push_back(p.z - it->second);
  }
  for (const Soil& p : soil_a) {
    const int k = segment_of(p.s);
    if (k >= 0 && k < num_segments) heights_a[k].push_back(p.z);
  }

  std::vector<double> across_offsets, vertical_offsets, spreads;
  const Eigen::Vector3d across(frame.across.x(), frame.across.y(), 0.0);
  for (int k = 0; k < num_segments; ++k) {
    if (static_cast<int>(differences[k].size()) < options.min_points || heights_a[k].empty()) {
      continue;
    }
    const double dz = Median(differences[k]);
    std::vector<double> deviations;
    for (double d : differences[k]) deviations.push_back(std::abs(d - dz));
    const double s = lo + (k + 0.5) * options.segment_m;
    double l_a = 0, l_b = 0, z_unused = 0;
    track_a.At(s, &l_a, &z_unused);
    track_b.At(s, &l_b, &z_unused);
    GroundTie tie;
    tie.point_a = frame.Point(s, l_a, Median(heights_a[k]));
    tie.point_b = tie.point_a + (l_b - l_a) * across + dz * Eigen::Vector3d::UnitZ();
    tie.state_a = NearestState(a.cameras, tie.point_a);
    tie.state_b = NearestState(b.cameras, tie.point_b);
    tie.across = across;
    ties.push_back(tie);
    across_offsets.push_back(l_b - l_a);
    vertical_offsets.push_back(dz);
    spreads.push_back(Median(std::move(deviations)));
  }
  sum.ties = static_cast<int>(ties.size());
  if (!ties.empty()) {
    sum.median_across_m = Median(across_offsets);
    sum.median_vertical_m = Median(vertical_offsets);
    sum.median_spread_m = Median(spreads);
  }
  return ties;
}

}  // namespace crop4d::fusion
