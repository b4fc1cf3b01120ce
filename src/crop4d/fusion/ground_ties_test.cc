// Ground ties on synthetic passes: a row of raised beds with gentle relief, soil points seen by
// two passes along it whose frames are displaced (a metre-level receiver's error), plants and a
// tree line that must not count.

#include "crop4d/fusion/ground_ties.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace crop4d::fusion {
namespace {

constexpr std::array<std::uint8_t, 3> kSoil{120, 95, 70};
constexpr std::array<std::uint8_t, 3> kLeaf{60, 150, 50};

// The true ground: beds every 0.91 m (6 cm high, crest on x = 0), relief along the row.
double Terrain(double x, double y) {
  return 0.03 * (1.0 + std::cos(2.0 * M_PI * x / 0.91)) + 0.1 * std::sin(2.0 * M_PI * y / 25.0);
}

struct PassSpec {
  Eigen::Vector3d frame_error = Eigen::Vector3d::Zero();  // where the pass's frame puts things
  double track_x = 0.0;                                   // the true lateral track (driving)
  bool reverse = false;
  std::uint32_t seed = 1;
  double heading_deg = 0.0;  // the pass's frame rotated about the vertical (a wrong heading)
};

GroundTiePass MakePass(const PassSpec& spec, double noise_m = 0.005) {
  std::mt19937 rng(spec.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_m);
  const double yaw = spec.heading_deg * M_PI / 180.0;
  const Eigen::Matrix3d rotation =
      Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const auto placed = [&](const Eigen::Vector3d& p) {
    return Eigen::Vector3d(rotation * p + spec.frame_error);
  };
  GroundTiePass pass;
  for (int k = 0; k <= 150; ++k) {
    const double y = spec.reverse ? 15.0 - 0.1 * k : 0.1 * k;
    const Eigen::Vector3d camera(spec.track_x, y, Terrain(spec.track_x, y) + 1.5);
    pass.cameras.emplace_back(Eigen::Quaterniond::Identity(), placed(camera));
  }
  for (int k = 0; k < 20000; ++k) {  // soil within 1.4 m of the track
    const double x = spec.track_x + 2.8 * (uniform(rng) - 0.5), y = 15.0 * uniform(rng);
    pass.points.push_back(placed(Eigen::Vector3d(x, y, Terrain(x, y) + noise(rng))));
    pass.colors.push_back(kSoil);
  }
  for (int k = 0; k < 3000; ++k) {  // leaves on the row, 10–30 cm up
    const double x = 0.15 * (uniform(rng) - 0.5), y = 15.0 * uniform(rng);
    pass.points.push_back(placed(Eigen::Vector3d(x, y, Terrain(x, y) + 0.1 + 0.2 * uniform(rng))));
    pass.colors.push_back(kLeaf);
  }
  for (int k = 0; k < 2000; ++k) {  // brown tree trunks 30 m away, well above the ground
    pass.points.push_back(placed(Eigen::Vector3d(30.0, 15.0 * uniform(rng), 3.0 * uniform(rng))));
    pass.colors.push_back(kSoil);
  }
  return pass;
}

TEST(GroundTies, MeasureTheOffsetAcrossTheRowAndVertically) {
  const PassSpec spec_a{Eigen::Vector3d(0.3, -0.4, 1.2), 0.0, false, 1};
  for (bool reverse : {false, true}) {
    SCOPED_TRACE(reverse ? "b driven the other way" : "b driven the same way");
    // Pass b's frame is 1.7 m across and 0.6 m down from a's, 5 cm along; its vehicle drove
    // 3 cm beside a's. (An error along the row is not measured: the ties then compare the
    // ground at places that far apart, and the relief's slope, up to 2.5 % here, enters.)
    const PassSpec spec_b{Eigen::Vector3d(0.3 + 1.7, -0.4 + 0.05, 1.2 - 0.6), 0.03, reverse, 2};
    GroundTieSummary summary;
    const std::vector<GroundTie> ties =
        ComputeGroundTies(MakePass(spec_a), MakePass(spec_b), GroundTieOptions(), &summary);
    EXPECT_EQ(summary.segments, 14);  // 14.95 m of common track
    EXPECT_GE(summary.ties, 14);
    ASSERT_EQ(summary.ties, static_cast<int>(ties.size()));
    // The leaves and the tree line are not soil.
    EXPECT_LT(summary.soil_points_a, 20001);
    EXPECT_GT(summary.soil_points_a, 15000);
    // The offset of b's frame: 1.7 m across (plus the 3 cm of driving, which the ties cannot
    // tell from it), −0.6 m vertically; nothing along.
    // Pass a drives north, so "across" (to its left) points west.
    EXPECT_NEAR(summary.median_across_m, -1.73, 0.01);
    EXPECT_NEAR(summary.median_vertical_m, -0.6, 0.005);
    EXPECT_LT(summary.median_spread_m, 0.01);
    for (const GroundTie& t : ties) {
      EXPECT_NEAR(t.across.x(), -1.0, 1e-6);
      const Eigen::Vector3d d = t.point_b - t.point_a;
      EXPECT_NEAR(d.y(), 0.0, 1e-9);
      EXPECT_NEAR(d.z(), -0.6, 0.01);
      EXPECT_NEAR(d.x(), 1.73, 0.01);
      // Each tie hangs on the camera nearest to it in each pass.
      EXPECT_LT(std::abs(t.point_a.y() - (0.1 * t.state_a - 0.4)), 0.051);
      const double y_b = reverse ? 15.0 - 0.1 * t.state_b : 0.1 * t.state_b;
      EXPECT_LT(std::abs(t.point_b.y() - (y_b - 0.35)), 0.051);
    }
  }
}

TEST(GroundTies, NoTieWithoutCommonSoilOrOnCrossingTracks) {
  const PassSpec spec_a{Eigen::Vector3d::Zero(), 0.0, false, 1};
  // Tracks 30° apart: not the same row.
  PassSpec crossing{Eigen::Vector3d(0.5, 0.0, 0.0), 0.0, false, 2};
  crossing.heading_deg = 30.0;
  GroundTieSummary summary;
  EXPECT_TRUE(ComputeGroundTies(MakePass(spec_a), MakePass(crossing), GroundTieOptions(), &summary)
                  .empty());
  // Tracks that do not overlap along the row.
  EXPECT_TRUE(ComputeGroundTies(MakePass(spec_a),
                                MakePass({Eigen::Vector3d(0.0, 40.0, 0.0), 0.0, false, 2}),
                                GroundTieOptions(), &summary)
                  .empty());
  // Nothing but plants.
  GroundTiePass green = MakePass({Eigen::Vector3d::Zero(), 0.0, false, 3});
  for (auto& c : green.colors) c = kLeaf;
  EXPECT_TRUE(ComputeGroundTies(MakePass(spec_a), green, GroundTieOptions(), &summary).empty());
  EXPECT_EQ(summary.soil_points_b, 0);
  EXPECT_EQ(summary.ties, 0);
}

TEST(GroundTies, RejectsBadInput) {
  GroundTiePass a = MakePass({Eigen::Vector3d::Zero(), 0.0, false, 1});
  GroundTiePass b = a;
  b.colors.pop_back();
  EXPECT_THROW(ComputeGroundTies(a, b, GroundTieOptions()), std::invalid_argument);
  GroundTieOptions bad;
  bad.segment_m = 0;
  EXPECT_DEATH(ComputeGroundTies(a, a, bad), "segment_m");
  // A pass with a single camera has no track: no ties, no crash.
  GroundTiePass single = a;
  single.cameras.resize(1);
  EXPECT_TRUE(ComputeGroundTies(single, a, GroundTieOptions()).empty());
}

}  // namespace
}  // namespace crop4d::fusion
