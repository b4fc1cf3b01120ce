#include "crop4d/fusion/ground_ties.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>
#include <unordered_map>

#include "crop4d/core/color.h"
#include "crop4d/slam/track_profile.h"

namespace crop4d::fusion {
namespace {

double Median(std::vector<double> values) {
  if (values.empty()) return std::numeric_limits<double>::quiet_NaN();
  const auto mid = values.begin() + values.size() / 2;
  std::nth_element(values.begin(), mid, values.end());
  return *mid;
}

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

// A soil point in a's frame, l relative to its own pass's track.
struct Soil {
  double s, l_rel, z;
};

// The soil beside a pass's own track (in pass a's frame).
std::vector<Soil> SoilPoints(const GroundTiePass& pass, const slam::TrackProfile& track,
                             const GroundTieOptions& o) {
  std::vector<Soil> soil;
  for (std::size_t i = 0; i < pass.points.size(); ++i) {
    if (ExcessGreen(pass.colors[i]) > o.max_excess_green) continue;
    const double s = track.Along(pass.points[i]);
    if (s < track.min_s() || s > track.max_s()) continue;
    const slam::TrackProfile::Position camera = track.At(s);
    const double l = track.Across(pass.points[i]) - camera.l;
    if (std::abs(l) > o.band_half_width_m) continue;
    if (pass.points[i].z() > camera.z - o.min_depth_below_camera_m) continue;
    soil.push_back({s, l, pass.points[i].z()});
  }
  return soil;
}

std::vector<Eigen::Vector3d> Centres(const std::vector<geometry::Rigid3>& cameras) {
  std::vector<Eigen::Vector3d> centres;
  for (const geometry::Rigid3& c : cameras) centres.push_back(c.translation());
  return centres;
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

OptionCheck GroundTieOptions::Check() const {
  OptionChecker c;
  c.Greater("max_excess_green", max_excess_green, -1)
      .Greater("band_half_width_m", band_half_width_m, 0)
      .AtLeast("min_depth_below_camera_m", min_depth_below_camera_m, 0)
      .Greater("segment_m", segment_m, 0)
      .Greater("cell_along_m", cell_along_m, 0)
      .Greater("cell_across_m", cell_across_m, 0)
      .Greater("min_points", min_points, 0)
      .Between("max_heading_difference_deg", max_heading_difference_deg, 0.0, 90.0);
  return c.Result();
}

std::vector<GroundTie> ComputeGroundTies(const GroundTiePass& a, const GroundTiePass& b,
                                         const GroundTieOptions& options,
                                         GroundTieSummary* summary) {
  CROP4D_CHECK_OPTIONS(options, "ComputeGroundTies");
  if (a.colors.size() != a.points.size() || b.colors.size() != b.points.size()) {
    throw std::invalid_argument("ComputeGroundTies: one colour per point needed");
  }
  GroundTieSummary local;
  GroundTieSummary& sum = summary != nullptr ? *summary : local;
  sum = {};
  std::vector<GroundTie> ties;
  if (a.cameras.size() < 2 || b.cameras.size() < 2) return ties;

  // Pass a's track frame: s along its heading, l across it (to its left), z up.
  Eigen::Vector2d origin;
  const Eigen::Vector2d along = Heading(a.cameras, &origin);
  if (std::abs(Heading(b.cameras, nullptr).dot(along)) <
      std::cos(options.max_heading_difference_deg * M_PI / 180.0)) {
    return ties;
  }
  const slam::TrackProfile track_a(Centres(a.cameras), origin, along);
  const slam::TrackProfile track_b(Centres(b.cameras), origin, along);
  const double lo = std::max(track_a.min_s(), track_b.min_s());
  const double hi = std::min(track_a.max_s(), track_b.max_s());
  if (hi - lo < options.segment_m) return ties;

  const std::vector<Soil> soil_a = SoilPoints(a, track_a, options);
  const std::vector<Soil> soil_b = SoilPoints(b, track_b, options);
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
  const Eigen::Vector3d across(track_a.across().x(), track_a.across().y(), 0.0);
  for (int k = 0; k < num_segments; ++k) {
    if (static_cast<int>(differences[k].size()) < options.min_points || heights_a[k].empty()) {
      continue;
    }
    const double dz = Median(differences[k]);
    std::vector<double> deviations;
    for (double d : differences[k]) deviations.push_back(std::abs(d - dz));
    const double s = lo + (k + 0.5) * options.segment_m;
    const double l_a = track_a.At(s).l, l_b = track_b.At(s).l;
    GroundTie tie;
    tie.point_a = track_a.Point(s, l_a, Median(heights_a[k]));
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
